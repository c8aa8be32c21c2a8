/*
 * robot.c -- the hooks of fmu_model.h for a robot FMU: the robot-generic model behind every
 * PKM robot FMU.
 *
 * The model holds the state (t, x, xd), the input tau and the pending parameters of one
 * FMU instance, and computes outputs by calling the reference core (pkm.h).  It contains
 * no physics: everything a robot-specific table can name (channels of fmu_model.h) is
 * one core call.  See docs/fmu.md.
 */
#include "fmu_model.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Wall-clock limit of one fmi2DoStep [s] (docs/fmu.md, Bounded work). */
#define FMU_STEP_TIME_LIMIT 1.0

enum { V_KIN = 1, V_ACC = 2, V_SING = 4, V_ENERGY = 8, V_DRIVE = 16 };

struct fmu_model {
  const fmu_model_desc* desc;
  int cs;            /* Co-Simulation (owns a pkm_sim) or Model Exchange */
  int nd, np;
  pkm_model* m;
  pkm_data* d;
  pkm_sim* sim;

  double t;
  double *x, *xd, *tau, *x0, *xd0, *par; /* par: pending parameter values */
  double *xdd, *q, *qd, *qdrv, *qddrv;    /* computed on demand (valid bits) */
  double sing[2], energy[2];
  unsigned valid;

  pkm_sim_options opt;         /* pending solver settings                    */
  pkm_sim_options opt_applied; /* settings the current sim was created with  */
  double tol_override;         /* importer's tolerance, <= 0 for none        */
  double input_gain;           /* effort on the joint per unit of input (input.gain) */
  double tau_eff[16];          /* input_gain x tau: what the core is given   */
  int started;                 /* plant_start succeeded since the last reset */
  int dirty;                   /* a parameter or x0/xd0 changed since then   */
  int model_ok;                /* the core model is validated                */

  char msg[2048];
};

const char* fmu_model_error(const fmu_model* p) { return p ? p->msg : "model is NULL"; }
double fmu_model_time(const fmu_model* p) { return p->t; }
int fmu_model_nstates(const fmu_model* p) { return 2 * p->nd; }
int fmu_model_dirty(const fmu_model* p) { return p->dirty || !p->started; }

/* Name of the table row of a channel entry, for messages. */
static const char* var_name(const fmu_model* p, fmu_channel ch, int index) {
  for (int k = 0; k < p->desc->nvars; ++k)
    if (p->desc->vars[k].channel == ch && p->desc->vars[k].index == index) return p->desc->vars[k].name;
  return "?";
}

/* The effort the core is given: the inputs times input.gain (a Quattro driven with motor
 * torques has input.gain = gear.ratio). */
static const double* effort(fmu_model* p) {
  for (int i = 0; i < p->nd; ++i) p->tau_eff[i] = p->input_gain * p->tau[i];
  return p->tau_eff;
}

static void set_starts(fmu_model* p) {
  pkm_sim_default_options(&p->opt);
  p->input_gain = 1.0;
  for (int k = 0; k < p->desc->nvars; ++k) {
    const fmu_var* v = &p->desc->vars[k];
    switch (v->channel) {
      case FMU_CH_PARAM: p->par[v->index] = v->start; break;
      case FMU_CH_TAU: p->tau[v->index] = v->start; break;
      case FMU_CH_POSE0: p->x0[v->index] = v->start; break;
      case FMU_CH_TWIST0: p->xd0[v->index] = v->start; break;
      case FMU_CH_SOLVER_METHOD: p->opt.method = (int)v->start; break;
      case FMU_CH_SOLVER_RTOL: p->opt.rtol = v->start; break;
      case FMU_CH_SOLVER_ATOL: p->opt.atol = v->start; break;
      case FMU_CH_SOLVER_MAX_STEP: p->opt.max_step = v->start; break;
      case FMU_CH_INPUT_GAIN: p->input_gain = v->start; break;
      case FMU_CH_SOLVER_MAX_STEPS: p->opt.max_steps = (long)v->start; break;
      case FMU_CH_SOLVER_SING_MIN: p->opt.sing_min = v->start; break;
      default: break;
    }
  }
  memcpy(p->x, p->x0, sizeof(double) * p->nd);
  memcpy(p->xd, p->xd0, sizeof(double) * p->nd);
  p->t = 0;
  p->valid = 0;
  p->started = 0;
  p->dirty = 1;
  p->tol_override = 0;
}

