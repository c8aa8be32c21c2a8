#pragma once
#include "common/robot.hpp"

namespace pkm {
// xd = J^-1 qd and xdd = J^-1 (qdd - Jdot xd); Error(PKM_ERR_SINGULAR) at a singular J.
void pose_velocity(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* qd,
                   double* xd);
void pose_acceleration(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                       const double* qdd, double* xdd);
}  // namespace pkm
