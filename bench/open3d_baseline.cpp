#include "open3d_baseline.hpp"

#include <chrono>
#include <functional>
#include <utility>

#include <omp.h>
#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/CorrespondenceChecker.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/pipelines/registration/TransformationEstimation.h>
#include <open3d/utility/Random.h>

namespace mfpc::bench {

namespace geometry = open3d::geometry;
namespace registration = open3d::pipelines::registration;

struct Open3dModel::Described {
    std::shared_ptr<geometry::PointCloud> cloud;  // down-sampled, with normals
    std::shared_ptr<registration::Feature> features;
};

namespace {

using Clock = std::chrono::steady_clock;

double elapsed_ms(Clock::time_point since)
{
    return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

geometry::PointCloud to_open3d(const PointCloud& cloud)
{
    geometry::PointCloud out;
    out.points_.reserve(cloud.size());
    for (const Point& p : cloud.points) out.points_.emplace_back(p.cast<double>());
    return out;
}

// Down-sampling, normals and FPFH, the same for model and scene; adds to times.
Open3dModel::Described describe(const geometry::PointCloud& cloud, const Open3dParams& params, Open3dStageTimes& times)
{
    Open3dModel::Described out;
    auto t = Clock::now();
    out.cloud = cloud.VoxelDownSample(params.voxel);
    times.downsample += elapsed_ms(t);

    t = Clock::now();
    out.cloud->EstimateNormals(
        geometry::KDTreeSearchParamHybrid(params.normal_radius * params.voxel, params.normal_max_neighbours));
    if (params.orient_normals) out.cloud->OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
    times.normals += elapsed_ms(t);

    t = Clock::now();
    out.features = registration::ComputeFPFHFeature(
        *out.cloud, geometry::KDTreeSearchParamHybrid(params.fpfh_radius * params.voxel, params.fpfh_max_neighbours));
    times.fpfh += elapsed_ms(t);
    return out;
}

Pose to_pose(const Eigen::Matrix4d& matrix)
{
    Pose pose = Pose::Identity();
    pose.matrix() = matrix.cast<float>();
    return pose;
}

// The scene points (and their features) farther than params.removal_distance from every point of
// the model placed at `transform`. The scene's features are kept, not recomputed: removing an
// instance does not change the surface its neighbours' FPFH described.
Open3dModel::Described remove_instance(const Open3dModel::Described& scene, const geometry::PointCloud& model,
                                       const Eigen::Matrix4d& transform, const Open3dParams& params)
{
    geometry::PointCloud placed = model;
    placed.Transform(transform);
    const geometry::KDTreeFlann tree(placed);
    std::vector<std::size_t> keep;
    std::vector<int> index;
    std::vector<double> distance2;
    for (std::size_t i = 0; i < scene.cloud->points_.size(); ++i) {
        if (tree.SearchHybrid(scene.cloud->points_[i], params.removal_distance, 1, index, distance2) == 0) {
            keep.push_back(i);
        }
    }
    Open3dModel::Described out;
    out.cloud = scene.cloud->SelectByIndex(keep);
    out.features = std::make_shared<registration::Feature>();
    out.features->data_.resize(scene.features->data_.rows(), Eigen::Index(keep.size()));
    for (std::size_t i = 0; i < keep.size(); ++i) {
        out.features->data_.col(Eigen::Index(i)) = scene.features->data_.col(Eigen::Index(keep[i]));
    }
    return out;
}

}  // namespace

Open3dModel open3d_prepare_model(const PointCloud& model, const Open3dParams& params, int threads)
{
    // Open3D's legacy geometry and registration code parallelizes with OpenMP, sized by this
    // thread's OpenMP setting (utility::EstimateMaxThreads).
    omp_set_num_threads(threads);
    Open3dModel out;
    auto t = Clock::now();
    const geometry::PointCloud cloud = to_open3d(model);
    out.times.convert = elapsed_ms(t);

    t = Clock::now();
    auto described = std::make_shared<Open3dModel::Described>(describe(cloud, params, out.times));
    out.times.total = elapsed_ms(t);
    out.points = described->cloud->points_.size();
    out.described = std::move(described);
    return out;
}

Open3dResult open3d_recognize(const Open3dModel& model, const PointCloud& scene, const Open3dParams& params,
                              int threads)
{
    omp_set_num_threads(threads);
    Open3dResult out;
    auto t = Clock::now();
    const geometry::PointCloud cloud = to_open3d(scene);
    out.times.convert = elapsed_ms(t);

    const auto start = Clock::now();
    Open3dModel::Described remaining = describe(cloud, params, out.times);
    out.scene_points = remaining.cloud->points_.size();

    const geometry::PointCloud& model_cloud = *model.described->cloud;
    const double ransac_distance = params.ransac_distance * params.voxel;
    const registration::CorrespondenceCheckerBasedOnEdgeLength edge_length(params.edge_length_similarity);
    const registration::CorrespondenceCheckerBasedOnDistance distance(ransac_distance);
    const std::vector<std::reference_wrapper<const registration::CorrespondenceChecker>> checkers = {edge_length,
                                                                                                     distance};
    while (int(out.instances.size()) < params.max_instances) {
        // RANSAC needs 3 correspondences and ICP a target; fewer points left is no instance.
        if (remaining.cloud->points_.size() < 3) {
            out.last_fitness = 0;
            break;
        }
        ++out.rounds;
        t = Clock::now();
        open3d::utility::random::Seed(params.seed);
        const registration::RegistrationResult ransac = registration::RegistrationRANSACBasedOnFeatureMatching(
            model_cloud, *remaining.cloud, *model.described->features, *remaining.features, false, ransac_distance,
            registration::TransformationEstimationPointToPoint(false), 3, checkers,
            registration::RANSACConvergenceCriteria(params.ransac_iterations, params.ransac_confidence));
        out.times.ransac += elapsed_ms(t);

        t = Clock::now();
        const registration::RegistrationResult icp =
            registration::RegistrationICP(model_cloud, *remaining.cloud, params.icp_distance * params.voxel,
                                          ransac.transformation_, registration::TransformationEstimationPointToPlane());
        out.times.icp += elapsed_ms(t);

        out.last_fitness = icp.fitness_;
        if (icp.fitness_ < params.min_fitness) break;
        out.instances.push_back(Open3dInstance{to_pose(icp.transformation_), ransac.fitness_, icp.fitness_, icp.inlier_rmse_});
        if (int(out.instances.size()) == params.max_instances) {
            out.last_fitness = 0;
            break;
        }

        t = Clock::now();
        remaining = remove_instance(remaining, model_cloud, icp.transformation_, params);
        out.times.remove += elapsed_ms(t);
    }
    out.times.total = elapsed_ms(start);
    return out;
}

}  // namespace mfpc::bench
