/*
 * fmu_instance.c -- the FMI-version-independent part of every PKM FMU (fmu_instance.h):
 * written once for the FMI 2.0 and the FMI 3.0 layer.  The FMU state (its blocks) is
 * fmu_state.c.
 *
 * Every call checks the instance's state against the state machine, every failure is
 * logged with the function name and the model's what/where message, and the status
 * escalates the state (Error -> error state; a Discarded Co-Simulation step -> step
 * failed, with the state at the event time).  An instance owns all its memory, the
 * importer's callbacks are copied at instantiation; nothing here is global and mutable,
 * so instances run side by side.
 */
#include "fmu_instance.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static const char* const LOG_NAMES[] = {"logEvents", "logStatusWarning", "logStatusDiscard",
                                        "logStatusError", "logStatusFatal", "logFmiCalls"};
#define LOG_NCAT 6

static void vlog(const fmu_instance* c, fmu_status st, int cat, const char* fmt, va_list ap) {
  if (!c || !c->emit) return;
  /* Errors, discards and warnings are always reported; the rest only when asked for. */
  if (st == FMU_OK && !(c->log_mask & (unsigned)cat)) return;
  char msg[4096];
  vsnprintf(msg, sizeof msg, fmt, ap);
  int k = 0;
  while (k < LOG_NCAT - 1 && (1 << k) != cat) ++k;
  c->emit(c, st, LOG_NAMES[k], msg);
}

void fmu_log(const fmu_instance* c, fmu_status st, int cat, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vlog(c, st, cat, fmt, ap);
  va_end(ap);
}

int fmu_model_fail(char* msg, size_t size, int status, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, size, fmt, ap);
  va_end(ap);
  return status;
}

fmu_status fmu_error(fmu_instance* c, const char* fn, const char* fmt, ...) {
  char msg[3000];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: %s", fn, msg);
  c->state = S_ERROR;
  return FMU_ERROR;
}

/* The last line of defence of the array getters: no value leaves as an infinity or a NaN
 * with OK (the variable getters have their own, per variable, in the model). */
fmu_status fmu_finite_or_error(fmu_instance* c, const char* fn, const char* what, const double* v, size_t n) {
  for (size_t i = 0; i < n; ++i)
    if (!isfinite(v[i]))
      return fmu_error(c, fn, "%s %zu is not finite (%g) at t = %.9g s: a state or an input is too large", what, i,
                       v[i], fmu_model_time(c->model));
  return FMU_OK;
}

static const char* state_name(int s) {
  switch (s) {
    case S_INSTANTIATED: return "instantiated";
    case S_INIT: return "initialization mode";
    case S_EVENT: return "event mode";
    case S_CONT: return "continuous-time mode";
    case S_STEP_COMPLETE: return "step complete";
    case S_STEP_FAILED: return "step failed";
    case S_TERMINATED: return "terminated";
    case S_ERROR: return "error";
    case S_FATAL: return "fatal";
    default: return "unknown";
  }
}

/* A call in a wrong state is an error of the importer: logged, but it does not corrupt
 * the instance. */
int fmu_bad_call(fmu_instance* c, const char* fn, int allowed) {
  if (!c) return 1;
  if (c->state & allowed) {
    fmu_log(c, FMU_OK, LOG_CALLS, "%s", fn);
    return 0;
  }
  fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: not allowed in state '%s'", fn, state_name(c->state));
  return 1;
}

fmu_status fmu_set_debug_logging(fmu_instance* c, const char* fn, int on, size_t n, const char* const cats[]) {
  if (fmu_bad_call(c, fn, S_ANY)) return FMU_ERROR;
  if (n == 0) {
    c->log_mask = on ? ~0u : 0u;
    return FMU_OK;
  }
  if (!cats) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: %zu categories in a NULL array", fn, n);
    return FMU_ERROR;
  }
  for (size_t i = 0; i < n; ++i) {
    int k = 0;
    while (k < LOG_NCAT && (!cats[i] || strcmp(cats[i], LOG_NAMES[k]) != 0)) ++k;
    if (k == LOG_NCAT) {
      fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: unknown log category '%s'", fn, cats[i] ? cats[i] : "(null)");
      return FMU_ERROR;
    }
    if (on)
      c->log_mask |= 1u << k;
    else
      c->log_mask &= ~(1u << k);
  }
  return FMU_OK;
}

