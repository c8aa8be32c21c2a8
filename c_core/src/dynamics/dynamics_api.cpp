// C API: dynamics.
#include "common/guard.hpp"
#include "dynamics/drive.hpp"

using namespace pkm;

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
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, tau, {{x, "x"}, {xd, "xd"}, {xdd, "xdd"}, {tau, "tau"}},
                        [&](const RobotModel&, size_t k) {
    const double* xk = row_at(x, k, nd, "pose x");
    const double* xdk = row_at(xd, k, nd, "pose velocity xd");
    total_inverse_dynamics(m, d, xk, xdk, row_at(xdd, k, nd, "pose acceleration xdd"), tau + k * nd);
  });
}

int pkm_mechanism_inverse_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x,
                                         const double* xd, const double* xdd, double* tau, int* status) {
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, tau, {{x, "x"}, {xd, "xd"}, {xdd, "xdd"}, {tau, "tau"}},
                        [&](const RobotModel& rm, size_t k) {
    const double* xk = row_at(x, k, nd, "pose x");
    const double* xdk = row_at(xd, k, nd, "pose velocity xd");
    m->robot->inverse_dynamics(rm, *d->rd, xk, xdk, row_at(xdd, k, nd, "pose acceleration xdd"), tau + k * nd);
  });
}

int pkm_add_drive_inverse_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x,
                                         const double* xd, const double* xdd, double* tau, int* status) {
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, tau, {{x, "x"}, {xd, "xd"}, {xdd, "xdd"}, {tau, "tau"}},
                        [&](const RobotModel&, size_t k) {
    const double* xk = row_at(x, k, nd, "pose x");
    const double* xdk = row_at(xd, k, nd, "pose velocity xd");
    const double* xddk = row_at(xdd, k, nd, "pose acceleration xdd");
    check_finite(tau + k * nd, nd, "mechanism effort tau");
    add_drive_inverse_dynamics(m, d, xk, xdk, xddk, tau + k * nd);
  });
}

int pkm_add_drive_efforts_batch(const pkm_model* m, pkm_data* d, size_t n, const double* q, const double* qd,
                                const double* qdd, double* tau, int* status) {
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, tau, {{q, "q"}, {qd, "qd"}, {qdd, "qdd"}, {tau, "tau"}},
                        [&](const RobotModel&, size_t k) {
    const double* qk = row_at(q, k, nd, "joint position q");
    const double* qdk = row_at(qd, k, nd, "joint velocity qd");
    const double* qddk = row_at(qdd, k, nd, "joint acceleration qdd");
    check_finite(tau + k * nd, nd, "mechanism effort tau");
    add_drive_efforts(*m->drive, nd, qk, qdk, qddk, tau + k * nd);
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
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, xdd, {{x, "x"}, {xd, "xd"}, {tau, "tau"}, {xdd, "xdd"}},
                        [&](const RobotModel&, size_t k) {
    const double* xk = row_at(x, k, nd, "pose x");
    const double* xdk = row_at(xd, k, nd, "pose velocity xd");
    total_forward_dynamics(m, d, xk, xdk, row_at(tau, k, nd, "actuator effort tau"), xdd + k * nd);
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
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, tau_applied, {{tau_cmd, "tau_cmd"}, {tau_applied, "tau_applied"}},
                        [&](const RobotModel&, size_t k) {
    actuator_effort(*m->drive, row_at(tau_cmd, k, nd, "commanded effort tau_cmd"), tau_applied + k * nd);
  });
}

int pkm_measure_joints_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, const double* xd,
                             const double* tau, double* q_meas, int* status) {
  const int nd = d ? d->ndof : 0;
  return prepared_batch(m, d, n, status, q_meas, {{x, "x"}, {xd, "xd"}, {tau, "tau"}, {q_meas, "q_meas"}},
                        [&](const RobotModel&, size_t k) {
    const double* xk = row_at(x, k, nd, "pose x");
    const double* xdk = row_at(xd, k, nd, "pose velocity xd");
    measure_joints(m, d, xk, xdk, row_at(tau, k, nd, "applied effort tau"), q_meas + k * nd);
  });
}

}  // extern "C"
