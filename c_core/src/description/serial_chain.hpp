// A serial arm from a description (docs/robots.md, Serial arms): an open chain of revolute
// and prismatic joints from the base to the end effector, every joint actuated and every
// joint a coordinate (x = q, J = 1).
//
// Model.  Joint i's frame is placed in joint i-1's moved frame (the base for the first) by
// a constant origin and roll-pitch-yaw rotation (URDF's <origin xyz rpy>: R = Rz(yaw)
// Ry(pitch) Rx(roll)), then moved by the joint: a rotation q_i about its unit axis
// (revolute), or a translation q_i along it (prismatic).  Link i is the body joint i moves:
// its mass, centre of mass and inertia about the centre of mass in joint i's moved frame
// (URDF's <inertial>).  The tool frame (the end effector) is a constant placement in the
// last joint's moved frame; a payload point mass sits in it.
//
// Algorithms (Featherstone 2008, ch. 5-6), with spatial vectors [angular; linear] written
// in world coordinates about the world origin: the recursive Newton-Euler algorithm for the
// inverse dynamics, the composite-rigid-body algorithm for the mass matrix, the forward
// dynamics M^-1 (tau - h) by a Cholesky factor, h the inverse dynamics at qdd = 0.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "description/described_robot.hpp"

namespace pkm {
namespace described {

constexpr int kMaxChainJoints = 6;  // the drive layer's joints (dynamics/drive.hpp)

// What a description declares of one joint beyond its parameters.
struct ChainJointInfo {
  std::string name;  // the joint's name (pose coordinate name)
  bool prismatic = false;
  bool limited = true;  // a continuous joint has no limit parameters
};

struct ChainJoint {
  bool prismatic = false;
  bool limited = true;
  Eigen::Matrix3d R0;  // origin rotation in the parent's frame
  Eigen::Vector3d p0;  // origin position in the parent's frame [m]
  Eigen::Vector3d axis;  // unit axis in the joint frame
  double qmin = 0, qmax = 0;
  double m = 0;            // link mass [kg]
  Eigen::Vector3d c;       // link centre of mass, joint frame [m]
  Eigen::Matrix3d Ic;      // link inertia about its centre of mass, joint frame axes [kg m2]
};

struct ChainModel final : RobotModel {
  int n = 0;
  ChainJoint j[kMaxChainJoints];
  Eigen::Matrix3d R_tool;
  Eigen::Vector3d p_tool;
  double m_payload = 0;
  Eigen::Vector3d c_payload;  // tool frame [m]
  Eigen::Vector3d g;          // world [m/s2]
  double home[kMaxChainJoints];
};

// Reads a description with [robot] kind = "serial" (called by read_description's caller,
// loader.cpp); throws Error(PKM_ERR_ARGUMENT, "file:line: field: what").
Description read_serial_description(const toml::Document& doc, const std::string& file,
                                    std::vector<ChainJointInfo>& joints);
// Whether a parsed description declares a serial arm ([robot] kind = "serial").
bool is_serial_description(const toml::Document& doc);

class SerialRobot final : public DescribedRobot {
 public:
  SerialRobot(Description d, std::vector<ChainJointInfo> joints, int serial);
  int ndof() const override { return (int)joints_.size(); }
  std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>& specs,
                                      const std::vector<double>& values) const override;
  void home(const RobotModel&, double* x) const override;
  std::unique_ptr<RobotData> make_data(const RobotModel&) const override { return std::make_unique<RobotData>(); }
  const char* joint_prefix() const override { return "joint"; }
  const char* joint_noun() const override { return "joint"; }
  // The drive layer's units follow the first joint; a description mixing revolute and
  // prismatic joints is refused (read_serial_description).
  bool joints_angular() const override { return !joints_[0].prismatic; }
  const char* limb_noun() const override { return "joint"; }
  const char* pose_name(int i) const override { return joints_[i].name.c_str(); }
  const char* pose_unit(int i) const override { return joints_[i].prismatic ? "m" : "rad"; }
  std::string joint_limit_param(int i, bool upper) const override;
  const char* geometry_param(int) const override { return nullptr; }

  void ik(const RobotModel&, RobotData&, const double* x, double* q) const override;
  void fk(const RobotModel&, RobotData&, const double* q, const double* x_guess, const pkm_fk_options& opt,
          double* x, pkm_fk_info& info) const override;
  void jacobians(const RobotModel&, RobotData&, const double* x, double* Jx, double* Jq, double* J) const override;
  void jacobian_dot(const RobotModel&, RobotData&, const double* x, const double* xd, double* Jdot) const override;
  void singularity(const RobotModel&, RobotData&, const double* x, double* measures) const override;
  void direct_singularity_guard(const RobotModel&, RobotData&, const double* x, double* measure_bound,
                                double* det_j) const override;
  void chain_points(const RobotModel&, RobotData&, const double* x, double* pts) const override;
  void platform_pose(const RobotModel&, RobotData&, const double* x, double* X, double* S) const override;
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
  std::vector<ChainJointInfo> joints_;
};

}  // namespace described
}  // namespace pkm
