/*
 * controller.c -- the hooks of fmu_model.h for a controller FMU: the core's sampled
 * controller (pkm.h "control", pkm_ctrl) behind the same generic FMI layer
 * (fmi2_functions.c) as the plant FMUs.  Co-Simulation only.
 *
 * Timing: at fmi2DoStep(t, h) the controller samples its inputs (readings q, qd and the
 * reference, as set before the call) at t, updates its states once and holds the effort
 * it computed as its output tau until the next step; before the first step tau is 0.  A
 * master that exchanges values after every step (Jacobi, e.g. OSP libcosim) therefore
 * applies tau computed at t over [t + h, t + 2h]: one communication step later than
 * cosim.master.run, which evaluates the controller between the plant's steps.  The same
 * loop in the core is cosim.master.run with actuator.delay = h (docs/fmu.md).
 *
 * Parameters: the core's parameters of the model the controller believes in (for the
 * gravity load, forward kinematics and inverse dynamics of PD + gravity and computed
 * torque), the kind and the gains / matrices of the law.  They are applied (and
 * checked by pkm_ctrl_create) when initialization ends.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_model.h"

struct fmu_model {
  const fmu_model_desc* desc;
  int nd, np, nx_max;
  pkm_model* m;
  pkm_ctrl* c;
  double t;
  double *par;                       /* pending core parameter values                  */
  double *q, *qd, *qref, *qdref, *qddref, *tau;
  double *kp, *kd, *ki, *sat;        /* nd x nd, nd                                     */
  double *A, *B, *C, *D;             /* nx_max x nx_max, nx_max x nd, nd x nx_max, nd x nd */
  double dt, tf;
  int kind, gravity_ref, gravity_ff, nx;
  int started, dirty;
  char msg[2048];
};

const char* fmu_model_error(const fmu_model* p) { return p ? p->msg : "controller is NULL"; }
double fmu_model_time(const fmu_model* p) { return p->t; }
int fmu_model_nstates(const fmu_model* p) {
  (void)p;
  return 0;
}
int fmu_model_dirty(const fmu_model* p) { return p->dirty || !p->started; }

/* The block of a channel's values: [count] doubles. */
static double* block(fmu_model* p, fmu_channel ch, size_t* count) {
  const size_t nd = (size_t)p->nd, nx = (size_t)p->nx_max;
  switch (ch) {
    case FMU_CH_CTRL_Q: *count = nd; return p->q;
    case FMU_CH_CTRL_QD: *count = nd; return p->qd;
    case FMU_CH_CTRL_QREF: *count = nd; return p->qref;
    case FMU_CH_CTRL_QDREF: *count = nd; return p->qdref;
    case FMU_CH_CTRL_QDDREF: *count = nd; return p->qddref;
    case FMU_CH_CTRL_TAU: *count = nd; return p->tau;
    case FMU_CH_CTRL_KP: *count = nd * nd; return p->kp;
    case FMU_CH_CTRL_KD: *count = nd * nd; return p->kd;
    case FMU_CH_CTRL_KI: *count = nd * nd; return p->ki;
    case FMU_CH_CTRL_SAT: *count = nd; return p->sat;
    case FMU_CH_CTRL_A: *count = nx * nx; return p->A;
    case FMU_CH_CTRL_B: *count = nx * nd; return p->B;
    case FMU_CH_CTRL_C: *count = nd * nx; return p->C;
    case FMU_CH_CTRL_D: *count = nd * nd; return p->D;
    case FMU_CH_PARAM: *count = (size_t)p->np; return p->par;
    default: *count = 0; return NULL;
  }
}

/* Every array of the controller in one allocation, in the order of the snapshot. */
static size_t arrays_size(int nd, int np, int nx) {
  return (size_t)np + 6 * (size_t)nd + 4 * (size_t)nd * nd + (size_t)nx * nx + 2 * (size_t)nx * nd;
}

