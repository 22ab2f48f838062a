#include "mfpc/recognition/statistics.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <limits>
#include <numbers>
#include <numeric>
#include <string>
#include <vector>

#include "mfpc/core/error.hpp"

namespace mfpc {

namespace {

constexpr double epsilon = std::numeric_limits<double>::epsilon();
constexpr double infinity = std::numeric_limits<double>::infinity();
constexpr double not_a_number = std::numeric_limits<double>::quiet_NaN();

// The shortest text that reads back as the same double, so a message shows the value exactly.
std::string text(double value)
{
    char buffer[32];
    const auto end = std::to_chars(buffer, buffer + sizeof buffer, value).ptr;
    return std::string(buffer, end);
}

[[noreturn]] void fail(const std::string& reason) { throw Error("statistics", reason); }

void check_degrees_of_freedom(double degrees_of_freedom)
{
    // An infinite value would be the normal distribution, which the substitution below cannot
    // express (t² / ν is 0 for every t); nobody's N runs give it.
    if (!(degrees_of_freedom > 0 && degrees_of_freedom < infinity))
        fail("degrees of freedom must be positive and finite, not " + text(degrees_of_freedom));
}

// ln Γ(z) minus Stirling's (z - 1/2) ln z - z + ln sqrt(2π), for z >= 10: the asymptotic series
// sum over k of B_2k / (2k (2k - 1) z^(2k - 1)). Its first omitted term, 691 / (360360 z^11), is
// below 2e-14 at z = 10.
double stirling_remainder(double z)
{
    const double w = 1 / (z * z);
    return (1.0 / 12 + w * (-1.0 / 360 + w * (1.0 / 1260 + w * (-1.0 / 1680 + w * (1.0 / 1188))))) / z;
}

// ln(sqrt(ν) B(ν/2, 1/2)), the normalizing constant of the t density, which tends to ln sqrt(2π)
// as ν grows. Its parts do not: ln Γ(ν/2) and ln Γ(ν/2 + 1/2) agree in all their leading digits
// (at ν = 1e6 both are near 6e6 and differ by 6.6), and ln B and ln sqrt(ν) are near ∓345 at
// ν = 1e300; taken apart, their rounding put the 0.975 quantile at ν = 1e300 eight units in the
// last place off (measured). For a = ν/2 >= 10 the Stirling series gives the whole as a sum of
// small terms:
//   ln Γ(a + 1/2) - ln Γ(a) = (a - 1/2) ln(1 + 1/(2a)) + (1/2) ln(a + 1/2) - 1/2 + R(a + 1/2) - R(a),
// and (1/2) ln(a + 1/2) - (1/2) ln ν = (1/2) ln((1 + 1/ν) / 2).
double log_scaled_beta(double nu)
{
    const double a = nu / 2;
    const double log_gamma_half = 0.5 * std::log(std::numbers::pi);  // ln Γ(1/2)
    if (a < 10) return std::lgamma(a) + log_gamma_half - std::lgamma(a + 0.5) + 0.5 * std::log(nu);
    const double rise_less_half_log_nu = (a - 0.5) * std::log1p(0.5 / a) - 0.5 +
                                         0.5 * (std::log1p(1 / nu) - std::numbers::ln2) +
                                         stirling_remainder(a + 0.5) - stirling_remainder(a);
    return log_gamma_half - rise_less_half_log_nu;
}

// The continued fraction of the regularized incomplete beta function (DLMF 8.17.22):
//   I_x(a, b) = x^a (1 - x)^b / (a B(a, b)) / (1 + d1 / (1 + d2 / (1 + d3 / ...))),
//   d(2m + 1) = -(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)),
//   d(2m)     = m (b - m) x / ((a + 2m - 1)(a + 2m)).
// Returns the denominator 1 + d1 / (1 + ...), evaluated front to back by the modified Lentz method
// (no need to pick the number of terms in advance). It converges quickly for
// x < (a + 1) / (a + b + 2): measured, at most 32 terms for Student's t over ν from 1e-3 to 1e300
// and t from 1e-2 to 1e20. The limit is only a guard against a loop that never ends.
double beta_fraction(double a, double b, double x)
{
    // Lentz replaces a vanishing partial denominator by this: near enough zero to act as one,
    // far enough from it that its reciprocal is finite.
    constexpr double tiny = 1e-300;
    constexpr int term_limit = 100000;
    double value = 1;
    double c = 1;  // ratio of successive numerators
    double d = 0;  // ratio of successive denominators
    auto fold = [&](double term) {
        d = 1 + term * d;
        if (std::fabs(d) < tiny) d = tiny;
        c = 1 + term / c;
        if (std::fabs(c) < tiny) c = tiny;
        d = 1 / d;
        const double change = c * d;
        value *= change;
        return change;
    };
    for (int step = 0; step < term_limit; ++step) {
        const double m = static_cast<double>(step);
        const double n = m + 1;
        // Each product is taken as two ratios near 1 so that a huge a (huge ν) cannot overflow.
        const double odd = -((a + m) / (a + 2 * m)) * ((a + b + m) / (a + 2 * m + 1)) * x;
        const double even = (n / (a + 2 * n - 1)) * ((b - n) / (a + 2 * n)) * x;
        const double change = fold(odd) * fold(even);
        if (std::fabs(change - 1) <= epsilon) return value;
    }
    fail("the incomplete beta continued fraction did not converge (a = " + text(a) + ", b = " + text(b) +
         ", x = " + text(x) + ")");
}

// I_x(a, b) and 1 - I_x(a, b). The fraction converges quickly on one side of the mean a / (a + b)
// only, so the other side goes through I_x(a, b) = 1 - I_y(b, a): whichever of the pair comes from
// a fraction keeps its full relative accuracy (it is the small one in the tails). x and y = 1 - x
// come in separately because the caller can form each without a subtraction, and so does
// ln(x^a y^b / B(a, b)), whose parts can be huge and cancel.
struct BetaPair {
    double lower;  // I_x(a, b)
    double upper;  // 1 - I_x(a, b)
};

BetaPair incomplete_beta(double a, double b, double x, double y, double log_front)
{
    if (x < (a + 1) / (a + b + 2)) {
        const double lower = std::exp(log_front - std::log(a)) / beta_fraction(a, b, x);
        return {lower, 1 - lower};
    }
    const double upper = std::exp(log_front - std::log(b)) / beta_fraction(b, a, y);
    return {1 - upper, upper};
}

// For large a, b = 1/2 and x near 1, the fraction above is a difference of nearly equal terms
// (its first partial denominator is 1 - x (ν + 1)/(ν + 2), about t²/ν): measured, Student t tails
// lost digits in proportion to ν, 1e-12 relative at ν = 1e6 and 1e-7 at 1e10. There an expansion
// in incomplete gamma functions takes over. With x = e^(-v0) and s = e^(-v),
//   I_x(a, b) = 1/B(a, b) ∫[v0, ∞) e^(-a v) (1 - e^(-v))^(b-1) dv,
// and 1 - e^(-v) = e^(-v/2) v h(v) with h(v) = sinh(v/2) / (v/2), even in v. With T = a + (b - 1)/2
// and h(v)^(b-1) = sum c_k v^(2k),
//   I_x(a, b) = 1/B(a, b) sum c_k T^-(b + 2k) Γ(b + 2k, T v0),
// every term positive in its gamma factor. h^(b-1) is analytic for |v| < 2π, so c_k shrinks like
// (2π)^(-2k), while Γ(b + 2k, T v0) / T^(2k) grows by at most about max(v0, 2k / T)^2 per step:
// for T >= 24 and v0 <= 1 successive terms fall by 40 or more, and measured, ten terms reach
// double precision. For b = 1/2, Γ(1/2, z) = sqrt(π) erfc(sqrt(z)), and
// Γ(s + 1, z) = s Γ(s, z) + z^s e^(-z) climbs from it by sums of positive terms.
constexpr int series_terms = 24;
constexpr double series_min_a = 25;    // a = ν / 2
constexpr double series_max_v0 = 1;    // v0 = -ln x = ln(1 + t²/ν)

// c_k for b = 1/2. In w = v², h = sum g_j w^j with g_j = 1 / (4^j (2j + 1)!), and c = h^β with
// β = b - 1 = -1/2 satisfies w h c' = β w h' c; comparing coefficients of w^n gives
//   n c_n = sum over j = 1..n of (j (β + 1) - n) g_j c_(n-j).
const std::array<double, series_terms>& student_series_coefficients()
{
    static const std::array<double, series_terms> coefficients = [] {
        constexpr double beta = -0.5;
        std::array<double, series_terms> g{};
        g[0] = 1;
        for (int j = 1; j < series_terms; ++j)
            g[static_cast<std::size_t>(j)] = g[static_cast<std::size_t>(j - 1)] / (4.0 * (2 * j) * (2 * j + 1));
        std::array<double, series_terms> c{};
        c[0] = 1;
        for (int n = 1; n < series_terms; ++n) {
            double sum = 0;
            for (int j = 1; j <= n; ++j)
                sum += (j * (beta + 1) - n) * g[static_cast<std::size_t>(j)] * c[static_cast<std::size_t>(n - j)];
            c[static_cast<std::size_t>(n)] = sum / n;
        }
        return c;
    }();
    return coefficients;
}

// I_x(ν/2, 1/2) by the series, for ν/2 >= series_min_a and v0 = -ln x <= series_max_v0;
// log_scaled_b is ln(sqrt(ν) B(ν/2, 1/2)).
double student_tail_series(double nu, double v0, double log_scaled_b)
{
    const auto& c = student_series_coefficients();
    const double big_t = nu / 2 - 0.25;
    const double z = big_t * v0;
    // R(s) = Γ(s, z) / T^(s - 1/2), so that the k-th term is c_k R(1/2 + 2k) / sqrt(T) and no
    // power of T overflows on the way: R(s + 1) = (s R(s) + v0^s sqrt(T) e^(-z)) / T.
    const double log_v0 = std::log(v0);
    const double log_scale = 0.5 * std::log(big_t) - z;
    double r = std::sqrt(std::numbers::pi) * std::erfc(std::sqrt(z));
    double s = 0.5;
    double sum = c[0] * r;
    for (std::size_t k = 1; k < c.size(); ++k) {
        for (int twice = 0; twice < 2; ++twice) {
            r = (s * r + std::exp(s * log_v0 + log_scale)) / big_t;
            s += 1;
        }
        const double term = c[k] * r;
        sum += term;
        if (std::fabs(term) <= epsilon / 2 * sum) break;
    }
    // 1 / (B sqrt(T)) = exp(-ln(sqrt(ν) B) + (1/2) ln(ν / T)), with ν / T = 2 / (1 - 1/(2ν)).
    return std::exp(-log_scaled_b + 0.5 * (std::numbers::ln2 - std::log1p(-0.5 / nu))) * sum;
}

// Student's t with ν degrees of freedom through the substitution x = ν / (ν + t²), which turns
// the density (1 + t²/ν)^(-(ν + 1)/2) / (sqrt(ν) B(ν/2, 1/2)) into the beta density with
// a = ν/2, b = 1/2: P(|T| > t) = I_x(ν/2, 1/2).
struct StudentT {
    double nu;
    double log_scaled_b;  // ln(sqrt(ν) B(ν/2, 1/2)), shared by every evaluation

