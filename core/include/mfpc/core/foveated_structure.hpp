#pragma once

#include <cstdint>
#include <string>

#include <Eigen/Core>

#include "mfpc/core/box.hpp"

namespace mfpc {

// A foveated structure (Oliveira et al. 2018, Section 4.1; Gomes et al. 2013): m + 1 nested boxes,
// levels k = 0..m. Level 0 is the outer box (min corner Δ, size S_0); level m is the fovea box
// (size S_m), centred at Δ + S_0/2 + F. For level k (paper Eq. 7 and 8):
//   S_k = (k (S_m - S_0) + m S_0) / m
//   δ_k = k (S_0 - S_m + 2F) / (2m)          (offset of box k's min corner from Δ)
// Level k is downsampled with voxel size d_k = d_0 + k (d_m - d_0) / m; keypoints on level k use
// radius r_k, interpolated the same way. A density of 0 keeps every point of the level.
// The most levels m a structure may have: levels travel as 8-bit numbers through the labelling
// kernel. The config reader and the kernel hold to the same bound.
inline constexpr int max_levels = 126;

struct FoveatedStructure {
    Eigen::Vector3f outer_min = Eigen::Vector3f::Zero();     // Δ
    Eigen::Vector3f outer_size = Eigen::Vector3f::Ones();    // S_0
    Eigen::Vector3f fovea_size = Eigen::Vector3f::Ones();    // S_m
    Eigen::Vector3f fovea_offset = Eigen::Vector3f::Zero();  // F
    int levels = 3;                                          // m
    float density_outer = 0.02f;                             // d_0 (metres)
    float density_fovea = 0.005f;                            // d_m (metres)
    float keypoint_radius_outer = 0.03f;                     // r_0 (metres)
    float keypoint_radius_fovea = 0.01f;                     // r_m (metres)
    std::string name;  // optional label from the config ("carton 2"), for messages and reports

    Box outer_box() const { return Box::from_min_size(outer_min, outer_size); }
    // Box k, k = 0..levels (Eq. 7, 8). Every caller computes boxes here, so the index-based
    // labelling and the reference implementation agree to the last bit on faces.
    // level_box(0) is exactly outer_box(); box k + 1 lies inside box k even after rounding.
    // Throws mfpc::Error for a level outside 0..levels or a structure that is not valid (levels < 1,
    // a size that is not positive, a fovea bigger than the outer box, |F| beyond the limit).
    Box level_box(int level) const;
    float density(int level) const;
    float keypoint_radius(int level) const;

    // The level of p: the largest k whose box contains p (closed boxes), or -1 when p lies in none.
    // A point in box k but not box k+1 is in level region B_k.
    int level_of(const Eigen::Vector3f& p) const;

    // The largest |F| per axis that keeps the fovea inside the outer box: (S_0 - S_m) / 2.
    Eigen::Vector3f fovea_offset_limit() const { return 0.5f * (outer_size - fovea_size); }
    // Sets F from an absolute fovea centre.
    void set_fovea_center(const Eigen::Vector3f& center);
    Eigen::Vector3f fovea_center() const { return outer_min + 0.5f * outer_size + fovea_offset; }
};

// A point's place after foveation: which structure and level it was kept in. -1 means "none"
// (a point outside every structure, or a cloud that was not foveated). Under redundancy treatment
// a point covered by several structures gets the densest (structure, level) covering it: smallest
// density(k) first, then the higher level k, then the lower structure index
// (tests/support/reference_foveation.hpp is the reference).
struct RegionLabel {
    std::int16_t structure = -1;
    std::int16_t level = -1;
    friend bool operator==(const RegionLabel&, const RegionLabel&) = default;
};

}  // namespace mfpc