fmu_model* fmu_model_create(const fmu_model_desc* desc, int cosimulation, char* err, size_t errlen) {
  if (!cosimulation) {
    if (err && errlen) snprintf(err, errlen, "%s is a Co-Simulation FMU only", desc->identifier);
    return NULL;
  }
  fmu_model* p = (fmu_model*)calloc(1, sizeof *p);
  if (!p) return NULL;
  p->desc = desc;
  if (desc->description && pkm_robot_register_description(desc->description, desc->robot, err, errlen) != PKM_OK) {
    free(p);
    return NULL;
  }
  p->m = pkm_model_create(desc->robot, desc->param_set, err, errlen);
  if (!p->m) {
    free(p);
    return NULL;
  }
  p->nd = pkm_model_ndof(p->m);
  p->np = pkm_model_nparam(p->m);
  p->nx_max = desc->lti_states;
  double* a = (double*)calloc(arrays_size(p->nd, p->np, p->nx_max) + 1, sizeof(double));
  if (!a || p->nd != desc->ndof || p->np != desc->nparam) {
    if (err && errlen)
      snprintf(err, errlen, "%s: the table was generated for %d joints and %d parameters, the core has %d and %d",
               desc->identifier, desc->ndof, desc->nparam, p->nd, p->np);
    free(a);
    pkm_model_destroy(p->m);
    free(p);
    return NULL;
  }
  const size_t nd = (size_t)p->nd, nx = (size_t)p->nx_max;
  p->par = a;
  a += p->np;
  double** vec[] = {&p->q, &p->qd, &p->qref, &p->qdref, &p->qddref, &p->tau};
  for (size_t k = 0; k < 6; ++k, a += nd) *vec[k] = a;
  double** mat[] = {&p->kp, &p->kd, &p->ki, &p->D};
  for (size_t k = 0; k < 4; ++k, a += nd * nd) *mat[k] = a;
  p->A = a;
  a += nx * nx;
  p->B = a;
  a += nx * nd;
  p->C = a;
  a += nd * nx;
  p->sat = (double*)calloc(nd, sizeof(double));
  if (!p->sat) {
    fmu_model_destroy(p);
    return NULL;
  }
  if (fmu_model_reset(p) != PKM_OK) {
    if (err && errlen) snprintf(err, errlen, "%s", p->msg);
    fmu_model_destroy(p);
    return NULL;
  }
  return p;
}

void fmu_model_destroy(fmu_model* p) {
  if (!p) return;
  pkm_ctrl_destroy(p->c);
  pkm_model_destroy(p->m);
  free(p->par);
  free(p->sat);
  free(p);
}

int fmu_model_reset(fmu_model* p) {
  pkm_ctrl_destroy(p->c);
  p->c = NULL;
  memset(p->par, 0, arrays_size(p->nd, p->np, p->nx_max) * sizeof(double));
  memset(p->sat, 0, (size_t)p->nd * sizeof(double));
  p->dt = 1e-3, p->tf = 0, p->kind = 0, p->gravity_ref = 0, p->gravity_ff = 0, p->nx = p->nx_max;
  for (int k = 0; k < p->desc->nvars; ++k) {
    const fmu_var* v = &p->desc->vars[k];
    if (v->causality == FMU_OUTPUT) continue;
    int s = v->type == FMU_INTEGER ? fmu_model_set_integer(p, v, (int)v->start) : fmu_model_set_real(p, v, v->start);
    if (s) return s;
  }
  p->t = 0;
  p->started = 0;
  p->dirty = 1;
  p->msg[0] = '\0';
  return PKM_OK;
}

int fmu_model_set_real(fmu_model* p, const fmu_var* v, double value) {
  if (!isfinite(value)) return fail(p, PKM_ERR_ARGUMENT, "%s = %g at t = %.9g s is not finite", v->name, value, p->t);
  switch (v->channel) {
    case FMU_CH_CTRL_DT: p->dt = value; break;
    case FMU_CH_CTRL_TF: p->tf = value; break;
    default: {
      size_t n = 0;
      double* b = block(p, v->channel, &n);
      if (!b || v->index < 0 || (size_t)v->index >= n)
        return fail(p, PKM_ERR_ARGUMENT, "variable %s cannot be set", v->name);
      b[v->index] = value;
    }
  }
  if (v->causality == FMU_PARAMETER) p->dirty = 1;
  return PKM_OK;
}

