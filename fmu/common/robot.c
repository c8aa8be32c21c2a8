/*
 * robot.c -- the hooks of fmu_model.h for a robot FMU: the robot-generic model behind every
 * PKM robot FMU.
 *
 * The model holds the state (t, x, xd), the input tau and the pending parameters of one
 * FMU instance, and computes outputs by calling the reference core (pkm.h).  It contains
 * no physics: everything a robot-specific table can name (channels of fmu_model.h) is
 * one core call.  See docs/fmu.md.
 */
#include "fmu_robot.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Wall-clock limit of one fmi2DoStep [s] (docs/fmu.md, Bounded work). */
#define FMU_STEP_TIME_LIMIT 1.0

const char* fmu_model_error(const fmu_model* p) { return p ? p->msg : "model is NULL"; }
double fmu_model_time(const fmu_model* p) { return p->t; }
int fmu_model_nstates(const fmu_model* p) { return 2 * p->nd; }
int fmu_model_dirty(const fmu_model* p) { return p->dirty || !p->started; }

/* Name of the table row of a channel entry, for messages. */
const char* fmu_robot_var_name(const fmu_model* p, fmu_channel ch, int index) {
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

int fmu_robot_ensure(fmu_model* p, unsigned bit, const char* what) {
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
        if ((s = fmu_robot_ensure(p, V_KIN, what))) return s;
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
    if (!(s = fmu_robot_ensure(p, need, v->name))) *value = derived[i];
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
int fmu_robot_apply(fmu_model* p) {
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
    return fail(p, PKM_ERR_PARAMETER, "%s = %d: use %s", fmu_robot_var_name(p, FMU_CH_SOLVER_METHOD, 0), o.method,
                known);
  }
  if (!(o.rtol > 0) || !(o.atol > 0))
    return fail(p, PKM_ERR_PARAMETER, "%s = %g and %s = %g must both be > 0",
                fmu_robot_var_name(p, FMU_CH_SOLVER_RTOL, 0), o.rtol, fmu_robot_var_name(p, FMU_CH_SOLVER_ATOL, 0),
                o.atol);
  if (o.max_steps <= 0 || o.max_steps > PKM_SIM_MAX_STEPS_LIMIT)
    return fail(p, PKM_ERR_PARAMETER,
                "%s = %ld must be in [1, %ld]: it is the work budget of one fmi2DoStep, which must return in bounded "
                "time (docs/fmu.md, Bounded work)",
                fmu_robot_var_name(p, FMU_CH_SOLVER_MAX_STEPS, 0), o.max_steps, PKM_SIM_MAX_STEPS_LIMIT);
  if (!(o.max_step >= 0) || !(o.sing_min >= 0))
    return fail(p, PKM_ERR_PARAMETER, "%s = %g (>= 0), %s = %ld (> 0), %s = %g (>= 0): out of range",
                fmu_robot_var_name(p, FMU_CH_SOLVER_MAX_STEP, 0), o.max_step,
                fmu_robot_var_name(p, FMU_CH_SOLVER_MAX_STEPS, 0), o.max_steps,
                fmu_robot_var_name(p, FMU_CH_SOLVER_SING_MIN, 0), o.sing_min);
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
                p->sing[1], fmu_robot_var_name(p, FMU_CH_SOLVER_SING_MIN, 0), p->opt_applied.sing_min);
  return PKM_OK;
}

int fmu_model_start(fmu_model* p, double t0) {
  p->started = 0;
  p->valid = 0;
  int s = fmu_robot_apply(p);
  if (s) return s;
  for (int i = 0; i < p->nd; ++i) {
    if (!isfinite(p->x0[i]))
      return fail(p, PKM_ERR_ARGUMENT, "initial pose %s = %g is not finite", fmu_robot_var_name(p, FMU_CH_POSE0, i),
                  p->x0[i]);
    if (!isfinite(p->xd0[i]))
      return fail(p, PKM_ERR_ARGUMENT, "initial rate %s = %g is not finite", fmu_robot_var_name(p, FMU_CH_TWIST0, i),
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
