// Over 600 lines on purpose: one structure. Its queries (radius, shell-ordered k nearest, nearest
// within a radius, batched k nearest, neighbourhood lists) share the row lookup and the shell
// walk, templates defined in this file so that every query inlines them; split across files they
// would move to a header every query includes, for no gain in what each file says.

#include "mfpc/index/neighbor_grid.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <tuple>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include "mfpc/core/error.hpp"
#include "mfpc/core/detail/floor.hpp"
#include "nearest_candidates.hpp"
#include "mfpc/index/detail/radix_sort.hpp"

namespace mfpc {
namespace {

constexpr std::uint64_t empty_row = std::numeric_limits<std::uint64_t>::max();

// Fibonacci hashing: the top bits of the product mix every bit of the key.
inline std::uint64_t hash_key(std::uint64_t key, int shift) { return (key * 0x9E3779B97F4A7C15ull) >> shift; }

}  // namespace

NeighborGrid::NeighborGrid(std::span<const Point> points, float cell_size)
    : points_(points), cell_size_(cell_size), inverse_cell_(1.0f / cell_size)
{
    if (!(cell_size > 0.0f) || !std::isfinite(cell_size))
        throw Error("neighbour grid", "cell size must be a positive number, got " + format_number(cell_size));
    if (points.size() >= std::numeric_limits<std::uint32_t>::max())
        throw Error("neighbour grid", "more than 2^32 - 1 points");
    if (points.empty()) return;

    // Each point's cell is recomputed where it is needed (three floors) rather than stored: a cell
    // array was 12 bytes a point of fresh memory to fill and read back, more than the floors cost.
    const auto cell_of = [inverse = inverse_cell_](const Point& p) {
        const Eigen::Vector3f q = p * inverse;
        return Eigen::Vector3i(floor_to<int>(q.x()), floor_to<int>(q.y()), floor_to<int>(q.z()));
    };
    struct Bounds {
        Eigen::Vector3i lo = Eigen::Vector3i::Constant(std::numeric_limits<int>::max());
        Eigen::Vector3i hi = Eigen::Vector3i::Constant(std::numeric_limits<int>::min());
    };
    const Bounds bounds = tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, points.size(), 4096), Bounds{},
        [&](const auto& range, Bounds b) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                const Eigen::Vector3f q = points[i] * inverse_cell_;
                // Also false for NaN.
                if (!(std::abs(q.x()) <= 1e9f && std::abs(q.y()) <= 1e9f && std::abs(q.z()) <= 1e9f))
                    throw Error("neighbour grid", "point " + std::to_string(i) +
                                                      " is not finite or lies more than 1e9 cells of " +
                                                      format_number(cell_size_) + " m from the origin");
                const Eigen::Vector3i c = cell_of(points[i]);
                b.lo = b.lo.cwiseMin(c);
                b.hi = b.hi.cwiseMax(c);
            }
            return b;
        },
        [](const Bounds& a, const Bounds& b) { return Bounds{a.lo.cwiseMin(b.lo), a.hi.cwiseMax(b.hi)}; });
    min_cell_ = bounds.lo;
    max_cell_ = bounds.hi;
    // Below 2^31 cells per axis: every cell lies within 1e9 cells of the origin.
    const Eigen::Vector3i extent = max_cell_ - min_cell_;
    row_length_ = std::uint64_t(extent.x()) + 1;
    rows_per_slice_ = std::uint64_t(extent.y()) + 1;
    const std::uint64_t row_count_bound = rows_per_slice_ * (std::uint64_t(extent.z()) + 1);  // below 2^62
    // Cells are numbered row-major over the occupied extent when the numbers fit 64 bits, as they
    // do for any cloud but one with points kilometres apart on two or three axes (a stray point).
    dense_keys_ = row_count_bound <= std::numeric_limits<std::uint64_t>::max() / row_length_;

    // Points ordered by (cell, index), so by (z, y, x) of their cells. Dense keys take 20-30 bits
    // on a room-sized scene at millimetre cells, so a stable radix sort in 11-bit digits takes 2
    // or 3 passes, where a comparison sort took 10 times as long. Otherwise the points are sorted
    // by x, then by row: more passes, for the rare cloud that needs them. Stable from index order,
    // either breaks ties by index, whatever the thread count.
    std::vector<std::uint64_t> keys;  // the sorted points' cell numbers, when dense
    if (dense_keys_) {
        const int key_bits = int(std::bit_width(row_count_bound * row_length_ - 1));
        detail::sort_by_key(
            points.size(), key_bits, [&](std::size_t i) { return cell_key(cell_of(points[i])); }, ordered_indices_,
            keys);
        // Each cell's points are one run of the sorted order, starting where the key changes.
        for (std::size_t i = 0; i < keys.size(); ++i) {
            if (i == 0 || keys[i] != keys[i - 1]) cell_begin_.push_back(std::uint32_t(i));
        }
    } else {
        struct Entry {
            std::uint64_t row;
            std::uint32_t x;  // from min_cell_
            std::uint32_t index;
        };
        std::vector<Entry> entries(points.size());
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096), [&](const auto& range) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                const Eigen::Vector3i d = cell_of(points[i]) - min_cell_;
                entries[i] = {std::uint64_t(d.z()) * rows_per_slice_ + std::uint64_t(d.y()), std::uint32_t(d.x()),
                              std::uint32_t(i)};
            }
        });
        detail::radix_sort(entries, 0, int(std::bit_width(std::uint32_t(extent.x()))),
                           [](const Entry& e) { return std::uint64_t(e.x); });
        detail::radix_sort(entries, 0, int(std::bit_width(row_count_bound - 1)), [](const Entry& e) { return e.row; });
        ordered_indices_.resize(points.size());
        for (std::size_t i = 0; i < entries.size(); ++i) {
            ordered_indices_[i] = entries[i].index;
            if (i == 0 || entries[i].row != entries[i - 1].row || entries[i].x != entries[i - 1].x)
                cell_begin_.push_back(std::uint32_t(i));
        }
    }
    ordered_points_.resize(points.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096), [&](const auto& range) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) ordered_points_[i] = points[ordered_indices_[i]];
    });

    // Cell and row numbers from each cell's coordinates, where the keys would need a 64-bit
    // division each.
    std::size_t row_count = 0;
    std::vector<std::uint64_t> row_keys(cell_begin_.size());  // per cell
    cell_x_.resize(cell_begin_.size());
    for (std::size_t c = 0; c < cell_begin_.size(); ++c) {
        const Eigen::Vector3i cell = cell_of(ordered_points_[cell_begin_[c]]);
        row_keys[c] = std::uint64_t(cell.z() - min_cell_.z()) * rows_per_slice_ + std::uint64_t(cell.y() - min_cell_.y());
        if (c == 0 || row_keys[c] != row_keys[c - 1]) ++row_count;
        cell_x_[c] = cell.x();
    }
    cell_begin_.push_back(std::uint32_t(points.size()));

    const std::size_t table_size = std::bit_ceil(std::max<std::size_t>(16, row_count * 2));
    rows_.assign(table_size, Row{empty_row, 0, 0});
    row_mask_ = table_size - 1;
    row_shift_ = 64 - std::countr_zero(table_size);
    for (std::uint32_t begin = 0; begin < cell_x_.size();) {
        const std::uint64_t row_key = row_keys[begin];
        std::uint32_t end = begin + 1;
        while (end < cell_x_.size() && row_keys[end] == row_key) ++end;
        std::uint64_t slot = hash_key(row_key, row_shift_);
        while (rows_[slot].key != empty_row) slot = (slot + 1) & row_mask_;
        rows_[slot] = Row{row_key, begin, end};
        begin = end;
    }
}

