// Small numeric helpers shared by robots' hot paths.
#pragma once

#include <cmath>

namespace pkm {

// sin and cos of a platform angle for the hot paths (the 6-PUS, the described robots).
// For |a| <= 0.8 rad the Taylor series to a^17 / a^16 is exact to rounding (remainder
// < 1e-18) and several times
// cheaper than the library call, which would otherwise be a third of the cost of
// inverse kinematics and a tenth of the forward dynamics.
inline void sin_cos_small(double a, double& s, double& c) {
  if (std::abs(a) <= 0.8) {
    const double a2 = a * a;
    s = a * (1 + a2 * (-1.0 / 6 + a2 * (1.0 / 120 + a2 * (-1.0 / 5040 + a2 * (1.0 / 362880 +
        a2 * (-1.0 / 39916800 + a2 * (1.0 / 6227020800 + a2 * (-1.0 / 1307674368000 +
        a2 * (1.0 / 355687428096000)))))))));
    c = 1 + a2 * (-0.5 + a2 * (1.0 / 24 + a2 * (-1.0 / 720 + a2 * (1.0 / 40320 + a2 * (-1.0 / 3628800 +
        a2 * (1.0 / 479001600 + a2 * (-1.0 / 87178291200 + a2 * (1.0 / 20922789888000))))))));
  } else {
    s = std::sin(a);
    c = std::cos(a);
  }
}

}  // namespace pkm
