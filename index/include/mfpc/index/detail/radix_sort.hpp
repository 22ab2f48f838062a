#pragma once

// Internal to mfpc: never installed (cmake/MfpcTargets.cmake skips detail/ folders) and included by
// no public header; on index's include path so that kernels/ can share it (voxel_grid).

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

namespace mfpc::detail {

// Stable LSD radix sort of `entries` by bits [low, low + bits) of key(entry), in 11-bit digits.
// With several threads each pass cuts the entries into blocks: the blocks count their digits in
// parallel, the counts become each block's start per digit (digit by digit, block by block), and
// each block scatters its own entries in order. A stable sort has one result, so the blocking,
// chosen by the thread count, cannot change it. With one thread there is one block, whose digit
// counts no pass changes, so they are all taken in one read.
template <class Entry, class Key>
void radix_sort(std::vector<Entry>& entries, int low, int bits, Key&& key)
{
    constexpr int digit_bits = 11;
    constexpr std::size_t buckets = std::size_t(1) << digit_bits;
    constexpr std::uint64_t digit_mask = buckets - 1;
    const std::size_t n = entries.size();
    const int passes = (bits + digit_bits - 1) / digit_bits;
    if (n < 2 || passes <= 0) return;
    const auto threads = std::size_t(std::min<std::size_t>(
        tbb::this_task_arena::max_concurrency(),
        tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism)));
    // Blocks of at least 16384 entries, at most 64 of them: few enough that the serial pass over
    // blocks x digits stays small beside the scatter.
    const std::size_t blocks = threads > 1 ? std::min<std::size_t>(64, (n + 16383) / 16384) : 1;
    const std::size_t block = (n + blocks - 1) / blocks;
    std::vector<std::uint32_t> starts(blocks * buckets * (blocks == 1 ? std::size_t(passes) : 1), 0);
    if (blocks == 1) {
        for (const Entry& entry : entries) {
            const std::uint64_t k = key(entry) >> low;
            for (int p = 0; p < passes; ++p) ++starts[std::size_t(p) * buckets + ((k >> (p * digit_bits)) & digit_mask)];
        }
    }
    std::vector<Entry> scratch(n);
    for (int p = 0; p < passes; ++p) {
        const int shift = low + p * digit_bits;
        std::uint32_t* const pass_starts = starts.data() + (blocks == 1 ? std::size_t(p) * buckets : 0);
        if (blocks > 1) {
            tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
                std::uint32_t* count = pass_starts + b * buckets;
                std::fill(count, count + buckets, 0u);
                for (std::size_t i = b * block, end = std::min(n, i + block); i < end; ++i)
                    ++count[(key(entries[i]) >> shift) & digit_mask];
            });
        }
        std::uint32_t sum = 0;
        bool shared = false;  // one digit in every entry: the pass would move nothing
        for (std::size_t d = 0; d < buckets; ++d) {
            const std::uint32_t digit_start = sum;
            for (std::size_t b = 0; b < blocks; ++b) sum += std::exchange(pass_starts[b * buckets + d], sum);
            shared |= sum - digit_start == n;
        }
        if (shared) continue;
        tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
            std::uint32_t* start = pass_starts + b * buckets;
            for (std::size_t i = b * block, end = std::min(n, i + block); i < end; ++i)
                scratch[start[(key(entries[i]) >> shift) & digit_mask]++] = entries[i];
        });
        entries.swap(scratch);
    }
}

// The indices 0..n-1 in ascending order of key_of(i), ties in index order, into `order`, and
// their keys in that order into `keys`; keys take key_bits bits. Key and index share one 64-bit
// word when they fit (they do but for huge extents): half the memory traffic of pairs.
template <class KeyOf>
void sort_by_key(std::size_t n, int key_bits, KeyOf&& key_of, std::vector<std::uint32_t>& order,
                 std::vector<std::uint64_t>& keys)
{
    order.resize(n);
    keys.resize(n);
    const tbb::blocked_range<std::size_t> all(0, n, 4096);
    const int index_bits = int(std::bit_width(n > 1 ? n - 1 : 0));
    if (key_bits + index_bits <= 64) {
        tbb::parallel_for(all, [&](const auto& range) {
            for (std::size_t i = range.begin(); i < range.end(); ++i)
                keys[i] = (std::uint64_t(key_of(i)) << index_bits) | std::uint64_t(i);
        });
        radix_sort(keys, index_bits, key_bits, [](std::uint64_t entry) { return entry; });
        const std::uint64_t index_mask = (std::uint64_t(1) << index_bits) - 1;
        tbb::parallel_for(all, [&](const auto& range) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                order[i] = std::uint32_t(keys[i] & index_mask);
                keys[i] >>= index_bits;
            }
        });
    } else {
        std::vector<std::pair<std::uint64_t, std::uint32_t>> pairs(n);
        tbb::parallel_for(all, [&](const auto& range) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) pairs[i] = {key_of(i), std::uint32_t(i)};
        });
        radix_sort(pairs, 0, key_bits, [](const auto& entry) { return entry.first; });
        tbb::parallel_for(all, [&](const auto& range) {
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                keys[i] = pairs[i].first;
                order[i] = pairs[i].second;
            }
        });
    }
}

}  // namespace mfpc::detail
