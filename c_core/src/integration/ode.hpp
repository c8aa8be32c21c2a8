// What a sim integrates: its own copy of the model, the work data, and the right-hand
// side of the state equation
//   dy/dt = f(y, u),  y = [x, xd] (+ [theta, theta_d] of the drive bodies),
// f = (xd, total forward dynamics under the effort u) and the drive bodies' rates.
// The steppers call it; it knows nothing of time, inputs or stop conditions.
#pragma once

#include <functional>
#include <memory>
#include <vector>

#include "common/handles.hpp"
#include "integration/drive_bodies.hpp"

namespace pkm {

class Ode {
 public:
  // Copies m (later changes of the caller's model do not reach the ODE); adjust may
  // change the copy's parameters before the work data are made (the stop conditions
  // open the joint limits there).  Throws Error.
  Ode(const pkm_model* m, const std::function<void(pkm_model*)>& adjust);
  ~Ode();
  Ode(const Ode&) = delete;
  Ode& operator=(const Ode&) = delete;

  int nd() const { return nd_; }
  int ny() const { return bodies_.state_size(); }
  const pkm_model* model() const { return model_; }
  pkm_data* data() const { return data_; }
  const Robot& robot() const { return *robot_; }
  const RobotModel& robot_model() const { return *rm_; }
  RobotData& robot_data() const { return *rd_; }
  const DriveBodies& bodies() const { return bodies_; }

  // The home pose at rest, the drive bodies at their joints (y of ny() values, zeroed).
  void home(double* y) const;
  // f = f(y, u): (xd, FD) and, for the two-body joints, (theta_d, theta_dd) with the
  // transmission's effort driving the carriage.  Throws like the robot.
  void rates(const double* y, const double* u, double* f) const;
  // The same split as f(y, tau) = F + B tau with B = d xdd / d tau (row-major nd x nd),
  // when the robot offers it cheaply and no joint is two bodies: writes F's accelerations
  // to f + nd and B; false otherwise (outputs untouched).
  bool rates_response(const double* y, const double* tau, double* f, double* B) const;
  // The joints q and rates qd of the robot at state y (throws like the robot's IK).
  void joints(const double* y, double* q, double* qd) const;
  // The effort reaching the mechanism for the command tau (the drive's saturation).
  void saturate(const double* tau, double* u) const;

  // The parameters' time courses (pkm_param_set_course), on the copy's values: the
  // steppers call trends_at(t) before each evaluation of f (the trends at the stage's
  // time, the drive layer recompiled); the sim splits an advance at next_step(a, b) (the
  // first step time, or time a trend reaches the end of its range, in (a, b), else b) and
  // calls steps_at(t) before each segment (every step on its side at t).  steps_at returns
  // 0 if nothing changed, 1 if the drive layer did, 2 if the mechanism was recompiled (new
  // work data: whoever holds them binds again), and throws Error naming the parameter and
  // the time once a trend has reached the end of its range (trends_at for a value out of it).
  bool has_courses() const { return !model_->courses.empty(); }
  void trends_at(double t);
  double next_step(double a, double b) const;
  int steps_at(double t);

 private:
  pkm_model* model_ = nullptr;  // owned copy
  pkm_data* data_ = nullptr;    // owned work data
  const Robot* robot_ = nullptr;
  const RobotModel* rm_ = nullptr;
  RobotData* rd_ = nullptr;
  int nd_ = 0;
  DriveBodies bodies_;
  std::vector<double> base_;  // the coursed parameters' own values, as model_->courses
  std::vector<int> slot_;     // a friction trend's place in the drive layer (drive::friction_slot), else -1
  bool trends_ = false;       // a course is a trend

  void recompile_drive();
};

}  // namespace pkm
