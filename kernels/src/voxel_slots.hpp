#pragma once

#include <bit>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace mfpc::detail {

// Numbers the occupied voxels (or cubes) of a grid in the order they are first met: the slot of
// voxel (i, j, k), relative to the lowest voxel of the range and each below 2^21, creating it when
// new. A dense array over the voxel range when that range is small next to the member count, else
// an open-addressing hash of the packed key; both give the same slots.
class VoxelSlots {
public:
    static constexpr std::uint32_t none = std::numeric_limits<std::uint32_t>::max();

    VoxelSlots(const Eigen::Matrix<std::int64_t, 3, 1>& extent, std::size_t members) : extent_(extent)
    {
        // Whichever table is smaller to clear: 4 bytes a dense cell, 12 bytes a hash entry (two
        // per member).
        const double cells = double(extent[0]) * double(extent[1]) * double(extent[2]);
        if (4.0 * cells <= 12.0 * double(std::bit_ceil(members * 2)) + 16384.0) {
            dense_.assign(std::size_t(cells), none);
        } else {
            capacity_ = std::bit_ceil(members * 2);
            shift_ = 64 - std::countr_zero(capacity_);
            keys_.assign(capacity_, empty_key);
            slots_.resize(capacity_);
        }
    }

    // The slot of voxel (i, j, k); `next` is the slot a new voxel gets. Returns {slot, is_new}.
    inline std::pair<std::uint32_t, bool> find(std::int64_t i, std::int64_t j, std::int64_t k, std::uint32_t next)
    {
        if (!dense_.empty()) {
            std::uint32_t& slot = dense_[std::size_t((i * extent_[1] + j) * extent_[2] + k)];
            if (slot != none) return {slot, false};
            slot = next;
            return {next, true};
        }
        const std::uint64_t key = (std::uint64_t(i) << 42) | (std::uint64_t(j) << 21) | std::uint64_t(k);
        std::size_t h = std::size_t((key * 0x9E3779B97F4A7C15ull) >> shift_);
        while (keys_[h] != key && keys_[h] != empty_key) h = (h + 1) & (capacity_ - 1);
        if (keys_[h] == key) return {slots_[h], false};
        keys_[h] = key;
        slots_[h] = next;
        return {next, true};
    }

private:
    static constexpr std::uint64_t empty_key = std::numeric_limits<std::uint64_t>::max();
    Eigen::Matrix<std::int64_t, 3, 1> extent_;
    std::vector<std::uint32_t> dense_;
    std::size_t capacity_ = 0;
    int shift_ = 0;
    std::vector<std::uint64_t> keys_;
    std::vector<std::uint32_t> slots_;
};

}  // namespace mfpc::detail