std::uint64_t NeighborGrid::group_key(const Eigen::Vector3i& cell) const
{
    if (dense_keys_) return cell_key(cell);
    // The cell's place in cell order, which orders as the dense numbers would.
    const Row* row = find_row(cell.y(), cell.z());
    if (row == nullptr) return std::numeric_limits<std::uint64_t>::max();
    const auto first = cell_x_.begin() + row->cell_begin, last = cell_x_.begin() + row->cell_end;
    const auto at = std::lower_bound(first, last, cell.x());
    return at != last && *at == cell.x() ? std::uint64_t(at - cell_x_.begin())
                                         : std::numeric_limits<std::uint64_t>::max();
}

const NeighborGrid::Row* NeighborGrid::find_row(int y, int z) const
{
    if (y < min_cell_.y() || y > max_cell_.y() || z < min_cell_.z() || z > max_cell_.z()) return nullptr;
    const std::uint64_t key = std::uint64_t(z - min_cell_.z()) * rows_per_slice_ + std::uint64_t(y - min_cell_.y());
    std::uint64_t slot = hash_key(key, row_shift_);
    while (true) {
        const Row& row = rows_[slot];
        if (row.key == key) return &row;
        if (row.key == empty_row) return nullptr;
        slot = (slot + 1) & row_mask_;
    }
}

bool NeighborGrid::row_range(int y, int z, int x0, int x1, std::uint32_t& begin, std::uint32_t& end) const
{
    return cells_range(find_row(y, z), x0, x1, begin, end);
}

bool NeighborGrid::cells_range(const Row* row, int x0, int x1, std::uint32_t& begin, std::uint32_t& end) const
{
    if (row == nullptr || x1 < x0) return false;
    const auto first = cell_x_.begin() + row->cell_begin;
    const auto last = cell_x_.begin() + row->cell_end;
    const auto lo = std::lower_bound(first, last, x0);
    // The end by a forward scan: queries span a few cells, and each cell it passes holds points
    // the caller reads anyway, so this costs less than a second binary search.
    auto hi = lo;
    while (hi != last && *hi <= x1) ++hi;
    if (lo == hi) return false;
    begin = cell_begin_[std::size_t(lo - cell_x_.begin())];
    end = cell_begin_[std::size_t(hi - cell_x_.begin())];
    return true;
}

