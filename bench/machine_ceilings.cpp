#include "machine_ceilings.hpp"

#include <immintrin.h>

#include <chrono>
#include <cstddef>
#include <cstring>
#include <memory>
#include <thread>
#include <vector>

namespace mfpc::bench {
namespace {

using Clock = std::chrono::steady_clock;

// Runs body(thread) on `threads` threads at once; returns the wall-clock seconds of the whole.
template <class Body>
double run_side_by_side(int threads, Body body)
{
    const auto start = Clock::now();
    std::vector<std::thread> workers;
    for (int t = 0; t < threads; ++t) workers.emplace_back(body, t);
    for (std::thread& w : workers) w.join();
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// Twelve independent chains: enough to cover the multiply-add latency on both FMA ports of
// current x86 cores (4 cycles x 2 ports needs 8).
constexpr int chains = 12;

__attribute__((target("avx512f"))) float fma_avx512(std::size_t iterations)
{
    __m512 acc[chains];
    for (int c = 0; c < chains; ++c) acc[c] = _mm512_set1_ps(float(c));
    const __m512 a = _mm512_set1_ps(0.999999f), b = _mm512_set1_ps(1e-7f);
    for (std::size_t i = 0; i < iterations; ++i)
        for (int c = 0; c < chains; ++c) acc[c] = _mm512_fmadd_ps(acc[c], a, b);
    alignas(64) float lanes[16];
    float sum = 0;
    for (int c = 0; c < chains; ++c) {
        _mm512_store_ps(lanes, acc[c]);
        for (float v : lanes) sum += v;
    }
    return sum;
}

__attribute__((target("avx2,fma"))) float fma_avx2(std::size_t iterations)
{
    __m256 acc[chains];
    for (int c = 0; c < chains; ++c) acc[c] = _mm256_set1_ps(float(c));
    const __m256 a = _mm256_set1_ps(0.999999f), b = _mm256_set1_ps(1e-7f);
    for (std::size_t i = 0; i < iterations; ++i)
        for (int c = 0; c < chains; ++c) acc[c] = _mm256_fmadd_ps(acc[c], a, b);
    alignas(32) float lanes[8];
    float sum = 0;
    for (int c = 0; c < chains; ++c) {
        _mm256_store_ps(lanes, acc[c]);
        for (float v : lanes) sum += v;
    }
    return sum;
}

float mul_add_sse2(std::size_t iterations)
{
    __m128 acc[chains];
    for (int c = 0; c < chains; ++c) acc[c] = _mm_set1_ps(float(c));
    const __m128 a = _mm_set1_ps(0.999999f), b = _mm_set1_ps(1e-7f);
    for (std::size_t i = 0; i < iterations; ++i)
        for (int c = 0; c < chains; ++c) acc[c] = _mm_add_ps(_mm_mul_ps(acc[c], a), b);
    alignas(16) float lanes[4];
    float sum = 0;
    for (int c = 0; c < chains; ++c) {
        _mm_store_ps(lanes, acc[c]);
        for (float v : lanes) sum += v;
    }
    return sum;
}

double measure_gflops(int threads, const char*& isa)
{
    float (*kernel)(std::size_t) = mul_add_sse2;
    int lanes = 4;
    isa = "SSE2 mul+add";
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx512f")) {
        kernel = fma_avx512;
        lanes = 16;
        isa = "AVX-512 FMA";
    } else if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) {
        kernel = fma_avx2;
        lanes = 8;
        isa = "AVX2 FMA";
    }
    constexpr std::size_t iterations = 4'000'000;
    std::vector<float> sink(std::size_t(threads), 0.0f);
    double best = 0;
    for (int pass = 0; pass < 4; ++pass) {
        const double seconds = run_side_by_side(threads, [&](int t) { sink[std::size_t(t)] += kernel(iterations); });
        const double flops = double(threads) * double(iterations) * chains * lanes * 2.0;
        best = std::max(best, flops / seconds * 1e-9);
    }
    volatile float keep = sink[0];
    (void)keep;
    return best;
}

double measure_bandwidth(int threads)
{
    // 256 MiB per array: well past the last-level cache of any current x86 socket. Each thread
    // first touches its own share, so its pages are local to it.
    constexpr std::size_t count = std::size_t(64) << 20;
    std::unique_ptr<float[]> a(new float[count]);
    std::unique_ptr<float[]> b(new float[count]);
    const std::size_t share = count / std::size_t(threads);
    auto slice = [&](int t) { return std::size_t(t) * share; };
    auto length = [&](int t) { return t + 1 == threads ? count - slice(t) : share; };
    run_side_by_side(threads, [&](int t) {
        for (std::size_t i = slice(t); i < slice(t) + length(t); ++i) a[i] = float(i & 1023);
        std::memset(b.get() + slice(t), 0, length(t) * sizeof(float));
    });
    double best = 0;
    for (int pass = 0; pass < 5; ++pass) {
        const double seconds = run_side_by_side(threads, [&](int t) {
            std::memcpy(b.get() + slice(t), a.get() + slice(t), length(t) * sizeof(float));
        });
        best = std::max(best, 2.0 * double(count * sizeof(float)) / seconds * 1e-9);
    }
    volatile float keep = b[count / 2];
    (void)keep;
    return best;
}

}  // namespace

Ceilings measure_ceilings(int threads)
{
    Ceilings c;
    c.threads = threads;
    c.bandwidth_gbs = measure_bandwidth(threads);
    c.gflops = measure_gflops(threads, c.isa);
    return c;
}

}  // namespace mfpc::bench
