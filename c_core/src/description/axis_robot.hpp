// A single-axis robot from a description: one leg of an axis kind (joint_kind.hpp), the
// platform carried by the actuated joint, the coordinate the joint coordinate (q = x,
// J = 1).  Its algorithms are written once over the kind's geometry and terms.
#pragma once

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

struct AxisRobotModel final : RobotModel {
  const AxisKind* kind = nullptr;
  AxisModel a;
  AxisBodies b;
  double M = 0;     // inertia along the axis [kg | kg m2]
  double home = 0;  // [m | rad]
};

class AxisRobot final : public DescribedRobot {
 public:
  AxisRobot(Description d, int serial) : DescribedRobot(std::move(d), serial), kind_(description().legs[0]->axis) {}
  const AxisKind& kind() const { return *kind_; }
  std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>& specs,
                                      const std::vector<double>& values) const override;
  void home(const RobotModel&, double* x) const override;
  const char* joint_prefix() const override { return kind_->prefix(); }
  const char* joint_noun() const override { return kind_->noun(); }
  bool joints_angular() const override { return kind_->angular(); }
  const char* geometry_param(int) const override { return nullptr; }
  // None on a continuous axis (`continuous = true`): the sim's stops and every check skip it.
  std::string joint_limit_param(int i, bool upper) const override;
  void platform_pose(const RobotModel&, RobotData&, const double* x, double* X, double* S) const override;

  void ik(const RobotModel&, RobotData&, const double* x, double* q) const override;
  void fk(const RobotModel&, RobotData&, const double* q, const double* x_guess, const pkm_fk_options& opt,
          double* x, pkm_fk_info& info) const override;
  void jacobians(const RobotModel&, RobotData&, const double* x, double* Jx, double* Jq, double* J) const override;
  void jacobian_dot(const RobotModel&, RobotData&, const double* x, const double* xd, double* Jdot) const override;
  void singularity(const RobotModel&, RobotData&, const double* x, double* measures) const override;
  void direct_singularity_guard(const RobotModel&, RobotData&, const double* x, double* measure_bound,
                                double* det_j) const override;
  void chain_points(const RobotModel&, RobotData&, const double* x, double* pts) const override;
  // The carriage or link an axis moves is its platform for the pose (platform_pose), but the
  // platform force (dynamics/platform_force.hpp) is not declared for it: one joint carries it.
  bool has_platform() const override { return false; }
  void joint_acceleration(const RobotModel&, RobotData&, const double* x, const double* xd, const double* xdd,
                          double* qdd) const override;
  void inverse_dynamics(const RobotModel&, RobotData&, const double* x, const double* xd, const double* xdd,
                        double* tau) const override;
  void mass_matrix(const RobotModel&, RobotData&, const double* x, double* M) const override;
  void forward_dynamics(const RobotModel&, RobotData&, const double* x, const double* xd, const double* tau,
                        double* xdd) const override;
  bool forward_dynamics_response(const RobotModel&, RobotData&, const double* x, const double* xd,
                                 const double* tau, double* xdd, double* B) const override;
  void energy(const RobotModel&, RobotData&, const double* x, const double* xd, double* kinetic,
              double* potential) const override;

 private:
  const AxisKind* kind_;
};

}  // namespace described
}  // namespace pkm
