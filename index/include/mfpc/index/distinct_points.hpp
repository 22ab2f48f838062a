#pragma once

/// @file
/// @brief Exact duplicate points found in linear time, so that neighbour searches can collapse them
/// before they see them.

#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc {

/// @brief Where each point's position first occurs in a cloud.
///
/// Exact duplicates (the same three floats; +0 and -0 alike) carry no geometry, but every
/// neighbourhood search pays for each of them: m copies of one position make an m x m search. A
/// caller collapses them with first() before it searches.
struct DistinctPoints {
    /// first[i] is the index of the first point at point i's position (i itself for a point seen
    /// for the first time). Empty when every position is distinct, the common case.
    std::vector<std::uint32_t> first;
    std::size_t count = 0;  ///< The number of distinct positions.

    /// @brief Whether no position occurs twice.
    /// @return True when first is empty.
    bool all_distinct() const noexcept { return first.empty(); }
    /// @brief The indices of the first point at each distinct position, in increasing order.
    /// @return 0 .. n-1 when all are distinct.
    std::vector<std::uint32_t> representatives(std::size_t n) const;
};

/// @brief Finds the exact duplicates of a cloud: each point's bits hashed into an open-addressing
/// table, so expected O(n) whatever the duplicates (copies of one point cost one comparison each).
/// Serial, so the same result at any thread count.
/// @param points The cloud (fewer than 2^31 points).
/// @return Where each position first occurs.
DistinctPoints distinct_points(std::span<const Point> points);

}  // namespace mfpc
