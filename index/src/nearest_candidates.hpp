#pragma once

// Private to index/: the k-best list shared by the grid and the organized k-nearest searches.

#include <algorithm>
#include <cassert>
#include <cstdint>
#include <utility>
#include <vector>

namespace mfpc::detail {

// (squared distance, point index): ordered so that ties go to the lower index.
using Candidate = std::pair<float, std::uint32_t>;

// Keeps `best` the sorted `want` smallest candidates seen. For the small k of normal estimation an
// insertion from the back beats a heap (and vector::insert, whose memmove call cost more than the
// few moves it makes), and most candidates fail the first compare.
// want must be positive: callers return before searching when no neighbour is wanted.
inline void keep_nearest(std::vector<Candidate>& best, std::size_t want, const Candidate& candidate)
{
    assert(want > 0);
    if (best.size() == want) {
        // Most candidates are farther than the k-th best: one float compare, not the pair's.
        if (candidate.first > best.back().first || !(candidate < best.back())) return;
    } else {
        best.push_back(candidate);
    }
    std::size_t i = best.size() - 1;
    for (; i > 0 && candidate < best[i - 1]; --i) best[i] = best[i - 1];
    best[i] = candidate;
}

}  // namespace mfpc::detail
