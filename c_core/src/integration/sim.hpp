// A robot's task-space state (x, xd) integrated under a zero-order-hold input tau: the
// implementation behind pkm_sim (see integration/sim_api.cpp and docs/integration.md).
//
// The sim holds the state and the inputs and delegates each concern to a part of its own:
//   Ode             (ode.hpp)              the model copy and the state equation dy/dt = f(y, u)
//   DriveBodies     (drive_bodies.hpp)     the two-body joints' drive states, inside the ODE
//   StopConditions  (stop_conditions.hpp)  joint limits and the direct singularity
//   CommandDelay, ReadingDelay (delay_line.hpp)  actuator.delay and sensor.delay
//   StepBudget      (step_budget.hpp)      max_steps and the wall-clock limit of an advance
//   Stepper         (stepper.hpp)          the integrator, one file per kind: erk_stepper.cpp,
//                                          cvode_stepper.cpp
// It is written against the Robot interface only, so it serves every robot that provides
// forward_dynamics (directly or through the generic form).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/handles.hpp"
#include "integration/delay_line.hpp"
#include "integration/ode.hpp"
#include "integration/step_budget.hpp"
#include "integration/stepper.hpp"
#include "integration/stop_conditions.hpp"

namespace pkm {

class Sim {
 public:
  // Copies the model (later changes of the caller's model do not reach the sim) and
  // validates the options; throws Error naming the bad option.  The initial state is
  // the robot's home pose at rest, t = 0, tau = 0.
  Sim(const pkm_model* m, const pkm_sim_options& opt);
  Sim(const Sim&) = delete;
  Sim& operator=(const Sim&) = delete;

  // Throws Error (state unchanged) on a non-finite, unreachable, out-of-limit or singular state.
  void reset(double t0, const double* x, const double* xd);
  void set_input(const double* tau);
  // Integrates to t_end; on a stop or failure, keeps the state where it stopped and
  // throws Error with the status and a message naming the leg and the time.
  void advance(double t_end);
  void get_state(double* t, double* x, double* xd) const;
  // Drive-side position and rate per joint: the drive body's for a two-body joint
  // (drive.two_body), the joint's own otherwise.
  void drive_state(double* theta, double* theta_d);
  bool two_body() const { return !ode_.bodies().empty(); }
  // Pose acceleration at the current state under the command tau (dead zone, saturation).
  void acceleration(const double* tau, double* xdd);
  const pkm_sim_stats& stats() const { return stats_; }
  // A wall-clock limit per advance [s] (0: none): past it the advance stops as if its step
  // budget ran out.  The one result of a sim that depends on the machine, for hosts that
  // must get an answer in bounded time (the FMUs).
  void set_time_limit(double seconds) { budget_.set_time_limit(seconds); }
  int ndof() const { return nd_; }
  // Everything that determines the future of the sim (pkm_sim_state_*): t, state, held
  // input, the stepper's block (the explicit method's next step size) and the
  // actuator-delay history it needs.
  size_t state_size() const;
  void state_save(double* buf) const;
  void state_load(const double* buf, size_t n);

  std::string error;  // message of the last failure (pkm_sim_error)

  // The sim's own model copy and work data (for the closed loop's joint readings).
  const pkm_model* model() const { return ode_.model(); }
  pkm_data* data() const { return ode_.data(); }
  const double* held_input() const { return tau_.data(); }
  // The effort acting on the mechanism at the sim's time from the commands issued before
  // it: the held input, or with an actuator delay the command issued at t - delay (zero
  // before the first).  What the sensor model's compliance deflects under at a sample.
  void applied_effort(double* tau) const;
  // A known external effort per joint [N or N m] (a measured force on the carriage), held
  // from now on and added to the actuator effort, with no saturation and no delay.
  void set_external(const double* f);
  bool actuator_delayed() const { return commands_.active(); }
  // The closed loop's delay line of joint readings (drive parameter sensor.delay > 0):
  // records the sample (t, q, qd) and replaces q, qd by the reading and rate of
  // t - sensor.delay.  reset() forgets the samples at or after its t0 (a rollback).
  void delayed_reading(double t, double* q, double* qd) { readings_.read(t, q, qd); }

 private:
  // Integrates one segment [t_, b] with a constant applied effort; throws on a stop.
  void segment(double b);
  // Puts the parameters' time courses at time t (steps on their side, trends at t),
  // binding the stops again and restarting the steppers where a step changed something.
  void courses_at(double t);
  void add_external() {
    for (int i = 0; i < nd_; ++i) applied_[i] += external_[i];
  }

  pkm_sim_options opt_{};
  StopConditions stops_;
  Ode ode_;
  int nd_ = 0;
  int ny_ = 0;  // state length: 2 nd, or 4 nd with two-body joints (y = [x, xd, theta, theta_d])

  double t_ = 0.0;
  std::vector<double> y_;         // state [x, xd], then [theta, theta_d] of the drive bodies if any
  std::vector<double> tau_;       // held command (after saturation), nd
  std::vector<double> applied_;   // effort reaching the mechanism in the current segment, nd
  std::vector<double> external_;  // known external effort held (set_external), nd
  std::vector<double> g_;         // stop values at the start of an advance
  CommandDelay commands_;
  ReadingDelay readings_;

  pkm_sim_stats stats_{};
  StepBudget budget_;
  Ivp ivp_;
  std::unique_ptr<Stepper> stepper_;   // the integrator of opt_.method
  std::unique_ptr<Stepper> stiff_;     // BDF, made when an explicit stepper first hands over
};

}  // namespace pkm

struct pkm_sim {
  pkm::Sim sim;
  pkm_sim(const pkm_model* m, const pkm_sim_options& o) : sim(m, o) {}
};
