#pragma once

// Private to kernels/: four float lanes in GCC/Clang vector extensions (SSE2 on x86-64, NEON on
// arm64, scalar code elsewhere), shared by the SHOT and BOARD kernels.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace mfpc::detail {

constexpr std::size_t lanes = 4;
using Float4 = float __attribute__((vector_size(16)));
using Int4 = std::int32_t __attribute__((vector_size(16)));

inline Float4 load(const float* p)
{
    Float4 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline Int4 load(const std::int32_t* p)
{
    Int4 v;
    std::memcpy(&v, p, sizeof v);
    return v;
}
inline void store(float* p, Float4 v) { std::memcpy(p, &v, sizeof v); }

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
