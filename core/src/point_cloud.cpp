#include "mfpc/core/point_cloud.hpp"

#include <string>

#include "mfpc/core/error.hpp"

namespace mfpc {

void check_cloud(const PointCloud& cloud, const char* what)
{
    const std::size_t n = cloud.size();
    if (cloud.has_normals() && cloud.normals.size() != n) {
        throw Error(what, std::to_string(cloud.normals.size()) + " normals for " + std::to_string(n) + " points");
    }
    if (cloud.has_colors() && cloud.colors.size() != n) {
        throw Error(what, std::to_string(cloud.colors.size()) + " colours for " + std::to_string(n) + " points");
    }
    if (!cloud.source_index.empty()) {
        if (cloud.source_index.size() != n) {
            throw Error(what, "index map has " + std::to_string(cloud.source_index.size()) + " entries for " +
                                  std::to_string(n) + " points");
        }
        for (std::size_t i = 0; i < n; ++i) {
            if (cloud.source_index[i] >= cloud.source_size()) {
                throw Error(what, "index map entry " + std::to_string(i) + " (" + std::to_string(cloud.source_index[i]) +
                                      ") is outside the " + std::to_string(cloud.width) + "x" +
                                      std::to_string(cloud.height) + " source");
            }
        }
    }
    for (std::size_t i = 0; i < n; ++i) {
        if (!cloud.points[i].allFinite()) {
            throw Error(what, "point " + std::to_string(i) + " is not finite");
        }
        if (!within_coordinate_range(cloud.points[i])) {
            throw Error(what, "point " + std::to_string(i) + " has a coordinate beyond ±" +
                                  max_coordinate_text + ", the supported range");
        }
    }
}

PointCloud select(const PointCloud& cloud, std::span<const std::uint32_t> indices)
{
    PointCloud out;
    out.width = cloud.width;
    out.height = cloud.height;
    out.points.reserve(indices.size());
    out.source_index.reserve(indices.size());
    if (cloud.has_normals()) out.normals.reserve(indices.size());
    if (cloud.has_colors()) out.colors.reserve(indices.size());
    for (std::uint32_t i : indices) {
        out.points.push_back(cloud.points[i]);
        out.source_index.push_back(cloud.source_position(i));
        if (cloud.has_normals()) out.normals.push_back(cloud.normals[i]);
        if (cloud.has_colors()) out.colors.push_back(cloud.colors[i]);
    }
    return out;
}

}  // namespace mfpc
