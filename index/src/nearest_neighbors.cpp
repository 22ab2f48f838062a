#include "mfpc/index/nearest_neighbors.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <flann/flann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace mfpc {

double mean_spacing(std::span<const Point> points)
{
    if (points.size() < 2) return 0.0;
    // Point is packed float xyz, so the cloud is already the row-major n x 3 matrix FLANN reads.
    const flann::Matrix<float> dataset(const_cast<float*>(points.data()->data()), points.size(), 3);
    flann::Index<flann::L2_Simple<float>> tree(dataset, flann::KDTreeSingleIndexParams(15));
    tree.buildIndex();

    // Fixed-size blocks reduced in block order keep the sum identical at any thread count.
    constexpr std::size_t block = 4096;
    const std::size_t blocks = (points.size() + block - 1) / block;
    std::vector<double> block_sums(blocks, 0.0);
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
        const std::size_t begin = b * block;
        const std::size_t count = std::min(block, points.size() - begin);
        const flann::Matrix<float> queries(const_cast<float*>(points[begin].data()), count, 3);
        std::vector<int> indices(count * 2);
        std::vector<float> distances(count * 2);
        flann::Matrix<int> index_matrix(indices.data(), count, 2);
        flann::Matrix<float> distance_matrix(distances.data(), count, 2);
        flann::SearchParams search(flann::FLANN_CHECKS_UNLIMITED);
        tree.knnSearch(queries, index_matrix, distance_matrix, 2, search);
        double sum = 0.0;
        for (std::size_t i = 0; i < count; ++i) {
            // The first neighbour is the point itself, unless a duplicate took its place; either
            // way the second distance is the nearest other point.
            sum += std::sqrt(double(distances[i * 2 + 1]));
        }
        block_sums[b] = sum;
    });
    double total = 0.0;
    for (double s : block_sums) total += s;
    return total / double(points.size());
}

}  // namespace mfpc
