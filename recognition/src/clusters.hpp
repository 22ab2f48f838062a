#pragma once

// The connected components automatic placement splits a scene into. Private to the recognition
// module; declared here so that the tests can hold it against the definition.

#include <cstdint>
#include <span>
#include <vector>

#include "mfpc/core/point_cloud.hpp"

namespace mfpc::detail {

// Connected components of the (finite) points `members` names: two join when they lie within `gap` of each
// other on every axis (|a - b| <= gap per coordinate, as float arithmetic gives it). Components
// come in the order of their lowest member, each listing its members in increasing order. Exactly
// the components of that pairwise test, found through cells a hair wider than `gap`.
std::vector<std::vector<std::uint32_t>> clusters_of(std::span<const Point> points,
                                                    std::span<const std::uint32_t> members, float gap);

}  // namespace mfpc::detail
