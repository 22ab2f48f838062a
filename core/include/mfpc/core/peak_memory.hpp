#pragma once

/// @file
/// @brief The process's peak resident memory, for the memory figures of runs and benchmarks.

#include <cstddef>

namespace mfpc {

/// @brief Starts a new measurement of the process's peak resident memory.
///
/// On Linux the kernel's high-water mark (VmHWM) is reset to the current resident size, so that
/// peak_memory_bytes() afterwards is the peak of what ran in between. Where the reset is not
/// possible it does nothing, and the peak is the process's since it started.
/// @return Whether the mark was reset.
bool reset_peak_memory();

/// @brief The process's peak resident memory in bytes since it started or since the last
/// successful reset_peak_memory(); 0 when the system does not say.
///
/// Read from the kernel's VmHWM; where there is no /proc, getrusage's peak, which cannot be reset.
/// @return The peak in bytes, or 0.
std::size_t peak_memory_bytes();

}  // namespace mfpc