template <class Visit>
void NeighborGrid::for_each_search_range(const Point& center, float radius, Visit&& visit) const
{
    Eigen::Vector3i lo, hi;
    if (!search_box(center, radius, lo, hi)) return;
    for (int z = lo.z(); z <= hi.z(); ++z) {
        for (int y = lo.y(); y <= hi.y(); ++y) {
            std::uint32_t begin = 0, end = 0;
            if (row_range(y, z, lo.x(), hi.x(), begin, end)) visit(begin, end);
        }
    }
}

template <class Visit>
void NeighborGrid::for_each_shell_range(const Eigen::Vector3i& c, int ring, Visit&& visit) const
{
    // Rows outside the occupied range are empty: a wide shell around a far centre skips them.
    const int z_end = std::min(c.z() + ring, max_cell_.z()), y_end = std::min(c.y() + ring, max_cell_.y());
    for (int z = std::max(c.z() - ring, min_cell_.z()); z <= z_end; ++z) {
        const bool z_face = std::abs(z - c.z()) == ring;
        for (int y = std::max(c.y() - ring, min_cell_.y()); y <= y_end; ++y) {
            std::uint32_t begin = 0, end = 0;
            if (z_face || std::abs(y - c.y()) == ring) {
                if (row_range(y, z, c.x() - ring, c.x() + ring, begin, end)) visit(begin, end);
            } else {  // ring > 0 here: ring 0 is all face
                if (row_range(y, z, c.x() - ring, c.x() - ring, begin, end)) visit(begin, end);
                if (row_range(y, z, c.x() + ring, c.x() + ring, begin, end)) visit(begin, end);
            }
        }
    }
}

float NeighborGrid::shell_margin(const Point& center, const Eigen::Vector3i& c, int ring) const
{
    const Eigen::Vector3f block_lo = (c.array() - ring).cast<float>() * cell_size_;
    const Eigen::Vector3f block_hi = (c.array() + ring + 1).cast<float>() * cell_size_;
    // Shrunk by a relative 1e-5: cell membership came from floor(p / cell) in float, which may put
    // a point a rounding error outside its nominal cell.
    return std::min((center - block_lo).minCoeff(), (block_hi - center).minCoeff()) -
           1e-5f * (center.cwiseAbs().maxCoeff() + cell_size_);
}

bool NeighborGrid::search_box(const Point& center, float radius, Eigen::Vector3i& lo, Eigen::Vector3i& hi) const
{
    if (points_.empty() || !(radius >= 0.0f) || !center.allFinite()) return false;
    // Clamped in float before the int conversion, so a far-away centre cannot overflow it.
    const Eigen::Vector3f lo_f = ((center.array() - radius) * inverse_cell_).floor();
    const Eigen::Vector3f hi_f = ((center.array() + radius) * inverse_cell_).floor();
    lo = lo_f.cwiseMax(min_cell_.cast<float>()).cwiseMin(max_cell_.cast<float>() + Eigen::Vector3f::Ones()).cast<int>();
    hi = hi_f.cwiseMin(max_cell_.cast<float>()).cwiseMax(min_cell_.cast<float>() - Eigen::Vector3f::Ones()).cast<int>();
    return !(hi.array() < lo.array()).any();
}

void NeighborGrid::radius_search(const Point& center, float radius, std::vector<std::uint32_t>& indices,
                                 std::vector<float>& squared_distances) const
{
    indices.clear();
    squared_distances.clear();
    const float radius2 = radius * radius;
    // The candidates' ranges first, so the outputs grow once. Then every candidate is written and
    // only those within the radius are kept (the count moves past them): a branch per candidate,
    // taken about half the time on a surface, was mispredicted often enough to cost a quarter of
    // the search. The ranges are per thread, as knn_search's candidates: a query allocates
    // nothing once its thread has seen as many rows; they carry nothing from one query to the next.
    thread_local std::vector<std::pair<std::uint32_t, std::uint32_t>> ranges;
    ranges.clear();
    std::size_t candidates = 0;
    for_each_search_range(center, radius, [&](std::uint32_t begin, std::uint32_t end) {
        ranges.emplace_back(begin, end);
        candidates += end - begin;
    });
    indices.resize(candidates);
    squared_distances.resize(candidates);
    std::size_t found = 0;
    for (const auto& [begin, end] : ranges) {
        for (std::uint32_t i = begin; i < end; ++i) {
            const float d2 = detail::squared_distance(ordered_points_[i], center);
            indices[found] = ordered_indices_[i];
            squared_distances[found] = d2;
            found += d2 < radius2;
        }
    }
    indices.resize(found);
    squared_distances.resize(found);
}