/* In initialization mode the outputs are computed from the pending start values. */
static fmu_status ensure_started(fmu_instance* c, const char* fn) {
  if (!fmu_model_dirty(c->model)) return FMU_OK;
  if (fmu_model_start(c->model, c->start_time)) return fmu_error(c, fn, "%s", fmu_model_error(c->model));
  return FMU_OK;
}

/* ------------------------------------------------------- life of an instance */

fmu_instance* fmu_instantiate(const char* fn, fmu_instance* head, size_t size, const char* name, const char* token,
                              const char* token_word, int cosimulation) {
  head->name = (char*)(name ? name : "?");
  head->state = 0;
  if (!name || !*name) {
    fmu_log(head, FMU_ERROR, LOG_ERROR, "%s: missing instance name", fn);
    return NULL;
  }
  if (!token || strcmp(token, head->token) != 0) {
    fmu_log(head, FMU_ERROR, LOG_ERROR,
            "%s: %s %s does not match this binary's %s (modelDescription.xml of another build?)", fn, token_word,
            token ? token : "(null)", head->token);
    return NULL;
  }
  char err[1024] = "";
  fmu_model* p = fmu_model_create(&FMU_MODEL, cosimulation, err, sizeof err);
  if (!p) {
    fmu_log(head, FMU_ERROR, LOG_ERROR, "%s: %s", fn, err);
    return NULL;
  }
  fmu_instance* c = (fmu_instance*)calloc(1, size);
  char* copy = (char*)malloc(strlen(name) + 1);
  if (!c || !copy) {
    fmu_log(head, FMU_ERROR, LOG_ERROR, "%s: out of memory", fn);
    free(c);
    free(copy);
    fmu_model_destroy(p);
    return NULL;
  }
  strcpy(copy, name);
  memcpy(c, head, size);
  c->name = copy;
  c->cosimulation = cosimulation;
  c->model = p;
  c->state = S_INSTANTIATED;
  fmu_log(c, FMU_OK, LOG_EVENTS, "%s: %s %s (%s), token %s", fn, FMU_MODEL.identifier,
          cosimulation ? "Co-Simulation" : "Model Exchange", FMU_MODEL.robot, token);
  return c;
}

void fmu_free(fmu_instance* c) {
  if (!c) return;
  fmu_model_destroy(c->model);
  free(c->name);
  free(c);
}

fmu_status fmu_reset(fmu_instance* c, const char* fn) {
  if (fmu_bad_call(c, fn, S_ANY)) return FMU_ERROR;
  fmu_model_reset(c->model);
  c->start_time = c->stop_time = 0;
  c->stop_defined = 0;
  c->terminated = 0;
  c->last_successful_time = 0;
  c->state = S_INSTANTIATED;
  return FMU_OK;
}

fmu_status fmu_setup(fmu_instance* c, const char* fn, int tolerance_defined, double tolerance, double start_time,
                     int stop_defined, double stop_time) {
  if (!isfinite(start_time) || (stop_defined && !(stop_time >= start_time)))
    return fmu_error(c, fn, "start time %g, stop time %g: need finite start <= stop", start_time, stop_time);
  if (tolerance_defined && !(tolerance > 0 && tolerance < 1))
    return fmu_error(c, fn, "tolerance %g is no relative tolerance: it must be in (0, 1)", tolerance);
  c->start_time = start_time;
  c->stop_time = stop_time;
  c->stop_defined = stop_defined != 0;
  /* The importer's tolerance, when given, is the integrator's relative tolerance. */
  fmu_model_set_tolerance(c->model, tolerance_defined ? tolerance : 0.0);
  fmu_model_set_time(c->model, start_time);
  return FMU_OK;
}

