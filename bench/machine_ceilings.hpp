#pragma once

// The machine's two ceilings, measured in the benchmark's own run, and the floor they put under a
// stage (issue 31): the time the bytes a stage must touch would take at the measured memory
// bandwidth, or its arithmetic at the measured peak, whichever is longer. A stage's time over its
// floor says how far it is from what this machine allows.

#include <algorithm>

namespace mfpc::bench {

/// @brief What this machine sustains with a number of threads, measured now.
struct Ceilings {
    int threads = 1;
    /// A STREAM-like copy (b[i] = a[i]) of arrays far larger than any cache, each thread its
    /// share; bytes counted as STREAM does (read plus written). GB/s.
    double bandwidth_gbs = 0;
    /// Single-precision fused multiply-adds on independent registers at the widest vector width
    /// this CPU runs (AVX-512, else AVX2 with FMA, else SSE2 multiply and add), each thread its own
    /// chain; 2 flops per multiply-add. GFLOP/s.
    double gflops = 0;
    const char* isa = "";  ///< The vector instructions the peak was measured with.
};

/// @brief Measures both ceilings with `threads` threads running at once (best of a few passes).
/// @param threads How many threads copy and compute side by side.
/// @return The ceilings.
Ceilings measure_ceilings(int threads);

/// @brief The compulsory work of one run of a stage: the bytes it must read and write at least once,
/// and the floating-point operations its formulas need at least.
struct StageWork {
    double bytes = 0;
    double flops = 0;
};

/// @brief The floor of a stage on this machine: max(bytes / bandwidth, flops / peak).
/// @param work The stage's compulsory work.
/// @param c The ceilings at the stage's thread count.
/// @return Milliseconds.
inline double floor_ms(const StageWork& work, const Ceilings& c)
{
    const double memory = c.bandwidth_gbs > 0 ? work.bytes / (c.bandwidth_gbs * 1e6) : 0.0;
    const double arithmetic = c.gflops > 0 ? work.flops / (c.gflops * 1e6) : 0.0;
    return std::max(memory, arithmetic);
}

/// @brief Which ceiling sets the floor.
/// @param work The stage's compulsory work.
/// @param c The ceilings at the stage's thread count.
/// @return "memory" or "arith".
inline const char* floor_bound(const StageWork& work, const Ceilings& c)
{
    const double memory = c.bandwidth_gbs > 0 ? work.bytes / (c.bandwidth_gbs * 1e6) : 0.0;
    const double arithmetic = c.gflops > 0 ? work.flops / (c.gflops * 1e6) : 0.0;
    return memory >= arithmetic ? "memory" : "arith";
}

}  // namespace mfpc::bench
