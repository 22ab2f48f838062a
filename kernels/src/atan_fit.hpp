#pragma once

namespace mfpc::detail {

// atan(t) = t * P(t^2) for t in [0, 1]: the coefficients of P, highest degree first, a Chebyshev
// fit of atan(sqrt(s)) / sqrt(s) on [0, 1] (|error| < 1e-8 rad in double; a float evaluation adds
// a few 1e-8). SHOT and BOARD use it in place of libm's atan2, which costs them several times more.
inline constexpr double atan_fit[] = {0.0027662835013404015, -0.01573124912073214, 0.04213762358723227,
                                      -0.07456854825872634,  0.10618370636906622,  -0.14197797794075448,
                                      0.1999187202910766,    -0.33333036709286157, 0.9999999817886557};

}  // namespace mfpc::detail
