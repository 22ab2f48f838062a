#include "clusters.hpp"

#include <algorithm>
#include <numeric>

#include "mfpc/core/detail/slot_table.hpp"

namespace mfpc::detail {

std::vector<std::vector<std::uint32_t>> clusters_of(std::span<const Point> points,
                                                    std::span<const std::uint32_t> members, float gap)
{
    std::vector<std::uint32_t> parent(members.size());
    std::iota(parent.begin(), parent.end(), 0u);
    auto root = [&](std::uint32_t i) {
        while (parent[i] != i) i = parent[i] = parent[parent[i]];
        return i;
    };
    // Cells a hair wider than gap, so that a pair the float test passes lies at most one cell apart
    // on each axis: the subtraction's rounding (2^-24 of gap) and the division's (2^-53 of the
    // quotient, under 2^-21 of a cell while quotients stay under 2^31 cells, as the floor of the
    // edge keeps them) both fit in the 2^-20 the edge adds. With cells of edge gap exactly, points
    // rounding puts two cells apart can still pass the test. A cell may now hold points farther than
    // gap apart, which the joins within a cell allow for.
    double extent = 0;
    for (const std::uint32_t m : members) extent = std::max(extent, double(points[m].cwiseAbs().maxCoeff()));
    const double edge = std::max(double(gap) * (1.0 + 0x1p-20), extent * 0x1p-31);
    using Cell = Eigen::Matrix<std::int64_t, 3, 1>;  // quotients reach 2^31, and a neighbour one past
    // floor() by truncation (std::floor is a call without SSE4.1).
    auto floor_of = [](double x) {
        const auto t = std::int64_t(x);
        return t - std::int64_t(x < double(t));
    };
    auto cell_of = [&](const Point& p) {
        return Cell(floor_of(double(p.x()) / edge), floor_of(double(p.y()) / edge), floor_of(double(p.z()) / edge));
    };
    // Cells that share a key share a list; every pair in it is checked by distance all the same.
    auto key_of = [](const Cell& c) {
        return (std::uint64_t(c.x()) & 0x1fffff) << 42 | (std::uint64_t(c.y()) & 0x1fffff) << 21 |
               (std::uint64_t(c.z()) & 0x1fffff);
    };
    // The cells numbered as first met, and each cell's members side by side in increasing order (a
    // counting sort): a flat table, where a map of lists spent most of the search allocating them.
    std::vector<Cell> cell(members.size());
    std::vector<std::uint32_t> cell_number(members.size()), count;
    detail::SlotTable table(members.size());
    for (std::uint32_t i = 0; i < members.size(); ++i) {
        cell[i] = cell_of(points[members[i]]);
        const auto [number, added] = table.find_or_add(key_of(cell[i]), std::uint32_t(count.size()));
        if (added) count.push_back(0);
        ++count[number];
        cell_number[i] = number;
    }
    std::vector<std::uint32_t> start(count.size() + 1, 0);
    for (std::size_t c = 0; c < count.size(); ++c) start[c + 1] = start[c] + count[c];
    std::vector<std::uint32_t> by_cell(members.size());
    std::vector<std::uint32_t> cursor(start.begin(), start.end() - 1);
    std::vector<Cell> cell_at(count.size());  // each numbered cell's coordinates
    for (std::uint32_t i = 0; i < members.size(); ++i) {
        by_cell[cursor[cell_number[i]]++] = i;
        cell_at[cell_number[i]] = cell[i];
    }
    // The 13 neighbour cells after each cell (offsets above zero, in x then y then z), looked up
    // once per cell rather than once per member.
    constexpr int forward = 13;
    std::vector<std::uint32_t> neighbours(count.size() * forward, detail::SlotTable::none);
    for (std::size_t c = 0; c < count.size(); ++c) {
        int n = 0;
        for (int dx = 0; dx <= 1; ++dx)
            for (int dy = dx ? -1 : 0; dy <= 1; ++dy)
                for (int dz = dx || dy ? -1 : 0; dz <= 1; ++dz)
                    if (dx || dy || dz) neighbours[c * forward + n++] = table.find(key_of(cell_at[c] + Cell(dx, dy, dz)));
    }
    // The lower index roots, so the components are the same whatever the order of the joins.
    auto join = [&](std::uint32_t i, std::uint32_t j) {
        const std::uint32_t a = root(i), b = root(j);
        if (a != b) parent[std::max(a, b)] = std::min(a, b);
    };
    auto within = [&](std::uint32_t i, std::uint32_t j) {
        return !((points[members[j]] - points[members[i]]).cwiseAbs().array() > gap).any();
    };
    // Every pair the test joins, but tested only while it could join two components. Two points
    // of one cell are within gap of each other but near its faces, so each member is first held
    // against its cell's first, and against the rest of the cell only when that fails.
    for (std::size_t c = 0; c < count.size(); ++c) {
        const std::uint32_t first = by_cell[start[c]];
        for (std::uint32_t k = start[c] + 1; k < start[c + 1]; ++k) {
            const std::uint32_t i = by_cell[k];
            if (within(first, i)) {
                join(first, i);
                continue;
            }
            for (std::uint32_t l = start[c]; l < start[c + 1]; ++l)
                if (by_cell[l] != i && root(by_cell[l]) != root(i) && within(i, by_cell[l])) join(i, by_cell[l]);
        }
    }
    // Then each member against the 13 neighbour cells after its own (a pair's other member would
    // find this one in a cell before its own), skipping the points already in its component: most
    // cells are one component by now, so one point within gap joins all of it.
    for (std::uint32_t i = 0; i < members.size(); ++i) {
        const std::uint32_t own = cell_number[i];
        std::uint32_t component = root(i);
        for (int n = 0; n < forward; ++n) {
            const std::uint32_t near = neighbours[std::size_t(own) * forward + std::size_t(n)];
            if (near == detail::SlotTable::none) continue;
            for (std::uint32_t k = start[near]; k < start[near + 1]; ++k) {
                const std::uint32_t j = by_cell[k];
                if (root(j) == component || !within(i, j)) continue;
                join(i, j);
                component = root(i);
            }
        }
    }
    std::vector<std::vector<std::uint32_t>> clusters;
    std::vector<std::int64_t> slot(members.size(), -1);
    for (std::uint32_t i = 0; i < members.size(); ++i) {
        const std::uint32_t r = root(i);
        if (slot[r] < 0) {
            slot[r] = std::int64_t(clusters.size());
            clusters.emplace_back();
        }
        clusters[std::size_t(slot[r])].push_back(members[i]);
    }
    return clusters;
}

}  // namespace mfpc::detail
