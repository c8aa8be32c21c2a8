#pragma once
#include "common/robot.hpp"

namespace pkm {
// The line search of the Newton forward kinematics (the generic one and robots' own):
// tries the step fractions 1, 1/2, ..., 2^-29 of a step dx, trial(s) evaluating the
// residual norm at x + s dx and throwing Error where that pose is not valid (the fraction
// is then halved).  True at the first fraction that reduces the residual norm rn (or meets
// tol); the caller's state is then that of the last trial.  A template so that a robot's
// fast path keeps its trial inlined.
template <class Trial>
inline bool backtracking_step(double rn, double tol, Trial&& trial) {
  double step = 1.0;
  for (int ls = 0; ls < 30; ++ls, step *= 0.5) {
    double rt;
    try {
      rt = trial(step);
    } catch (const Error&) {
      continue;
    }
    if (rt < rn || rt <= tol) return true;
  }
  return false;
}

// xd = J^-1 qd and xdd = J^-1 (qdd - Jdot xd); Error(PKM_ERR_SINGULAR) at a singular J.
void pose_velocity(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* qd,
                   double* xd);
void pose_acceleration(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                       const double* qdd, double* xdd);
}  // namespace pkm
