#include "integration/drive_bodies.hpp"

namespace pkm {

DriveBodies::DriveBodies(const pkm_model* m, int nd) : nd_(nd) {
  if (m->drive)
    for (int i = 0; i < nd; ++i)
      if (m->drive->two_body_joint(i)) joints_.push_back(i);
  if (!joints_.empty()) carriage_ = drive::carriage_side(*m->drive);
}

void DriveBodies::start(const double* q, const double* qd, double* y) const {
  for (int i : joints_) {
    y[2 * nd_ + i] = q[i];
    if (qd) y[3 * nd_ + i] = qd[i];
  }
}

void DriveBodies::rates(const drive::Params& dp, const double* y, const double* q, const double* qd, const double* u,
                        double* eff, double* f) const {
  const int n = nd_;
  const double* th = y + 2 * n;
  const double* thd = y + 3 * n;
  double fr[6];
  for (int i = 0; i < n; ++i) eff[i] = u[i];
  drive::friction(dp, thd, fr);
  for (int i = 0; i < n; ++i) f[2 * n + i] = 0.0, f[3 * n + i] = 0.0;
  for (int i : joints_) {
    const double t = drive::transmitted_effort(dp, i, th[i] - q[i], thd[i] - qd[i]);
    eff[i] = t;
    f[2 * n + i] = thd[i];
    f[3 * n + i] = (u[i] - t - fr[i]) / dp.rotor[i];
  }
}

void DriveBodies::read(const double* y, double* theta, double* theta_d) const {
  for (int i : joints_) {
    if (theta) theta[i] = y[2 * nd_ + i];
    if (theta_d) theta_d[i] = y[3 * nd_ + i];
  }
}

}  // namespace pkm