fmu_model* fmu_model_create(const fmu_model_desc* desc, int cosimulation, char* err, size_t errlen) {
  char cerr[1024] = "";
  /* A described robot: the FMU carries its description; the core compiles it once. */
  if (desc->description &&
      pkm_robot_register_description(desc->description, desc->robot, cerr, sizeof cerr) != PKM_OK) {
    snprintf(err, errlen, "cannot compile the description of robot '%s': %s", desc->robot, cerr);
    return NULL;
  }
  pkm_model* m = pkm_model_create(desc->robot, desc->param_set, cerr, sizeof cerr);
  if (!m) {
    snprintf(err, errlen, "cannot create the core model of robot '%s': %s", desc->robot, cerr);
    return NULL;
  }
  /* The table was generated from the core's parameter table; a mismatch means the .so
   * was built against another core and its modelDescription.xml would lie. */
  int np = pkm_model_nparam(m), nd = pkm_model_ndof(m), seen = 0;
  if (nd != desc->ndof || np != desc->nparam) {
    snprintf(err, errlen, "robot '%s' has %d dof and %d parameters in the core, the FMU table %d and %d",
             desc->robot, nd, np, desc->ndof, desc->nparam);
    pkm_model_destroy(m);
    return NULL;
  }
  for (int k = 0; k < desc->nvars; ++k) {
    const fmu_var* v = &desc->vars[k];
    if (v->channel != FMU_CH_PARAM) continue;
    ++seen;
    if (v->index < 0 || v->index >= np || strcmp(pkm_param_name(m, v->index), v->name) != 0) {
      snprintf(err, errlen, "FMU variable %s does not match core parameter %d (%s)", v->name, v->index,
               pkm_param_name(m, v->index));
      pkm_model_destroy(m);
      return NULL;
    }
  }
  if (seen != np) {
    snprintf(err, errlen, "the FMU table lists %d of the core's %d parameters", seen, np);
    pkm_model_destroy(m);
    return NULL;
  }

  fmu_model* p = (fmu_model*)calloc(1, sizeof *p);
  double* buf = (double*)calloc((size_t)(10 * nd + np), sizeof(double));
  pkm_data* d = pkm_data_create(m);
  if (!p || !buf || !d) {
    snprintf(err, errlen, "out of memory");
    free(p);
    free(buf);
    pkm_data_destroy(d);
    pkm_model_destroy(m);
    return NULL;
  }
  p->desc = desc;
  p->cs = cosimulation;
  p->nd = nd;
  p->np = np;
  p->m = m;
  p->d = d;
  p->x = buf;
  p->xd = p->x + nd;
  p->tau = p->xd + nd;
  p->x0 = p->tau + nd;
  p->xd0 = p->x0 + nd;
  p->xdd = p->xd0 + nd;
  p->q = p->xdd + nd;
  p->qd = p->q + nd;
  p->qdrv = p->qd + nd;
  p->qddrv = p->qdrv + nd;
  p->par = p->qddrv + nd;
  p->model_ok = 1;
  set_starts(p);
  return p;
}

void fmu_model_destroy(fmu_model* p) {
  if (!p) return;
  pkm_sim_destroy(p->sim);
  pkm_data_destroy(p->d);
  pkm_model_destroy(p->m);
  free(p->x);
  free(p);
}

int fmu_model_reset(fmu_model* p) {
  set_starts(p);
  p->msg[0] = '\0';
  return PKM_OK;
}

void fmu_model_set_tolerance(fmu_model* p, double rtol) {
  if (rtol != p->tol_override) p->dirty = 1;
  p->tol_override = rtol;
}

/* ----------------------------------------------------------------- set / get */