std::size_t NeighborGrid::largest_cell() const
{
    std::size_t largest = 0;
    for (std::size_t c = 0; c + 1 < cell_begin_.size(); ++c)
        largest = std::max<std::size_t>(largest, cell_begin_[c + 1] - cell_begin_[c]);
    return largest;
}

std::size_t NeighborGrid::candidate_count(const Point& center, float radius) const
{
    std::size_t count = 0;
    for_each_search_range(center, radius, [&](std::uint32_t begin, std::uint32_t end) { count += end - begin; });
    return count;
}

Neighborhoods NeighborGrid::radius_neighborhoods(std::span<const Point> centers, float radius) const
{
    if (!(radius > 0.0f) || !std::isfinite(radius))
        throw Error("neighbour grid", "neighbourhood radius must be a positive number, got " + format_number(radius));
    Neighborhoods out;
    out.surface = points_;
    out.centers.assign(centers.begin(), centers.end());
    out.radius = radius;
    out.offsets.assign(centers.size() + 1, 0);
    const float radius2 = radius * radius;

    // Centres are grouped by the lowest cell of their search box, and a group reads the rows of
    // the boxes' union once, into coordinate arrays: the row lookups, most of a search's cost,
    // are shared (keypoints a centimetre apart share a box of 4 cm cells), and the distance loop
    // vectorises. Each centre then takes, row by row in radius_search's order, the candidates of
    // its own box, with radius_search's arithmetic and test: the same neighbours, in the same
    // order, with the same squared distances.
    struct Member {
        std::uint32_t center;
        Eigen::Vector3i lo, hi;
    };
    std::vector<Member> members;
    members.reserve(centers.size());
    if (centers.size() >= std::numeric_limits<std::uint32_t>::max())
        throw Error("neighbour grid", "more than 2^32 - 1 neighbourhood centres");
    for (std::uint32_t c = 0; c < std::uint32_t(centers.size()); ++c) {
        Eigen::Vector3i lo, hi;
        if (search_box(centers[c], radius, lo, hi)) members.push_back({c, lo, hi});
    }
    // By (z, y, x) of the lowest cell, then centre.
    tbb::parallel_sort(members.begin(), members.end(), [](const Member& a, const Member& b) {
        return std::tie(a.lo.z(), a.lo.y(), a.lo.x(), a.center) < std::tie(b.lo.z(), b.lo.y(), b.lo.x(), b.center);
    });
    std::vector<std::uint32_t> groups;  // start of each run of equal lowest cells, plus the end
    for (std::uint32_t i = 0; i < members.size(); ++i)
        if (i == 0 || members[i].lo != members[i - 1].lo) groups.push_back(i);
    groups.push_back(std::uint32_t(members.size()));

    // Fixed chunks of groups, each searched into its own lists, then copied to the centres' places:
    // the same result at any thread count.
    constexpr std::size_t chunk = 16;
    struct Part {
        std::vector<std::uint32_t> indices;
        std::vector<float> squared_distances;
        std::vector<std::pair<std::uint32_t, std::size_t>> starts;  // (centre, first entry)
    };
    std::vector<Part> parts((groups.size() - 1 + chunk - 1) / chunk);
    tbb::parallel_for(std::size_t(0), parts.size(), [&](std::size_t p) {
        struct Span {  // a row of the union, in the gathered candidates
            int y, z;
            std::uint32_t first_cell, last_cell;  // its cells in `cells`
            std::uint32_t end;                    // its candidates end here (they start at its first cell's)
        };
        std::vector<Span> rows;
        std::vector<std::pair<int, std::uint32_t>> cells;  // (x, first candidate), row by row
        std::vector<float> xs, ys, zs, d2s;
        std::vector<std::uint32_t> ids;
        Part& part = parts[p];
        const std::size_t group_end = std::min(groups.size() - 1, (p + 1) * chunk);
        for (std::size_t g = p * chunk; g < group_end; ++g) {
            const std::uint32_t first = groups[g], last = groups[g + 1];
            const Eigen::Vector3i lo = members[first].lo;
            Eigen::Vector3i hi = members[first].hi;
            for (std::uint32_t m = first + 1; m < last; ++m) hi = hi.cwiseMax(members[m].hi);
            rows.clear(), cells.clear(), xs.clear(), ys.clear(), zs.clear(), ids.clear();
            for (int z = lo.z(); z <= hi.z(); ++z) {
                for (int y = lo.y(); y <= hi.y(); ++y) {
                    const Row* row = find_row(y, z);
                    if (row == nullptr) continue;
                    const auto row_first = cell_x_.begin() + row->cell_begin;
                    const auto row_last = cell_x_.begin() + row->cell_end;
                    const auto c0 = std::lower_bound(row_first, row_last, lo.x());
                    const auto c1 = std::upper_bound(c0, row_last, hi.x());
                    if (c0 == c1) continue;
                    const std::uint32_t first_cell = std::uint32_t(cells.size());
                    for (auto c = c0; c != c1; ++c) {
                        cells.emplace_back(*c, std::uint32_t(ids.size()));
                        const std::size_t cell = std::size_t(c - cell_x_.begin());
                        for (std::uint32_t i = cell_begin_[cell]; i < cell_begin_[cell + 1]; ++i) {
                            xs.push_back(ordered_points_[i].x());
                            ys.push_back(ordered_points_[i].y());
                            zs.push_back(ordered_points_[i].z());
                            ids.push_back(ordered_indices_[i]);
                        }
                    }
                    rows.push_back({y, z, first_cell, std::uint32_t(cells.size()), std::uint32_t(ids.size())});
                }
            }
            for (std::uint32_t m = first; m < last; ++m) {
                const Member& member = members[m];
                const Point& center = centers[member.center];
                const float cx = center.x(), cy = center.y(), cz = center.z();
                part.starts.emplace_back(member.center, part.indices.size());
                for (const Span& row : rows) {
                    if (row.y > member.hi.y() || row.z > member.hi.z()) continue;
                    // The row's candidates up to the member's last cell along x.
                    std::uint32_t end = row.end;
                    for (std::uint32_t c = row.last_cell; c > row.first_cell && cells[c - 1].first > member.hi.x(); --c)
                        end = cells[c - 1].second;
                    const std::uint32_t begin = cells[row.first_cell].second;
                    // Distances in one loop (it vectorises), then the kept ones packed.
                    const float* x = xs.data() + begin;
                    const float* y = ys.data() + begin;
                    const float* z = zs.data() + begin;
                    const std::uint32_t count = end - begin;
                    d2s.resize(count);
                    float* d2 = d2s.data();
                    for (std::uint32_t j = 0; j < count; ++j) {
                        const float dx = x[j] - cx, dy = y[j] - cy, dz = z[j] - cz;
                        d2[j] = dx * dx + dy * dy + dz * dz;
                    }
                    std::size_t found = part.indices.size();
                    part.indices.resize(found + count);
                    part.squared_distances.resize(found + count);
                    std::uint32_t* out_index = part.indices.data();
                    float* out_d2 = part.squared_distances.data();
                    const std::uint32_t* id = ids.data() + begin;
                    for (std::uint32_t j = 0; j < count; ++j) {
                        out_index[found] = id[j];
                        out_d2[found] = d2[j];
                        found += d2[j] < radius2;
                    }
                    part.indices.resize(found);
                    part.squared_distances.resize(found);
                }
            }
        }
    });
    // Where the s-th centre's list of a part ends: where the next one's starts.
    auto list_end = [](const Part& part, std::size_t s) {
        return s + 1 < part.starts.size() ? part.starts[s + 1].second : part.indices.size();
    };
    // Counts into offsets, then every centre's list copied to its place.
    for (const Part& part : parts)
        for (std::size_t s = 0; s < part.starts.size(); ++s)
            out.offsets[part.starts[s].first + 1] = list_end(part, s) - part.starts[s].second;
    for (std::size_t i = 0; i < centers.size(); ++i) out.offsets[i + 1] += out.offsets[i];
    out.indices.resize(out.offsets.back());
    out.squared_distances.resize(out.offsets.back());
    tbb::parallel_for(std::size_t(0), parts.size(), [&](std::size_t p) {
        const Part& part = parts[p];
        for (std::size_t s = 0; s < part.starts.size(); ++s) {
            const auto [center, begin] = part.starts[s];
            const std::size_t end = list_end(part, s);
            const auto at = std::ptrdiff_t(out.offsets[center]);
            std::copy(part.indices.begin() + std::ptrdiff_t(begin), part.indices.begin() + std::ptrdiff_t(end),
                      out.indices.begin() + at);
            std::copy(part.squared_distances.begin() + std::ptrdiff_t(begin),
                      part.squared_distances.begin() + std::ptrdiff_t(end), out.squared_distances.begin() + at);
        }
    });
    return out;
}

