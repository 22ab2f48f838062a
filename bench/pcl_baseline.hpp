#pragma once

// PCL 1.13's correspondence-grouping pipeline, as the PCL tutorial "3D Object Recognition based on
// Correspondence Grouping" writes it (geometry only: PointXYZ instead of PointXYZRGBA), shared by
// the benchmarks that run it beside ours. PCL's feature headers (seconds of compile time each) stay
// in pcl_baseline.cpp; this header needs only PCL's point types.

#include <cmath>
#include <cstddef>
#include <vector>

#include <Eigen/StdVector>
#include <pcl/correspondence.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

namespace mfpc::bench {

using PclPoint = pcl::PointXYZ;
using PclNormal = pcl::Normal;
using PclDescriptor = pcl::SHOT352;
using PclFrame = pcl::ReferenceFrame;

// The tutorial's values (shared data README, "Reference result").
struct PclParams {
    int normal_k = 10;
    float model_sampling = 0.01f;
    float scene_sampling = 0.03f;
    float shot_radius = 0.02f;
    float lrf_radius = 0.015f;
    float match_threshold = 0.25f;  // squared SHOT distance
    float hough_bin = 0.01f;
    float hough_threshold = 5.0f;
};

// Milliseconds per stage; pcl_features adds to them, pcl_recognize fills them.
struct PclStageTimes {
    double normals = 0, keypoints = 0, descriptors = 0, lrf = 0, match = 0, group = 0;
};

// One cloud's features: normals of every point, uniform-sampling keypoints, SHOT over the full
// cloud (SHOT's own frames), BOARD frames of the keypoints (for Hough).
struct PclFeatures {
    pcl::PointCloud<PclNormal>::Ptr normals{new pcl::PointCloud<PclNormal>};
    pcl::PointCloud<PclPoint>::Ptr keypoints{new pcl::PointCloud<PclPoint>};
    pcl::PointCloud<PclDescriptor>::Ptr descriptors{new pcl::PointCloud<PclDescriptor>};
    pcl::PointCloud<PclFrame>::Ptr frames{new pcl::PointCloud<PclFrame>};
};

struct PclResult {
    PclFeatures scene;
    pcl::CorrespondencesPtr correspondences{new pcl::Correspondences};
    std::vector<Eigen::Matrix4f, Eigen::aligned_allocator<Eigen::Matrix4f>> poses;  // model -> scene
    std::vector<pcl::Correspondences> clustered;  // per pose, its clustered correspondences
    PclStageTimes times;
};

/// @brief Describes one cloud as the tutorial does: NormalEstimationOMP (k neighbours, `threads`
/// threads), UniformSampling keypoints at `sampling`, SHOTEstimationOMP over the whole cloud,
/// BOARD frames; adds each stage's milliseconds to `times`.
PclFeatures pcl_features(const pcl::PointCloud<PclPoint>::ConstPtr& cloud, float sampling, const PclParams& params,
                         int threads, PclStageTimes& times);

/// @brief The tutorial's scene side against a described model: the scene's features, each finite
/// scene descriptor's nearest model descriptor (KdTreeFLANN, squared distance under the
/// threshold), Hough3DGrouping; poses map model into scene. Only normals and SHOT use `threads`.
PclResult pcl_recognize(const PclFeatures& model, const pcl::PointCloud<PclPoint>::ConstPtr& scene,
                        const PclParams& params, int threads);

inline std::size_t count_finite_descriptors(const pcl::PointCloud<PclDescriptor>& descriptors)
{
    std::size_t count = 0;
    for (const PclDescriptor& d : descriptors) count += std::isfinite(d.descriptor[0]) ? 1 : 0;
    return count;
}

inline std::size_t count_finite_frames(const pcl::PointCloud<PclFrame>& frames)
{
    std::size_t count = 0;
    for (const PclFrame& f : frames)
        count += std::isfinite(f.x_axis[0]) && std::isfinite(f.y_axis[0]) && std::isfinite(f.z_axis[0]) ? 1 : 0;
    return count;
}

}  // namespace mfpc::bench
