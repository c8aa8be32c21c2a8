// Time courses of named parameters (pkm.h, "Time courses"): what pkm_param_set_course
// stores in a model and pkm_sim evaluates at its integrator's time.  The model keeps the
// parameter's own value (pkm_param_get, what every function outside pkm_sim uses); the
// course says how the value moves from it with time.
#pragma once

#include <string>
#include <vector>

#include "pkm/pkm.h"

namespace pkm {

struct ParamSpec;

struct Course {
  int param = -1;     // parameter index
  int kind = PKM_COURSE_NONE;
  double change = 0;  // trend: rate [unit/s]; step: the step's size [unit]
  double t0 = 0;      // trend: the time of the parameter's own value; step: when it happens [s]
};

// The value at time t of a parameter of value p under course c:
//   trend p + change (t - t0); step p before t0, p + change from t0 on.
inline double course_value(const Course& c, double p, double t) {
  if (c.kind == PKM_COURSE_TREND) return p + c.change * (t - c.t0);
  if (c.kind == PKM_COURSE_STEP) return t >= c.t0 ? p + c.change : p;
  return p;
}

// Throws Error(PKM_ERR_PARAMETER) if value v of parameter s at time t is outside its
// valid range, naming the parameter, the course and the time.
void check_course_value(const ParamSpec& s, const Course& c, double v, double t);

}  // namespace pkm