int fmu_model_set_integer(fmu_model* p, const fmu_var* v, int value) {
  switch (v->channel) {
    case FMU_CH_CTRL_KIND: p->kind = value; break;
    case FMU_CH_CTRL_GRAVITY_REF: p->gravity_ref = value; break;
    case FMU_CH_CTRL_GRAVITY_FF: p->gravity_ff = value; break;
    case FMU_CH_CTRL_NX:
      if (value < 0 || value > p->nx_max)
        return fail(p, PKM_ERR_ARGUMENT, "%s = %d: this FMU has room for 0..%d LTI states", v->name, value, p->nx_max);
      p->nx = value;
      break;
    default: return fail(p, PKM_ERR_ARGUMENT, "variable %s is not an Integer", v->name);
  }
  p->dirty = 1;
  return PKM_OK;
}

int fmu_model_get_real(fmu_model* p, const fmu_var* v, double* value) {
  switch (v->channel) {
    case FMU_CH_CTRL_DT: *value = p->dt; return PKM_OK;
    case FMU_CH_CTRL_TF: *value = p->tf; return PKM_OK;
    default: {
      size_t n = 0;
      const double* b = block(p, v->channel, &n);
      if (!b || v->index < 0 || (size_t)v->index >= n) return fail(p, PKM_ERR_ARGUMENT, "variable %s is not a Real", v->name);
      *value = b[v->index];
      if (!isfinite(*value)) return fail(p, PKM_ERR_ARGUMENT, "%s is not finite at t = %.9g s", v->name, p->t);
      return PKM_OK;
    }
  }
}

int fmu_model_get_integer(fmu_model* p, const fmu_var* v, int* value) {
  switch (v->channel) {
    case FMU_CH_CTRL_KIND: *value = p->kind; return PKM_OK;
    case FMU_CH_CTRL_GRAVITY_REF: *value = p->gravity_ref; return PKM_OK;
    case FMU_CH_CTRL_GRAVITY_FF: *value = p->gravity_ff; return PKM_OK;
    case FMU_CH_CTRL_NX: *value = p->nx; return PKM_OK;
    default: return fail(p, PKM_ERR_ARGUMENT, "variable %s is not an Integer", v->name);
  }
}

void fmu_model_set_tolerance(fmu_model* p, double rtol) { (void)p, (void)rtol; }
void fmu_model_set_time(fmu_model* p, double t) { p->t = t; }

/* The core model (parameters through pkm_param_set + validate) and the law (pkm_ctrl_create). */
int fmu_model_start(fmu_model* p, double t0) {
  char cerr[1024] = "";
  for (int i = 0; i < p->np; ++i)
    if (pkm_param_get(p->m, i) != p->par[i] && pkm_param_set(p->m, i, p->par[i], cerr, sizeof cerr) != PKM_OK)
      return fail(p, PKM_ERR_PARAMETER, "%s", cerr);
  if (pkm_model_validate(p->m, cerr, sizeof cerr) != PKM_OK) return fail(p, PKM_ERR_PARAMETER, "%s", cerr);
  /* The LTI matrices in use: the leading nx x nx block of the FMU's room, packed. */
  const int nd = p->nd, nx = p->nx, room = p->nx_max;
  double *A = NULL, *C = NULL;
  if (nx > 0) {
    A = (double*)malloc(sizeof(double) * (size_t)(nx * nx + nd * nx));
    if (!A) return fail(p, PKM_ERR_INTERNAL, "out of memory");
    C = A + nx * nx;
    for (int r = 0; r < nx; ++r)
      for (int c = 0; c < nx; ++c) A[r * nx + c] = p->A[r * room + c];
    for (int i = 0; i < nd; ++i)
      for (int c = 0; c < nx; ++c) C[i * nx + c] = p->C[i * room + c];
  }
  int any_sat = 0;
  for (int i = 0; i < nd; ++i) any_sat |= p->sat[i] != 0;
  pkm_ctrl_spec s;
  memset(&s, 0, sizeof s);
  s.kind = p->kind;
  s.dt = p->dt;
  s.kp = p->kp, s.kd = p->kd, s.ki = p->ki;
  s.deriv_filter = p->tf;
  s.saturation = any_sat ? p->sat : NULL;
  s.gravity_at_reference = p->gravity_ref;
  s.gravity_feedforward = p->gravity_ff;
  s.nx = nx;
  s.A = A, s.B = p->B, s.C = C, s.D = p->D;
  pkm_ctrl_destroy(p->c);
  p->c = pkm_ctrl_create(p->m, &s, cerr, sizeof cerr);
  free(A);
  if (!p->c) return fail(p, PKM_ERR_PARAMETER, "%s", cerr);
  if (pkm_ctrl_reset(p->c, NULL) != PKM_OK) return fail(p, PKM_ERR_INTERNAL, "%s", pkm_ctrl_error(p->c));
  memset(p->tau, 0, sizeof(double) * (size_t)nd);
  p->t = t0;
  p->started = 1;
  p->dirty = 0;
  return PKM_OK;
}

