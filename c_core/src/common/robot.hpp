// Internal interface between the C API (c_core/src/*/..._api.cpp) and the robots.
//
// A Robot is a stateless description of one robot kind (a vtable): its parameter
// table, how a parameter vector is compiled into a constant RobotModel, and its
// kinematics and dynamics.  Algorithms throw pkm::Error; the C boundary turns that
// into a status and a message (see common/guard.hpp).  Default implementations of
// the generic algorithms (forward kinematics by damped Newton, velocity and
// acceleration kinematics, forward dynamics from the mass matrix) live in
// kinematics/ and dynamics/ and work for any robot that supplies ik, jacobians,
// jacobian_dot, mass_matrix and inverse_dynamics.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "pkm/pkm.h"

namespace pkm {

struct Error : std::runtime_error {
  int status;
  Error(int s, const std::string& msg) : std::runtime_error(msg), status(s) {}
};

// One named parameter: Modelica-style dotted name, unit, description, default and the
// closed range its own value must lie in (cross-parameter checks belong in compile()).
struct ParamSpec {
  std::string name, unit, description;
  double value;
  double lo = -1e300, hi = 1e300;
};

// Robot-specific constant data derived from a parameter vector (geometry in the
// layout the algorithms want).  Built by Robot::compile, shared read-only by every
// pkm_data of the model.
struct RobotModel {
  virtual ~RobotModel() = default;
};

// Robot-specific mutable work buffers (one per pkm_data).
struct RobotData {
  virtual ~RobotData() = default;
};

class Robot {
 public:
  virtual ~Robot() = default;
  virtual const char* name() const = 0;
  // One line saying what the robot is, and the description file it was compiled from
  // ("" for the robots written in C++).
  virtual const char* title() const { return ""; }
  virtual const char* source_file() const { return ""; }
  virtual int ndof() const = 0;

  // Parameter table of a named set ("default", ...); throws Error(PKM_ERR_ARGUMENT)
  // naming the known sets if the set is unknown.
  virtual std::vector<ParamSpec> param_specs(const std::string& set) const = 0;
  // Checks the parameter vector as a whole and derives the constant model; throws
  // Error(PKM_ERR_PARAMETER) with the parameter names involved.
  virtual std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>& specs,
                                              const std::vector<double>& values) const = 0;
  virtual std::unique_ptr<RobotData> make_data(const RobotModel&) const {
    return std::make_unique<RobotData>();
  }
  virtual void home(const RobotModel&, double* x) const = 0;
  // How the drive layer (dynamics/drive.hpp) names and measures the actuated joints:
  // parameter prefix ("rail" -> "rail[i].coulomb"), the noun in messages, and whether
  // q is an angle [rad, N m] or a length [m, N].
  virtual const char* joint_prefix() const { return "joint"; }
  virtual const char* joint_noun() const { return "joint"; }
  virtual bool joints_angular() const { return true; }

  // --- facts the rest of the toolkit reads through pkm.h (nothing outside restates them)
  // Names of the parameter sets param_specs accepts, "default" first.
  virtual std::vector<std::string> param_sets() const { return {"default"}; }
  // Values a parameter set gives to parameters outside the robot's own table (the drive
  // layer's, e.g. "rail[1].coulomb"), applied after the drive layer adds them.
  virtual std::vector<std::pair<std::string, double>> param_overrides(const std::string&) const { return {}; }
  // Name and unit of pose coordinate i (0-based, i < ndof()).
  virtual const char* pose_name(int i) const = 0;
  virtual const char* pose_unit(int i) const = 0;
  // What an external tracker of this robot measures, one column each (recordings' pose
  // columns): the pose coordinates unless the robot measures something else (the
  // four-bar: the coupler's mid point X, not the crank angle).
  virtual int tracker_count() const { return ndof(); }
  virtual const char* tracker_name(int i) const { return pose_name(i); }
  virtual const char* tracker_unit(int i) const { return pose_unit(i); }
  // The parameter holding actuated joint i's lower (upper) limit, "" if there is none;
  // the integrator stops there (pkm_sim) and the FMUs report it.
  virtual std::string joint_limit_param(int, bool /*upper*/) const { return ""; }
  // The parameters a geometric (kinematic) error of this robot is described by, in order
  // (the discrepancy engine's geometry effect and the blind generator read them); nullptr
  // past the end.  One per actuated joint, indexed like the joints, makes a per-joint
  // effect.  None: the toolkit takes every length parameter outside the drive layer that
  // moves a joint (what the generic calibration fits).
  virtual const char* geometry_param(int) const { return nullptr; }
  // How limit and singularity messages name the chain of joint i ("leg 3", "joint 2").
  virtual const char* limb_noun() const { return joint_noun(); }
  // The robot-specific C function families this robot provides beyond the common set
  // (pkm_model_has, through robot_features): "fourbar_output" stands for pkm_fourbar_output,
  // and so on.
  virtual std::vector<const char*> features() const { return {}; }

