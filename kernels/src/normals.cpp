#include "mfpc/kernels/normals.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

// The normals of `queries` from their k nearest among the points of `source` (a NeighborGrid or an
// OrganizedNeighbors: the same answers, found differently).
template <class Source>
void normals_from(std::span<const Point> queries, const Source& source, const NormalParams& params,
                  std::span<Point> normals)
{
    const std::span<const Point> surface = source.points();
    if (normals.size() != queries.size())
        throw Error("estimate_normals", "normals has " + std::to_string(normals.size()) + " entries for " +
                                            std::to_string(queries.size()) + " query points");
    if (params.k < 3) throw Error("estimate_normals", "k must be at least 3, got " + std::to_string(params.k));
    if (!params.viewpoint.allFinite()) throw Error("estimate_normals", "the viewpoint is not finite");

    const Point undefined = Point::Constant(std::numeric_limits<float>::quiet_NaN());
    const std::size_t k = std::min<std::size_t>(std::size_t(params.k), surface.size());
    if (k < 3) {
        std::fill(normals.begin(), normals.end(), undefined);
        return;
    }
    // Neighbours in batches (a grid's queries that share a cell share their candidates; the depth
    // image's prefetch ahead), then one PCA per query; batches bound the neighbour buffer. 2^14
    // queries (about 2 MB of buffers at k = 30) keep it in cache and its pages few: a fresh page
    // costs microseconds on a virtual machine, and at 2^16 (8 MB a buffer, faulted in on each
    // call) recognize()'s normals took 1.6-1.8 times longer on milk_pair; 2^12 and 2^13 pay the
    // batch searches' set-up more often.
    constexpr std::size_t batch = 1 << 14;
    std::vector<std::uint32_t> neighbours(std::min(batch, queries.size()) * k);
    std::vector<float> squared_distances(neighbours.size());
    for (std::size_t offset = 0; offset < queries.size(); offset += batch) {
        const std::size_t count = std::min(batch, queries.size() - offset);
        source.knn_search_batch(queries.subspan(offset, count), int(k),
                                std::span<std::uint32_t>(neighbours).first(count * k),
                                std::span<float>(squared_distances).first(count * k));
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 1024), [&](const auto& range) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                const std::uint32_t* own = neighbours.data() + i * k;
                // Double precision and a two-pass covariance: PCL's single-pass float covariance
                // loses digits far from the origin; ours is the value PCL approximates.
                Eigen::Vector3d mean = Eigen::Vector3d::Zero();
                for (std::size_t j = 0; j < k; ++j) mean += surface[own[j]].cast<double>();
                mean /= double(k);
                Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
                for (std::size_t j = 0; j < k; ++j) {
                    const Eigen::Vector3d d = surface[own[j]].cast<double>() - mean;
                    covariance.noalias() += d * d.transpose();
                }
                covariance /= double(k);
                Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
                solver.computeDirect(covariance);
                // Neighbours at one spot or on one line (a single scan row) span no plane: two
                // eigenvalues vanish, to within what the closed-form solver resolves (about 1e-9
                // of the largest; a scan row measured 4e-9). PCL gives NaN there too.
                const Eigen::Vector3d eigenvalues = solver.eigenvalues();
                const Point& query = queries[offset + i];
                if (!(eigenvalues(1) > 1e-7 * eigenvalues(2))) {
                    normals[offset + i] = undefined;
                    continue;
                }
                Point normal = solver.eigenvectors().col(0).cast<float>();  // smallest eigenvalue first
                if ((params.viewpoint - query).dot(normal) < 0.0f) normal = -normal;
                normals[offset + i] = normal;
            }
        });
    }
}

}  // namespace

void estimate_normals(std::span<const Point> queries, const NeighborGrid& surface, const NormalParams& params,
                      std::span<Point> normals)
{
    normals_from(queries, surface, params, normals);
}

void estimate_normals(std::span<const Point> queries, const OrganizedNeighbors& surface, const NormalParams& params,
                      std::span<Point> normals)
{
    normals_from(queries, surface, params, normals);
}

void orient_normals(std::span<Point> normals, std::span<const Point> reference)
{
    if (normals.size() != reference.size())
        throw Error("orient_normals", "one reference normal per normal is needed (" + std::to_string(normals.size()) +
                                          " normals, " + std::to_string(reference.size()) + " references)");
    for (std::size_t i = 0; i < normals.size(); ++i)
        if (reference[i].allFinite() && normals[i].dot(reference[i]) < 0.0f) normals[i] = -normals[i];
}

}  // namespace mfpc
