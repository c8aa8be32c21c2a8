#include "integration/ode.hpp"

#include <cmath>

#include "common/guard.hpp"
#include "dynamics/drive.hpp"
#include "kinematics/generic_kinematics.hpp"

namespace pkm {

Ode::Ode(const pkm_model* m, const std::function<void(pkm_model*)>& adjust) {
  try {
    model_ = pkm_model_copy(m);
    PKM_REQUIRE(model_ != nullptr, PKM_ERR_INTERNAL, "out of memory copying the model");
    robot_ = model_->robot;
    nd_ = robot_->ndof();
    if (adjust) adjust(model_);
    data_ = pkm_data_create(model_);
    PKM_REQUIRE(data_ != nullptr, PKM_ERR_INTERNAL, "out of memory creating the work data");
    rm_ = &prepare(model_, data_);
    rd_ = data_->rd.get();
    bodies_ = DriveBodies(model_, nd_);
    for (const auto& c : model_->courses) {
      base_.push_back(model_->values[c.param]);
      slot_.push_back(c.kind == PKM_COURSE_TREND ? drive::friction_slot(*robot_, model_->specs[c.param].name) : -1);
      trends_ |= c.kind == PKM_COURSE_TREND;
    }
    PKM_REQUIRE(nd_ <= 6, PKM_ERR_INTERNAL, "the simulator supports up to 6 actuated joints");
  } catch (...) {
    if (data_) pkm_data_destroy(data_);
    if (model_) pkm_model_destroy(model_);
    throw;
  }
}

Ode::~Ode() {
  if (data_) pkm_data_destroy(data_);
  if (model_) pkm_model_destroy(model_);
}

void Ode::home(double* y) const {
  robot_->home(*rm_, y);
  if (!bodies_.empty()) {  // the drive bodies at their joints, at rest
    double q[6];
    robot_->ik(*rm_, *rd_, y, q);
    bodies_.start(q, nullptr, y);
  }
}

void Ode::rates(const double* y, const double* u, double* f) const {
  const int n = nd_;
  for (int i = 0; i < n; ++i) f[i] = y[n + i];
  if (bodies_.empty()) {
    total_forward_dynamics(model_, data_, y, y + n, u, f + n);
    return;
  }
  // Two-body joints: the carriage feels the transmitted effort, the drive body the command
  // less that effort and its own friction.
  double q[6], qd[6], eff[6];
  joints(y, q, qd);
  bodies_.rates(*model_->drive, y, q, qd, u, eff, f);
  total_forward_dynamics(model_, bodies_.carriage(), data_, y, y + n, eff, f + n);
}

bool Ode::rates_response(const double* y, const double* tau, double* f, double* B) const {
  return bodies_.empty() && total_forward_dynamics_response(model_, data_, y, y + nd_, tau, f + nd_, B);
}

void Ode::joints(const double* y, double* q, double* qd) const {
  robot_->ik(*rm_, *rd_, y, q);
  joint_velocity(*robot_, *rm_, *rd_, y, y + nd_, qd);
}

void Ode::saturate(const double* tau, double* u) const {
  if (model_->drive)
    actuator_effort(*model_->drive, tau, u);
  else
    for (int i = 0; i < nd_; ++i) u[i] = tau[i];
}

// ------------------------------------------------------------------ time courses

void Ode::recompile_drive() {
  model_->drive = drive::compile(*robot_, model_->specs, model_->values);
  if (bodies_.empty()) return;
  DriveBodies b(model_, nd_);
  PKM_REQUIRE(b.state_size() == bodies_.state_size(), PKM_ERR_PARAMETER,
              "a parameter's time course changes which joints are two bodies (drive.two_body)");
  bodies_ = b;
}

void Ode::trends_at(double t) {
  if (!trends_) return;
  bool changed = false, patched = false;
  std::shared_ptr<drive::Params> fast;  // the friction trends' values set in place of a compile
  const auto& cs = model_->courses;
  for (size_t k = 0; k < cs.size(); ++k) {
    if (cs[k].kind != PKM_COURSE_TREND) continue;
    const double v = course_value(cs[k], base_[k], t);
    double& p = model_->values[cs[k].param];
    if (v == p) continue;
    check_course_value(model_->specs[cs[k].param], cs[k], v, t);
    p = v;
    if (slot_[k] < 0) {
      changed = true;
      continue;
    }
    if (!fast) fast = std::make_shared<drive::Params>(*model_->drive);
    drive::set_friction(*fast, slot_[k], v);
    patched = true;
  }
  if (changed) {
    recompile_drive();  // reads every value, the friction's set above included
  } else if (patched) {
    model_->drive = fast;
    if (!bodies_.empty()) recompile_drive();  // the carriage side is derived from the drive layer
  }
}

// When a trend reaches the end of its parameter's range (inf: never).
static double range_exit(const Course& c, const ParamSpec& s, double p) {
  if (c.kind != PKM_COURSE_TREND || c.change == 0) return INFINITY;
  const double bound = c.change > 0 ? s.hi : s.lo;
  return std::fabs(bound) >= 1e300 ? INFINITY : c.t0 + (bound - p) / c.change;
}

double Ode::next_step(double a, double b) const {
  const auto& cs = model_->courses;
  for (size_t k = 0; k < cs.size(); ++k) {
    const double t = cs[k].kind == PKM_COURSE_STEP ? cs[k].t0 : range_exit(cs[k], model_->specs[cs[k].param], base_[k]);
    if (t > a && t < b) b = t;
  }
  return b;
}

int Ode::steps_at(double t) {
  bool drive = false, mechanism = false;
  const auto& cs = model_->courses;
  for (size_t k = 0; k < cs.size(); ++k) {
    const ParamSpec& s = model_->specs[cs[k].param];
    const double exit = range_exit(cs[k], s, base_[k]);
    if (t >= exit)  // the sim went as far as the trend allows: it stops there
      throw Error(PKM_ERR_PARAMETER, "parameter " + s.name + " reaches the end of its valid range [" + num(s.lo) +
                                         ", " + num(s.hi) + "] at t = " + num(exit) + " s (its trend of " +
                                         num(cs[k].change, 6) + " " + s.unit + "/s from " + num(base_[k], 6) + " " +
                                         s.unit + " at t0 = " + num(cs[k].t0) + " s)");
    if (cs[k].kind != PKM_COURSE_STEP) continue;
    const double v = course_value(cs[k], base_[k], t);
    double& p = model_->values[cs[k].param];
    if (v == p) continue;
    check_course_value(model_->specs[cs[k].param], cs[k], v, t);
    p = v;
    (pkm_param_in_drive_layer(model_, cs[k].param) == 1 ? drive : mechanism) = true;
  }
  if (mechanism) {
    try {
      model_->compiled = std::shared_ptr<const RobotModel>(robot_->compile(model_->specs, model_->values));
    } catch (const Error& e) {
      throw Error(e.status, std::string("a parameter's step at t = ") + num(t) + " s: " + e.what());
    }
    rm_ = &prepare(model_, data_);
    rd_ = data_->rd.get();
  }
  if (drive) recompile_drive();
  return mechanism ? 2 : drive ? 1 : 0;
}

}  // namespace pkm
