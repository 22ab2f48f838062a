#include "pcl_baseline.hpp"

#include <chrono>

#include <pcl/features/board.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/features/shot_omp.h>
#include <pcl/filters/uniform_sampling.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/recognition/cg/hough_3d.h>

namespace mfpc::bench {
namespace {

using Clock = std::chrono::steady_clock;

double elapsed_ms(Clock::time_point since)
{
    return std::chrono::duration<double, std::milli>(Clock::now() - since).count();
}

}  // namespace

PclFeatures pcl_features(const pcl::PointCloud<PclPoint>::ConstPtr& cloud, float sampling, const PclParams& params,
                         int threads, PclStageTimes& times)
{
    PclFeatures out;
    auto t = Clock::now();
    pcl::NormalEstimationOMP<PclPoint, PclNormal> normals;
    normals.setNumberOfThreads(unsigned(threads));
    normals.setKSearch(params.normal_k);
    normals.setInputCloud(cloud);
    normals.compute(*out.normals);
    times.normals += elapsed_ms(t);

    t = Clock::now();
    pcl::UniformSampling<PclPoint> sampling_filter;
    sampling_filter.setInputCloud(cloud);
    sampling_filter.setRadiusSearch(sampling);
    sampling_filter.filter(*out.keypoints);
    times.keypoints += elapsed_ms(t);

    t = Clock::now();
    pcl::SHOTEstimationOMP<PclPoint, PclNormal, PclDescriptor> shot;
    shot.setNumberOfThreads(unsigned(threads));
    shot.setRadiusSearch(params.shot_radius);
    shot.setInputCloud(out.keypoints);
    shot.setInputNormals(out.normals);
    shot.setSearchSurface(cloud);
    shot.compute(*out.descriptors);
    times.descriptors += elapsed_ms(t);

    t = Clock::now();
    pcl::BOARDLocalReferenceFrameEstimation<PclPoint, PclNormal, PclFrame> board;
    board.setFindHoles(true);
    board.setRadiusSearch(params.lrf_radius);
    board.setInputCloud(out.keypoints);
    board.setInputNormals(out.normals);
    board.setSearchSurface(cloud);
    board.compute(*out.frames);
    times.lrf += elapsed_ms(t);
    return out;
}

PclResult pcl_recognize(const PclFeatures& model, const pcl::PointCloud<PclPoint>::ConstPtr& scene,
                        const PclParams& params, int threads)
{
    PclResult out;
    out.scene = pcl_features(scene, params.scene_sampling, params, threads, out.times);

    // The tutorial's matching: a kd-tree over the model descriptors (built here, as the tutorial
    // does, and as ours builds its tree per call), each finite scene descriptor's nearest neighbour.
    auto t = Clock::now();
    pcl::KdTreeFLANN<PclDescriptor> match_search;
    match_search.setInputCloud(model.descriptors);
    std::vector<int> index(1);
    std::vector<float> distance(1);
    for (std::size_t i = 0; i < out.scene.descriptors->size(); ++i) {
        const PclDescriptor& d = (*out.scene.descriptors)[i];
        if (!std::isfinite(d.descriptor[0])) continue;  // skipping NaNs
        const int found = match_search.nearestKSearch(d, 1, index, distance);
        if (found == 1 && distance[0] < params.match_threshold) {
            out.correspondences->push_back(pcl::Correspondence(index[0], int(i), distance[0]));
        }
    }
    out.times.match = elapsed_ms(t);

    t = Clock::now();
    pcl::Hough3DGrouping<PclPoint, PclPoint, PclFrame, PclFrame> clusterer;
    clusterer.setHoughBinSize(params.hough_bin);
    clusterer.setHoughThreshold(params.hough_threshold);
    clusterer.setUseInterpolation(true);
    clusterer.setUseDistanceWeight(false);
    clusterer.setInputCloud(model.keypoints);
    clusterer.setInputRf(model.frames);
    clusterer.setSceneCloud(out.scene.keypoints);
    clusterer.setSceneRf(out.scene.frames);
    clusterer.setModelSceneCorrespondences(out.correspondences);
    clusterer.recognize(out.poses, out.clustered);
    out.times.group = elapsed_ms(t);
    return out;
}

}  // namespace mfpc::bench
