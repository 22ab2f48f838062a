#include "mfpc/kernels/shot.hpp"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Eigenvalues>
#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include "atan_fit.hpp"
#include "mfpc/core/error.hpp"
#include "mfpc/kernels/detail/lanes.hpp"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

// What PCL 1.13 computes (shot_lrf.hpp, shot.hpp), reproduced because descriptors are matched
// against PCL-made ones and PCL is the oracle of this kernel:
//   - one neighbourhood per keypoint: the surface points with squared distance < r^2 (FLANN's test
//     is strict, the grid's is not), shared by the frame and the descriptor (PCL searches twice
//     with the same radius);
//   - the frame in double, as PCL, because its signs are decided by counting points on either side
//     of the eigenvectors, and drift there flips whole axes;
//   - every discrete decision of the descriptor (spatial volume, cosine bin) on exactly the float
//     values PCL decides on, with its order of operations: PCL's interpolation is not continuous
//     across those boundaries, so a point a rounding error on the other side moves whole votes;
//   - the continuous parts cheaper: float instead of double, polynomial acos and atan (errors
//     below 1e-7 in a weight) instead of libm's, four neighbours at a time in SIMD registers and
//     without PCL's unpredictable branches, and no sorting of the neighbourhood.
// On the shared clouds every frame and descriptor is within 2e-6 of PCL's (tests/oracle).
namespace mfpc {
namespace {

constexpr int cosine_bins = 10;
// PCL gives each spatial volume 11 slots for its 10 cosine bins: the bin is floor(b + 0.5) with
// b = 5 (1 + cos) in [0, 10], so normals within ~26 degrees of z vote into an 11th slot, and the
// interpolation on the cosine wraps modulo 10 (bin 9 spills into bin 0, not into the 11th slot).
// Kept as PCL has it, so descriptors are interchangeable with PCL's.
constexpr int volume_stride = cosine_bins + 1;
constexpr int volume_count = 32;  // 8 azimuth sectors x 2 elevation halves x 2 radial shells
static_assert(volume_count * volume_stride == int(shot_size));
constexpr std::size_t min_neighbours = 5;

constexpr double pi = 3.14159265358979323846;
constexpr float tiny_coordinate = 1e-30f;  // PCL zeroes frame coordinates below this

// Four lanes (mfpc/kernels/detail/lanes.hpp), with SSE2 intrinsics where the vector extensions
// lack an operation or compile it poorly.
using detail::abs4;
using detail::Float4;
using detail::horner;
using detail::Int4;
using detail::lanes;
using detail::load;
using Double2 = double __attribute__((vector_size(16)));
using Int2 = std::int32_t __attribute__((vector_size(8)));
using Long2 = std::int64_t __attribute__((vector_size(16)));

template <class T, class V>
inline void store(std::array<T, lanes>& out, V v)
{
    static_assert(sizeof out == sizeof v);
    std::memcpy(out.data(), &v, sizeof v);
}

// Four floats as two pairs of doubles.
inline std::array<Double2, 2> to_doubles(Float4 v)
{
#if defined(__SSE2__)
    const __m128 w = std::bit_cast<__m128>(v);
    return {std::bit_cast<Double2>(_mm_cvtps_pd(w)), std::bit_cast<Double2>(_mm_cvtps_pd(_mm_movehl_ps(w, w)))};
#else
    return {Double2{v[0], v[1]}, Double2{v[2], v[3]}};
#endif
}
// Selections by a mask (comparisons give -1 or 0 per lane) without blends, which SSE2 lacks.
inline Float4 keep_if(Float4 v, Int4 mask) { return std::bit_cast<Float4>(std::bit_cast<Int4>(v) & mask); }
inline Float4 keep_unless(Float4 v, Int4 mask) { return std::bit_cast<Float4>(std::bit_cast<Int4>(v) & ~mask); }
inline Float4 negate_if(Float4 v, Int4 mask)
{
    return std::bit_cast<Float4>(std::bit_cast<Int4>(v) ^ (mask & std::numeric_limits<std::int32_t>::min()));
}
// a < b ? a : b and a > b ? a : b, which is what minps and maxps compute (NaN included).
inline Float4 min4(Float4 a, Float4 b)
{
#if defined(__SSE2__)
    return std::bit_cast<Float4>(_mm_min_ps(std::bit_cast<__m128>(a), std::bit_cast<__m128>(b)));
#else
    return a < b ? a : b;
#endif
}
inline Float4 max4(Float4 a, Float4 b)
{
#if defined(__SSE2__)
    return std::bit_cast<Float4>(_mm_max_ps(std::bit_cast<__m128>(a), std::bit_cast<__m128>(b)));
#else
    return a > b ? a : b;
#endif
}
inline Float4 clamp4(Float4 v, float lo, float hi)
{
    const Float4 low = Float4{} + lo, high = Float4{} + hi;
    return min4(max4(v, low), high);
}
inline Float4 sqrt4(Float4 v)
{
#if defined(__SSE2__)
    return std::bit_cast<Float4>(_mm_sqrt_ps(std::bit_cast<__m128>(v)));
#else
    for (std::size_t i = 0; i < lanes; ++i) v[i] = std::sqrt(v[i]);
    return v;
#endif
}
inline Double2 sqrt2(Double2 v)
{
#if defined(__SSE2__)
    return std::bit_cast<Double2>(_mm_sqrt_pd(std::bit_cast<__m128d>(v)));
#else
    for (std::size_t i = 0; i < 2; ++i) v[i] = std::sqrt(v[i]);
    return v;
#endif
}

// atan(t) / (pi / 4) for t in [0, 1].
inline Float4 atan_in_eighths(Float4 t)
{
    return t * horner(t * t, detail::atan_fit, 4 / pi);
}

// acos(c) / (pi / 2) for c in [-1, 1]: sqrt(1 - |c|) * P(|c|), a Chebyshev fit of
// acos(a) / sqrt(1 - a) on [0, 1] (|error| < 5e-9 rad in double), scaled, reflected for c < 0.
inline Float4 acos_in_quarters(Float4 c)
{
    static constexpr double fit[] = {0.0006845318147962699, -0.003974577696981246, 0.011028380656028748,
                                     -0.020727665245290787, 0.032571170170718006,  -0.050593573883134575,
                                     0.08903013693955901,   -0.21460116073167954,  1.5707963226438153};
    const Float4 a = abs4(c);
    const Float4 r = sqrt4(1.0f - a) * horner(a, fit, 2 / pi);
    return c < 0.0f ? 2.0f - r : r;
}

// The smallest float v in [lo, hi] with pass(v), for a predicate that is false and then true over
// the floats: turns PCL's double-precision tests of float inputs into float thresholds.
template <class Predicate>
float first_float(float lo, float hi, Predicate pass)
{
    constexpr std::int64_t sign = std::numeric_limits<std::int32_t>::min();
    auto key = [](float v) {  // order-preserving map of the floats onto integers
        const auto bits = std::int64_t(std::bit_cast<std::int32_t>(v));
        return bits < 0 ? sign - bits : bits;
    };
    auto value = [](std::int64_t k) { return std::bit_cast<float>(std::int32_t(k < 0 ? sign - k : k)); };
    std::int64_t a = key(lo), b = key(hi);
    while (a < b) {
        const std::int64_t mid = a + (b - a) / 2;
        if (pass(value(mid)))
            b = mid;
        else
            a = mid + 1;
    }
    return value(a);
}

// What the kernel needs from the radius, derived once per call.
struct Constants {
    double radius;
    float squared;          // FLANN's bound float(r^2), met with <
    float outer_squared;    // d^2 >= this  <=>  PCL's outer shell test sqrt(double(d^2)) > r / 2
    float nonzero_squared;  // d^2 >= this  <=>  PCL's sqrt(double(d^2)) >= 1e-15 (else skipped)
    float inverse_half;     // 2 / r
    explicit Constants(float r) : radius(r), squared(r * r), inverse_half(float(2.0 / double(r)))
    {
        const double half = radius / 2;
        const float max_float = std::numeric_limits<float>::max();
        outer_squared = first_float(0.0f, max_float, [&](float v) { return std::sqrt(double(v)) > half; });
        nonzero_squared = first_float(0.0f, max_float, [](float v) { return std::sqrt(double(v)) >= 1e-15; });
    }
};

// A column of the neighbourhood, only ever grown, with room for a whole last block of lanes.
template <class T>
struct Column {
    std::vector<T> values;
    void reserve(std::size_t count)
    {
        if (values.size() < count + lanes) values.resize(count + lanes);
    }
    T& operator[](std::size_t i) { return values[i]; }
    const T& operator[](std::size_t i) const { return values[i]; }
};

struct RankedNeighbour {
    float squared_distance;
    std::uint32_t index;     // into the surface: FLANN breaks distance ties by it
    std::uint32_t position;  // into the neighbourhood columns
    bool operator<(const RankedNeighbour& other) const
    {
        return squared_distance < other.squared_distance ||
               (squared_distance == other.squared_distance && index < other.index);
    }
};

// Per-task buffers, grown to the largest neighbourhood and reused for every keypoint of a range.
struct Scratch {
    std::vector<std::uint32_t> found;
    std::vector<float> found_squared;
    // The neighbourhood, all points within the radius but the keypoint and its duplicates (neither
    // the frame nor the histogram uses them): offsets from the keypoint, squared distances,
    // surface indices, normals, and whether the histogram takes the point (-1) or not (0: no
    // normal, or a distance PCL takes for 0).
    Column<float> dx, dy, dz, squared, nx, ny, nz;
    Column<std::uint32_t> index;
    Column<std::int32_t> described;
    std::vector<RankedNeighbour> ranked;
    // One histogram per lane, so that consecutive neighbours (often in the same bins) do not wait
    // for each other's additions; summed in a fixed order at the end.
    alignas(16) std::array<float, lanes * shot_size> histograms{};
    // A block's five (bin, weight) pairs per lane, on their way into the histograms.
    alignas(16) std::array<std::array<std::int32_t, lanes>, 5> slots{};
    alignas(16) std::array<std::array<float, lanes>, 5> weights{};