/* One sample at the current time from the inputs as set; tau is held until the next. */
int fmu_model_step(fmu_model* p, double t_end) {
  if (!p->c) return fail(p, PKM_ERR_INTERNAL, "the controller is not initialized");
  double tau[64];
  int s = pkm_ctrl_update(p->c, p->t, p->q, p->qd, p->qref, p->qdref, p->qddref, NULL, tau);
  if (s != PKM_OK) return fail(p, s, "%s", pkm_ctrl_error(p->c));
  memcpy(p->tau, tau, sizeof(double) * (size_t)p->nd);
  p->t = t_end;
  return PKM_OK;
}

/* No continuous states, derivatives or event indicators. */
int fmu_model_set_states(fmu_model* p, const double* s, size_t n) {
  (void)s;
  return n == 0 ? PKM_OK : fail(p, PKM_ERR_UNSUPPORTED, "a controller FMU has no continuous states");
}
int fmu_model_get_states(const fmu_model* p, double* s, size_t n) {
  (void)p, (void)s;
  return n == 0 ? PKM_OK : PKM_ERR_UNSUPPORTED;
}
int fmu_model_get_derivatives(fmu_model* p, double* ds, size_t n) {
  (void)ds;
  return n == 0 ? PKM_OK : fail(p, PKM_ERR_UNSUPPORTED, "a controller FMU has no continuous states");
}
int fmu_model_get_indicators(fmu_model* p, double* z, size_t n) {
  (void)z;
  return n == 0 ? PKM_OK : fail(p, PKM_ERR_UNSUPPORTED, "a controller FMU has no event indicators");
}
int fmu_model_check_limits(fmu_model* p, double tol) {
  (void)p, (void)tol;
  return PKM_OK;
}

/* Snapshot: t, started, dirty, kind, gravity_ref, gravity_ff, nx, dt, tf, every array,
 * saturation, then the law's own state (pkm_ctrl_state_save) when started. */
enum { CSNAP_HEAD = 9 };

static size_t fixed_size(const fmu_model* p) {
  return CSNAP_HEAD + arrays_size(p->nd, p->np, p->nx_max) + (size_t)p->nd + 1;
}
size_t fmu_model_snapshot_min_size(const fmu_model* p) { return fixed_size(p); }
size_t fmu_model_snapshot_size(const fmu_model* p) {
  return fixed_size(p) + (p->started && p->c ? pkm_ctrl_state_size(p->c) : 0);
}

