// The stop conditions of a sim: the actuated joints' limits named in the model's
// parameters (stroke / joint limits) and the robot's direct-singularity measure against
// sim option sing_min, with the sign of det J (it flips when the motion passes through a
// direct singularity).  Each is a value g that is positive inside and crosses zero at the
// stop: the steppers evaluate them (as CVODE root functions, or at every accepted step of
// an explicit method) and locate the crossing; the messages name the joint and the time.
#pragma once

#include <string>
#include <vector>

#include "common/handles.hpp"

namespace pkm {

// One actuated-joint limit found among the model parameters: the root function
// g = q_j - value (lower) or value - q_j (upper) stops the integration at g = 0.
struct JointLimit {
  int joint;          // 0-based actuated joint
  bool upper;         // qmax (true) or qmin (false)
  double value;       // [m or rad]
  std::string param;  // its parameter name, e.g. "rail[3].qmax"
  std::string unit;   // its unit
  std::string noun;   // "leg", "arm" or "joint" (how the message names the joint)
};

class StopConditions {
 public:
  // The singularity stop is evaluated exactly only where the cheap bound (explicit
  // methods) or the measure at a segment's start (CVODE) is below this x sing_min.
  static constexpr double kSingGuard = 100.0;

  // Finds the joint limits in the model copy, then opens them there to the end of their
  // valid range (the stops stay the limits found).  Before the copy's work data exist.
  void find(pkm_model* copy, double sing_min);
  // With the copy's robot and work data: the singularity stop is on if the robot
  // provides the measures (tried at the home state y) and sing_min > 0.
  void bind(const Robot& robot, const RobotModel& rm, RobotData& rd, const double* y);

  int nlimits() const { return (int)limits_.size(); }
  int nstop() const { return nstop_; }    // stop values: the limits, then the singularity margin
  int nroots() const { return nroots_; }  // nstop() plus the det J sign value
  bool singularity() const { return sing_root_; }
  double sing_min() const { return sing_min_; }
  // The distance below which the exact singularity measure is needed.
  double sing_guard() const;
  bool is_limit(int k) const { return k < (int)limits_.size(); }
  int status(int k) const;  // PKM_ERR_JOINT_LIMIT or PKM_ERR_SINGULAR

  // g[nroots()] at y: the limits' margins, the singularity margin (exact false: reported
  // far away, 1.0) and det J.  Throws Error from the robot (unreachable pose...).
  void roots(const double* y, double* g, bool exact = true);
  // g[nstop()] at y with the robot's cheap singularity guard: the exact measure only where
  // the bound is near sing_min; det and bound the guard's det J and bound (1 without).
  void guard(const double* y, double* g, double& det, double& bound);
  double measure(const double* y);  // direct-singularity measure (the robot's measures[1])
  double det_j(const double* y);    // det J = det(Jq^-1 Jx)
  // The message of stop k with values g at time t: reached in a step, or (at_start) the
  // state is on or beyond it.
  std::string message(int k, const double* g, double t, bool at_start) const;
  // Throws (naming the joint or the measure) if state y lies beyond a stop by more than
  // round-off: a state given to reset.
  void check_start(const double* y);

 private:
  void open(pkm_model* copy);
  std::vector<JointLimit> limits_;
  double sing_min_ = 0.0;
  bool sing_root_ = false;
  int nstop_ = 0, nroots_ = 0;
  int nd_ = 0;
  const Robot* robot_ = nullptr;
  const RobotModel* rm_ = nullptr;
  RobotData* rd_ = nullptr;
  std::vector<double> q_, g_;  // work buffers
};

}  // namespace pkm