bool Neighborhoods::is_of(std::span<const Point> points, std::span<const Point> at) const
{
    // No memcmp of empty spans: their data() may be null, which memcmp must not get.
    return surface.data() == points.data() && surface.size() == points.size() && centers.size() == at.size() &&
           (at.empty() || std::memcmp(centers.data(), at.data(), at.size() * sizeof(Point)) == 0);
}

void Neighborhoods::check_serves(std::span<const Point> points, std::span<const Point> at, float needed,
                                 const char* where, const char* what) const
{
    if (!is_of(points, at)) throw Error(where, "the support neighbourhoods are of other keypoints or another surface");
    if (radius < needed)
        throw Error(where, "the support neighbourhoods reach " + format_number(radius) + ", " + what + " need " +
                               format_number(needed));
}

void Neighborhoods::within(std::size_t center, float r, std::vector<std::uint32_t>& indices_out,
                           std::vector<float>& squared_out) const
{
    if (!(r <= radius))
        throw Error("neighbour grid", "neighbourhoods of radius " + format_number(radius) + " cannot give radius " +
                                          format_number(r));
    const auto found = indices_of(center);
    const auto squared = squared_distances_of(center);
    if (r == radius) {
        indices_out.assign(found.begin(), found.end());
        squared_out.assign(squared.begin(), squared.end());
        return;
    }
    // The bound radius_search uses; the subsequence keeps its (cell, index) order.
    const float r2 = r * r;
    indices_out.clear();
    squared_out.clear();
    for (std::size_t i = 0; i < found.size(); ++i) {
        if (squared[i] < r2) {
            indices_out.push_back(found[i]);
            squared_out.push_back(squared[i]);
        }
    }
}

