#pragma once

// Shared inputs of the PCL oracle tests: a real cloud as both an mfpc cloud and a dense PCL cloud
// (the same finite points in the same order), PCL's own normals for it, and a fixed keypoint
// subset, so each kernel is compared with PCL on identical inputs.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <pcl/features/normal_3d.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include "mfpc/core/cloud_io.hpp"
#include "mfpc/core/pcl_adapter.hpp"
#include "mfpc/core/point_cloud.hpp"

namespace mfpc::test {

struct OracleCloud {
    PointCloud cloud;                                  // finite points, as read_cloud gives them
    pcl::PointCloud<pcl::PointXYZ>::Ptr pcl_cloud;     // the same points, dense, same order
    pcl::PointCloud<pcl::Normal>::Ptr pcl_normals;     // PCL NormalEstimation, k = 10, kd-tree
    std::vector<Point> normals;                        // pcl_normals as mfpc points (NaN kept)
    std::vector<std::uint32_t> keypoints;              // every `stride`-th point
    pcl::PointCloud<pcl::PointXYZ>::Ptr pcl_keypoints;
    std::vector<Point> keypoint_points;
};

// PCL NormalEstimation, k = 10, kd-tree, into pcl_normals and normals.
inline void add_pcl_normals(OracleCloud& out)
{
    pcl::NormalEstimation<pcl::PointXYZ, pcl::Normal> estimation;
    estimation.setInputCloud(out.pcl_cloud);
    estimation.setSearchMethod(pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>));
    estimation.setKSearch(10);
    estimation.compute(*out.pcl_normals);
    out.normals.reserve(out.cloud.size());
    for (const auto& n : *out.pcl_normals) out.normals.emplace_back(n.normal_x, n.normal_y, n.normal_z);
}

// `with_normals` false leaves pcl_normals and normals empty (PCL's normals of a whole scene cost
// about a second).
inline OracleCloud load_oracle_cloud(const std::filesystem::path& path, std::size_t stride, bool with_normals = true)
{
    OracleCloud out;
    out.cloud = read_cloud(path);
    out.pcl_cloud.reset(new pcl::PointCloud<pcl::PointXYZ>(to_pcl(out.cloud)));
    out.pcl_normals.reset(new pcl::PointCloud<pcl::Normal>);
    if (with_normals) add_pcl_normals(out);

    out.pcl_keypoints.reset(new pcl::PointCloud<pcl::PointXYZ>);
    for (std::size_t i = 0; i < out.cloud.size(); i += stride) {
        out.keypoints.push_back(std::uint32_t(i));
        out.keypoint_points.push_back(out.cloud.points[i]);
        out.pcl_keypoints->push_back((*out.pcl_cloud)[i]);
    }
    return out;
}

}  // namespace mfpc::test