int fmu_model_set_real(fmu_model* p, const fmu_var* v, double value) {
  int i = v->index;
  switch (v->channel) {
    case FMU_CH_TAU:
      /* An input is used at once by the next step: a NaN must not get that far. */
      if (!isfinite(value))
        return fail(p, PKM_ERR_ARGUMENT, "input %s = %g at t = %.9g s is not finite", v->name, value, p->t);
      p->tau[i] = value;
      p->valid &= ~(unsigned)V_ACC;
      return PKM_OK;
    case FMU_CH_PARAM: p->par[i] = value; break;
    case FMU_CH_POSE0: p->x0[i] = value; break;
    case FMU_CH_TWIST0: p->xd0[i] = value; break;
    case FMU_CH_SOLVER_RTOL: p->opt.rtol = value; break;
    case FMU_CH_SOLVER_ATOL: p->opt.atol = value; break;
    case FMU_CH_SOLVER_MAX_STEP: p->opt.max_step = value; break;
    case FMU_CH_SOLVER_SING_MIN: p->opt.sing_min = value; break;
    case FMU_CH_INPUT_GAIN:
      if (!(isfinite(value) && value > 0 && value < 1e6))
        return fail(p, PKM_ERR_PARAMETER, "%s = %g must be a positive gain below 1e6", v->name, value);
      p->input_gain = value;
      break;
    default: return fail(p, PKM_ERR_ARGUMENT, "variable %s cannot be set", v->name);
  }
  p->dirty = 1;
  return PKM_OK;
}

int fmu_model_set_integer(fmu_model* p, const fmu_var* v, int value) {
  switch (v->channel) {
    case FMU_CH_SOLVER_METHOD: p->opt.method = value; break;
    case FMU_CH_SOLVER_MAX_STEPS: p->opt.max_steps = value; break;
    default: return fail(p, PKM_ERR_ARGUMENT, "variable %s cannot be set", v->name);
  }
  p->dirty = 1;
  return PKM_OK;
}

static int need_model(fmu_model* p, const char* what) {
  if (!p->started || !p->model_ok)
    return fail(p, PKM_ERR_ARGUMENT, "%s is computed from the state, which exists after initialization", what);
  return PKM_OK;
}

static int core_fail(fmu_model* p, int s, const char* what) {
  return fail(p, s, "%s at t = %.9g s: %s", what, p->t, pkm_data_error(p->d));
}

static int ensure(fmu_model* p, unsigned bit, const char* what) {
  if (p->valid & bit) return PKM_OK;
  int s = need_model(p, what);
  if (s) return s;
  switch (bit) {
    case V_KIN:
      if ((s = pkm_ik(p->m, p->d, p->x, p->q))) return core_fail(p, s, "inverse kinematics");
      if ((s = pkm_joint_velocity(p->m, p->d, p->x, p->xd, p->qd))) return core_fail(p, s, "joint velocity");
      break;
    case V_ACC:
      if (pkm_model_two_body_joints(p->m) > 0 && p->cs && p->sim && p->started) {
        /* the carriages feel what the transmissions carry: the integrator's own rates */
        if ((s = pkm_sim_acceleration(p->sim, effort(p), p->xdd)))
          return fail(p, s, "acceleration at t = %.9g s: %s", p->t, pkm_sim_error(p->sim));
      } else if ((s = pkm_forward_dynamics(p->m, p->d, p->x, p->xd, effort(p), p->xdd))) {
        return core_fail(p, s, "forward dynamics");
      }
      break;
    case V_DRIVE:
      if (p->cs && p->sim && p->started) {
        if ((s = pkm_sim_drive_state(p->sim, p->qdrv, p->qddrv)))
          return fail(p, s, "drive state at t = %.9g s: %s", p->t, pkm_sim_error(p->sim));
      } else {
        if ((s = ensure(p, V_KIN, what))) return s;
        memcpy(p->qdrv, p->q, sizeof(double) * p->nd);
        memcpy(p->qddrv, p->qd, sizeof(double) * p->nd);
      }
      break;
    case V_SING:
      if ((s = pkm_singularity(p->m, p->d, p->x, p->sing))) return core_fail(p, s, "singularity measure");
      break;
    case V_ENERGY:
      if ((s = pkm_energy(p->m, p->d, p->x, p->xd, &p->energy[0], &p->energy[1])))
        return core_fail(p, s, "energy");
      break;
  }
  p->valid |= bit;
  return PKM_OK;
}

