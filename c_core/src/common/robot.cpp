// Defaults of the Robot interface for functions a robot does not provide.
#include "common/robot.hpp"

namespace pkm {

void Robot::ik(const RobotModel&, RobotData&, const double*, double*) const { unsupported(*this, "inverse kinematics"); }
void Robot::jacobians(const RobotModel&, RobotData&, const double*, double*, double*, double*) const {
  unsupported(*this, "Jacobians");
}
void Robot::jacobian_dot(const RobotModel&, RobotData&, const double*, const double*, double*) const {
  unsupported(*this, "the Jacobian time derivative");
}
void Robot::singularity(const RobotModel&, RobotData&, const double*, double*) const {
  unsupported(*this, "singularity measures");
}
void Robot::chain_points(const RobotModel&, RobotData&, const double*, double*) const {
  unsupported(*this, "chain points (the robots written in C++ have their own calls)");
}
void Robot::platform_pose(const RobotModel&, RobotData&, const double*, double*, double*) const {
  unsupported(*this, "the platform's full pose (the described robots have it)");
}
void Robot::inverse_dynamics(const RobotModel&, RobotData&, const double*, const double*, const double*,
                             double*) const {
  unsupported(*this, "inverse dynamics");
}
void Robot::mass_matrix(const RobotModel&, RobotData&, const double*, double*) const {
  unsupported(*this, "the mass matrix");
}
void Robot::energy(const RobotModel&, RobotData&, const double*, const double*, double*, double*) const {
  unsupported(*this, "energy");
}

}  // namespace pkm