  // --- kinematics (x[nd] pose, q[nd] joints; matrices row-major [nd,nd])
  virtual void ik(const RobotModel&, RobotData&, const double* x, double* q) const;
  virtual void jacobians(const RobotModel&, RobotData&, const double* x, double* Jx,
                         double* Jq, double* J) const;
  virtual void jacobian_dot(const RobotModel&, RobotData&, const double* x, const double* xd,
                            double* Jdot) const;
  virtual void singularity(const RobotModel&, RobotData&, const double* x,
                           double* measures) const;
  // Each leg's base joint, moving proximal joint and platform joint (pts[nd,3,3]) for
  // drawing; default: unsupported.
  virtual void chain_points(const RobotModel&, RobotData&, const double* x, double* pts) const;
  // The platform's full pose X[6] = (x, y, z, rx, ry, rz) at coordinates x, the undeclared
  // components held (0) or dependent (solved from passive joints), and the motion map
  // S[6,nd] = dX/dx (may be nullptr); default: unsupported.
  virtual void platform_pose(const RobotModel&, RobotData&, const double* x, double* X, double* S) const;
  // The robot has a platform (or end effector) whose full pose platform_pose gives: the
  // platform force (dynamics/platform_force.hpp) acts on it.  Default: none.
  virtual bool has_platform() const { return false; }
  // What the integrator checks at every step, cheaply: a lower bound of the direct
  // singularity measure (measures[1]; a bound above a threshold proves the measure is
  // above it, so the exact measure is needed only near its threshold) and a value whose
  // sign flips when the motion passes through a direct singularity (det J).  Default:
  // the exact measure and det J from an LU of J (kinematics/generic_kinematics.cpp).
  virtual void direct_singularity_guard(const RobotModel&, RobotData&, const double* x,
                                        double* measure_bound, double* det_j) const;
  // Overridable generic algorithms (defaults in kinematics/ and dynamics/).
  virtual void fk(const RobotModel&, RobotData&, const double* q, const double* x_guess,
                  const pkm_fk_options& opt, double* x, pkm_fk_info& info) const;
  virtual void joint_acceleration(const RobotModel&, RobotData&, const double* x,
                                  const double* xd, const double* xdd, double* qdd) const;

  // --- dynamics
  virtual void inverse_dynamics(const RobotModel&, RobotData&, const double* x, const double* xd,
                                const double* xdd, double* tau) const;
  virtual void mass_matrix(const RobotModel&, RobotData&, const double* x, double* M) const;
  virtual void forward_dynamics(const RobotModel&, RobotData&, const double* x, const double* xd,
                                const double* tau, double* xdd) const;
  virtual void energy(const RobotModel&, RobotData&, const double* x, const double* xd,
                      double* kinetic, double* potential) const;
  // Forward dynamics plus their response to the efforts, B = d xdd / d tau (row-major
  // ndof x ndof), from the same factorisation.  The accelerations are affine in tau, so
  // FD(x, xd, tau + dtau) = FD(x, xd, tau) + B dtau: the integrator carries its last
  // stage across a change of the held input for the price of one small product.  false:
  // the robot has no cheap B (outputs untouched).
  virtual bool forward_dynamics_response(const RobotModel&, RobotData&, const double*, const double*,
                                         const double*, double*, double*) const {
    return false;
  }
  // The generic forward dynamics (dynamics/generic_dynamics.cpp: xdd = M^-1 (J^T tau - h))
  // and, with B != nullptr, B = M^-1 J^T from the same factor.  A robot that keeps the
  // generic forward dynamics offers its response through this.
  void generic_forward_dynamics(const RobotModel&, RobotData&, const double* x, const double* xd,
                                const double* tau, double* xdd, double* B) const;
};

// The robots compiled into the core and the descriptions in the search path
// (robots/registry.cpp, description/described_robot.hpp).  find_robot also takes a path to
// a description file; nullptr if unknown, Error if the description is bad.
const Robot* find_robot(const std::string& name);
int robot_count();
const Robot* robot_at(int i);  // nullptr if out of range (or a bad description)
const char* robot_name_at(int i);  // "" if out of range
std::string known_robots();
// A robot written in C++ goes by this name (a description may not take it).
bool is_builtin_robot(const std::string& name);
// The robot-specific C function families a robot provides (pkm_model_has): its own
// features() and those of the facts modules of robots/ that apply to it (the 6-PUS
// calibration rows of robots/sixpus_facts.cpp for a described 6-PUS).
std::vector<const char*> robot_features(const Robot& r);

[[noreturn]] void unsupported(const Robot& r, const char* what);

}  // namespace pkm