void fmu_model_snapshot_save(const fmu_model* p, double* b) {
  b[0] = p->t, b[1] = p->started, b[2] = p->dirty, b[3] = p->kind, b[4] = p->gravity_ref, b[5] = p->gravity_ff;
  b[6] = p->nx, b[7] = p->dt, b[8] = p->tf;
  double* v = b + CSNAP_HEAD;
  const size_t na = arrays_size(p->nd, p->np, p->nx_max);
  memcpy(v, p->par, na * sizeof(double));
  v += na;
  memcpy(v, p->sat, (size_t)p->nd * sizeof(double));
  v += p->nd;
  const size_t nc = p->started && p->c ? pkm_ctrl_state_size(p->c) : 0;
  v[0] = (double)nc;
  if (nc) pkm_ctrl_state_save(p->c, v + 1);
}

/* Everything is checked before it is used (nothing is changed here): the length, every
 * value finite, flags, the kind and the LTI state count whole and in range (nx sizes the
 * copies plant_start makes); the gains then go through pkm_ctrl_create and the law's state
 * through pkm_ctrl_state_load, which checks it against the law's own layout. */
int fmu_model_snapshot_check(fmu_model* p, const double* b, size_t n) {
  const size_t fixed = fixed_size(p);
  if (n < fixed)
    return fail(p, PKM_ERR_ARGUMENT, "FMU state is damaged: %zu values where the layout needs at least %zu", n, fixed);
  for (size_t k = 0; k < n; ++k)
    if (!isfinite(b[k])) return fail(p, PKM_ERR_ARGUMENT, "FMU state is damaged: value %zu is not finite (%g)", k, b[k]);
  if (!fmu_whole(b[fixed - 1], 0, (double)(n - fixed)) || (size_t)b[fixed - 1] != n - fixed)
    return fail(p, PKM_ERR_ARGUMENT, "FMU state is damaged: %zu values where the layout needs %zu + %g", n, fixed,
                b[fixed - 1]);
  const char* bad = NULL;
  if (!fmu_whole(b[1], 0, 1) || !fmu_whole(b[2], 0, 1))
    bad = "started or dirty flag (0 or 1)";
  else if (!fmu_whole(b[3], -2147483647.0, 2147483647.0) || !fmu_whole(b[4], -2147483647.0, 2147483647.0) ||
           !fmu_whole(b[5], -2147483647.0, 2147483647.0))
    bad = "controller.kind or gravity flag (an Integer)";
  else if (!fmu_whole(b[6], 0, p->nx_max))
    bad = "LTI state count lti.nx (this FMU has room for 0..lti_states)";
  else if (n > fixed && b[1] == 0)
    bad = "controller state (there is one only for a started controller)";
  if (bad) return fail(p, PKM_ERR_ARGUMENT, "FMU state is damaged: invalid %s (lti.nx = %g, room %d)", bad, b[6],
                       p->nx_max);
  return PKM_OK;
}

/* Loads a snapshot that passed plant_snapshot_check. */
int fmu_model_snapshot_load(fmu_model* p, const double* b, size_t n) {
  const size_t fixed = fixed_size(p);
  p->t = b[0];
  const int started = b[1] != 0, dirty = b[2] != 0;
  p->kind = (int)b[3], p->gravity_ref = (int)b[4], p->gravity_ff = (int)b[5], p->nx = (int)b[6];
  p->dt = b[7], p->tf = b[8];
  const double* v = b + CSNAP_HEAD;
  const size_t na = arrays_size(p->nd, p->np, p->nx_max);
  memcpy(p->par, v, na * sizeof(double));
  v += na;
  memcpy(p->sat, v, (size_t)p->nd * sizeof(double));
  p->started = 0;
  p->dirty = dirty;
  if (!started) return PKM_OK;
  double tau[64];
  memcpy(tau, p->tau, sizeof(double) * (size_t)p->nd);
  const double t = p->t;
  int s = fmu_model_start(p, t);
  if (s) return s;
  memcpy(p->tau, tau, sizeof(double) * (size_t)p->nd);
  if (pkm_ctrl_state_load(p->c, b + fixed, n - fixed) != PKM_OK) {
    p->started = 0;
    return fail(p, PKM_ERR_ARGUMENT, "FMU state: %s", pkm_ctrl_error(p->c));
  }
  p->dirty = dirty;
  return PKM_OK;
}
