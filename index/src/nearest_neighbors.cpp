#include "mfpc/index/nearest_neighbors.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include <flann/flann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/index/distinct_points.hpp"

namespace mfpc {

namespace {

// The distance from each of `points` (all distinct) to its nearest other point, summed in fixed
// blocks reduced in order so that the sum is the same at any thread count; `counted(i)` says
// whether point i's distance enters the sum.
template <class Counted>
double sum_of_nearest(std::span<const Point> points, Counted&& counted)
{
    // Point is packed float xyz, so the cloud is already the row-major n x 3 matrix FLANN reads.
    const flann::Matrix<float> dataset(const_cast<float*>(points.data()->data()), points.size(), 3);
    flann::Index<flann::L2_Simple<float>> tree(dataset, flann::KDTreeSingleIndexParams(15));
    tree.buildIndex();

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
        // The first neighbour is the point itself (the points are distinct), the second the
        // nearest other point.
        for (std::size_t i = 0; i < count; ++i)
            if (counted(begin + i)) sum += std::sqrt(double(distances[i * 2 + 1]));
        block_sums[b] = sum;
    });
    double total = 0.0;
    for (double s : block_sums) total += s;
    return total;
}

}  // namespace

double mean_spacing(std::span<const Point> points)
{
    if (points.size() < 2) return 0.0;
    for (std::size_t i = 0; i < points.size(); ++i) {
        // FLANN's tree build recurses on splits that overflow beyond this range (and on NaN).
        if (!within_coordinate_range(points[i])) {
            throw Error("mean spacing", "point " + std::to_string(i) + " is not finite or has a coordinate beyond ±" +
                                            max_coordinate_text);
        }
    }
    // Duplicates are at distance 0 from a copy and would make the exact search quadratic (m copies
    // of one position each visit all m): search the distinct positions only.
    const DistinctPoints distinct = distinct_points(points);
    if (distinct.all_distinct()) return sum_of_nearest(points, [](std::size_t) { return true; }) / double(points.size());
    if (distinct.count < 2) return 0.0;
    const std::vector<std::uint32_t> heads = distinct.representatives(points.size());
    std::vector<std::uint32_t> copies(points.size(), 0);
    for (std::uint32_t f : distinct.first) ++copies[f];
    std::vector<Point> positions;
    positions.reserve(heads.size());
    for (std::uint32_t h : heads) positions.push_back(points[h]);
    // A position held once contributes its distance; every point of a repeated one contributes 0.
    const double total = sum_of_nearest(positions, [&](std::size_t i) { return copies[heads[i]] == 1; });
    return total / double(points.size());
}

}  // namespace mfpc
