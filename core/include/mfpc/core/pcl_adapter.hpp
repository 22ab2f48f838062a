#pragma once

/// @file
/// @brief Conversions between mfpc::PointCloud and PCL clouds, for code that already uses PCL
/// (tests, benchmarks, users migrating a pipeline).
///
/// This is the only mfpc header that includes PCL, and no other mfpc header includes it: the
/// library itself never needs PCL, and including it costs seconds of compile time, so only
/// translation units that want the bridge pay for it. Header-only, so the mfpc libraries do not
/// link PCL either.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include "mfpc/core/error.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

namespace detail {

// The empty cloud that from_pcl fills, with room for every point of a `width` x `height` PCL
// cloud holding `count` points. A PCL cloud whose width x height disagrees with its size (built by
// hand) is treated as the unorganized list it really is.
inline PointCloud begin_from_pcl(std::uint32_t width, std::uint32_t height, std::size_t count, bool with_colors)
{
    if (count > std::numeric_limits<std::uint32_t>::max()) {
        throw Error("from_pcl", std::to_string(count) + " points is more than a source index can address");
    }
    PointCloud cloud;
    const bool organized = height > 1 && std::size_t(width) * height == count;
    cloud.width = organized ? width : static_cast<std::uint32_t>(count);
    cloud.height = organized ? height : 1;
    cloud.points.reserve(count);
    cloud.source_index.reserve(count);
    if (with_colors) cloud.colors.reserve(count);
    return cloud;
}

// Same rule as read_cloud: the index map is left empty when every point was kept (the identity).
inline void finish_from_pcl(PointCloud& cloud, std::size_t count)
{
    if (cloud.size() == count) {
        cloud.source_index.clear();
        cloud.source_index.shrink_to_fit();
    }
}

}  // namespace detail

/// @brief The finite points of `in` (x, y and z finite), each with its row-major position in `in`
/// as the source index, so an organized (dense or not) PCL cloud keeps its pixel coordinates as a
/// cloud read by read_cloud does. One pass, one copy.
///
/// A PCL cloud whose width x height disagrees with its size (built by hand) is taken as the
/// unorganized list it really is. As in read_cloud, the index map is left empty when every point
/// was kept (the identity).
/// @param in The PCL cloud.
/// @return The mfpc cloud of its finite points.
/// @throws mfpc::Error (where "from_pcl") when `in` holds more points than a 32-bit source index
/// can address.
inline PointCloud from_pcl(const pcl::PointCloud<pcl::PointXYZ>& in)
{
    PointCloud cloud = detail::begin_from_pcl(in.width, in.height, in.size(), false);
    for (std::size_t i = 0; i < in.size(); ++i) {
        const pcl::PointXYZ& p = in[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
        cloud.points.emplace_back(p.x, p.y, p.z);
        cloud.source_index.push_back(static_cast<std::uint32_t>(i));
    }
    detail::finish_from_pcl(cloud, in.size());
    return cloud;
}

/// @brief As from_pcl(const pcl::PointCloud<pcl::PointXYZ>&), with the colour of each kept point
/// (alpha is dropped).
/// @param in The PCL cloud.
/// @return The mfpc cloud of its finite points, with colours.
/// @throws mfpc::Error (where "from_pcl") when `in` holds more points than a 32-bit source index
/// can address.
inline PointCloud from_pcl(const pcl::PointCloud<pcl::PointXYZRGBA>& in)
{
    PointCloud cloud = detail::begin_from_pcl(in.width, in.height, in.size(), true);
    for (std::size_t i = 0; i < in.size(); ++i) {
        const pcl::PointXYZRGBA& p = in[i];
        if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
        cloud.points.emplace_back(p.x, p.y, p.z);
        cloud.colors.push_back(Rgb{p.r, p.g, p.b});
        cloud.source_index.push_back(static_cast<std::uint32_t>(i));
    }
    detail::finish_from_pcl(cloud, in.size());
    return cloud;
}

/// @brief The points of `cloud` as an unorganized, dense PCL cloud (width = size, height = 1), in
/// order. Normals, colours and source positions are not carried over.
/// @param cloud The mfpc cloud.
/// @return The PCL cloud of its points.
inline pcl::PointCloud<pcl::PointXYZ> to_pcl(const PointCloud& cloud)
{
    pcl::PointCloud<pcl::PointXYZ> out;
    out.resize(cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) {
        out[i].x = cloud.points[i].x();
        out[i].y = cloud.points[i].y();
        out[i].z = cloud.points[i].z();
    }
    out.width = static_cast<std::uint32_t>(cloud.size());
    out.height = 1;
    out.is_dense = true;
    return out;
}

}  // namespace mfpc
