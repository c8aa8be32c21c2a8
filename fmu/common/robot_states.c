/*
 * robot_states.c -- the hooks of fmu_model.h for a robot FMU's states: Model Exchange's
 * continuous states, derivatives and event indicators (singularity, stroke limits), and
 * the snapshot behind an FMU state (saved, checked, loaded).  The rest of the model is
 * robot.c; the struct they share is fmu_robot.h.
 */
#include "fmu_robot.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* ------------------------------------------------------------ model exchange */

void fmu_model_set_time(fmu_model* p, double t) {
  if (t != p->t) p->valid = 0;
  p->t = t;
}

/* A state (x, xd) the robot can be in: finite, with an energy that does not overflow. */
static int check_states(fmu_model* p, const double* x, const double* xd, const char* what) {
  for (int i = 0; i < 2 * p->nd; ++i) {
    const double v = i < p->nd ? x[i] : xd[i - p->nd];
    if (!isfinite(v))
      return fail(p, PKM_ERR_ARGUMENT, "%s %d (%s) = %g at t = %.9g s is not finite", what, i,
                  i < p->nd ? fmu_robot_var_name(p, FMU_CH_POSE, i) : fmu_robot_var_name(p, FMU_CH_TWIST, i - p->nd), v,
                  p->t);
  }
  double kinetic = 0, potential = 0;
  if (pkm_energy(p->m, p->d, x, xd, &kinetic, &potential) == PKM_ERR_ARGUMENT)
    return fail(p, PKM_ERR_ARGUMENT, "%ss at t = %.9g s: %s", what, p->t, pkm_data_error(p->d));
  return PKM_OK;
}

int fmu_model_set_states(fmu_model* p, const double* s, size_t n) {
  if (n != (size_t)(2 * p->nd))
    return fail(p, PKM_ERR_ARGUMENT, "%zu continuous states given, the model has %d", n, 2 * p->nd);
  /* A state the robot cannot be in (an energy that overflows) is refused, as a start is. */
  int st = check_states(p, s, s + p->nd, "continuous state");
  if (st) return st;
  memcpy(p->x, s, sizeof(double) * p->nd);
  memcpy(p->xd, s + p->nd, sizeof(double) * p->nd);
  p->valid = 0;
  return PKM_OK;
}

int fmu_model_get_states(const fmu_model* p, double* s, size_t n) {
  if (n != (size_t)(2 * p->nd)) return PKM_ERR_ARGUMENT;
  memcpy(s, p->x, sizeof(double) * p->nd);
  memcpy(s + p->nd, p->xd, sizeof(double) * p->nd);
  return PKM_OK;
}

int fmu_model_get_derivatives(fmu_model* p, double* ds, size_t n) {
  if (n != (size_t)(2 * p->nd))
    return fail(p, PKM_ERR_ARGUMENT, "%zu derivatives asked for, the model has %d states", n, 2 * p->nd);
  int s = fmu_robot_ensure(p, V_ACC, "state derivative");
  if (s) return s;
  memcpy(ds, p->xd, sizeof(double) * p->nd);
  memcpy(ds + p->nd, p->xdd, sizeof(double) * p->nd);
  return PKM_OK;
}

int fmu_model_get_indicators(fmu_model* p, double* z, size_t n) {
  const fmu_model_desc* D = p->desc;
  if (n != (size_t)D->nindicators)
    return fail(p, PKM_ERR_ARGUMENT, "%zu event indicators asked for, the model has %d", n, D->nindicators);
  int s = fmu_robot_ensure(p, V_SING, "event indicator");
  if (s) return s;
  z[0] = p->sing[1] - p->opt_applied.sing_min;
  if (!D->qmin_param) return PKM_OK;
  s = fmu_robot_ensure(p, V_KIN, "event indicator");
  if (s == PKM_ERR_JOINT_LIMIT) {
    /* Past a limit the core gives no stroke.  Root finding only needs the sign, and
     * every indicator of a pose past a limit being negative still brackets the crossing
     * (the message of plant_check_limits then names the leg). */
    for (int i = 0; i < 2 * p->nd; ++i) z[1 + i] = -1.0;
    return PKM_OK;
  }
  if (s) return s;
  for (int i = 0; i < p->nd; ++i) {
    z[1 + 2 * i] = p->q[i] - pkm_param_get(p->m, D->qmin_param[i]);
    z[2 + 2 * i] = pkm_param_get(p->m, D->qmax_param[i]) - p->q[i];
  }
  return PKM_OK;
}

