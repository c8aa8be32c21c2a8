// C API: dynamics.
#include "common/guard.hpp"

using namespace pkm;

extern "C" {

int pkm_inverse_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* xdd,
                         double* tau) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_finite(xdd, d->ndof, "pose acceleration xdd");
    check_out(tau, "tau");
    d->robot->inverse_dynamics(rm, *d->rd, x, xd, xdd, tau);
  });
}

int pkm_inverse_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, const double* xd,
                               const double* xdd, double* tau, int* status) {
  int s = guard(d, [&] {
    prepare(m, d);
    check_out(x, "x");
    check_out(xd, "xd");
    check_out(xdd, "xdd");
    check_out(tau, "tau");
  });
  if (s != PKM_OK) return s;
  const int nd = d->ndof;
  const RobotModel& rm = *m->compiled;
  return run_batch(d, n, status, tau, nd, [&](size_t k) {
    check_finite(x + k * nd, nd, "pose x");
    check_finite(xd + k * nd, nd, "pose velocity xd");
    check_finite(xdd + k * nd, nd, "pose acceleration xdd");
    d->robot->inverse_dynamics(rm, *d->rd, x + k * nd, xd + k * nd, xdd + k * nd, tau + k * nd);
  });
}

int pkm_forward_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* tau,
                         double* xdd) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_finite(tau, d->ndof, "actuator effort tau");
    check_out(xdd, "xdd");
    d->robot->forward_dynamics(rm, *d->rd, x, xd, tau, xdd);
  });
}

int pkm_forward_dynamics_batch(const pkm_model* m, pkm_data* d, size_t n, const double* x, const double* xd,
                               const double* tau, double* xdd, int* status) {
  int s = guard(d, [&] {
    prepare(m, d);
    check_out(x, "x");
    check_out(xd, "xd");
    check_out(tau, "tau");
    check_out(xdd, "xdd");
  });
  if (s != PKM_OK) return s;
  const int nd = d->ndof;
  const RobotModel& rm = *m->compiled;
  return run_batch(d, n, status, xdd, nd, [&](size_t k) {
    check_finite(x + k * nd, nd, "pose x");
    check_finite(xd + k * nd, nd, "pose velocity xd");
    check_finite(tau + k * nd, nd, "actuator effort tau");
    d->robot->forward_dynamics(rm, *d->rd, x + k * nd, xd + k * nd, tau + k * nd, xdd + k * nd);
  });
}

int pkm_mass_matrix(const pkm_model* m, pkm_data* d, const double* x, double* M) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_out(M, "M");
    d->robot->mass_matrix(rm, *d->rd, x, M);
  });
}

int pkm_gravity_load(const pkm_model* m, pkm_data* d, const double* x, double* g) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_out(g, "g");
    double zero[6] = {0, 0, 0, 0, 0, 0};
    d->robot->inverse_dynamics(rm, *d->rd, x, zero, zero, g);
  });
}

int pkm_energy(const pkm_model* m, pkm_data* d, const double* x, const double* xd, double* kinetic,
               double* potential) {
  return guard(d, [&] {
    const RobotModel& rm = prepare(m, d);
    check_finite(x, d->ndof, "pose x");
    check_finite(xd, d->ndof, "pose velocity xd");
    check_out(kinetic, "kinetic");
    check_out(potential, "potential");
    d->robot->energy(rm, *d->rd, x, xd, kinetic, potential);
  });
}

}  // extern "C"
