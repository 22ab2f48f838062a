#pragma once

/// @file
/// @brief BOARD local reference frames (as PCL 1.13's BOARDLocalReferenceFrameEstimation) at
/// keypoints.

#include <cstdint>
#include <span>

#include <Eigen/Core>

#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/neighbor_grid.hpp"

namespace mfpc {

/// @brief A local reference frame: rows are the x, y and z axes in scene coordinates (the layout
/// of PCL's ReferenceFrame::rf). Undefined frames are all NaN.
using LocalReferenceFrame = Eigen::Matrix3f;

/// @brief Whether a frame is defined.
/// @param frame The frame.
/// @return True when every entry is finite (undefined frames are all NaN).
inline bool is_valid(const LocalReferenceFrame& frame) { return frame.allFinite(); }

/// @brief Parameters of BOARD: PCL 1.13's.
///
/// BOARD (Petrelli & Di Stefano 2011) with PCL 1.13's parameters. One reading differs from PCL:
/// PCL measures the margin ring against its tangent radius even when that is unset (0), so with
/// PCL's defaults, as in its correspondence-grouping tutorial, the ring is every neighbour at a
/// nonzero distance. Here tangent_radius = 0 means the radius, as the paper intends; PCL's default
/// behaviour is margin_threshold = 0, and PCL with setTangentRadius(radius) is the default here.
struct BoardParams {
    float radius = 0.015f;           ///< r_l: support of the plane fit (z axis).
    float tangent_radius = 0.0f;     ///< Support of the x axis search; 0: the same as radius.
    bool find_holes = true;          ///< As PCL's tutorial (PCL's own default is false).
    float margin_threshold = 0.85f;  ///< x axis candidates lie beyond this fraction of the tangent radius.
    int margin_bins = 24;            ///< Angular bins for hole finding.
    /// A gap in the margin ring wider than this fraction of the full turn (measured between the
    /// points that bound it) is a hole.
    float hole_size_probability = 0.2f;
    /// A hole counts only when the mean steepness of its two borders exceeds this (each in [0, 1]:
    /// 1 for the normal most different from z, 0 for one along z).
    float steep_threshold = 0.1f;
};

/// @brief BOARD frame at each keypoint from the points of `surface` within the radius and their
/// normals (surface_normals[i] belongs to surface.points()[i]), as PCL's
/// BOARDLocalReferenceFrameEstimation.
///
/// z is the normal of the least-squares plane through the neighbours, pointing to the side of the
/// mean of their normals; x points (projected on the plane) to the neighbour of the margin ring
/// (squared distance > (margin_threshold * tangent radius)^2) whose normal is the most different
/// from z, or of the whole tangent support when the ring is empty; with find_holes, a large enough
/// gap in the ring with steep borders sets x instead; y = z cross x.
///
/// A frame is undefined (all NaN) when the keypoint is not finite, has fewer than 6 neighbours, or
/// no neighbour in the tangent support has a defined normal (as PCL), and also where PCL returns a
/// degenerate frame with zero x and y rows: all neighbours at one spot, or x chosen towards a
/// neighbour straight above the keypoint. An undefined (NaN) normal takes no part in the z sign nor
/// in choosing x.
///
/// Unlike PCL, the result is reproducible: the neighbours come in no distance order, so ties that
/// PCL settles by scan order go to the nearer neighbour, then the lower index; and hole finding
/// places its sectors from a fixed axis orthogonal to z where PCL draws a random one. A hole that
/// empties a whole sector gives the same x either way; where the placement decides (see board.cpp)
/// x can differ from a given PCL draw. Bit-identical at any thread count.
/// @param keypoints The keypoints.
/// @param surface The grid over the points that make the frames.
/// @param surface_normals One normal per surface point: surface_normals.size() must equal
/// surface.size().
/// @param params The BOARD parameters.
/// @param frames Receives one frame per keypoint: frames.size() must equal keypoints.size().
/// @param support When given, holds the keypoints' neighbourhoods in `surface` (from
/// surface.radius_neighborhoods(keypoints, r) with r >= both radii), read instead of searching:
/// the same frames, without a search per keypoint when SHOT shares them.
/// @return The number of undefined frames.
/// @throws mfpc::Error when the span sizes do not match, when `support` is of other keypoints, of
/// another surface or of too small a radius, or when a parameter is invalid (a radius not positive
/// and finite, a tangent radius neither 0 nor positive and finite, margin_bins below 1, a margin
/// threshold below 0 or not finite, a hole size probability or steep threshold not finite).
std::size_t board_frames(std::span<const Point> keypoints, const NeighborGrid& surface,
                         std::span<const Point> surface_normals, const BoardParams& params,
                         std::span<LocalReferenceFrame> frames, const Neighborhoods* support = nullptr);

}  // namespace mfpc