fmu_status fmu_exit_initialization(fmu_instance* c, const char* fn) {
  if (fmu_bad_call(c, fn, S_INIT)) return FMU_ERROR;
  if (ensure_started(c, fn) != FMU_OK) return FMU_ERROR;
  c->last_successful_time = c->start_time;
  c->terminated = 0;
  c->state = c->cosimulation ? S_STEP_COMPLETE : S_EVENT;
  fmu_log(c, FMU_OK, LOG_EVENTS, "%s: started at t = %.9g s", fn, c->start_time);
  return FMU_OK;
}

fmu_status fmu_terminate(fmu_instance* c, const char* fn) {
  if (fmu_bad_call(c, fn, S_EVENT | S_CONT | S_STEP_COMPLETE | S_STEP_FAILED)) return FMU_ERROR;
  c->state = S_TERMINATED;
  return FMU_OK;
}

/* ------------------------------------------------------------ variable values */

const fmu_var* fmu_lookup(fmu_instance* c, const char* fn, unsigned vr, fmu_type type, const char* type_name) {
  if (vr < 1 || vr > (unsigned)FMU_MODEL.nvars) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: unknown value reference %u (1..%d)", fn, vr, FMU_MODEL.nvars);
    return NULL;
  }
  const fmu_var* v = &FMU_MODEL.vars[vr - 1];
  if (v->type != type) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: value reference %u (%s) is not a%s %s", fn, vr, v->name,
            strchr("AEIOU", type_name[0]) ? "n" : "", type_name);
    return NULL;
  }
  return v;
}

/* Parameters are fixed once initialization is over; inputs are set any time a value
 * can be used. */
static int settable(fmu_instance* c, const char* fn, const fmu_var* v) {
  if (v->causality == FMU_PARAMETER && !(c->state & (S_INSTANTIATED | S_INIT))) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: parameter %s is fixed: set it before the end of initialization", fn,
            v->name);
    return 0;
  }
  if (v->causality == FMU_OUTPUT) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: %s is an output and cannot be set", fn, v->name);
    return 0;
  }
  return 1;
}

fmu_status fmu_get_real(fmu_instance* c, const char* fn, const fmu_var* v, double* value) {
  if (c->state == S_INIT && v->causality == FMU_OUTPUT && ensure_started(c, fn) != FMU_OK) return FMU_ERROR;
  if (fmu_model_get_real(c->model, v, value)) return fmu_error(c, fn, "%s: %s", v->name, fmu_model_error(c->model));
  return FMU_OK;
}

fmu_status fmu_get_integer(fmu_instance* c, const char* fn, const fmu_var* v, int* value) {
  if (fmu_model_get_integer(c->model, v, value)) return fmu_error(c, fn, "%s: %s", v->name, fmu_model_error(c->model));
  return FMU_OK;
}

fmu_status fmu_set_real(fmu_instance* c, const char* fn, const fmu_var* v, double value) {
  if (!settable(c, fn, v)) return FMU_ERROR;
  if (fmu_model_set_real(c->model, v, value)) return fmu_error(c, fn, "%s", fmu_model_error(c->model));
  return FMU_OK;
}

fmu_status fmu_set_integer(fmu_instance* c, const char* fn, const fmu_var* v, int value) {
  if (!settable(c, fn, v)) return FMU_ERROR;
  if (fmu_model_set_integer(c->model, v, value)) return fmu_error(c, fn, "%s", fmu_model_error(c->model));
  return FMU_OK;
}

/* ----------------------------------------------------------- Model Exchange */

fmu_status fmu_enter_event_mode(fmu_instance* c, const char* fn) {
  if (fmu_bad_call(c, fn, S_EVENT | S_CONT)) return FMU_ERROR;
  c->state = S_EVENT;
  return FMU_OK;
}

