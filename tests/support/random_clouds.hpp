#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "mfpc/core/foveated_structure.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc::test {

// Points uniform in [-1, 1]^3, a quarter of them snapped to a 5 cm lattice so that many share
// coordinates (and so voxels and box faces).
inline std::vector<Point> random_points(std::size_t count, std::uint32_t seed)
{
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> coordinate(-1.0f, 1.0f);
    std::vector<Point> points(count);
    for (std::size_t i = 0; i < count; ++i) {
        Point p(coordinate(rng), coordinate(rng), coordinate(rng));
        if (i % 4 == 0) p = (p / 0.05f).array().round().matrix() * 0.05f;
        points[i] = p;
    }
    return points;
}

// A structure with its outer box somewhere in [-1.2, 1.2]^3, a fovea anywhere inside it (sometimes
// touching a face), and densities from "keep everything" to coarse.
inline FoveatedStructure random_structure(std::mt19937& rng, int levels)
{
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    FoveatedStructure s;
    s.levels = levels;
    s.outer_size = Eigen::Vector3f(0.3f + 1.2f * unit(rng), 0.3f + 1.2f * unit(rng), 0.3f + 1.2f * unit(rng));
    s.outer_min = Eigen::Vector3f(-1.2f + (2.4f - s.outer_size.x()) * unit(rng),
                                  -1.2f + (2.4f - s.outer_size.y()) * unit(rng),
                                  -1.2f + (2.4f - s.outer_size.z()) * unit(rng));
    s.fovea_size = s.outer_size.cwiseProduct(Eigen::Vector3f(0.1f + 0.8f * unit(rng), 0.1f + 0.8f * unit(rng),
                                                             0.1f + 0.8f * unit(rng)));
    const Eigen::Vector3f limit = s.fovea_offset_limit();
    for (int axis = 0; axis < 3; ++axis) {
        const float choice = unit(rng);
        // A fovea on the outer box's face now and then: the edge case of Eq. 8.
        s.fovea_offset[axis] = choice < 0.1f ? limit[axis] : choice < 0.2f ? -limit[axis]
                                                                         : (2.0f * unit(rng) - 1.0f) * limit[axis];
    }
    const float coarse = 0.02f + 0.1f * unit(rng);
    const float choice = unit(rng);
    s.density_outer = coarse;
    s.density_fovea = choice < 0.2f ? 0.0f : choice < 0.3f ? coarse : coarse * (0.1f + 0.5f * unit(rng));
    return s;
}

}  // namespace mfpc::test
