#pragma once

/// @file
/// @brief The foveated structure (paper Eq. 1, 7 and 8): nested level boxes with a density and a
/// keypoint radius per level, and the region label a point gets from foveation.

#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "mfpc/core/box.hpp"

namespace mfpc {

/// @brief The most levels m a structure may have: levels travel as 8-bit numbers through the
/// labelling kernel. The config reader and the kernel hold to the same bound.
inline constexpr int max_levels = 126;

/// @brief A foveated structure (Oliveira et al. 2018, Section 4.1; Gomes et al. 2013): m + 1 nested
/// boxes, levels k = 0..m.
///
/// Level 0 is the outer box (min corner Δ, size S_0); level m is the fovea box (size S_m), centred
/// at Δ + S_0/2 + F. For level k (paper Eq. 7 and 8):
///
///     S_k = (k (S_m - S_0) + m S_0) / m
///     δ_k = k (S_0 - S_m + 2F) / (2m)          (offset of box k's min corner from Δ)
///
/// Level k is downsampled with voxel size d_k = d_0 + k (d_m - d_0) / m; keypoints on level k use
/// radius r_k, interpolated the same way. A density of 0 keeps every point of the level.
struct FoveatedStructure {
    Eigen::Vector3f outer_min = Eigen::Vector3f::Zero();     ///< Δ: the outer box's min corner.
    Eigen::Vector3f outer_size = Eigen::Vector3f::Ones();    ///< S_0: the outer box's size.
    Eigen::Vector3f fovea_size = Eigen::Vector3f::Ones();    ///< S_m: the fovea box's size.
    Eigen::Vector3f fovea_offset = Eigen::Vector3f::Zero();  ///< F: the fovea centre's offset from the outer box's.
    int levels = 3;                                          ///< m.
    float density_outer = 0.02f;                             ///< d_0 (metres).
    float density_fovea = 0.005f;                            ///< d_m (metres).
    float keypoint_radius_outer = 0.03f;                     ///< r_0 (metres).
    float keypoint_radius_fovea = 0.01f;                     ///< r_m (metres).
    std::string name;  ///< Optional label from the config ("carton 2"), for messages and reports.

    /// @brief The outer box (level 0), unchecked.
    /// @return The box from Δ of size S_0.
    Box outer_box() const { return Box::from_min_size(outer_min, outer_size); }
    /// @brief Box k, k = 0..levels (Eq. 7, 8).
    ///
    /// Every caller computes boxes here, so the index-based labelling and the reference
    /// implementation agree to the last bit on faces. level_box(0) is exactly outer_box(); box
    /// k + 1 lies inside box k even after rounding.
    /// @param level k, 0..levels.
    /// @return Box k.
    /// @throws mfpc::Error for a level outside 0..levels or a structure that is not valid
    /// (levels < 1, a non-finite corner, size or offset, a size that is not positive, a fovea
    /// bigger than the outer box, |F| beyond fovea_offset_limit()).
    Box level_box(int level) const;
    /// @brief The voxel size d_k of level k, interpolated between d_0 and d_m (exactly d_0 and d_m
    /// at the ends).
    /// @param level k, 0..levels.
    /// @return d_k (metres); 0 keeps every point of the level.
    /// @throws mfpc::Error for levels < 1 or a level outside 0..levels.
    float density(int level) const;
    /// @brief The keypoint radius r_k of level k, interpolated between r_0 and r_m (exactly r_0
    /// and r_m at the ends).
    /// @param level k, 0..levels.
    /// @return r_k (metres).
    /// @throws mfpc::Error for levels < 1 or a level outside 0..levels.
    float keypoint_radius(int level) const;

    /// @brief The level of p: the largest k whose box contains p (closed boxes). A point in box k
    /// but not box k+1 is in level region B_k.
    /// @param p The point.
    /// @return k, or -1 when p lies in none of the boxes.
    /// @throws mfpc::Error as level_box for a structure that is not valid.
    int level_of(const Eigen::Vector3f& p) const;

    /// @brief The largest |F| per axis that keeps the fovea inside the outer box.
    /// @return (S_0 - S_m) / 2.
    Eigen::Vector3f fovea_offset_limit() const { return 0.5f * (outer_size - fovea_size); }
    /// @brief Sets F from an absolute fovea centre, in the same order of rounding as the config
    /// reader's "fovea_center", so both give the same F. F is neither checked nor clamped here
    /// (level_box refuses a fovea outside the outer box).
    /// @param center The fovea's centre.
    void set_fovea_center(const Eigen::Vector3f& center);
    /// @brief The absolute fovea centre.
    /// @return Δ + S_0/2 + F.
    Eigen::Vector3f fovea_center() const { return outer_min + 0.5f * outer_size + fovea_offset; }
};

/// @brief The per-level detail of a structure: densities d_0, d_m and keypoint radii r_0, r_m
/// (defaults: those of the shipped milk-carton configs).
struct LevelDetail {
    float density_outer = 0.02f;          ///< d_0 (metres).
    float density_fovea = 0.005f;         ///< d_m (metres).
    float keypoint_radius_outer = 0.03f;  ///< r_0 (metres).
    float keypoint_radius_fovea = 0.01f;  ///< r_m (metres).
};

/// @brief The structure of m levels between two boxes: `outer` is level 0, `fovea` level m (its
/// centre set with set_fovea_center, as the config reader's "fovea_center"). Neither is checked
/// here: level_box refuses a fovea that does not fit.
/// @param outer The outer box.
/// @param fovea The fovea box, inside `outer`.
/// @param levels m.
/// @param detail The densities and keypoint radii.
/// @param name The structure's label.
/// @return The structure.
FoveatedStructure structure_between(const Box& outer, const Box& fovea, int levels, const LevelDetail& detail,
                                    std::string name = {});

/// @brief A point's place after foveation: which structure and level it was kept in.
///
/// -1 means "none" (a point outside every structure, or a cloud that was not foveated). Under
/// redundancy treatment a point covered by several structures gets the densest (structure, level)
/// covering it: smallest density(k) first, then the higher level k, then the lower structure index
/// (tests/support/reference_foveation.hpp is the reference).
struct RegionLabel {
    std::int16_t structure = -1;  ///< The structure's index in the config, or -1.
    std::int16_t level = -1;      ///< The level k, or -1.
    /// @brief Whether two labels name the same region.
    /// @return True when structure and level both match.
    friend bool operator==(const RegionLabel&, const RegionLabel&) = default;
};

}  // namespace mfpc