int fmu_model_check_limits(fmu_model* p, double tol) {
  const fmu_model_desc* D = p->desc;
  int s = fmu_robot_ensure(p, V_SING, "singularity check");
  if (s) return s;
  if (p->sing[1] - p->opt_applied.sing_min <= tol)
    return fail(p, PKM_ERR_SINGULAR,
                "direct (type 2) singularity: %s = %.6g reached %s = %.6g at t = %.10g s",
                fmu_robot_var_name(p, FMU_CH_SING, 1), p->sing[1], fmu_robot_var_name(p, FMU_CH_SOLVER_SING_MIN, 0),
                p->opt_applied.sing_min, p->t);
  if (!D->qmin_param) return PKM_OK;
  if ((s = fmu_robot_ensure(p, V_KIN, "stroke-limit check"))) return s;
  for (int i = 0; i < p->nd; ++i) {
    for (int w = 0; w < 2; ++w) {
      int par = w ? D->qmax_param[i] : D->qmin_param[i];
      double lim = pkm_param_get(p->m, par), margin = w ? lim - p->q[i] : p->q[i] - lim;
      if (margin <= tol)
        return fail(p, PKM_ERR_JOINT_LIMIT, "joint %d reached its %s limit %s = %.6g %s at t = %.10g s (%s = %.10g)",
                    i + 1, w ? "upper" : "lower", pkm_param_name(p->m, par), lim, pkm_param_unit(p->m, par), p->t,
                    fmu_robot_var_name(p, FMU_CH_Q, i), p->q[i]);
    }
  }
  return PKM_OK;
}

/* ------------------------------------------------------------------ snapshot */

/* Layout (doubles): t, started, dirty, reserved (1), tol_override, 6 solver settings, input gain,
 * x, xd, tau, x0, xd0 (nd each), par (np), then the length n_sim of the integrator's
 * own state and that state (pkm_sim_state_save: held input, the explicit method's next
 * step size, the actuator-delay history), so a restored state advances exactly as the
 * original did. */
enum { SNAP_HEAD = 12 };

static size_t snapshot_fixed(const fmu_model* p) { return (size_t)(SNAP_HEAD + 5 * p->nd + p->np + 1); }

size_t fmu_model_snapshot_min_size(const fmu_model* p) { return snapshot_fixed(p); }

size_t fmu_model_snapshot_size(const fmu_model* p) {
  const size_t nsim = (p->cs && p->sim && p->started) ? pkm_sim_state_size(p->sim) : 0;
  return snapshot_fixed(p) + nsim;
}

void fmu_model_snapshot_save(const fmu_model* p, double* b) {
  b[0] = p->t;
  b[1] = p->started;
  b[2] = p->dirty;
  b[3] = 1.0; /* reserved: whether the core model validated is history, not state */
  b[4] = p->tol_override;
  b[5] = p->opt.method;
  b[6] = p->opt.rtol;
  b[7] = p->opt.atol;
  b[8] = p->opt.max_step;
  b[9] = (double)p->opt.max_steps;
  b[10] = p->opt.sing_min;
  b[11] = p->input_gain;
  double* v = b + SNAP_HEAD;
  const double* src[5] = {p->x, p->xd, p->tau, p->x0, p->xd0};
  for (int k = 0; k < 5; ++k, v += p->nd) memcpy(v, src[k], sizeof(double) * p->nd);
  memcpy(v, p->par, sizeof(double) * p->np);
  v += p->np;
  const size_t nsim = (p->cs && p->sim && p->started) ? pkm_sim_state_size(p->sim) : 0;
  v[0] = (double)nsim;
  if (nsim) pkm_sim_state_save(p->sim, v + 1);
}

/* The name of value k of a snapshot, for messages. */
static void snapshot_field(const fmu_model* p, size_t k, char* out, size_t len) {
  static const char* const head[SNAP_HEAD] = {"t", "started", "dirty", "reserved", "tolerance", "solver.method",
                                              "solver.rtol", "solver.atol", "solver.maxStep", "solver.maxSteps",
                                              "solver.singMin", "input.gain"};
  static const char* const vec[5] = {"x", "xd", "tau", "x0", "xd0"};
  const size_t nd = (size_t)p->nd, fixed = snapshot_fixed(p);
  if (k < SNAP_HEAD)
    snprintf(out, len, "%s", head[k]);
  else if (k < SNAP_HEAD + 5 * nd)
    snprintf(out, len, "%s[%zu]", vec[(k - SNAP_HEAD) / nd], (k - SNAP_HEAD) % nd + 1);
  else if (k + 1 < fixed)
    snprintf(out, len, "parameter %s", pkm_param_name(p->m, (int)(k - SNAP_HEAD - 5 * nd)));
  else if (k + 1 == fixed)
    snprintf(out, len, "integrator state length");
  else
    snprintf(out, len, "integrator state value %zu", k - fixed);
}

