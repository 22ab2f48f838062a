#pragma once

// Internal to mfpc: never installed (cmake/MfpcTargets.cmake skips detail/ folders) and included by
// no public header; on kernels' include path so that recognition/ can share it. Float and 32-bit
// integer lanes in GCC/Clang vector extensions, one type for every width: 4 lanes are one SSE2
// register on x86-64 (NEON on arm64), 8 lanes one AVX register in a function compiled for AVX and
// two SSE halves elsewhere, scalar code where there is neither. Arithmetic, comparisons (-1 in every
// lane where they hold, 0 elsewhere) and __builtin_shufflevector are the compiler's; this adds the
// unaligned loads and stores, and what the SHOT and BOARD kernels share.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <type_traits>

namespace mfpc::detail {

template <typename T, std::size_t N>
struct LaneVector {
    static_assert(std::has_single_bit(N), "vector extensions take a power of two lanes");
    using type [[gnu::vector_size(N * sizeof(T))]] = T;
};

// N float lanes, and N 32-bit integer lanes (what comparing float lanes gives).
template <std::size_t N>
using FloatLanes = typename LaneVector<float, N>::type;
template <std::size_t N>
using IntLanes = typename LaneVector<std::int32_t, N>::type;

// The width of the SHOT and BOARD loops and of foveation's axis lanes: one SSE2 register, which
// every x86-64 machine has.
constexpr std::size_t lanes = 4;
using Float4 = FloatLanes<lanes>;
using Int4 = IntLanes<lanes>;
// Descriptor matching's width: one AVX register where the function is compiled for AVX.
using Float8 = FloatLanes<8>;
using Int8 = IntLanes<8>;

// The lanes of v from p and back, p unaligned, at any width. v by reference: a vector wider than
// 16 bytes returned by value from a function not compiled for AVX changes the ABI (GCC warns, Clang
// refuses), and matching's 8 lanes are used in such functions. The bytes go through a local of the
// vector type: copied to or from the reference directly, GCC 12 moved them as integers (vmovdqu
// into float arithmetic), no longer the code that matching was measured with.
template <typename V, typename T>
inline void load(V& v, const T* p)
{
    static_assert(std::is_same_v<std::remove_cvref_t<decltype(v[0])>, T>, "lanes of another type");
    V local;
    std::memcpy(&local, p, sizeof local);
    v = local;
}
template <typename T, typename V>
inline void store(T* p, const V& v)
{
    static_assert(std::is_same_v<std::remove_cvref_t<decltype(v[0])>, T>, "lanes of another type");
    const V local = v;
    std::memcpy(p, &local, sizeof local);
}

// Four lanes from p by value, which a 16-byte vector can be everywhere.
inline Float4 load(const float* p)
{
    Float4 v;
    load(v, p);
    return v;
}
inline Int4 load(const std::int32_t* p)
{
    Int4 v;
    load(v, p);
    return v;
}

inline Float4 abs4(Float4 v) { return std::bit_cast<Float4>(std::bit_cast<Int4>(v) & 0x7fffffff); }

// The polynomial with these coefficients (highest degree first), each scaled by `scale` and
// rounded to float, evaluated at x by Horner's rule in float.
template <std::size_t N>
inline Float4 horner(Float4 x, const double (&coefficients)[N], double scale)
{
    Float4 p = Float4{} + float(coefficients[0] * scale);
    for (std::size_t i = 1; i < N; ++i) p = p * x + float(coefficients[i] * scale);
    return p;
}

}  // namespace mfpc::detail