void NeighborGrid::knn_search(const Point& center, int k, std::vector<std::uint32_t>& indices,
                              std::vector<float>& squared_distances) const
{
    indices.clear();
    squared_distances.clear();
    if (points_.empty() || k <= 0) return;
    // A point not finite has no nearest points (its distances are all NaN or infinite), and its
    // cell does not fit an int.
    if (!center.allFinite()) throw Error("neighbour grid", "a k-nearest query is not finite");
    const std::size_t want = std::min<std::size_t>(std::size_t(k), points_.size());

    // The best `want` candidates so far. Per thread, so that a query allocates nothing once the
    // thread has seen a k this large.
    thread_local std::vector<detail::Candidate> best;
    best.clear();
    best.reserve(want + 1);
    auto consider = [&](std::uint32_t begin, std::uint32_t end) {
        for (std::uint32_t i = begin; i < end; ++i)
            detail::keep_nearest(best, want, {detail::squared_distance(ordered_points_[i], center), ordered_indices_[i]});
    };

    const Eigen::Vector3f cf = (center * inverse_cell_).array().floor();
    const Eigen::Vector3i c = cf.cwiseMax(min_cell_.cast<float>() - Eigen::Vector3f::Constant(2.0f))
                                  .cwiseMin(max_cell_.cast<float>() + Eigen::Vector3f::Constant(2.0f))
                                  .cast<int>();
    // Shells of cells at Chebyshev distance 0, 1, 2, ... from the centre's cell, until the k-th
    // candidate is closer than anything outside the block. Each shell costs a row lookup per row
    // it crosses, so a centre far from its k-th neighbour (an outlier, or a grid with a few far
    // points) would pay rings^3 lookups: once they would cost more than reading every point, every
    // point is read instead. The k nearest are the same: keep_nearest does not depend on the order.
    const int max_ring = std::max((c - min_cell_).cwiseAbs().maxCoeff(), (max_cell_ - c).cwiseAbs().maxCoeff());
    const std::size_t budget = points_.size() / 8 + 64;
    std::size_t lookups = 0;
    for (int ring = 0; ring <= max_ring; ++ring) {
        const Eigen::Vector3i lo = (c.array() - ring).max(min_cell_.array());
        const Eigen::Vector3i hi = (c.array() + ring).min(max_cell_.array());
        lookups += std::size_t(std::max(0, hi.y() - lo.y() + 1)) * std::size_t(std::max(0, hi.z() - lo.z() + 1));
        if (lookups > budget) {
            best.clear();
            consider(0, std::uint32_t(points_.size()));
            break;
        }
        for_each_shell_range(c, ring, consider);
        if (best.size() < want) continue;
        const float margin = shell_margin(center, c, ring);
        if (margin > 0.0f && best.back().first < margin * margin) break;
    }
    indices.reserve(best.size());
    squared_distances.reserve(best.size());
    for (const auto& [d2, index] : best) {
        indices.push_back(index);
        squared_distances.push_back(d2);
    }
}