fmu_status fmu_enter_continuous_time_mode(fmu_instance* c, const char* fn) {
  if (fmu_bad_call(c, fn, S_EVENT)) return FMU_ERROR;
  c->state = S_CONT;
  return FMU_OK;
}

/* Where a state event lands, the indicator is zero up to the importer's root finding. */
#define LIMIT_TOL 1e-9

/* In Model Exchange the importer owns time: at the edge of the usable workspace the
 * FMU can only ask it to stop (terminateSimulation), saying why, where and when. */
static int reached_limit(fmu_instance* c, const char* fn) {
  if (!fmu_model_check_limits(c->model, LIMIT_TOL)) return 0;
  c->terminated = 1;
  c->last_successful_time = fmu_model_time(c->model);
  fmu_log(c, FMU_WARNING, LOG_WARNING, "%s: stopping the simulation: %s", fn, fmu_model_error(c->model));
  return 1;
}

fmu_status fmu_update_discrete_states(fmu_instance* c, const char* fn, int* terminate) {
  if (fmu_bad_call(c, fn, S_EVENT)) return FMU_ERROR;
  if (!terminate) return fmu_error(c, fn, "NULL output argument");
  *terminate = c->terminated || reached_limit(c, fn);
  return *terminate ? FMU_WARNING : FMU_OK;
}

fmu_status fmu_completed_integrator_step(fmu_instance* c, const char* fn, int* enter_event_mode, int* terminate) {
  if (fmu_bad_call(c, fn, S_CONT)) return FMU_ERROR;
  if (!enter_event_mode || !terminate) return fmu_error(c, fn, "NULL output argument");
  *enter_event_mode = 0;
  /* Also catches an importer that steps past a limit without locating the event. */
  *terminate = reached_limit(c, fn);
  if (!*terminate) c->last_successful_time = fmu_model_time(c->model);
  return *terminate ? FMU_WARNING : FMU_OK;
}

fmu_status fmu_set_time(fmu_instance* c, const char* fn, double time) {
  if (fmu_bad_call(c, fn, S_EVENT | S_CONT)) return FMU_ERROR;
  if (!isfinite(time)) return fmu_error(c, fn, "time %g is not finite", time);
  fmu_model_set_time(c->model, time);
  return FMU_OK;
}

fmu_status fmu_set_states(fmu_instance* c, const char* fn, const double* x, size_t nx) {
  if (fmu_bad_call(c, fn, S_CONT)) return FMU_ERROR;
  if (!x) return fmu_error(c, fn, "x is NULL");
  if (fmu_model_set_states(c->model, x, nx)) return fmu_error(c, fn, "%s", fmu_model_error(c->model));
  return FMU_OK;
}

/* A model status of a model evaluation: an error of the model or the arguments moves to
 * the error state; a singular pose is a Discard (the solver may retry with a smaller step,
 * or stop). */
static fmu_status evaluation(fmu_instance* c, const char* fn, int s, const char* what, const double* v, size_t n) {
  if (s == PKM_OK) return fmu_finite_or_error(c, fn, what, v, n);
  if (s == PKM_ERR_ARGUMENT || s == PKM_ERR_PARAMETER || s == PKM_ERR_INTERNAL)
    return fmu_error(c, fn, "%s", fmu_model_error(c->model));
  fmu_log(c, FMU_DISCARD, LOG_DISCARD, "%s: %s", fn, fmu_model_error(c->model));
  return FMU_DISCARD;
}

fmu_status fmu_get_derivatives(fmu_instance* c, const char* fn, double* dx, size_t nx) {
  if (fmu_bad_call(c, fn, S_ME_VALUES)) return FMU_ERROR;
  if (!dx) return fmu_error(c, fn, "derivatives is NULL");
  if (c->state == S_INIT && ensure_started(c, fn) != FMU_OK) return FMU_ERROR;
  return evaluation(c, fn, fmu_model_get_derivatives(c->model, dx, nx), "derivative", dx, nx);
}

