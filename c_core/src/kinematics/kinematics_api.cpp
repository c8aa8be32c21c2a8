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

// Joint values outside the range of their joint have no pose: refused up front, naming the
// joint, its value and its range (the robot's joint_limit_param, indexed in the model once;
// none for a joint without).
static void check_joint_range(const pkm_model* m, const double* q) {
  const Robot& r = *m->robot;
  for (int i = 0; i < r.ndof(); ++i) {
    double lim[2];
    for (int up = 0; up < 2; ++up) {
      const int k = m->joint_limit_index[2 * (size_t)i + (size_t)up];
      if (k < 0) return;
      lim[up] = m->values[(size_t)k];
    }
    if (q[i] < lim[0] || q[i] > lim[1])
      throw Error(PKM_ERR_JOINT_LIMIT, std::string(r.limb_noun()) + " " + std::to_string(i + 1) + " joint q = " +
                                           num(q[i], 6) + " outside [" + num(lim[0], 6) + ", " + num(lim[1], 6) +
                                           "]: no pose has these joints");
  }
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
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, q, {{x, "x"}, {q, "q"}}, [&](const RobotModel& rm, size_t k) {
    d->robot->ik(rm, *d->rd, row_at(x, k, nd, "pose x"), q + k * nd);
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
    check_joint_range(m, q);
    d->robot->fk(rm, *d->rd, q, x_guess, fk_defaults(opt), x, inf);
  });
}

int pkm_fk_batch(const pkm_model* m, pkm_data* d, size_t n, const double* q, const double* x_guess,
                 const pkm_fk_options* opt, double* x, int* status) {
  const int nd = d ? d->ndof : 0;
  const pkm_fk_options o = fk_defaults(opt);
  return prepared_batch(m, d, n, status, x, {{q, "q"}, {x_guess, "x_guess"}, {x, "x"}},
                        [&](const RobotModel& rm, size_t k) {
    const double* qk = row_at(q, k, nd, "joints q");
    const double* gk = row_at(x_guess, k, nd, "pose guess x_guess");
    pkm_fk_info info{0, 0.0};
    check_joint_range(m, qk);
    d->robot->fk(rm, *d->rd, qk, gk, o, x + k * nd, info);
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

int pkm_chain_points(const pkm_model* m, pkm_data* d, const double* x, double* pts) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_out(pts, "pts");
    d->robot->chain_points(rm, *d->rd, x, pts);
  });
}

int pkm_platform_pose(const pkm_model* m, pkm_data* d, const double* x, double* X, double* S) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_out(X, "X");
    d->robot->platform_pose(rm, *d->rd, x, X, S);
  });
}

int pkm_joint_velocity(const pkm_model* m, pkm_data* d, const double* x, const double* xd, double* qd) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    const int n = d->ndof;
    check_finite(x, n, "pose x");
    check_finite(xd, n, "pose velocity xd");
    check_out(qd, "qd");
    joint_velocity(*d->robot, rm, *d->rd, x, xd, qd);
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
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, xd, {{x, "x"}, {qd, "qd"}, {xd, "xd"}},
                        [&](const RobotModel& rm, size_t k) {
    const double* xk = row_at(x, k, nd, "pose x");
    pose_velocity(*d->robot, rm, *d->rd, xk, row_at(qd, k, nd, "joint velocity qd"), xd + k * nd);
  });
}

int pkm_pose_acceleration_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, const double* xd,
                                const double* qdd, double* xdd, int* status) {
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, xdd, {{x, "x"}, {xd, "xd"}, {qdd, "qdd"}, {xdd, "xdd"}},
                        [&](const RobotModel& rm, size_t k) {
    const double* xk = row_at(x, k, nd, "pose x");
    const double* xdk = row_at(xd, k, nd, "pose velocity xd");
    pose_acceleration(*d->robot, rm, *d->rd, xk, xdk, row_at(qdd, k, nd, "joint acceleration qdd"), xdd + k * nd);
  });
}

}  // extern "C"