int fmu_model_get_real(fmu_model* p, const fmu_var* v, double* value) {
  int i = v->index, s = PKM_OK;
  /* Outputs computed on demand: the quantity they need (ensure) and where it lands. */
  unsigned need = 0;
  const double* derived = NULL;
  switch (v->channel) {
    case FMU_CH_ACCEL: need = V_ACC, derived = p->xdd; break;
    case FMU_CH_Q: need = V_KIN, derived = p->q; break;
    case FMU_CH_QD: need = V_KIN, derived = p->qd; break;
    case FMU_CH_Q_DRIVE: need = V_DRIVE, derived = p->qdrv; break;
    case FMU_CH_QD_DRIVE: need = V_DRIVE, derived = p->qddrv; break;
    case FMU_CH_SING: need = V_SING, derived = p->sing; break;
    case FMU_CH_ENERGY: need = V_ENERGY, derived = p->energy; break;
    default: break;
  }
  if (derived) {
    if (!(s = ensure(p, need, v->name))) *value = derived[i];
  } else switch (v->channel) {
    case FMU_CH_PARAM: *value = p->par[i]; break;
    case FMU_CH_TAU: *value = p->tau[i]; break;
    case FMU_CH_POSE: *value = p->x[i]; break;
    case FMU_CH_TWIST: *value = p->xd[i]; break;
    case FMU_CH_POSE0: *value = p->x0[i]; break;
    case FMU_CH_TWIST0: *value = p->xd0[i]; break;
    case FMU_CH_SOLVER_RTOL: *value = p->opt.rtol; break;
    case FMU_CH_SOLVER_ATOL: *value = p->opt.atol; break;
    case FMU_CH_SOLVER_MAX_STEP: *value = p->opt.max_step; break;
    case FMU_CH_SOLVER_SING_MIN: *value = p->opt.sing_min; break;
    case FMU_CH_INPUT_GAIN: *value = p->input_gain; break;
    default: return fail(p, PKM_ERR_ARGUMENT, "variable %s is not a Real", v->name);
  }
  /* The last line of defence: no value leaves the FMU as an infinity or a NaN with OK. */
  if (s == PKM_OK && !isfinite(*value))
    return fail(p, PKM_ERR_ARGUMENT, "%s is not finite (%g) at t = %.9g s: an input or a state is too large", v->name,
                *value, p->t);
  return s;
}

int fmu_model_get_integer(fmu_model* p, const fmu_var* v, int* value) {
  switch (v->channel) {
    case FMU_CH_SOLVER_METHOD: *value = p->opt.method; return PKM_OK;
    case FMU_CH_SOLVER_MAX_STEPS: *value = (int)p->opt.max_steps; return PKM_OK;
    default: return fail(p, PKM_ERR_ARGUMENT, "variable %s is not an Integer", v->name);
  }
}

/* ------------------------------------------------------------ apply / start */

/* The core's integration methods (pkm_sim_method): whether code is one of them, and the
 * list "2 (explicit Runge-Kutta 5(4)), ..., or 1 (CVODE Adams)" for a message. */
static int method_known(int code) {
  int c;
  for (int i = 0; i < pkm_sim_method_count(); ++i)
    if (pkm_sim_method(i, &c, NULL, NULL, NULL) == PKM_OK && c == code) return 1;
  return 0;
}

static void method_list(char* out, size_t len) {
  size_t k = 0;
  const int n = pkm_sim_method_count();
  out[0] = '\0';
  for (int i = 0; i < n && k < len; ++i) {
    int c;
    const char* title;
    if (pkm_sim_method(i, &c, NULL, &title, NULL) != PKM_OK) continue;
    const int w = snprintf(out + k, len - k, "%s%d (%s)", i == 0 ? "" : (i + 1 == n ? " or " : ", "), c, title);
    if (w < 0) break;
    k += (size_t)w;
  }
}

static int same_options(const pkm_sim_options* a, const pkm_sim_options* b) {
  return a->method == b->method && a->rtol == b->rtol && a->atol == b->atol && a->max_step == b->max_step &&
         a->max_steps == b->max_steps && a->sing_min == b->sing_min;
}

