#include "mfpc/recognition/matching.hpp"

#include <algorithm>
#include <memory>
#include <string>

#include <flann/flann.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "mfpc/core/error.hpp"
#include "mfpc/kernels/shot.hpp"

namespace mfpc {

std::vector<Correspondence> match_descriptors(const Features& model, const Features& scene, const MatchParams& params)
{
    if (!(params.threshold > 0.0f)) throw Error("match_descriptors", "match_threshold must be positive");
    if (params.k < 1) throw Error("match_descriptors", "match k must be at least 1");
    if (!params.exact && (params.trees < 1 || params.checks < 1))
        throw Error("match_descriptors", "approximate matching needs trees >= 1 and checks >= 1");
    if (model.size() == 0 || scene.size() == 0) return {};

    const bool model_to_scene = params.direction == MatchDirection::model_to_scene;
    const Features& indexed = model_to_scene ? scene : model;
    const Features& queried = model_to_scene ? model : scene;
    const int k = model_to_scene ? std::min<int>(params.k, int(indexed.size())) : 1;

    const flann::Matrix<float> data(const_cast<float*>(indexed.descriptors.data()), indexed.size(), shot_size);
    std::unique_ptr<flann::Index<flann::L2<float>>> index;
    if (params.exact) {
        index = std::make_unique<flann::Index<flann::L2<float>>>(data, flann::KDTreeSingleIndexParams(15));
    } else {
        // Seeding fixes FLANN's split choices; its input shuffle uses std::random_device, so
        // approximate matches can still differ from run to run (the README says so).
        flann::seed_random(1);
        index = std::make_unique<flann::Index<flann::L2<float>>>(data, flann::KDTreeIndexParams(params.trees));
    }
    index->buildIndex();

    std::vector<int> found(queried.size() * std::size_t(k), -1);
    std::vector<float> distances(queried.size() * std::size_t(k), 0.0f);
    const flann::SearchParams search(params.exact ? flann::FLANN_CHECKS_UNLIMITED : params.checks);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queried.size(), 64), [&](const auto& range) {
        const std::size_t count = range.end() - range.begin();
        flann::Matrix<float> queries(const_cast<float*>(queried.descriptors.data()) + range.begin() * shot_size, count,
                                     shot_size);
        flann::Matrix<int> indices(found.data() + range.begin() * std::size_t(k), count, std::size_t(k));
        flann::Matrix<float> dists(distances.data() + range.begin() * std::size_t(k), count, std::size_t(k));
        flann::SearchParams local = search;
        local.cores = 1;
        index->knnSearch(queries, indices, dists, std::size_t(k), local);
    });

    std::vector<Correspondence> out;
    for (std::size_t q = 0; q < queried.size(); ++q) {
        for (int j = 0; j < k; ++j) {
            const int hit = found[q * std::size_t(k) + std::size_t(j)];
            const float d2 = distances[q * std::size_t(k) + std::size_t(j)];
            if (hit < 0 || !(d2 < params.threshold)) continue;
            out.push_back(model_to_scene ? Correspondence{std::uint32_t(q), std::uint32_t(hit), d2}
                                         : Correspondence{std::uint32_t(hit), std::uint32_t(q), d2});
        }
    }
    std::sort(out.begin(), out.end(), [](const Correspondence& a, const Correspondence& b) {
        return a.model != b.model ? a.model < b.model : a.scene < b.scene;
    });
    return out;
}

}  // namespace mfpc
