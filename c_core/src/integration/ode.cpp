#include "integration/ode.hpp"

#include "common/guard.hpp"
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

}  // namespace pkm
