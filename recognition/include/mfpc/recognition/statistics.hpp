#pragma once

/// @file
/// @brief Summary statistics of repeated runs, with Student's t intervals (paper Table 7).

#include <cstddef>
#include <span>

namespace mfpc {

/// @brief What the experiment report (paper Table 7) says about N runs of one strategy.
///
/// The paper's interval uses the normal quantile 1.96; with the handful of runs an experiment
/// affords, that is too narrow, so the interval here uses Student's t with N - 1 degrees of
/// freedom.
struct Summary {
    std::size_t count = 0;          ///< N, the number of samples.
    double mean = 0;                ///< The sample mean.
    double variance = 0;            ///< Sample variance, divided by N - 1; 0 for one sample.
    double standard_deviation = 0;  ///< sqrt(variance).
    double t_quantile = 0;          ///< Two-sided Student t quantile at `confidence`, N - 1 df.
    double half_width = 0;          ///< t_quantile * standard_deviation / sqrt(N).
    double low = 0;                 ///< mean - half_width.
    double high = 0;                ///< mean + half_width.
    double min = 0;                 ///< The smallest sample.
    double max = 0;                 ///< The largest sample.
    double median = 0;              ///< Mean of the two middle samples for an even count.
    double confidence = 0.95;       ///< The confidence of the interval low..high.
};

/// @brief Summarizes the samples (in any order).
///
/// One sample leaves no degrees of freedom to estimate the spread with: variance and standard
/// deviation are 0, and t_quantile, half_width, low and high are NaN (no interval exists).
/// @param samples The samples.
/// @param confidence The confidence of the interval, in (0, 1).
/// @return The summary.
/// @throws mfpc::Error("statistics", ...) for an empty span, a NaN or infinite sample, samples so
/// large that their spread overflows, or a confidence outside (0, 1).
Summary summarize(std::span<const double> samples, double confidence = 0.95);

/// @brief P(T <= t) for Student's t with the given degrees of freedom (any positive finite value,
/// not only integers); t may be infinite.
///
/// Lower tails keep their relative accuracy: against 60-digit references (ν from 1e-3 to 1e15,
/// |t| up to 1e300) the relative error was below 1e-14 wherever P(T <= t) > 1e-20, growing like
/// 2e-16 |ln P| beyond (1.6e-13 at P = 1e-274).
/// @param t The value.
/// @param degrees_of_freedom ν, positive and finite.
/// @return P(T <= t).
/// @throws mfpc::Error for a NaN t or degrees of freedom that are not positive and finite.
double student_t_cdf(double t, double degrees_of_freedom);

/// @brief The t with P(T <= t) = probability: the inverse of student_t_cdf.
///
/// Against 60-digit references the relative error was below 1.6e-14 for ν >= 0.1 at every
/// probability from 1e-300 to 1 - 1e-12, and 3e-13 at ν = 1e-3.
/// @param probability The probability, in (0, 1).
/// @param degrees_of_freedom ν, positive and finite.
/// @return The quantile; an infinity where the answer lies beyond the double range (tiny degrees
/// of freedom with an extreme probability).
/// @throws mfpc::Error for a probability outside (0, 1) or degrees of freedom that are not
/// positive and finite.
double student_t_quantile(double probability, double degrees_of_freedom);

/// @brief 100 (reference - value) / reference: how many percent `value` (a run time, a point
/// count) is below `reference`, negative where it is above.
/// @param reference The baseline, positive and finite.
/// @param value The value compared with it, finite.
/// @return The reduction in percent.
/// @throws mfpc::Error for a reference that is not positive and finite, a value that is not
/// finite, or a reduction that overflows.
double reduction_percent(double reference, double value);

}  // namespace mfpc