bool NeighborGrid::nearest(const Point& center, float radius, std::uint32_t& index, float& squared_distance_out) const
{
    if (points_.empty() || !(radius >= 0.0f)) return false;
    const float radius2 = radius * radius;
    const Eigen::Vector3f cf = (center * inverse_cell_).array().floor();
    if (!cf.allFinite() || (cf.array() < (min_cell_.cast<float>().array() - 1.0f - radius * inverse_cell_)).any() ||
        (cf.array() > (max_cell_.cast<float>().array() + 1.0f + radius * inverse_cell_)).any())
        return false;  // farther than the radius from every cell
    // Clamped as in knn_search: with a huge radius the centre may be far outside the grid, and its
    // cell (and the neighbours of it) must still fit an int. A clamped cell only widens the box.
    const Eigen::Vector3i c = cf.cwiseMax(min_cell_.cast<float>() - Eigen::Vector3f::Constant(2.0f))
                                  .cwiseMin(max_cell_.cast<float>() + Eigen::Vector3f::Constant(2.0f))
                                  .cast<int>();
    bool found = false;
    float best = radius2;
    auto consider = [&](std::uint32_t begin, std::uint32_t end) {
        for (std::uint32_t i = begin; i < end; ++i) {
            const float d2 = detail::squared_distance(ordered_points_[i], center);
            if (d2 < best || (found && d2 == best && ordered_indices_[i] < index)) {
                if (!(d2 < radius2)) continue;
                found = true;
                best = d2;
                index = ordered_indices_[i];
            }
        }
    };
    // The centre's own cell first: on a surface its nearest point is usually a fraction of a cell
    // away, and then only the few cells within that distance remain, not whole shells around it
    // (ICP and verification ask this of every model point, many times over).
    const Row* own_row = find_row(c.y(), c.z());
    std::uint32_t begin = 0, end = 0;
    if (cells_range(own_row, c.x(), c.x(), begin, end)) consider(begin, end);
    // Widened by a relative 1e-5, as shell_margin is narrowed: floor(p / cell) in float may put a
    // point a rounding error outside its nominal cell.
    const float slack = 1e-5f * (center.cwiseAbs().maxCoeff() + cell_size_);
    const float reach = (found ? std::sqrt(best) : radius) * (1.0f + 1e-5f) + slack;
    // Clamped to the occupied cells in float before the int conversion, as in radius_search.
    const Eigen::Vector3i lo = ((center.array() - reach) * inverse_cell_)
                                   .floor()
                                   .max(min_cell_.cast<float>().array())
                                   .min(max_cell_.cast<float>().array() + 1.0f)
                                   .cast<int>();
    const Eigen::Vector3i hi = ((center.array() + reach) * inverse_cell_)
                                   .floor()
                                   .min(max_cell_.cast<float>().array())
                                   .max(min_cell_.cast<float>().array() - 1.0f)
                                   .cast<int>();
    // How far the centre lies from cells y (or z) along that axis.
    auto gap = [&](int cell, float coordinate) {
        const float below = float(cell) * cell_size_ - coordinate, above = coordinate - float(cell + 1) * cell_size_;
        return std::max(0.0f, std::max(below, above));
    };
    for (int z = lo.z(); z <= hi.z(); ++z) {
        const float gap_z = gap(z, center.z());
        for (int y = lo.y(); y <= hi.y(); ++y) {
            // A row farther than the best so far holds no nearer point: skipped unlooked. "Farther"
            // with the box's own widening (relative to the distance, and to the coordinates), since
            // a point's cell and a cell's edge each round at the magnitude of the coordinates.
            const float gap_y = gap(y, center.y());
            const float limit = std::sqrt(best) * (1.0f + 1e-5f) + slack;
            if (found && gap_y * gap_y + gap_z * gap_z > limit * limit) continue;
            if (y == c.y() && z == c.z()) {  // the centre's row, less its cell
                if (cells_range(own_row, lo.x(), c.x() - 1, begin, end)) consider(begin, end);
                if (cells_range(own_row, c.x() + 1, hi.x(), begin, end)) consider(begin, end);
            } else if (row_range(y, z, lo.x(), hi.x(), begin, end)) {
                consider(begin, end);
            }
        }
    }
    if (found) squared_distance_out = best;
    return found;
}

