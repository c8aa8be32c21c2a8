// pkm_effort_map: a drive's command-to-effort map, sampled (pkm.h "drive: command to
// effort"), what a torque sensor or a motor current reads against the commanded effort.
#include <cmath>
#include <string>

#include "common/guard.hpp"

using namespace pkm;

extern "C" int pkm_effort_map(size_t n, double dt, const double* u, double gain, double offset, double lag,
                              double limit, double y0, double* y, char* err, size_t errlen) {
  return guard_err(err, errlen, [&] {
    PKM_REQUIRE(u != nullptr && y != nullptr, PKM_ERR_ARGUMENT, "effort map: u or y is NULL");
    PKM_REQUIRE(std::isfinite(dt) && dt > 0, PKM_ERR_ARGUMENT, "effort map: dt = " + num(dt) + " s must be > 0");
    PKM_REQUIRE(std::isfinite(gain) && std::isfinite(offset) && std::isfinite(y0), PKM_ERR_ARGUMENT,
                "effort map: gain = " + num(gain) + ", offset = " + num(offset) + ", y0 = " + num(y0) +
                    " must be finite");
    PKM_REQUIRE(std::isfinite(lag) && lag >= 0, PKM_ERR_ARGUMENT,
                "effort map: lag = " + num(lag) + " s must be finite and >= 0");
    PKM_REQUIRE(!std::isnan(limit), PKM_ERR_ARGUMENT, "effort map: limit is NaN (<= 0 or inf: none)");
    // Exact for an effort held over the sample: y(t + dt) = a y(t) + (1 - a) e.
    const double a = lag > 0 ? std::exp(-dt / lag) : 0.0;
    double prev = y0;
    for (size_t k = 0; k < n; ++k) {
      PKM_REQUIRE(std::isfinite(u[k]), PKM_ERR_ARGUMENT,
                  "effort map: u[" + std::to_string(k) + "] is not finite (" + num(u[k]) + ")");
      double e = gain * u[k];
      if (limit > 0) e = std::fmax(-limit, std::fmin(limit, e));
      e += offset;
      prev = a * prev + (1.0 - a) * e;
      y[k] = prev;
    }
  });
}
