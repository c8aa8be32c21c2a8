// pkm::Sim: the state, the inputs and the order of things in an advance; the integration
// itself is its stepper's (integration/stepper.hpp).
//
//   dy/dt = [xd; FD(x, xd, tau_applied)],
// FD the total forward dynamics (robot mechanics + drive friction and rotor inertia),
// tau_applied the saturated command held over an advance (zero-order hold), or with an
// actuator delay the command issued `delay` earlier: an advance is integrated piecewise
// between the switches of the delay line, each piece a segment of constant effort.
#include "integration/sim.hpp"

#include <algorithm>
#include <cmath>

#include "common/guard.hpp"

namespace pkm {

namespace {

pkm_sim_options checked_options(const pkm_model* m, const pkm_sim_options& o) {
  PKM_REQUIRE(m != nullptr, PKM_ERR_ARGUMENT, "model is NULL");
  check_method(o.method);
  auto bad = [](const std::string& what) { throw Error(PKM_ERR_ARGUMENT, "pkm_sim options: " + what); };
  if (!(std::isfinite(o.rtol) && o.rtol > 0 && o.rtol < 1))
    bad("rtol = " + num(o.rtol) + " must be in (0, 1)");
  if (!(std::isfinite(o.atol) && o.atol > 0)) bad("atol = " + num(o.atol) + " must be finite and > 0");
  if (!(std::isfinite(o.max_step) && o.max_step >= 0))
    bad("max_step = " + num(o.max_step) + " s must be finite and >= 0 (0 = unlimited)");
  if (o.max_steps <= 0 || o.max_steps > PKM_SIM_MAX_STEPS_LIMIT)
    bad("max_steps = " + std::to_string(o.max_steps) + " must be in [1, " + std::to_string(PKM_SIM_MAX_STEPS_LIMIT) +
        "]: it bounds the work of one advance (a call must return; docs/integration.md, Bounded work)");
  if (!(std::isfinite(o.sing_min) && o.sing_min >= 0 && o.sing_min < 1))
    bad("sing_min = " + num(o.sing_min) + " must be in [0, 1) (0 = no singularity stop)");
  PKM_REQUIRE(m->compiled != nullptr, PKM_ERR_PARAMETER,
              "the model's parameters were changed and not validated: call pkm_model_validate before pkm_sim_create");
  return o;
}

}  // namespace

// ----------------------------------------------------------------- construction

Sim::Sim(const pkm_model* m, const pkm_sim_options& opt)
    : opt_(checked_options(m, opt)),
      ode_(m, [this](pkm_model* copy) { stops_.find(copy, opt_.sing_min); }),
      nd_(ode_.nd()),
      ny_(ode_.ny()),
      ivp_{opt_, ode_, stops_, budget_, stats_, t_, y_, applied_} {
  y_.assign(ny_, 0.0);
  tau_.assign(nd_, 0.0);
  applied_.assign(nd_, 0.0);
  external_.assign(nd_, 0.0);
  const pkm_model* copy = ode_.model();
  commands_ = CommandDelay(nd_, copy->drive ? copy->drive->actuator_delay : 0.0);
  readings_ = ReadingDelay(nd_, copy->drive ? copy->drive->sensor_delay : 0.0);
  ode_.home(y_.data());
  stops_.bind(ode_.robot(), ode_.robot_model(), ode_.robot_data(), y_.data());
  g_.assign(stops_.nroots(), 0.0);
  stepper_ = make_stepper(opt_.method, ivp_);
  budget_ = StepBudget(opt_.max_steps, stepper_->budget_advice());
}

// -------------------------------------------------------------------- the state

void Sim::reset(double t0, const double* x, const double* xd) {
  PKM_REQUIRE(std::isfinite(t0), PKM_ERR_ARGUMENT, "reset: t0 = " + num(t0) + " is not finite");
  check_finite(x, nd_, "reset: pose x");
  check_finite(xd, nd_, "reset: pose velocity xd");
  std::vector<double> y(ny_, 0.0);
  for (int i = 0; i < nd_; ++i) {
    y[i] = x[i];
    y[nd_ + i] = xd[i];
  }
  // The parameters' courses at t0 first (a rollback across a step takes the values before
  // it), so the advance after a state load finds them in place and keeps the loaded step size.
  courses_at(t0);
  stops_.check_start(y.data());
  // A start whose energy overflows (a rate of 1e200 m/s) is no state of a robot.
  double kinetic = 0, potential = 0;
  try {
    total_energy(ode_.model(), ode_.data(), y.data(), y.data() + nd_, &kinetic, &potential);
    if (two_body()) {  // the drive bodies start at their joints, with their rates
      double q[6], qd[6];
      ode_.joints(y.data(), q, qd);
      ode_.bodies().start(q, qd, y.data());
    }
  } catch (const Error& e) {
    throw Error(e.status, std::string("reset: ") + e.what());
  }
  t_ = t0;
  y_.swap(y);
  stepper_->restart();  // a new start: nothing carried from the last segment
  // Commands and readings recorded at or after t0 belong to the future being rolled back.
  commands_.rollback(t0);
  readings_.rollback(t0);
}

void Sim::set_input(const double* tau) {
  check_finite(tau, nd_, "input tau");
  double sat[6];
  // Saturation (drive parameters <j>[i].effort_max) acts on the command itself.
  ode_.saturate(tau, sat);
  for (int i = 0; i < nd_; ++i) tau_[i] = sat[i];
}

void Sim::set_external(const double* f) {
  check_finite(f, nd_, "external effort");
  for (int i = 0; i < nd_; ++i) external_[i] = f[i];
}

void Sim::applied_effort(double* tau) const {
  if (!commands_.active()) {
    for (int i = 0; i < nd_; ++i) tau[i] = tau_[i];
    return;
  }
  commands_.acting_at(t_, tau);
}

void Sim::get_state(double* t, double* x, double* xd) const {
  if (t) *t = t_;
  for (int i = 0; i < nd_; ++i) {
    if (x) x[i] = y_[i];
    if (xd) xd[i] = y_[nd_ + i];
  }
}

void Sim::drive_state(double* theta, double* theta_d) {
  const DriveBodies& bodies = ode_.bodies();
  if (!bodies.all()) {
    double q[6], qd[6];
    ode_.joints(y_.data(), q, qd);
    for (int i = 0; i < nd_; ++i) {
      if (theta) theta[i] = q[i];
      if (theta_d) theta_d[i] = qd[i];
    }
  }
  bodies.read(y_.data(), theta, theta_d);
}

void Sim::acceleration(const double* tau, double* xdd) {
  check_finite(tau, nd_, "acceleration: tau");
  double u[6], f[24];
  courses_at(t_);
  ode_.saturate(tau, u);
  ode_.rates(y_.data(), u, f);
  for (int i = 0; i < nd_; ++i) xdd[i] = f[nd_ + i];
}

// ------------------------------------------------------------------- advancing

void Sim::advance(double t_end) {
  PKM_REQUIRE(std::isfinite(t_end), PKM_ERR_ARGUMENT, "advance: t_end = " + num(t_end) + " is not finite");
  PKM_REQUIRE(t_end >= t_, PKM_ERR_ARGUMENT,
              "advance: t_end = " + num(t_end, 17) + " s is before the current time t = " + num(t_, 17) + " s");
  if (t_end == t_) return;
  budget_.start(t_, t_end);

  // A state on or beyond a stop boundary cannot be advanced: a stepper only sees the
  // crossings inside its steps, so it would miss one that already happened.
  try {
    stepper_->start_values(g_.data());
  } catch (const Error& e) {
    throw Error(e.status, std::string(e.what()) + " at t = " + num(t_) + " s");
  }
  for (int k = 0; k < stops_.nstop(); ++k)
    if (g_[k] <= 0) throw Error(stops_.status(k), stops_.message(k, g_.data(), t_, true));

  if (!commands_.active() && !ode_.has_courses()) {
    applied_ = tau_;
    add_external();
    segment(t_end);
    return;
  }

  // With an actuator delay the applied effort switches wherever a past command's start
  // plus the delay falls inside the interval, and a parameter's step (pkm_param_set_course)
  // switches the dynamics at its time: integrate piecewise, restarting the stepper's
  // segment at each switch so no step straddles a discontinuity.
  if (commands_.active()) commands_.issue(t_, tau_.data());
  while (t_ < t_end) {
    const double b = ode_.next_step(t_, commands_.active() ? commands_.next_switch(t_, t_end) : t_end);
    courses_at(t_);
    if (commands_.active())
      commands_.command_at(0.5 * (t_ + b) - commands_.delay(), applied_.data());
    else
      applied_ = tau_;
    add_external();
    segment(b);
  }
  if (commands_.active()) commands_.forget_before(t_);
}

void Sim::courses_at(double t) {
  if (!ode_.has_courses()) return;
  const int changed = ode_.steps_at(t);
  ode_.trends_at(t);
  if (changed == 2) stops_.bind(ode_.robot(), ode_.robot_model(), ode_.robot_data(), y_.data());
  if (changed) {  // what the steppers carried was computed with the values before the step
    stepper_->restart();
    if (stiff_) stiff_->restart();
  }
}

void Sim::segment(double b) {
  if (stepper_->advance(b)) return;
  // A stiff stretch: the explicit stepper stopped at its last accepted step; BDF takes the
  // rest of the segment on the same step budget, and the next segment starts explicit again.
  stepper_->restart();
  if (!stiff_) stiff_ = make_stepper(PKM_BDF, ivp_);
  stiff_->advance(b);
}

// ------------------------------------------------------------------ saved state

// Layout: version, nd, t, y[ny] (2 nd; 4 nd with drive bodies), tau[nd], the stepper's
// block, the delay line's command count, its commands (1 + nd each).
size_t Sim::state_size() const {
  return 4 + (size_t)ny_ + (size_t)nd_ + stepper_->state_size() + commands_.saved_count(t_) * (1 + (size_t)nd_);
}

void Sim::state_save(double* b) const {
  size_t k = 0;
  b[k++] = two_body() ? 2.0 : 1.0;  // layout version: 2 with the drive bodies' states
  b[k++] = nd_;
  b[k++] = t_;
  for (int i = 0; i < ny_; ++i) b[k++] = y_[i];
  for (int i = 0; i < nd_; ++i) b[k++] = tau_[i];
  stepper_->save(b + k);
  k += stepper_->state_size();
  commands_.save(t_, b + k);
}

void Sim::state_load(const double* b, size_t n) {
  PKM_REQUIRE(b != nullptr, PKM_ERR_ARGUMENT, "state: buffer is NULL");
  const double version = two_body() ? 2.0 : 1.0;
  const size_t ny = (size_t)ny_, nd = (size_t)nd_;
  const size_t block = 3 + ny + nd;                     // the stepper's block
  const size_t count = block + stepper_->state_size();  // the delay line's count
  PKM_REQUIRE(n >= count + 1 && b[0] == version && b[1] == nd_, PKM_ERR_ARGUMENT,
              "state: not a pkm_sim state of this robot and drive layer (layout version " + num(version) + ", " +
                  std::to_string(nd_) + " joints)");
  for (size_t k = 0; k < n; ++k)
    PKM_REQUIRE(std::isfinite(b[k]), PKM_ERR_ARGUMENT, "state: entry " + std::to_string(k) + " is not finite");
  const double nh_value = b[count];
  PKM_REQUIRE(nh_value >= 0 && nh_value < 1e9 && nh_value == std::floor(nh_value), PKM_ERR_ARGUMENT,
              "state: a history length of " + num(nh_value) + " entries is not a count");
  const size_t nh = (size_t)nh_value;
  PKM_REQUIRE(n == count + 1 + nh * (1 + nd), PKM_ERR_ARGUMENT,
              "state: " + std::to_string(n) + " values do not match the history length it declares");
  const double t = b[2];
  stepper_->check(b + block, t);
  CommandDelay::check_saved(b + count + 1, nh, nd_, t);
  std::vector<double> x(b + 3, b + 3 + nd_), xd(b + 3 + nd_, b + 3 + 2 * nd_);
  reset(t, x.data(), xd.data());  // checks the state as any reset does; restarts the stepper
  for (size_t i = 2 * nd; i < ny; ++i) y_[i] = b[3 + i];  // the drive bodies as saved
  for (int i = 0; i < nd_; ++i) tau_[i] = b[3 + ny + i];
  stepper_->load(b + block);
  commands_.load(b + count + 1, nh);
}

}  // namespace pkm