    void reserve(std::size_t count)
    {
        for (auto* column : {&dx, &dy, &dz, &squared, &nx, &ny, &nz}) column->reserve(count);
        index.reserve(count);
        described.reserve(count);
    }
};

// Fills the neighbourhood columns of `keypoint` and returns its size. The padding after it fills
// a last block of lanes with values whose results are never used.
// The candidates are `found` (surface indices) with their squared distances: a radius search, or
// shared neighbourhoods of a radius at least as large (the keep test below bounds them).
std::size_t gather(const Point& keypoint, std::span<const Point> points, std::span<const std::uint32_t> found_indices,
                   std::span<const float> found_squared, std::span<const Point> normals, const Constants& k, Scratch& s)
{
    const std::size_t found = found_indices.size();
    s.reserve(found);
    // Written unconditionally, kept by advancing `count`: no branch to mispredict. The tests are
    // on bit patterns, cheaper than float comparisons here: squared distances are >= +0, where
    // the order of floats is that of their bits.
    auto bits = [](float v) { return std::bit_cast<std::uint32_t>(v); };
    constexpr std::uint32_t exponent = 0x7f800000u;  // all ones: Inf or NaN
    auto finite = [&](float v) { return (bits(v) & exponent) != exponent; };
    const std::uint32_t squared_bound = bits(k.squared), nonzero_bound = bits(k.nonzero_squared);
    std::size_t count = 0;
    for (std::size_t i = 0; i < found; ++i) {
        const std::uint32_t d2 = bits(found_squared[i]);
        const std::uint32_t index = found_indices[i];
        const Point& p = points[index];
        const float dx = p.x() - keypoint.x(), dy = p.y() - keypoint.y(), dz = p.z() - keypoint.z();
        // PCL skips points equal to the keypoint (itself, duplicates: all offsets +-0) in the
        // frame, and points at distance < 1e-15 (the same ones, give or take an underflow) in the
        // histogram.
        const bool keep = (d2 < squared_bound) & (((bits(dx) | bits(dy) | bits(dz)) << 1) != 0);
        const Point& n = normals[index];
        const bool described = finite(n.x()) & finite(n.y()) & finite(n.z()) & (d2 >= nonzero_bound);
        s.dx[count] = dx;
        s.dy[count] = dy;
        s.dz[count] = dz;
        s.squared[count] = found_squared[i];
        s.index[count] = index;
        s.nx[count] = described ? n.x() : 0.0f;
        s.ny[count] = described ? n.y() : 0.0f;
        s.nz[count] = described ? n.z() : 1.0f;
        s.described[count] = described ? -1 : 0;
        count += keep;
    }
    for (std::size_t i = count; i < count + lanes; ++i) {
        s.dx[i] = s.dy[i] = s.dz[i] = s.squared[i] = s.nx[i] = s.ny[i] = s.nz[i] = 0.0f;
        s.described[i] = 0;
    }
    return count;
}

// PCL's product of a neighbour's offset (a double row of its vij) with a double axis.
inline double offset_dot(const Scratch& s, std::size_t j, const Eigen::Vector3d& axis)
{
    return (double(s.dx[j]) * axis.x() + double(s.dy[j]) * axis.y()) + double(s.dz[j]) * axis.z();
}

// PCL's tie break when exactly half the neighbours lie on each side of an axis: the 5 neighbours
// around the median of the distance-sorted neighbourhood vote with strictly positive
// projections; the axis is flipped if fewer than 3 do.
bool flip_on_tie(Scratch& s, std::size_t count, const Eigen::Vector3d& axis)
{
    s.ranked.resize(count);
    for (std::size_t j = 0; j < count; ++j) s.ranked[j] = {s.squared[j], s.index[j], std::uint32_t(j)};
    const std::size_t median = count / 2;
    const auto first = s.ranked.begin() + std::ptrdiff_t(median - 2);
    const auto last = s.ranked.begin() + std::ptrdiff_t(median + 3);
    std::nth_element(s.ranked.begin(), first, s.ranked.end());
    std::partial_sort(first, last, s.ranked.end());
    int positive = 0;
    for (auto it = first; it != last; ++it) positive += offset_dot(s, it->position, axis) > 0;
    return positive < 3;
}

// SHOT's frame (PCL's SHOTLocalReferenceFrameEstimation::getLocalRF) over the `count` neighbours
// in `s`: the eigenvectors of the covariance weighted by r - d, x (largest eigenvalue) and z
// (smallest) each turned toward the majority of the neighbours, y = z x x. False when undefined
// (fewer than 5 neighbours besides the keypoint, or a NaN eigen decomposition).
bool shot_frame(Scratch& s, std::size_t count, const Constants& k, LocalReferenceFrame& frame)
{
    if (count < min_neighbours) return false;
    // Weighted sums in two lanes of doubles (even and odd neighbours; the padding weighs 0),
    // added up in a fixed order: the same result whatever thread runs it.
    Double2 c00{}, c01{}, c02{}, c11{}, c12{}, c22{}, weight_sum{};
    const Double2 lane_index = {0, 1};
    for (std::size_t j = 0; j < count; j += lanes) {
        const auto xs = to_doubles(load(&s.dx[j])), ys = to_doubles(load(&s.dy[j])), zs = to_doubles(load(&s.dz[j]));
        const auto d2s = to_doubles(load(&s.squared[j]));
        for (std::size_t half = 0; half < 2; ++half) {
            const Double2 x = xs[half], y = ys[half], z = zs[half];
            const Double2 real = lane_index + double(j + 2 * half) < double(count) ? Double2{} + 1.0 : Double2{};
            const Double2 weight = real * (k.radius - sqrt2(d2s[half]));
            c00 += weight * (x * x);
            c01 += weight * (x * y);
            c02 += weight * (x * z);
            c11 += weight * (y * y);
            c12 += weight * (y * z);
            c22 += weight * (z * z);
            weight_sum += weight;
        }
    }
    auto total = [](Double2 v) { return v[0] + v[1]; };
    Eigen::Matrix3d covariance;
    covariance << total(c00), total(c01), total(c02), total(c01), total(c11), total(c12), total(c02), total(c12),
        total(c22);
    covariance /= total(weight_sum);
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
    if (!solver.eigenvalues().allFinite()) return false;
    Eigen::Vector3d x_axis = solver.eigenvectors().col(2);
    Eigen::Vector3d z_axis = solver.eigenvectors().col(0);

    // Neighbours on the positive side (>= 0) of each axis, with PCL's double products; the
    // padding lanes are masked out.
    Long2 x_positive{}, z_positive{};
    for (std::size_t j = 0; j < count; j += lanes) {
        const auto xs = to_doubles(load(&s.dx[j])), ys = to_doubles(load(&s.dy[j])), zs = to_doubles(load(&s.dz[j]));
        for (std::size_t half = 0; half < 2; ++half) {
            const Double2 x = xs[half], y = ys[half], z = zs[half];
            const Long2 real = lane_index + double(j + 2 * half) < double(count);
            x_positive -= real & ((x * x_axis.x() + y * x_axis.y()) + z * x_axis.z() >= 0.0);
            z_positive -= real & ((x * z_axis.x() + y * z_axis.y()) + z * z_axis.z() >= 0.0);
        }
    }
    const std::int64_t x_balance = 2 * (x_positive[0] + x_positive[1]) - std::int64_t(count);
    if (x_balance < 0 || (x_balance == 0 && flip_on_tie(s, count, x_axis))) x_axis = -x_axis;
    const std::int64_t z_balance = 2 * (z_positive[0] + z_positive[1]) - std::int64_t(count);
    if (z_balance < 0 || (z_balance == 0 && flip_on_tie(s, count, z_axis))) z_axis = -z_axis;

    const Eigen::Vector3f x = x_axis.cast<float>();
    const Eigen::Vector3f z = z_axis.cast<float>();
    frame.row(0) = x.transpose();
    frame.row(1) = z.cross(x).transpose();
    frame.row(2) = z.transpose();
    return true;
}

inline Int4 times_stride(Int4 v) { return (v << 3) + (v << 1) + v; }  // v * 11, without SSE4.1
static_assert(volume_stride == 11);

// The SHOT histogram (PCL's SHOTEstimation::interpolateSingleChannel and normalizeHistogram) in
// `frame` over the `count` neighbours in `s`, into `out`; false when undefined (NaN).
//
// Per neighbour PCL adds a weight to its own bin and, along each of cosine, radius, elevation and
// azimuth, the linear interpolation weight toward the nearest neighbouring bin of that one
// dimension. Here the five (bin, weight) pairs of four neighbours at a time are computed without
// branches (a missing neighbouring bin gets weight 0, added to a valid bin), then added in PCL's
// order.
bool shot_histogram(Scratch& s, std::size_t count, const Constants& k, const LocalReferenceFrame& frame,
                    std::span<float> out)
{
    const float x0 = frame(0, 0), x1 = frame(0, 1), x2 = frame(0, 2);
    const float y0 = frame(1, 0), y1 = frame(1, 1), y2 = frame(1, 2);
    const float z0 = frame(2, 0), z1 = frame(2, 1), z2 = frame(2, 2);
    float* h = s.histograms.data();
    std::fill(s.histograms.begin(), s.histograms.end(), 0.0f);
    const Int4 lane_histogram = {0, int(shot_size), 2 * int(shot_size), 3 * int(shot_size)};

    for (std::size_t j = 0; j < count; j += lanes) {
        const Float4 dx = load(&s.dx[j]), dy = load(&s.dy[j]), dz = load(&s.dz[j]);
        const Float4 d2 = load(&s.squared[j]);

        // Coordinates in the frame with the float operations of PCL's SSE Vector4f dot (zero 4th
        // lane): every volume decision below is taken on these exact values.
        Float4 x = (dx * x0 + dz * x2) + dy * x1;
        Float4 y = (dx * y0 + dz * y2) + dy * y1;
        Float4 z = (dx * z0 + dz * z2) + dy * z1;
        x = keep_unless(x, abs4(x) < tiny_coordinate);
        y = keep_unless(y, abs4(y) < tiny_coordinate);
        z = keep_unless(z, abs4(z) < tiny_coordinate);

        // The volume: PCL's azimuth bit pattern (8 sectors), then elevation and radial halves.
        const Float4 ax = abs4(x), ay = abs4(y);
        const Int4 x_positive = x > 0.0f, x_negative = x < 0.0f, x_zero = x == 0.0f;
        const Int4 y_positive = y > 0.0f, y_negative = y < 0.0f, y_zero = y == 0.0f;
        const Int4 bit4 = y_positive | (y_zero & x_negative);
        const Int4 bit3 = bit4 ^ (x_positive | (x_zero & y_positive));
        const Int4 same_sign = (x_positive & y_positive) | (x_negative & y_negative) | x_zero;
        const Int4 late_half = (same_sign & (ax < ay)) | (~same_sign & (ax > ay));
        const Int4 upper = z > 0.0f;
        const Int4 outer = d2 >= k.outer_squared;
        // (Comparisons give -1 or 0 per lane.)
        const Int4 volume = (bit4 & 16) | (bit3 & 8) | (late_half & 4) | (outer & 2) | (upper & 1);

        // Cosine of the normal with the frame's z axis: PCL's exact bin, then the weight toward
        // the nearer neighbouring bin.
        const Float4 cosine = clamp4((load(&s.nx[j]) * z0 + load(&s.nz[j]) * z2) + load(&s.ny[j]) * z1, -1.0f, 1.0f);
        // PCL's bin floor(((1 + c) * 10) / 2 + 0.5) in double is floor(5 c + 5.5), exact in double
        // for every float c that is not within 2^-29 of 0 (and the bin is 5 either way there).
        const auto cosines = to_doubles(cosine);
        const Int2 low_bins = __builtin_convertvector(cosines[0] * 5.0 + 5.5, Int2);
        const Int2 high_bins = __builtin_convertvector(cosines[1] * 5.0 + 5.5, Int2);
        const Int4 bin = __builtin_shufflevector(low_bins, high_bins, 0, 1, 2, 3);  // truncation: >= 0
        const Float4 cosine_offset = (cosine + 1.0f) * 5.0f - __builtin_convertvector(bin, Float4);
        const Float4 cosine_weight = abs4(cosine_offset);
        const Int4 next_bin = bin + 1 - ((bin >= 9) & cosine_bins);   // 9 -> 0, 10 -> 1
        const Int4 previous_bin = bin - 1 + ((bin == 0) & cosine_bins);  // 0 -> 9
        const Int4 cosine_neighbour = previous_bin + ((cosine_offset > 0.0f) & (next_bin - previous_bin));
        Float4 self = 1.0f - cosine_weight;

        // Radius in half radii, t in [0, 2): shells centred at 0.5 and 1.5; the innermost and
        // outermost quarters vote only for their own shell.
        const Float4 distance = sqrt4(d2);
        const Float4 t = distance * k.inverse_half;
        const Float4 radial_offset = t - (0.5f + keep_if(Float4{} + 1.0f, outer));
        self += 1.0f - abs4(radial_offset);
        const Float4 radial_weight = max4(negate_if(radial_offset, outer), Float4{});
        const Int4 radial_step = volume_stride * 2 - (outer & (volume_stride * 4));  // to volume -+ 2

        // Inclination in right angles, in [0, 2]; the same rule for the two elevation halves.
        const Float4 inclination = acos_in_quarters(clamp4(z / distance, -1.0f, 1.0f));
        const Float4 elevation_offset = inclination - (1.5f - keep_if(Float4{} + 1.0f, upper));
        self += 1.0f - abs4(elevation_offset);
        const Float4 elevation_weight = max4(negate_if(elevation_offset, ~upper), Float4{});
        const Int4 elevation_step = volume_stride - (upper & (volume_stride * 2));  // to volume -+ 1

        // Azimuth: the angle from the nearest axis, in eighths of a turn, is the position within
        // the sector for the sectors that start on an axis, 1 - the position for those that
        // start on a diagonal (the late halves of the quadrants). No azimuth at x = y = 0.
        // (At x = y = 0 the ratio is 0 / 0, NaN, and masked out.)
        const Int4 has_azimuth = ~(x_zero & y_zero);
        const Float4 angle = atan_in_eighths(min4(ax, ay) / max4(ax, ay));
        const Float4 azimuth_offset = clamp4(negate_if(angle - 0.5f, late_half), -0.5f, 0.5f);
        self += keep_if(1.0f - abs4(azimuth_offset), has_azimuth);
        const Float4 azimuth_weight = keep_if(abs4(azimuth_offset), has_azimuth);
        const Int4 azimuth_neighbour = (volume + 28 + ((azimuth_offset > 0.0f) & -24)) & 31;  // sector +- 1

        // A neighbour without a normal (or at distance 0 for PCL) adds 0 wherever it points.
        const Int4 described = load(&s.described[j]);
        const Int4 own = times_stride(volume) + lane_histogram;
        const Int4 own_bin = own + bin;
        // Through memory: reading lanes back is cheaper than shuffling them out of registers.
        auto& slot = s.slots;
        auto& weight = s.weights;
        store(slot[0], own + cosine_neighbour);
        store(slot[1], own_bin + radial_step);
        store(slot[2], own_bin + elevation_step);
        store(slot[3], times_stride(azimuth_neighbour) + lane_histogram + bin);
        store(slot[4], own_bin);
        store(weight[0], keep_if(cosine_weight, described));
        store(weight[1], keep_if(radial_weight, described));
        store(weight[2], keep_if(elevation_weight, described));
        store(weight[3], keep_if(azimuth_weight, described));
        store(weight[4], keep_if(self, described));
        auto add = [&](std::size_t lane) {
            for (std::size_t v = 0; v < 5; ++v) h[slot[v][lane]] += weight[v][lane];
        };
        if (j + lanes <= count) {
            add(0);
            add(1);
            add(2);
            add(3);
        } else {
            for (std::size_t lane = 0; lane < count - j; ++lane) add(lane);
        }
    }

    // The lanes' histograms summed, then the L2 normalisation as PCL: float squares summed in
    // double, divided by the float norm. An empty histogram (no neighbour with a normal) gives
    // 0 / 0, NaN, as in PCL.
    for (std::size_t i = 0; i < shot_size; ++i)
        h[i] = (h[i] + h[shot_size + i]) + (h[2 * shot_size + i] + h[3 * shot_size + i]);
    std::array<double, lanes> norm2{};
    for (std::size_t i = 0; i < shot_size; i += lanes) {
        for (std::size_t lane = 0; lane < lanes; ++lane) norm2[lane] += h[i + lane] * h[i + lane];
    }
    static_assert(shot_size % lanes == 0);
    const float norm = float(std::sqrt((norm2[0] + norm2[1]) + (norm2[2] + norm2[3])));
    for (std::size_t i = 0; i < shot_size; ++i) out[i] = h[i] / norm;
    return norm > 0;
}

// Frame and descriptor of one keypoint; false when either is undefined.
// `support`: when given, the neighbourhoods of the keypoints (this one is `at`), read instead of
// searching the grid.
bool describe(const Point& keypoint, const NeighborGrid& surface, std::span<const Point> normals,
              const Neighborhoods* support, std::size_t at, const Constants& k, Scratch& s, LocalReferenceFrame& frame,
              std::span<float> descriptor)
{
    constexpr float nan = std::numeric_limits<float>::quiet_NaN();
    if (keypoint.allFinite()) {
        std::size_t count = 0;
        if (support) {
            count = gather(keypoint, surface.points(), support->indices_of(at), support->squared_distances_of(at),
                           normals, k, s);
        } else {
            surface.radius_search(keypoint, float(k.radius), s.found, s.found_squared);
            count = gather(keypoint, surface.points(), s.found, s.found_squared, normals, k, s);
        }
        // PCL's own test for too small a histogram support (5 points, the keypoint included)
        // cannot fail once the frame is defined: that takes 5 neighbours besides the keypoint.
        if (shot_frame(s, count, k, frame)) return shot_histogram(s, count, k, frame, descriptor);
    }
    frame.setConstant(nan);
    std::fill(descriptor.begin(), descriptor.end(), nan);
    return false;
}

}  // namespace

std::size_t shot_descriptors(std::span<const Point> keypoints, const NeighborGrid& surface,
                             std::span<const Point> surface_normals, const ShotParams& params,
                             std::span<LocalReferenceFrame> frames, std::span<float> descriptors,
                             const Neighborhoods* support)
{
    if (!(params.radius > 0.0f) || !std::isfinite(params.radius))
        throw Error("shot_descriptors", "radius must be a positive number, got " + format_number(params.radius));
    if (surface_normals.size() != surface.size())
        throw Error("shot_descriptors", std::to_string(surface_normals.size()) + " normals for " +
                                            std::to_string(surface.size()) + " surface points");
    if (frames.size() != keypoints.size())
        throw Error("shot_descriptors", std::to_string(frames.size()) + " frames for " +
                                            std::to_string(keypoints.size()) + " keypoints");
    if (descriptors.size() != keypoints.size() * shot_size)
        throw Error("shot_descriptors", std::to_string(descriptors.size()) + " descriptor values for " +
                                            std::to_string(keypoints.size()) + " keypoints (352 each)");
    if (support) support->check_serves(surface.points(), keypoints, params.radius, "shot_descriptors", "the descriptors");

    const Constants constants(params.radius);
    return tbb::parallel_reduce(
        tbb::blocked_range<std::size_t>(0, keypoints.size(), 8), std::size_t(0),
        [&](const tbb::blocked_range<std::size_t>& range, std::size_t undefined) {
            Scratch scratch;
            for (std::size_t i = range.begin(); i < range.end(); ++i) {
                if (!describe(keypoints[i], surface, surface_normals, support, i, constants, scratch, frames[i],
                              descriptors.subspan(i * shot_size, shot_size)))
                    ++undefined;
            }
            return undefined;
        },
        [](std::size_t a, std::size_t b) { return a + b; });
}

}  // namespace mfpc