/* Pending parameters into the core model, pending solver settings into a (new) sim. */
static int apply(fmu_model* p) {
  char cerr[1024] = "";
  int changed = !p->model_ok;
  for (int i = 0; i < p->np; ++i) {
    double cur = pkm_param_get(p->m, i);
    if (p->par[i] == cur) continue;
    int s = pkm_param_set(p->m, i, p->par[i], cerr, sizeof cerr);
    if (s) {
      p->model_ok = 0;
      return fail(p, s, "%s", cerr);
    }
    changed = 1;
  }
  if (changed) {
    int s = pkm_model_validate(p->m, cerr, sizeof cerr);
    p->model_ok = (s == PKM_OK);
    if (s) return fail(p, s, "%s", cerr);
  }
  /* The outputs are the readings now: a sensor lag is for the importer to model, so a
   * non-zero one is refused rather than ignored without a word. */
  int sd = pkm_param_index(p->m, "sensor.delay");
  if (sd >= 0 && pkm_param_get(p->m, sd) != 0)
    return fail(p, PKM_ERR_PARAMETER,
                "sensor.delay = %g s: this FMU outputs the joints at the current time and does not delay them; set it "
                "to 0 and delay the readings in the importer (the core's discrepancy replay models it)",
                pkm_param_get(p->m, sd));

  /* Two-body joints carry states of the integrator's own (the drive bodies): Model
   * Exchange exposes the pose states only. */
  if (!p->cs && pkm_model_two_body_joints(p->m) > 0)
    return fail(p, PKM_ERR_PARAMETER,
                "drive.two_body = 1 with a backlash or a compliance set: the drive bodies are states of the "
                "Co-Simulation FMU's own integrator, and Model Exchange has the pose states only; use Co-Simulation, "
                "or drive.two_body = 0 (the quasi-static reading model)");

  pkm_sim_options o = p->opt;
  if (p->tol_override > 0) o.rtol = p->tol_override;
  if (!method_known(o.method)) {
    char known[256];
    method_list(known, sizeof known);
    return fail(p, PKM_ERR_PARAMETER, "%s = %d: use %s", var_name(p, FMU_CH_SOLVER_METHOD, 0), o.method, known);
  }
  if (!(o.rtol > 0) || !(o.atol > 0))
    return fail(p, PKM_ERR_PARAMETER, "%s = %g and %s = %g must both be > 0", var_name(p, FMU_CH_SOLVER_RTOL, 0),
                o.rtol, var_name(p, FMU_CH_SOLVER_ATOL, 0), o.atol);
  if (o.max_steps <= 0 || o.max_steps > PKM_SIM_MAX_STEPS_LIMIT)
    return fail(p, PKM_ERR_PARAMETER,
                "%s = %ld must be in [1, %ld]: it is the work budget of one fmi2DoStep, which must return in bounded "
                "time (docs/fmu.md, Bounded work)",
                var_name(p, FMU_CH_SOLVER_MAX_STEPS, 0), o.max_steps, PKM_SIM_MAX_STEPS_LIMIT);
  if (!(o.max_step >= 0) || !(o.sing_min >= 0))
    return fail(p, PKM_ERR_PARAMETER, "%s = %g (>= 0), %s = %ld (> 0), %s = %g (>= 0): out of range",
                var_name(p, FMU_CH_SOLVER_MAX_STEP, 0), o.max_step, var_name(p, FMU_CH_SOLVER_MAX_STEPS, 0),
                o.max_steps, var_name(p, FMU_CH_SOLVER_SING_MIN, 0), o.sing_min);
  if (p->cs && (changed || !p->sim || !same_options(&o, &p->opt_applied))) {
    pkm_sim_destroy(p->sim);
    p->sim = pkm_sim_create(p->m, &o, cerr, sizeof cerr);
    if (!p->sim) return fail(p, PKM_ERR_INTEGRATION, "cannot create the integrator: %s", cerr);
    /* A host cannot interrupt fmi2DoStep: past this wall time it is Discarded. */
    pkm_sim_set_time_limit(p->sim, FMU_STEP_TIME_LIMIT);
  }
  p->opt_applied = o;
  return PKM_OK;
}

static int check_pose(fmu_model* p, const char* what) {
  int s = pkm_ik(p->m, p->d, p->x, p->q);
  if (s) return fail(p, s, "%s at t = %.9g s: %s", what, p->t, pkm_data_error(p->d));
  s = pkm_singularity(p->m, p->d, p->x, p->sing);
  if (s) return fail(p, s, "%s at t = %.9g s: %s", what, p->t, pkm_data_error(p->d));
  if (p->sing[1] < p->opt_applied.sing_min)
    return fail(p, PKM_ERR_SINGULAR,
                "%s at t = %.9g s is (nearly) singular: direct singularity measure %.3g < %s = %.3g", what, p->t,
                p->sing[1], var_name(p, FMU_CH_SOLVER_SING_MIN, 0), p->opt_applied.sing_min);
  return PKM_OK;
}

