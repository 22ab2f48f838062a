#include "mfpc/index/distinct_points.hpp"

#include <algorithm>
#include <bit>
#include <numeric>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

// The bits of a coordinate with -0 read as +0: equal floats, equal bits.
std::uint32_t coordinate_bits(float value) { return value == 0.0f ? 0u : std::bit_cast<std::uint32_t>(value); }

// A strong mix of the three coordinates (the finaliser of a 64-bit hash): nearby points, which
// differ in low mantissa bits, spread over the whole table.
std::uint64_t position_hash(const Point& p)
{
    std::uint64_t h = (std::uint64_t(coordinate_bits(p.x())) << 32 | coordinate_bits(p.y())) * 0x9e3779b97f4a7c15ull;
    h ^= coordinate_bits(p.z()) * 0xc2b2ae3d27d4eb4full;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdull;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ull;
    h ^= h >> 33;
    return h;
}

bool same_position(const Point& a, const Point& b)
{
    return a.x() == b.x() && a.y() == b.y() && a.z() == b.z();
}

}  // namespace

std::vector<std::uint32_t> DistinctPoints::representatives(std::size_t n) const
{
    std::vector<std::uint32_t> out;
    out.reserve(first.empty() ? n : count);
    for (std::size_t i = 0; i < n; ++i)
        if (first.empty() || first[i] == i) out.push_back(std::uint32_t(i));
    return out;
}

DistinctPoints distinct_points(std::span<const Point> points)
{
    const std::size_t n = points.size();
    if (n >= (std::size_t(1) << 31)) throw Error("distinct points", "clouds of 2^31 points or more are not supported");
    DistinctPoints result;
    result.count = n;
    if (n < 2) return result;

    // Open addressing, at most half full: slot -> 1 + the first index at a position (0: empty).
    // Points go in in index order, so the index a slot keeps is the first; m copies of a point all
    // land on its slot and cost one comparison each. Serial, in batches whose slots are fetched
    // ahead (the table is larger than the caches): a few milliseconds for a 640x480 scan, less
    // than sorting by hash took at any thread count.
    const std::size_t slots = std::bit_ceil(2 * n);
    const std::size_t mask = slots - 1;
    std::vector<std::uint32_t> table(slots, 0);
    constexpr std::size_t batch = 32;
    std::size_t slot_of[batch];
    for (std::size_t begin = 0; begin < n; begin += batch) {
        const std::size_t end = std::min(n, begin + batch);
        for (std::size_t i = begin; i < end; ++i) {
            slot_of[i - begin] = std::size_t(position_hash(points[i])) & mask;
            __builtin_prefetch(&table[slot_of[i - begin]]);
        }
        for (std::size_t i = begin; i < end; ++i) {
            const Point& p = points[i];
            for (std::size_t slot = slot_of[i - begin];; slot = (slot + 1) & mask) {
                const std::uint32_t held = table[slot];
                if (held == 0) {
                    table[slot] = std::uint32_t(i + 1);
                    break;
                }
                if (!same_position(points[held - 1], p)) continue;
                if (result.first.empty()) {
                    result.first.resize(n);
                    std::iota(result.first.begin(), result.first.end(), 0u);
                }
                result.first[i] = held - 1;
                --result.count;
                break;
            }
        }
    }
    return result;
}

}  // namespace mfpc