void NeighborGrid::knn_search_batch(std::span<const Point> queries, int k, std::span<std::uint32_t> indices,
                                    std::span<float> squared_distances) const
{
    const std::size_t want = k <= 0 ? 0 : std::min<std::size_t>(std::size_t(k), points_.size());
    if (indices.size() != queries.size() * want || squared_distances.size() != queries.size() * want)
        throw Error("neighbour grid", "knn_search_batch needs min(k, size) outputs per query");
    if (want == 0 || queries.empty()) return;
    detail::check_finite_queries(queries);

    // Queries grouped by their cell; a query outside the grid's cell range gets a group of its own,
    // and so does one in an empty cell when cells are not numbered densely.
    constexpr std::uint64_t outside = std::numeric_limits<std::uint64_t>::max();
    std::vector<std::pair<std::uint64_t, std::uint32_t>> order(queries.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 4096), [&](const auto& range) {
        for (std::size_t i = range.begin(); i < range.end(); ++i) {
            const Eigen::Vector3f c = (queries[i] * inverse_cell_).array().floor();
            std::uint64_t key = outside;
            if (c.allFinite() && (c.array() >= min_cell_.cast<float>().array()).all() &&
                (c.array() <= max_cell_.cast<float>().array()).all())
                key = group_key(c.cast<int>());
            order[i] = {key, std::uint32_t(i)};
        }
    });
    tbb::parallel_sort(order.begin(), order.end());
    std::vector<std::uint32_t> groups;  // start of each run of equal keys, plus the end
    for (std::uint32_t i = 0; i < order.size(); ++i)
        if (i == 0 || order[i].first != order[i - 1].first || order[i].first == outside) groups.push_back(i);
    groups.push_back(std::uint32_t(order.size()));

    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, groups.size() - 1, 16), [&](const auto& range) {
        // Candidates of the current block, as separate coordinate arrays so the distance loop
        // vectorises; the arithmetic is detail::squared_distance()'s, lane by lane, so results are equal.
        std::vector<float> xs, ys, zs, d2s;
        std::vector<std::uint32_t> ids;
        std::vector<std::uint64_t> keys;
        std::vector<std::uint32_t> one_indices;
        std::vector<float> one_distances;
        std::vector<std::pair<std::uint64_t, std::uint32_t>> pending, next_pending;
        constexpr int max_batch_ring = 6;
        for (std::size_t g = range.begin(); g < range.end(); ++g) {
            const std::uint32_t first = groups[g], last = groups[g + 1];
            auto fall_back = [&](std::uint32_t q) {
                knn_search(queries[q], int(want), one_indices, one_distances);
                std::copy(one_indices.begin(), one_indices.end(), indices.begin() + std::ptrdiff_t(q * want));
                std::copy(one_distances.begin(), one_distances.end(),
                          squared_distances.begin() + std::ptrdiff_t(q * want));
            };
            if (order[first].first == outside) {
                for (std::uint32_t i = first; i < last; ++i) fall_back(order[i].second);
                continue;
            }
            const Eigen::Vector3i c = (queries[order[first].second] * inverse_cell_).array().floor().cast<int>();
            xs.clear(), ys.clear(), zs.clear(), ids.clear();
            auto gather = [&](std::uint32_t begin, std::uint32_t end) {
                for (std::uint32_t i = begin; i < end; ++i) {
                    xs.push_back(ordered_points_[i].x());
                    ys.push_back(ordered_points_[i].y());
                    zs.push_back(ordered_points_[i].z());
                    ids.push_back(ordered_indices_[i]);
                }
            };
            // The block grows shell by shell for the queries it cannot yet answer (a sparse region
            // needs a wider block than a dense one), up to a limit past which knn_search takes over.
            pending.assign(order.begin() + first, order.begin() + last);
            float previous_kth = std::numeric_limits<float>::infinity();
            for (int ring = 0; !pending.empty(); ++ring) {
                if (ring > max_batch_ring) {
                    for (const auto& entry : pending) fall_back(entry.second);
                    break;
                }
                for_each_shell_range(c, ring, gather);
                const std::size_t count = ids.size();
                if (count < want) continue;
                d2s.resize(count);
                keys.resize(count);
                next_pending.clear();
                for (const auto& entry : pending) {
                    const std::uint32_t q = entry.second;
                    const Point& center = queries[q];
                    const float cx = center.x(), cy = center.y(), cz = center.z();
                    for (std::size_t j = 0; j < count; ++j) {
                        const float dx = xs[j] - cx, dy = ys[j] - cy, dz = zs[j] - cz;
                        d2s[j] = dx * dx + dy * dy + dz * dz;
                    }
                    // knn_search's stopping rule (the k-th nearest closer than the block's margin)
                    // holds when at least k candidates are that close, and the k nearest are then
                    // among them: only those are ranked, so the answer is knn_search's.
                    const float margin = shell_margin(center, c, ring);
                    const float limit = margin > 0.0f ? margin * margin : 0.0f;
                    auto take_closer = [&](float bound) {
                        std::size_t close = 0;
                        for (std::size_t j = 0; j < count; ++j) {  // without a branch: most fail the test
                            keys[close] = detail::candidate_key(d2s[j], ids[j]);
                            close += d2s[j] < bound;
                        }
                        return close;
                    };
                    // Ranking is most of the cost (60% of the search for the 30 nearest on a resampled
                    // surface, by perf), so a first try ranks only the candidates within 1.2 times the
                    // previous query's squared k-th distance (queries of one cell have about the
                    // same), and the margin's set when that holds fewer than k (1.2 measured 8%
                    // faster than 1.5 on a Kinect scene's resampled surface, 1.1 no faster).
                    std::size_t close = take_closer(std::min(limit, 1.2f * previous_kth));
                    if (close < want && 1.2f * previous_kth < limit) close = take_closer(limit);
                    if (close < want) {
                        next_pending.push_back(entry);
                        continue;
                    }
                    detail::select_smallest(std::span<std::uint64_t>(keys).first(close), want);
                    previous_kth = detail::candidate_of(keys[want - 1]).first;
                    for (std::size_t j = 0; j < want; ++j) {
                        const detail::Candidate nearest = detail::candidate_of(keys[j]);
                        indices[q * want + j] = nearest.second;
                        squared_distances[q * want + j] = nearest.first;
                    }
                }
                pending.swap(next_pending);
            }
        }
    });
}

}  // namespace mfpc

