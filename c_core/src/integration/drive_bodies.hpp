// The drive bodies of the two-body joints (drive.two_body = 1 and a backlash or a
// compliance on the joint): each one's position theta and rate theta_d are states of the
// sim of their own, after the pose and its rate: y = [x, xd, theta, theta_d] (4 nd
// values, the entries of the other joints unused).  The command drives the drive body;
// the carriage (the robot's joint) feels the effort the transmission carries.
#pragma once

#include <memory>
#include <vector>

#include "common/handles.hpp"
#include "dynamics/drive.hpp"

namespace pkm {

class DriveBodies {
 public:
  DriveBodies() = default;
  // The two-body joints of the model's drive layer (none without one).
  DriveBodies(const pkm_model* m, int nd);
  bool empty() const { return joints_.empty(); }
  bool all() const { return joints_.size() == (size_t)nd_; }
  // The state length with these joints: 2 nd, or 4 nd with drive bodies.
  int state_size() const { return empty() ? 2 * nd_ : 4 * nd_; }
  // The drive bodies at their joints q with the rates qd (nullptr: at rest).
  void start(const double* q, const double* qd, double* y) const;
  // Rates of the drive bodies (f[2 nd..4 nd)) at state y with joints q, qd and command u,
  // and the effort eff acting on each carriage (u on the other joints).
  void rates(const drive::Params& dp, const double* y, const double* q, const double* qd, const double* u,
             double* eff, double* f) const;
  // The drive layer the carriages feel (the two-body joints' friction and rotor inertia
  // act on their drive bodies).
  const drive::Params& carriage() const { return *carriage_; }
  // theta, theta_d of the drive bodies at state y (either may be nullptr); the other
  // joints' entries untouched.
  void read(const double* y, double* theta, double* theta_d) const;

 private:
  int nd_ = 0;
  std::vector<int> joints_;
  std::shared_ptr<const drive::Params> carriage_;
};

}  // namespace pkm