/* Everything a snapshot says, checked before any of it is used (nothing is changed): its
 * length, every value finite, flags, counts and enumerations whole and in range.  Values
 * that were checked when they were set (the input gain) are checked again; the parameters
 * and solver settings in force go through the core again when loaded (apply), and the
 * integrator's state through pkm_sim_state_load, which checks the state as a reset does. */
int fmu_model_snapshot_check(fmu_model* p, const double* b, size_t n) {
  const size_t fixed = snapshot_fixed(p);
  if (n < fixed)
    return fail(p, PKM_ERR_ARGUMENT, "FMU state is damaged: %zu values where the layout needs at least %zu", n, fixed);
  char field[96];
  for (size_t k = 0; k < n; ++k)
    if (!isfinite(b[k])) {
      snapshot_field(p, k, field, sizeof field);
      return fail(p, PKM_ERR_ARGUMENT, "FMU state is damaged: value %zu (%s) = %g is not finite", k, field, b[k]);
    }
  if (!fmu_whole(b[fixed - 1], 0, (double)(n - fixed)) || (size_t)b[fixed - 1] != n - fixed)
    return fail(p, PKM_ERR_ARGUMENT, "FMU state is damaged: %zu values where the layout needs %zu + %g", n, fixed,
                b[fixed - 1]);
  const char* bad = NULL;
  if (!fmu_whole(b[1], 0, 1) || !fmu_whole(b[2], 0, 1) || !fmu_whole(b[3], 0, 1))
    bad = "started, dirty or reserved flag (0 or 1)";
  else if (!(b[4] == 0 || (b[4] > 0 && b[4] < 1)))
    bad = "importer tolerance (0 for none, or in (0, 1))";
  else if (!fmu_whole(b[5], -2147483647.0, 2147483647.0) || !fmu_whole(b[9], -2147483647.0, 2147483647.0))
    bad = "solver.method or solver.maxSteps (an Integer)";
  else if (!(b[11] > 0 && b[11] < 1e6))
    bad = "input.gain (a positive gain below 1e6)";
  else if (n > fixed && !(p->cs && b[1] != 0))
    bad = "integrator state (there is one only for a started Co-Simulation)";
  if (bad) return fail(p, PKM_ERR_ARGUMENT, "FMU state is damaged: invalid %s", bad);
  return PKM_OK;
}

/* Loads a snapshot that passed plant_snapshot_check. */
int fmu_model_snapshot_load(fmu_model* p, const double* b, size_t n) {
  const size_t fixed = snapshot_fixed(p);
  const size_t nsim = n - fixed;
  const double* simstate = b + fixed;
  int started = b[1] != 0, dirty = b[2] != 0;
  p->tol_override = b[4];
  p->opt.method = (int)b[5];
  p->opt.rtol = b[6];
  p->opt.atol = b[7];
  p->opt.max_step = b[8];
  p->opt.max_steps = (long)b[9];
  p->opt.sing_min = b[10];
  p->input_gain = b[11];
  const double* v = b + SNAP_HEAD;
  double* dst[5] = {p->x, p->xd, p->tau, p->x0, p->xd0};
  for (int k = 0; k < 5; ++k, v += p->nd) memcpy(dst[k], v, sizeof(double) * p->nd);
  memcpy(p->par, v, sizeof(double) * p->np);
  p->t = b[0];
  p->valid = 0;
  p->started = 0;
  p->dirty = 1;
  if (!started) return PKM_OK;
  /* The snapshot's parameters and settings were in force when it was taken: put them
   * back into the core (a no-op when unchanged) and restore the integrator's state. */
  int s = fmu_robot_apply(p);
  if (s) return s;
  if ((s = check_states(p, p->x, p->xd, "FMU state: continuous state"))) return s;
  if (p->cs) {
    if (nsim)
      s = pkm_sim_state_load(p->sim, simstate, nsim);
    else
      s = pkm_sim_reset(p->sim, p->t, p->x, p->xd);
    if (s) return fail(p, s, "restoring the integrator at t = %.9g s: %s", p->t, pkm_sim_error(p->sim));
    /* The integrator's time and state are the model's: one state, not two. */
    double t = 0, x[16], xd[16];
    pkm_sim_get_state(p->sim, &t, x, xd);
    if (t != p->t || memcmp(x, p->x, sizeof(double) * p->nd) != 0 || memcmp(xd, p->xd, sizeof(double) * p->nd) != 0)
      return fail(p, PKM_ERR_ARGUMENT,
                  "FMU state is damaged: the integrator's time %.17g s or state differs from the model's (t = %.17g s)",
                  t, p->t);
  }
  p->started = 1;
  p->dirty = dirty;
  return PKM_OK;
}