fmu_status fmu_get_indicators(fmu_instance* c, const char* fn, double* z, size_t nz) {
  /* Also a variable's values in FMI 3.0 (<EventIndicator>), readable between steps. */
  if (fmu_bad_call(c, fn, S_ME_VALUES | S_STEP_COMPLETE | S_STEP_FAILED)) return FMU_ERROR;
  if (!z && nz > 0) return fmu_error(c, fn, "eventIndicators is NULL");
  if (c->state == S_INIT && ensure_started(c, fn) != FMU_OK) return FMU_ERROR;
  return evaluation(c, fn, fmu_model_get_indicators(c->model, z, nz), "event indicator", z, nz);
}

fmu_status fmu_get_states(fmu_instance* c, const char* fn, double* x, size_t nx) {
  if (fmu_bad_call(c, fn, S_ME_VALUES)) return FMU_ERROR;
  if (!x) return fmu_error(c, fn, "x is NULL");
  if (c->state == S_INIT && ensure_started(c, fn) != FMU_OK) return FMU_ERROR;
  if (fmu_model_get_states(c->model, x, nx))
    return fmu_error(c, fn, "%zu states asked for, the model has %d", nx, fmu_model_nstates(c->model));
  return fmu_finite_or_error(c, fn, "continuous state", x, nx);
}

fmu_status fmu_get_nominals(fmu_instance* c, const char* fn, double* nominals, size_t nx) {
  if (fmu_bad_call(c, fn, S_INSTANTIATED | S_ME_VALUES)) return FMU_ERROR;
  if (!nominals || nx != (size_t)fmu_model_nstates(c->model))
    return fmu_error(c, fn, "%zu nominals asked for, the model has %d states", nx, fmu_model_nstates(c->model));
  for (size_t i = 0; i < nx; ++i) nominals[i] = 1.0;
  return FMU_OK;
}

/* -------------------------------------------------------------- Co-Simulation */

fmu_status fmu_do_step(fmu_instance* c, const char* fn, double t, double h) {
  if (fmu_bad_call(c, fn, S_STEP_COMPLETE)) return FMU_ERROR;
  double now = fmu_model_time(c->model);
  if (!isfinite(t) || !isfinite(h) || h < 0)
    return fmu_error(c, fn, "communication point %g and step %g: need finite values and step >= 0", t, h);
  /* The importer keeps its own clock; accept its rounding, not a jump. */
  if (fabs(t - now) > 1e-9 * (1.0 + fabs(now)))
    return fmu_error(c, fn, "communication point t = %.17g s differs from the FMU time %.17g s", t, now);
  double t_end = t + h;
  if (c->stop_defined && t_end > c->stop_time * (1 + 1e-12) + 1e-12)
    return fmu_error(c, fn, "step to t = %.17g s goes past the stop time %.17g s", t_end, c->stop_time);
  if (h == 0) return FMU_OK;
  int s = fmu_model_step(c->model, t_end);
  if (s == PKM_OK) {
    c->last_successful_time = t_end;
    return FMU_OK;
  }
  if (s == PKM_ERR_SINGULAR || s == PKM_ERR_JOINT_LIMIT || s == PKM_ERR_UNREACHABLE || s == PKM_ERR_STEP_BUDGET) {
    /* The model stopped at the event (or where its step budget ran out): the state there
     * is consistent and readable. */
    c->last_successful_time = fmu_model_time(c->model);
    c->terminated = 1;
    c->stopped = s != PKM_ERR_STEP_BUDGET;
    c->state = S_STEP_FAILED;
    fmu_log(c, FMU_DISCARD, LOG_DISCARD, "%s from t = %.9g s to %.9g s: %s", fn, t, t_end, fmu_model_error(c->model));
    return FMU_DISCARD;
  }
  return fmu_error(c, fn, "from t = %.9g s to %.9g s: %s", t, t_end, fmu_model_error(c->model));
}
