#pragma once

// Internal to MFPC (shared by its modules, not installed).

#include <algorithm>
#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace mfpc::detail {

// Numbers 64-bit keys (any but all ones) by the slots their callers give them when first added:
// open addressing with Fibonacci hashing and linear probing, kept at most half full by growing.
// Shared by the voxel tables of downsampling and sampling and by the Hough bins of grouping.
class SlotTable {
public:
    static constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();

    // Room for `expected` keys without growing.
    explicit SlotTable(std::size_t expected = 0) { allocate(capacity_for(expected)); }

    // The entries `expected` keys take (12 bytes each): what a caller weighs against other tables.
    static std::size_t capacity_for(std::size_t expected) { return std::bit_ceil(std::max<std::size_t>(expected, 8) * 2); }

    // The slot of `key`, or none.
    std::uint32_t find(std::uint64_t key) const
    {
        std::size_t h = home(key);
        while (keys_[h] != key && keys_[h] != empty) h = (h + 1) & mask_;
        return keys_[h] == key ? slots_[h] : none;
    }

    // The slot of `key`, which becomes `next` when the key is new: {slot, is_new}.
    std::pair<std::uint32_t, bool> find_or_add(std::uint64_t key, std::uint32_t next)
    {
        std::size_t h = home(key);
        while (keys_[h] != key && keys_[h] != empty) h = (h + 1) & mask_;
        if (keys_[h] == key) return {slots_[h], false};
        if (2 * (used_ + 1) > keys_.size()) {
            grow();
            h = home(key);
            while (keys_[h] != empty) h = (h + 1) & mask_;
        }
        keys_[h] = key;
        slots_[h] = next;
        ++used_;
        return {next, true};
    }

private:
    static constexpr std::uint64_t empty = std::numeric_limits<std::uint64_t>::max();

    std::size_t home(std::uint64_t key) const { return std::size_t((key * 0x9E3779B97F4A7C15ull) >> shift_); }

    void allocate(std::size_t capacity)
    {
        keys_.assign(capacity, empty);
        slots_.resize(capacity);
        mask_ = capacity - 1;
        shift_ = 64 - std::countr_zero(capacity);
    }

    void grow()
    {
        std::vector<std::uint64_t> keys = std::move(keys_);
        std::vector<std::uint32_t> slots = std::move(slots_);
        allocate(keys.size() * 2);
        for (std::size_t e = 0; e < keys.size(); ++e) {
            if (keys[e] == empty) continue;
            std::size_t h = home(keys[e]);
            while (keys_[h] != empty) h = (h + 1) & mask_;
            keys_[h] = keys[e];
            slots_[h] = slots[e];
        }
    }

    std::vector<std::uint64_t> keys_;
    std::vector<std::uint32_t> slots_;
    std::size_t used_ = 0;
    std::size_t mask_ = 0;
    int shift_ = 64;
};

}  // namespace mfpc::detail
