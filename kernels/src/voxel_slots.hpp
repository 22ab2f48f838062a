#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "mfpc/core/detail/slot_table.hpp"

namespace mfpc::detail {

// Numbers the occupied voxels (or cubes) of a grid in the order they are first met: the slot of
// voxel (i, j, k), relative to the lowest voxel of the range and each below 2^21, creating it when
// new. A dense array over the voxel range when that range is small next to the member count, else
// a SlotTable of the packed key; both give the same slots.
class VoxelSlots {
public:
    static constexpr std::uint32_t none = SlotTable::none;

    VoxelSlots(const Eigen::Matrix<std::int64_t, 3, 1>& extent, std::size_t members) : extent_(extent)
    {
        // Whichever table is smaller to clear: 4 bytes a dense cell, 12 bytes a hash entry.
        const double cells = double(extent[0]) * double(extent[1]) * double(extent[2]);
        if (4.0 * cells <= 12.0 * double(SlotTable::capacity_for(members)) + 16384.0) {
            dense_.assign(std::size_t(cells), none);
        } else {
            hashed_ = SlotTable(members);
        }
    }

    // The slot of voxel (i, j, k); `next` is the slot a new voxel gets. Returns {slot, is_new}.
    // Forced inline: GCC 12 called it out of line from the one-shot foveate's member loop.
    __attribute__((always_inline)) inline std::pair<std::uint32_t, bool> find(std::int64_t i, std::int64_t j,
                                                                              std::int64_t k, std::uint32_t next)
    {
        if (!dense_.empty()) {
            std::uint32_t& slot = dense_[std::size_t((i * extent_[1] + j) * extent_[2] + k)];
            if (slot != none) return {slot, false};
            slot = next;
            return {next, true};
        }
        return hashed_.find_or_add((std::uint64_t(i) << 42) | (std::uint64_t(j) << 21) | std::uint64_t(k), next);
    }

private:
    Eigen::Matrix<std::int64_t, 3, 1> extent_;
    std::vector<std::uint32_t> dense_;
    SlotTable hashed_;  // at its smallest unless used
};

}  // namespace mfpc::detail
