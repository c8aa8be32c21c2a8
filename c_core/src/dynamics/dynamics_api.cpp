// C API: dynamics.
#include "common/guard.hpp"
#include "dynamics/drive.hpp"

using namespace pkm;

namespace {
// The pose inputs of the batched calls, named as in pkm.h's messages.
BatchRows pose_rows(const double* x) { return {x, "x", "pose x"}; }
BatchRows rate_rows(const double* xd) { return {xd, "xd", "pose velocity xd"}; }
BatchRows acceleration_rows(const double* xdd) { return {xdd, "xdd", "pose acceleration xdd"}; }
}  // namespace

extern "C" {

int pkm_inverse_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* xdd,
                         double* tau) {
  return guard(d, [&] {
    prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_finite(xdd, d->ndof, "pose acceleration xdd");
    check_out(tau, "tau");
    total_inverse_dynamics(m, d, x, xd, xdd, tau);
  });
}

int pkm_inverse_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, const double* xd,
                               const double* xdd, double* tau, int* status) {
  return rows_batch(m, d, n, status, {pose_rows(x), rate_rows(xd), acceleration_rows(xdd)}, tau, "tau",
                    [&](const RobotModel&, auto xk, auto xdk, auto xddk, double* tk) {
                      total_inverse_dynamics(m, d, xk, xdk, xddk, tk);
                    });
}

int pkm_mechanism_inverse_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x,
                                         const double* xd, const double* xdd, double* tau, int* status) {
  return rows_batch(m, d, n, status, {pose_rows(x), rate_rows(xd), acceleration_rows(xdd)}, tau, "tau",
                    [&](const RobotModel&, auto xk, auto xdk, auto xddk, double* tk) {
                      mechanism_inverse_dynamics(m, d, xk, xdk, xddk, tk);
                    });
}

int pkm_add_drive_inverse_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x,
                                         const double* xd, const double* xdd, double* tau, int* status) {
  return rows_batch(m, d, n, status, {pose_rows(x), rate_rows(xd), acceleration_rows(xdd)}, tau, "tau",
                    [&](const RobotModel&, auto xk, auto xdk, auto xddk, double* tk) {
                      check_finite(tk, d->ndof, "mechanism effort tau");
                      add_drive_inverse_dynamics(m, d, xk, xdk, xddk, tk);
                    });
}

int pkm_add_drive_efforts_batch(const pkm_model* m, pkm_data* d, size_t n, const double* q, const double* qd,
                                const double* qdd, double* tau, int* status) {
  const BatchRows joints[] = {{q, "q", "joint position q"}, {qd, "qd", "joint velocity qd"},
                              {qdd, "qdd", "joint acceleration qdd"}};
  return rows_batch(m, d, n, status, joints, tau, "tau",
                    [&](const RobotModel&, auto qk, auto qdk, auto qddk, double* tk) {
                      check_finite(tk, d->ndof, "mechanism effort tau");
                      add_drive_efforts(*m->drive, d->ndof, qk, qdk, qddk, tk);
                    });
}

int pkm_forward_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* tau,
                         double* xdd) {
  return guard(d, [&] {
    prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_finite(tau, d->ndof, "actuator effort tau");
    check_out(xdd, "xdd");
    total_forward_dynamics(m, d, x, xd, tau, xdd);
  });
}

int pkm_forward_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, const double* xd,
                               const double* tau, double* xdd, int* status) {
  return rows_batch(m, d, n, status, {pose_rows(x), rate_rows(xd), {tau, "tau", "actuator effort tau"}}, xdd, "xdd",
                    [&](const RobotModel&, auto xk, auto xdk, auto tk, double* xddk) {
                      total_forward_dynamics(m, d, xk, xdk, tk, xddk);
                    });
}

int pkm_mass_matrix(const pkm_model* m, pkm_data* d, const double* x, double* M) {
  return guard(d, [&] {
    prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_out(M, "M");
    total_mass_matrix(m, d, x, M);
  });
}

int pkm_gravity_load(const pkm_model* m, pkm_data* d, const double* x, double* g) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_out(g, "g");
    double zero[6] = {0, 0, 0, 0, 0, 0};
    d->robot->inverse_dynamics(rm, *d->rd, x, zero, zero, g);
    // so is a constant force on the platform (a wrench, a cable: at rest, no drag)
    platform_force::add(m, d, m->drive->platform, x, nullptr, 1.0, g);
    // a constant effort offset is a load like gravity: holding still needs it too
    for (int i = 0; i < d->ndof; ++i) g[i] += m->drive->offset[i];
  });
}

int pkm_energy(const pkm_model* m, pkm_data* d, const double* x, const double* xd, double* kinetic,
               double* potential) {
  return guard(d, [&] {
    prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_out(kinetic, "kinetic");
    check_out(potential, "potential");
    total_energy(m, d, x, xd, kinetic, potential);
  });
}

int pkm_joint_friction(const pkm_model* m, pkm_data* d, const double* qd, double* f) {
  return guard(d, [&] {
    prepare(m, d);
    check_finite(qd, d->ndof, "joint velocity qd");
    check_out(f, "f");
    drive::friction(*m->drive, qd, f);
  });
}

int pkm_actuator_effort(const pkm_model* m, pkm_data* d, const double* tau_cmd, double* tau_applied) {
  return guard(d, [&] {
    prepare(m, d);
    check_finite(tau_cmd, d->ndof, "commanded effort tau_cmd");
    check_out(tau_applied, "tau_applied");
    actuator_effort(*m->drive, tau_cmd, tau_applied);
  });
}

int pkm_measure_joints(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* tau,
                       double* q_meas) {
  return guard(d, [&] {
    prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_finite(tau, d->ndof, "applied effort tau");
    check_out(q_meas, "q_meas");
    measure_joints(m, d, x, xd, tau, q_meas);
  });
}

int pkm_sensor_readings(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* tau,
                        const double* theta, const double* theta_d, double* q_meas, double* qd_meas) {
  return guard(d, [&] {
    prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_finite(tau, d->ndof, "applied effort tau");
    if (theta) check_finite(theta, d->ndof, "drive body position theta");
    if (theta_d) check_finite(theta_d, d->ndof, "drive body rate theta_d");
    check_out(q_meas, "q_meas");
    sensor_readings(m, d, x, xd, tau, theta, theta_d, q_meas, qd_meas);
  });
}

int pkm_model_two_body_joints(const pkm_model* m) {
  if (!m || !m->drive) return 0;
  int n = 0;
  for (int i = 0; i < m->drive->nd; ++i) n += m->drive->two_body_joint(i) ? 1 : 0;
  return n;
}

int pkm_actuator_effort_batch(const pkm_model* m, pkm_data* d, size_t n, const double* tau_cmd,
                              double* tau_applied, int* status) {
  return rows_batch(m, d, n, status, {{tau_cmd, "tau_cmd", "commanded effort tau_cmd"}}, tau_applied, "tau_applied",
                    [&](const RobotModel&, auto uk, double* tk) { actuator_effort(*m->drive, uk, tk); });
}

int pkm_measure_joints_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, const double* xd,
                             const double* tau, double* q_meas, int* status) {
  return rows_batch(m, d, n, status, {pose_rows(x), rate_rows(xd), {tau, "tau", "applied effort tau"}}, q_meas,
                    "q_meas", [&](const RobotModel&, auto xk, auto xdk, auto tk, double* qk) {
                      measure_joints(m, d, xk, xdk, tk, qk);
                    });
}

}  // extern "C"
