#pragma once
#include <Eigen/Dense>
#include <cmath>

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

// The integrator's cheap direct-singularity check from the scaled Jacobian A (measures[1]
// = s_min / s_max of A): ||A||_F ||A^-1||_F >= s_max / s_min, so 1 / (||A||_F ||A^-1||_F) is a
// lower bound of the measure (at most a factor n below it) at the cost of one LU; the same
// LU gives det A, of the sign of det J.
template <class MatA>
inline void lu_singularity_guard(const MatA& A, double* measure_bound, double* det_a) {
  Eigen::PartialPivLU<MatA> lu(A);
  *det_a = lu.determinant();
  const auto d = lu.matrixLU().diagonal().cwiseAbs();
  if (!(d.minCoeff() > 1e-14 * d.maxCoeff())) {
    *measure_bound = 0.0;
    return;
  }
  const double bound = 1.0 / (A.norm() * lu.inverse().norm());
  *measure_bound = std::isfinite(bound) ? bound : 0.0;
}

// qd = J xd: the joint rates of a pose rate (pkm_joint_velocity, the drive layer's friction,
// the sensors, the two-body integrator).
void joint_velocity(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                    double* qd);
// xd = J^-1 qd and xdd = J^-1 (qdd - Jdot xd); Error(PKM_ERR_SINGULAR) at a singular J.
void pose_velocity(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* qd,
                   double* xd);
void pose_acceleration(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                       const double* qdd, double* xdd);
}  // namespace pkm
