// C API: kinematics.  Argument checks up front, then the robot's algorithm.
#include "common/guard.hpp"
#include "kinematics/generic_kinematics.hpp"

using namespace pkm;

static pkm_fk_options fk_defaults(const pkm_fk_options* o) {
  pkm_fk_options d{1e-13, 50, 1e-9};
  if (!o) return d;
  if (o->tol > 0) d.tol = o->tol;
  if (o->max_iter > 0) d.max_iter = o->max_iter;
  if (o->damping >= 0) d.damping = o->damping;
  return d;
}

extern "C" {

int pkm_ik(const pkm_model* m, pkm_data* d, const double* x, double* q) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_out(q, "q");
    d->robot->ik(rm, *d->rd, x, q);
  });
}

int pkm_ik_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, double* q, int* status) {
  int s = guard(d, [&] {
    prepare(m, d);
    check_out(x, "x");
    check_out(q, "q");
  });
  if (s != PKM_OK) return s;
  const int nd = d->ndof;
  const RobotModel& rm = *m->compiled;
  return run_batch(d, n, status, q, nd, [&](size_t k) {
    check_finite(x + k * nd, nd, "pose x");
    d->robot->ik(rm, *d->rd, x + k * nd, q + k * nd);
  });
}

int pkm_fk(const pkm_model* m, pkm_data* d, const double* q, const double* x_guess, const pkm_fk_options* opt,
           double* x, pkm_fk_info* info) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(q, d->ndof, "joints q");
    check_finite(x_guess, d->ndof, "pose guess x_guess");
    check_out(x, "x");
    pkm_fk_info tmp{0, 0.0};
    pkm_fk_info& inf = info ? *info : tmp;
    d->robot->fk(rm, *d->rd, q, x_guess, fk_defaults(opt), x, inf);
  });
}

int pkm_fk_batch(const pkm_model* m, pkm_data* d, size_t n, const double* q, const double* x_guess,
                 const pkm_fk_options* opt, double* x, int* status) {
  int s = guard(d, [&] {
    prepare(m, d);
    check_out(q, "q");
    check_out(x_guess, "x_guess");
    check_out(x, "x");
  });
  if (s != PKM_OK) return s;
  const int nd = d->ndof;
  const RobotModel& rm = *m->compiled;
  const pkm_fk_options o = fk_defaults(opt);
  return run_batch(d, n, status, x, nd, [&](size_t k) {
    check_finite(q + k * nd, nd, "joints q");
    check_finite(x_guess + k * nd, nd, "pose guess x_guess");
    pkm_fk_info info{0, 0.0};
    d->robot->fk(rm, *d->rd, q + k * nd, x_guess + k * nd, o, x + k * nd, info);
  });
}

int pkm_jacobians(const pkm_model* m, pkm_data* d, const double* x, double* Jx, double* Jq, double* J) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    d->robot->jacobians(rm, *d->rd, x, Jx, Jq, J);
  });
}

int pkm_jacobian_dot(const pkm_model* m, pkm_data* d, const double* x, const double* xd, double* Jdot) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_out(Jdot, "Jdot");
    d->robot->jacobian_dot(rm, *d->rd, x, xd, Jdot);
  });
}

int pkm_singularity(const pkm_model* m, pkm_data* d, const double* x, double* measures) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_out(measures, "measures");
    d->robot->singularity(rm, *d->rd, x, measures);
  });
}

int pkm_joint_velocity(const pkm_model* m, pkm_data* d, const double* x, const double* xd, double* qd) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    const int n = d->ndof;
    check_finite(x, n, "pose x");
    check_finite(xd, n, "pose velocity xd");
    check_out(qd, "qd");
    double J[36];
    d->robot->jacobians(rm, *d->rd, x, nullptr, nullptr, J);
    for (int i = 0; i < n; ++i) {
      double s = 0;
      for (int j = 0; j < n; ++j) s += J[i * n + j] * xd[j];
      qd[i] = s;
    }
  });
}

int pkm_pose_velocity(const pkm_model* m, pkm_data* d, const double* x, const double* qd, double* xd) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(qd, d->ndof, "joint velocity qd");
    check_out(xd, "xd");
    pose_velocity(*d->robot, rm, *d->rd, x, qd, xd);
  });
}

int pkm_joint_acceleration(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* xdd,
                           double* qdd) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_finite(xdd, d->ndof, "pose acceleration xdd");
    check_out(qdd, "qdd");
    d->robot->joint_acceleration(rm, *d->rd, x, xd, xdd, qdd);
  });
}

int pkm_pose_acceleration(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* qdd,
                          double* xdd) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_finite(qdd, d->ndof, "joint acceleration qdd");
    check_out(xdd, "xdd");
    pose_acceleration(*d->robot, rm, *d->rd, x, xd, qdd, xdd);
  });
}

int pkm_pose_velocity_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, const double* qd,
                            double* xd, int* status) {
  const RobotModel* rm = nullptr;
  int s = guard(d, [&] {
    rm = &prepare(m, d);
    check_out(x, "x");
    check_out(qd, "qd");
    check_out(xd, "xd");
  });
  if (s != PKM_OK) return s;
  const int nd = d->ndof;
  return run_batch(d, n, status, xd, nd, [&](size_t k) {
    check_finite(x + k * nd, nd, "pose x");
    check_finite(qd + k * nd, nd, "joint velocity qd");
    pose_velocity(*d->robot, *rm, *d->rd, x + k * nd, qd + k * nd, xd + k * nd);
  });
}

int pkm_pose_acceleration_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, const double* xd,
                                const double* qdd, double* xdd, int* status) {
  const RobotModel* rm = nullptr;
  int s = guard(d, [&] {
    rm = &prepare(m, d);
    check_out(x, "x");
    check_out(xd, "xd");
    check_out(qdd, "qdd");
    check_out(xdd, "xdd");
  });
  if (s != PKM_OK) return s;
  const int nd = d->ndof;
  return run_batch(d, n, status, xdd, nd, [&](size_t k) {
    check_finite(x + k * nd, nd, "pose x");
    check_finite(xd + k * nd, nd, "pose velocity xd");
    check_finite(qdd + k * nd, nd, "joint acceleration qdd");
    pose_acceleration(*d->robot, *rm, *d->rd, x + k * nd, xd + k * nd, qdd + k * nd, xdd + k * nd);
  });
}

}  // extern "C"