    explicit StudentT(double degrees_of_freedom)
        : nu(degrees_of_freedom), log_scaled_b(log_scaled_beta(degrees_of_freedom))
    {
    }

    // x = 1 / (1 + r) and y = r / (1 + r) with r = t²/ν, for t > 0 and finite, with ln x and
    // ln(ν y) = ln(t² / (1 + r)): ν y rather than y, because ln y and ln B(ν/2, 1/2) both grow
    // like ln ν and would cancel in the front factor of the fraction.
    struct Substitution {
        double x, y, log_x, log_nu_y;
    };

    Substitution substitute(double t) const
    {
        const double r = t * t / nu;
        if (std::isnormal(r)) {
            // Logarithms without cancellation: log1p of the smaller of r and 1/r.
            const double log_nu_y = r > 1 ? std::log(nu) - std::log1p(1 / r) : 2 * std::log(t) - std::log1p(r);
            return {1 / (1 + r), r / (1 + r), -std::log1p(r), log_nu_y};
        }
        // r overflowed or underflowed (tiny ν with huge t, huge ν with tiny t), where 1 + r is r
        // (or 1) to double precision.
        if (r > 1) {
            const double log_x = std::log(nu) - 2 * std::log(t);
            return {std::exp(log_x), 1, log_x, std::log(nu)};
        }
        const double log_nu_y = 2 * std::log(t);
        return {1, std::exp(log_nu_y - std::log(nu)), 0, log_nu_y};
    }

