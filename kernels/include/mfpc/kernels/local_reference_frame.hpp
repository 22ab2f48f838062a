#pragma once

#include <cstdint>
#include <span>

#include <Eigen/Core>

#include "mfpc/core/point_cloud.hpp"
#include "mfpc/index/neighbor_grid.hpp"

namespace mfpc {

// A local reference frame: rows are the x, y and z axes in scene coordinates (the layout of PCL's
// ReferenceFrame::rf). Undefined frames are all NaN.
using LocalReferenceFrame = Eigen::Matrix3f;

inline bool is_valid(const LocalReferenceFrame& frame) { return frame.allFinite(); }

// BOARD (Petrelli & Di Stefano 2011) with PCL 1.13's parameters. One reading differs from PCL:
// PCL measures the margin ring against its tangent radius even when that is unset (0), so with
// PCL's defaults, as in its correspondence-grouping tutorial, the ring is every neighbour at a
// nonzero distance. Here tangent_radius = 0 means the radius, as the paper intends; PCL's default
// behaviour is margin_threshold = 0, and PCL with setTangentRadius(radius) is the default here.
struct BoardParams {
    float radius = 0.015f;           // r_l: support of the plane fit (z axis)
    float tangent_radius = 0.0f;     // support of the x axis search; 0: the same as radius
    bool find_holes = true;          // as PCL's tutorial (PCL's own default is false)
    float margin_threshold = 0.85f;  // x axis candidates lie beyond this fraction of the tangent radius
    int margin_bins = 24;            // angular bins for hole finding
    float hole_size_probability = 0.2f;
    float steep_threshold = 0.1f;
};

// BOARD frame at each keypoint from the points of `surface` within the radius and their normals
// (surface_normals[i] belongs to surface.points()[i]), as PCL's BOARDLocalReferenceFrameEstimation:
// z is the normal of the least-squares plane through the neighbours, pointing to the side of the
// mean of their normals; x points (projected on the plane) to the neighbour of the margin ring
// (squared distance > (margin_threshold * tangent radius)^2) whose normal is the most different
// from z, or of the whole tangent support when the ring is empty; with find_holes, a large enough
// gap in the ring with steep borders sets x instead; y = z cross x.
//
// A frame is undefined (all NaN) when the keypoint is not finite, has fewer than 6 neighbours, or
// no neighbour in the tangent support has a defined normal (as PCL), and also where PCL returns a
// degenerate frame with zero x and y rows: all neighbours at one spot, or x chosen towards a
// neighbour straight above the keypoint. An undefined (NaN) normal takes no part in the z sign nor
// in choosing x.
//
// Unlike PCL, the result is reproducible: the neighbours come in no distance order, so ties that
// PCL settles by scan order go to the nearer neighbour, then the lower index; and hole finding
// places its sectors from a fixed axis orthogonal to z where PCL draws a random one. A hole that
// empties a whole sector gives the same x either way; where the placement decides (see board.cpp)
// x can differ from a given PCL draw. Bit-identical at any thread count.
//
// `support`, when given, holds the keypoints' neighbourhoods in `surface` (from
// surface.radius_neighborhoods(keypoints, r) with r >= both radii), read instead of searching: the
// same frames, without a search per keypoint when SHOT shares them.
//
// frames.size() must equal keypoints.size() and surface_normals.size() surface.size(); throws
// mfpc::Error when they do not, when `support` is of other keypoints, of another surface or of too
// small a radius, or when a parameter is invalid. Returns the number of undefined frames.
std::size_t board_frames(std::span<const Point> keypoints, const NeighborGrid& surface,
                         std::span<const Point> surface_normals, const BoardParams& params,
                         std::span<LocalReferenceFrame> frames, const Neighborhoods* support = nullptr);

}  // namespace mfpc