int fmu_model_start(fmu_model* p, double t0) {
  p->started = 0;
  p->valid = 0;
  int s = apply(p);
  if (s) return s;
  for (int i = 0; i < p->nd; ++i) {
    if (!isfinite(p->x0[i]))
      return fail(p, PKM_ERR_ARGUMENT, "initial pose %s = %g is not finite", var_name(p, FMU_CH_POSE0, i), p->x0[i]);
    if (!isfinite(p->xd0[i]))
      return fail(p, PKM_ERR_ARGUMENT, "initial rate %s = %g is not finite", var_name(p, FMU_CH_TWIST0, i),
                  p->xd0[i]);
  }
  p->t = t0;
  memcpy(p->x, p->x0, sizeof(double) * p->nd);
  memcpy(p->xd, p->xd0, sizeof(double) * p->nd);
  if ((s = check_pose(p, "initial pose"))) return s;
  if (p->cs && (s = pkm_sim_reset(p->sim, t0, p->x, p->xd)))
    return fail(p, s, "start at t = %.9g s: %s", t0, pkm_sim_error(p->sim));
  p->started = 1;
  p->dirty = 0;
  return PKM_OK;
}

/* ------------------------------------------------------------- co-simulation */

int fmu_model_step(fmu_model* p, double t_end) {
  int s = pkm_sim_set_input(p->sim, effort(p));
  if (s) return fail(p, s, "input at t = %.9g s: %s", p->t, pkm_sim_error(p->sim));
  s = pkm_sim_advance(p->sim, t_end);
  int g = pkm_sim_get_state(p->sim, &p->t, p->x, p->xd);
  p->valid = 0;
  if (s) return fail(p, s, "%s", pkm_sim_error(p->sim));
  if (g) return fail(p, g, "reading the integrator state: %s", pkm_sim_error(p->sim));
  return PKM_OK;
}

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
                  i < p->nd ? var_name(p, FMU_CH_POSE, i) : var_name(p, FMU_CH_TWIST, i - p->nd), v, p->t);
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
  int s = ensure(p, V_ACC, "state derivative");
  if (s) return s;
  memcpy(ds, p->xd, sizeof(double) * p->nd);
  memcpy(ds + p->nd, p->xdd, sizeof(double) * p->nd);
  return PKM_OK;
}

int fmu_model_get_indicators(fmu_model* p, double* z, size_t n) {
  const fmu_model_desc* D = p->desc;
  if (n != (size_t)D->nindicators)
    return fail(p, PKM_ERR_ARGUMENT, "%zu event indicators asked for, the model has %d", n, D->nindicators);
  int s = ensure(p, V_SING, "event indicator");
  if (s) return s;
  z[0] = p->sing[1] - p->opt_applied.sing_min;
  if (!D->qmin_param) return PKM_OK;
  s = ensure(p, V_KIN, "event indicator");
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
  int s = ensure(p, V_SING, "singularity check");
  if (s) return s;
  if (p->sing[1] - p->opt_applied.sing_min <= tol)
    return fail(p, PKM_ERR_SINGULAR,
                "direct (type 2) singularity: %s = %.6g reached %s = %.6g at t = %.10g s",
                var_name(p, FMU_CH_SING, 1), p->sing[1], var_name(p, FMU_CH_SOLVER_SING_MIN, 0),
                p->opt_applied.sing_min, p->t);
  if (!D->qmin_param) return PKM_OK;
  if ((s = ensure(p, V_KIN, "stroke-limit check"))) return s;
  for (int i = 0; i < p->nd; ++i) {
    for (int w = 0; w < 2; ++w) {
      int par = w ? D->qmax_param[i] : D->qmin_param[i];
      double lim = pkm_param_get(p->m, par), margin = w ? lim - p->q[i] : p->q[i] - lim;
      if (margin <= tol)
        return fail(p, PKM_ERR_JOINT_LIMIT, "joint %d reached its %s limit %s = %.6g %s at t = %.10g s (%s = %.10g)",
                    i + 1, w ? "upper" : "lower", pkm_param_name(p->m, par), lim, pkm_param_unit(p->m, par), p->t,
                    var_name(p, FMU_CH_Q, i), p->q[i]);
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
  int s = apply(p);
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