    // For t >= 0: P(T > t) and P(0 < T <= t), which sum to 1/2.
    struct Tails {
        double upper;
        double central;
    };

    Tails tails(double t) const
    {
        if (t == 0) return {0.5, 0};
        if (t == infinity) return {0, 0.5};
        const Substitution s = substitute(t);
        const double a = nu / 2;
        // Where the series applies it gives the tail, unless the tail is the larger half: then
        // the central part by the fraction, whose terms at such small t do not cancel. (The
        // fraction's own switch point, at t² near 3, would leave tails as large as 0.04 to
        // 0.5 - central and lose a digit.)
        if (a >= series_min_a && -s.log_x <= series_max_v0) {
            const double upper = student_tail_series(nu, -s.log_x, log_scaled_b) / 2;
            if (upper <= 0.25) return {upper, 0.5 - upper};
        }
        // ln(x^a y^(1/2) / B(a, 1/2)) = a ln x + (1/2) ln(ν y) - ln(sqrt(ν) B(a, 1/2))
        const double log_front = a * s.log_x + 0.5 * s.log_nu_y - log_scaled_b;
        const BetaPair beta = incomplete_beta(a, 0.5, s.x, s.y, log_front);
        return {beta.lower / 2, beta.upper / 2};
    }

    double density(double t) const
    {
        const double log_x = t == 0 ? 0 : substitute(std::fabs(t)).log_x;  // -ln(1 + t²/ν)
        return std::exp((nu + 1) / 2 * log_x - log_scaled_b);
    }
};

// The t >= 0 with P(T > t) = upper, for upper in (0, 1/2].
double upper_quantile(double upper, double degrees_of_freedom)
{
    if (upper == 0.5) return 0;
    const StudentT distribution(degrees_of_freedom);
    // Solve for whichever of P(T > t) and P(0 < T <= t) is the smaller number, so that the equation
    // keeps the digits of the target; above 1/4, 1/2 - upper is exact (Sterbenz).
    const bool central = upper > 0.25;
    const double target = central ? 0.5 - upper : upper;
    // g increases through zero at the answer. A tail falls off like e^(-t²/2) for large ν, and
    // Newton on the probability itself creeps there by steps of about 1/t (measured: 200 steps
    // left the 1e-300 quantile at ν = 1000 3% short); its logarithm is nearly straight, so the
    // tail equation is ln(P(T > t) / target) = 0, taken as a ratio to keep the digits of both.
    struct Equation {
        double value;
        double slope;
    };
    auto g = [&](double t) -> Equation {
        const StudentT::Tails tails = distribution.tails(t);
        const double density = distribution.density(t);
        if (central) return {tails.central - target, density};
        return {-std::log(tails.upper / target), density / tails.upper};
    };
    double low = 0;
    double high = 1;
    while (g(high).value < 0) {
        low = high;
        high *= 2;
        if (high == infinity) {
            high = std::numeric_limits<double>::max();
            if (g(high).value < 0) return infinity;  // beyond every double: tiny ν, extreme probability
            break;
        }
    }
    double t = low;
    // Newton doubles its correct digits per step, and where a step leaves the bracket (rounding,
    // a vanishing density) bisection halves it instead, so this many steps is a generous bound.
    for (int step = 0; step < 200; ++step) {
        const Equation equation = g(t);
        if (equation.value == 0) return t;
        if (equation.value < 0) low = t;
        else high = t;
        double next = t - equation.value / equation.slope;
        if (!(next > low && next < high)) next = low + (high - low) / 2;
        if (std::fabs(next - t) <= epsilon * next || high - low <= epsilon * high) return next;
        t = next;
    }
    return t;
}

}  // namespace

double student_t_cdf(double t, double degrees_of_freedom)
{
    check_degrees_of_freedom(degrees_of_freedom);
    if (std::isnan(t)) fail("the t of a Student t probability is NaN");
    const StudentT::Tails tails = StudentT(degrees_of_freedom).tails(std::fabs(t));
    if (t < 0) return tails.upper;
    // One rounding: add to whichever half was computed directly, the smaller one.
    return tails.upper < tails.central ? 1 - tails.upper : 0.5 + tails.central;
}

double student_t_quantile(double probability, double degrees_of_freedom)
{
    check_degrees_of_freedom(degrees_of_freedom);
    if (!(probability > 0 && probability < 1))
        fail("a Student t quantile needs a probability in (0, 1), not " + text(probability));
    // The distribution is symmetric; 1 - probability is exact for probability >= 1/2 (Sterbenz).
    if (probability < 0.5) return -upper_quantile(probability, degrees_of_freedom);
    return upper_quantile(1 - probability, degrees_of_freedom);
}

Summary summarize(std::span<const double> samples, double confidence)
{
    if (samples.empty()) fail("no samples to summarize");
    if (!(confidence > 0 && confidence < 1)) fail("confidence must lie in (0, 1), not " + text(confidence));
    for (std::size_t i = 0; i < samples.size(); ++i)
        if (!std::isfinite(samples[i])) fail("sample " + std::to_string(i) + " is " + text(samples[i]));

    Summary summary;
    summary.count = samples.size();
    summary.confidence = confidence;
    const double n = static_cast<double>(samples.size());

    // Two passes, the second about the first's mean: the sum of deviations, zero in exact
    // arithmetic, measures the first pass's rounding and corrects both the mean and the sum of
    // squares (the corrected two-pass algorithm). One pass of sum and sum of squares would lose
    // every digit of the variance when the spread is small against the mean, as with run times.
    double sum = 0;
    for (const double sample : samples) sum += sample;
    const double first_mean = sum / n;
    double deviation_sum = 0;
    double square_sum = 0;
    for (const double sample : samples) {
        const double deviation = sample - first_mean;
        deviation_sum += deviation;
        square_sum += deviation * deviation;
    }
    summary.mean = first_mean + deviation_sum / n;
    if (summary.count > 1)
        summary.variance = std::max(0.0, (square_sum - deviation_sum * deviation_sum / n) / (n - 1));
    if (!std::isfinite(summary.mean) || !std::isfinite(summary.variance))
        fail("the samples are too large to summarize: their sum or spread overflows a double");
    summary.standard_deviation = std::sqrt(summary.variance);

    if (summary.count > 1) {
        summary.t_quantile = upper_quantile((1 - confidence) / 2, n - 1);
        summary.half_width = summary.t_quantile * summary.standard_deviation / std::sqrt(n);
    } else {
        // No degrees of freedom: nothing measures the spread, and an interval of width 0 would
        // claim a certainty that one run cannot give.
        summary.t_quantile = not_a_number;
        summary.half_width = not_a_number;
    }
    summary.low = summary.mean - summary.half_width;
    summary.high = summary.mean + summary.half_width;

    std::vector<double> sorted(samples.begin(), samples.end());
    std::sort(sorted.begin(), sorted.end());
    summary.min = sorted.front();
    summary.max = sorted.back();
    const std::size_t middle = sorted.size() / 2;
    summary.median = sorted.size() % 2 == 1 ? sorted[middle] : std::midpoint(sorted[middle - 1], sorted[middle]);
    return summary;
}

double reduction_percent(double reference, double value)
{
    if (!(reference > 0 && reference < infinity))
        fail("a reduction needs a positive finite reference, not " + text(reference));
    if (!std::isfinite(value)) fail("a reduction needs a finite value, not " + text(value));
    // The difference first: it is exact when the two are within a factor 2 of each other.
    const double percent = (reference - value) / reference * 100;
    if (!std::isfinite(percent)) fail("the reduction from " + text(reference) + " to " + text(value) + " overflows");
    return percent;
}

}  // namespace mfpc
