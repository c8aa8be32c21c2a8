/*
 * fmi2_functions.c -- the FMI 2.0 functions (Model Exchange and Co-Simulation), written
 * once for every PKM FMU.  A model folder supplies FMU_MODEL (its generated variable
 * table); the physics is in the plant (plant.c), which calls the reference core.
 *
 * Every call checks the instance's state against the FMI 2.0 state machine, every
 * failure is logged with the function name and the plant's what/where message, and
 * the status escalates the state (Error -> error state; a Discarded Co-Simulation step
 * -> stepFailed, with the state at the event time).  An instance owns all its memory;
 * nothing here is global and mutable, so instances run side by side.
 */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "fmu_plant.h"

/* ---------------------------------------------------------------- states */

enum {
  S_INSTANTIATED = 1 << 0,
  S_INIT = 1 << 1,
  S_EVENT = 1 << 2,         /* ME */
  S_CONT = 1 << 3,          /* ME */
  S_STEP_COMPLETE = 1 << 4, /* CS */
  S_STEP_FAILED = 1 << 5,   /* CS */
  S_TERMINATED = 1 << 6,
  S_ERROR = 1 << 7,
  S_FATAL = 1 << 8
};
#define S_ANY \
  (S_INSTANTIATED | S_INIT | S_EVENT | S_CONT | S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED | S_ERROR)
#define S_HAS_VALUES (S_INIT | S_EVENT | S_CONT | S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED | S_ERROR)

enum {
  LOG_EVENTS = 1,
  LOG_WARNING = 2,
  LOG_DISCARD = 4,
  LOG_ERROR = 8,
  LOG_FATAL = 16,
  LOG_CALLS = 32
};
static const char* const LOG_NAMES[] = {"logEvents", "logStatusWarning", "logStatusDiscard",
                                        "logStatusError", "logStatusFatal", "logFmiCalls"};
#define LOG_NCAT 6

typedef struct instance {
  char* name;
  fmi2Type type;
  fmi2CallbackFunctions cb; /* copied: the importer's struct need not outlive the call */
  unsigned log_mask;        /* enabled categories (debug logging)                      */
  int state;
  fmu_plant* plant;
  double start_time, stop_time;
  int stop_defined;
  double last_successful_time;
  int terminated;
} instance;

static void vlog(instance* c, fmi2Status st, int cat, const char* fmt, va_list ap) {
  if (!c || !c->cb.logger) return;
  /* Errors, discards and warnings are always reported; the rest only when asked for. */
  if (st == fmi2OK && !(c->log_mask & (unsigned)cat)) return;
  char msg[4096], esc[8192];
  vsnprintf(msg, sizeof msg, fmt, ap);
  /* The logger treats the message as a printf format: protect '%'. */
  size_t j = 0;
  for (size_t i = 0; msg[i] && j + 2 < sizeof esc; ++i) {
    if (msg[i] == '%') esc[j++] = '%';
    esc[j++] = msg[i];
  }
  esc[j] = '\0';
  int k = 0;
  while (k < LOG_NCAT - 1 && (1 << k) != cat) ++k;
  c->cb.logger(c->cb.componentEnvironment, c->name, st, LOG_NAMES[k], esc);
}

static void logmsg(instance* c, fmi2Status st, int cat, const char* fmt, ...) {
  va_list ap;
  va_start(ap, fmt);
  vlog(c, st, cat, fmt, ap);
  va_end(ap);
}

/* Logs and moves to the error state. */
static fmi2Status error(instance* c, const char* fn, const char* fmt, ...) {
  char msg[3000];
  va_list ap;
  va_start(ap, fmt);
  vsnprintf(msg, sizeof msg, fmt, ap);
  va_end(ap);
  logmsg(c, fmi2Error, LOG_ERROR, "%s: %s", fn, msg);
  c->state = S_ERROR;
  return fmi2Error;
}

/* The last line of defence of the array getters: no value leaves as an infinity or a NaN
 * with OK (fmi2GetReal has its own, per variable, in the plant). */
static fmi2Status finite_or_error(instance* c, const char* fn, const char* what, const fmi2Real* v, size_t n) {
  for (size_t i = 0; i < n; ++i)
    if (!isfinite(v[i]))
      return error(c, fn, "%s %zu is not finite (%g) at t = %.9g s: a state or an input is too large", what, i, v[i],
                   plant_time(c->plant));
  return fmi2OK;
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

/* Checks the instance pointer and the state machine.  A call in a wrong state is an
 * error of the importer: logged, but it does not corrupt the instance. */
static int bad_call(instance* c, const char* fn, int allowed) {
  if (!c) return 1;
  if (c->state & allowed) {
    logmsg(c, fmi2OK, LOG_CALLS, "%s", fn);
    return 0;
  }
  logmsg(c, fmi2Error, LOG_ERROR, "%s: not allowed in state '%s'", fn, state_name(c->state));
  return 1;
}

static const fmu_var* lookup(instance* c, const char* fn, fmi2ValueReference vr, fmu_type type) {
  if (vr < 1 || vr > (fmi2ValueReference)FMU_MODEL.nvars) {
    logmsg(c, fmi2Error, LOG_ERROR, "%s: unknown value reference %u (1..%d)", fn, vr, FMU_MODEL.nvars);
    return NULL;
  }
  const fmu_var* v = &FMU_MODEL.vars[vr - 1];
  if (v->type != type) {
    logmsg(c, fmi2Error, LOG_ERROR, "%s: value reference %u (%s) is not a%s", fn, vr, v->name,
           type == FMU_REAL ? " Real" : "n Integer");
    return NULL;
  }
  return v;
}

/* Parameters are fixed once initialization is over; inputs are set any time a value
 * can be used. */
static int settable(instance* c, const char* fn, const fmu_var* v) {
  if (v->causality == FMU_PARAMETER && !(c->state & (S_INSTANTIATED | S_INIT))) {
    logmsg(c, fmi2Error, LOG_ERROR, "%s: parameter %s is fixed: set it before fmi2ExitInitializationMode", fn,
           v->name);
    return 0;
  }
  if (v->causality == FMU_OUTPUT) {
    logmsg(c, fmi2Error, LOG_ERROR, "%s: %s is an output and cannot be set", fn, v->name);
    return 0;
  }
  return 1;
}

/* In initialization mode the outputs are computed from the pending start values. */
static fmi2Status ensure_started(instance* c, const char* fn) {
  if (!plant_dirty(c->plant)) return fmi2OK;
  if (plant_start(c->plant, c->start_time)) return error(c, fn, "%s", plant_error(c->plant));
  return fmi2OK;
}

/* ---------------------------------------------------------- common functions */

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t n, const fmi2String cats[]) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2SetDebugLogging", S_ANY)) return fmi2Error;
  if (n == 0) {
    c->log_mask = loggingOn ? ~0u : 0u;
    return fmi2OK;
  }
  for (size_t i = 0; i < n; ++i) {
    int k = 0;
    while (k < LOG_NCAT && (!cats[i] || strcmp(cats[i], LOG_NAMES[k]) != 0)) ++k;
    if (k == LOG_NCAT) {
      logmsg(c, fmi2Error, LOG_ERROR, "fmi2SetDebugLogging: unknown log category '%s'", cats[i] ? cats[i] : "(null)");
      return fmi2Error;
    }
    if (loggingOn)
      c->log_mask |= 1u << k;
    else
      c->log_mask &= ~(1u << k);
  }
  return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
  (void)fmuResourceLocation;
  (void)visible;
  instance tmp;
  memset(&tmp, 0, sizeof tmp);
  if (functions) tmp.cb = *functions;
  tmp.name = (char*)(instanceName ? instanceName : "?");
  if (!instanceName || !*instanceName) {
    logmsg(&tmp, fmi2Error, LOG_ERROR, "fmi2Instantiate: missing instance name");
    return NULL;
  }
  if (!fmuGUID || strcmp(fmuGUID, FMU_MODEL.guid) != 0) {
    logmsg(&tmp, fmi2Error, LOG_ERROR,
           "fmi2Instantiate: GUID %s does not match this binary's %s (modelDescription.xml of another build?)",
           fmuGUID ? fmuGUID : "(null)", FMU_MODEL.guid);
    return NULL;
  }
  if (fmuType != fmi2ModelExchange && fmuType != fmi2CoSimulation) {
    logmsg(&tmp, fmi2Error, LOG_ERROR, "fmi2Instantiate: unknown FMU type %d", (int)fmuType);
    return NULL;
  }
  char err[1024] = "";
  fmu_plant* p = plant_create(&FMU_MODEL, fmuType == fmi2CoSimulation, err, sizeof err);
  if (!p) {
    logmsg(&tmp, fmi2Error, LOG_ERROR, "fmi2Instantiate: %s", err);
    return NULL;
  }
  instance* c = (instance*)calloc(1, sizeof *c);
  char* name = (char*)malloc(strlen(instanceName) + 1);
  if (!c || !name) {
    logmsg(&tmp, fmi2Error, LOG_ERROR, "fmi2Instantiate: out of memory");
    free(c);
    free(name);
    plant_destroy(p);
    return NULL;
  }
  strcpy(name, instanceName);
  *c = tmp;
  c->name = name;
  c->type = fmuType;
  c->plant = p;
  c->log_mask = loggingOn ? ~0u : 0u;
  c->state = S_INSTANTIATED;
  logmsg(c, fmi2OK, LOG_EVENTS, "fmi2Instantiate: %s %s (%s), GUID %s", FMU_MODEL.identifier,
         fmuType == fmi2CoSimulation ? "Co-Simulation" : "Model Exchange", FMU_MODEL.robot, FMU_MODEL.guid);
  return c;
}

void fmi2FreeInstance(fmi2Component comp) {
  instance* c = (instance*)comp;
  if (!c) return;
  plant_destroy(c->plant);
  free(c->name);
  free(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2SetupExperiment", S_INSTANTIATED)) return fmi2Error;
  if (!isfinite(startTime) || (stopTimeDefined && !(stopTime >= startTime)))
    return error(c, "fmi2SetupExperiment", "start time %g, stop time %g: need finite start <= stop", startTime,
                 stopTime);
  if (toleranceDefined && !(tolerance > 0 && tolerance < 1))
    return error(c, "fmi2SetupExperiment", "tolerance %g is no relative tolerance: it must be in (0, 1)", tolerance);
  c->start_time = startTime;
  c->stop_time = stopTime;
  c->stop_defined = stopTimeDefined != 0;
  /* The importer's tolerance, when given, is the integrator's relative tolerance. */
  plant_set_tolerance(c->plant, toleranceDefined ? tolerance : 0.0);
  plant_set_time(c->plant, startTime);
  return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2EnterInitializationMode", S_INSTANTIATED)) return fmi2Error;
  c->state = S_INIT;
  return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2ExitInitializationMode", S_INIT)) return fmi2Error;
  if (ensure_started(c, "fmi2ExitInitializationMode") != fmi2OK) return fmi2Error;
  c->last_successful_time = c->start_time;
  c->terminated = 0;
  c->state = c->type == fmi2CoSimulation ? S_STEP_COMPLETE : S_EVENT;
  logmsg(c, fmi2OK, LOG_EVENTS, "fmi2ExitInitializationMode: started at t = %.9g s", c->start_time);
  return fmi2OK;
}

fmi2Status fmi2Terminate(fmi2Component comp) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2Terminate", S_EVENT | S_CONT | S_STEP_COMPLETE | S_STEP_FAILED)) return fmi2Error;
  c->state = S_TERMINATED;
  return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component comp) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2Reset", S_ANY)) return fmi2Error;
  plant_reset(c->plant);
  c->start_time = c->stop_time = 0;
  c->stop_defined = 0;
  c->terminated = 0;
  c->last_successful_time = 0;
  c->state = S_INSTANTIATED;
  return fmi2OK;
}

/* ------------------------------------------------------------- get / set */

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetReal", S_INSTANTIATED | S_HAS_VALUES)) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return error(c, "fmi2GetReal", "NULL array for %zu values", nvr);
  for (size_t i = 0; i < nvr; ++i) {
    const fmu_var* v = lookup(c, "fmi2GetReal", vr[i], FMU_REAL);
    if (!v) return fmi2Error;
    if (c->state == S_INIT && v->causality == FMU_OUTPUT && ensure_started(c, "fmi2GetReal") != fmi2OK)
      return fmi2Error;
    if (plant_get_real(c->plant, v, &value[i]))
      return error(c, "fmi2GetReal", "%s: %s", v->name, plant_error(c->plant));
  }
  return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetInteger", S_INSTANTIATED | S_HAS_VALUES)) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return error(c, "fmi2GetInteger", "NULL array for %zu values", nvr);
  for (size_t i = 0; i < nvr; ++i) {
    const fmu_var* v = lookup(c, "fmi2GetInteger", vr[i], FMU_INTEGER);
    if (!v) return fmi2Error;
    int x = 0;
    if (plant_get_integer(c->plant, v, &x))
      return error(c, "fmi2GetInteger", "%s: %s", v->name, plant_error(c->plant));
    value[i] = x;
  }
  return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
  instance* c = (instance*)comp;
  (void)value;
  if (bad_call(c, "fmi2GetBoolean", S_INSTANTIATED | S_HAS_VALUES)) return fmi2Error;
  if (nvr == 0) return fmi2OK;
  logmsg(c, fmi2Error, LOG_ERROR, "fmi2GetBoolean: value reference %u: this FMU has no Boolean variables",
         vr ? vr[0] : 0u);
  return fmi2Error;
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
  instance* c = (instance*)comp;
  (void)value;
  if (bad_call(c, "fmi2GetString", S_INSTANTIATED | S_HAS_VALUES)) return fmi2Error;
  if (nvr == 0) return fmi2OK;
  logmsg(c, fmi2Error, LOG_ERROR, "fmi2GetString: value reference %u: this FMU has no String variables",
         vr ? vr[0] : 0u);
  return fmi2Error;
}

#define S_SETTABLE (S_INSTANTIATED | S_INIT | S_EVENT | S_CONT | S_STEP_COMPLETE)

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2SetReal", S_SETTABLE)) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return error(c, "fmi2SetReal", "NULL array for %zu values", nvr);
  for (size_t i = 0; i < nvr; ++i) {
    const fmu_var* v = lookup(c, "fmi2SetReal", vr[i], FMU_REAL);
    if (!v || !settable(c, "fmi2SetReal", v)) return fmi2Error;
    if (plant_set_real(c->plant, v, value[i])) return error(c, "fmi2SetReal", "%s", plant_error(c->plant));
  }
  return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2SetInteger", S_SETTABLE)) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return error(c, "fmi2SetInteger", "NULL array for %zu values", nvr);
  for (size_t i = 0; i < nvr; ++i) {
    const fmu_var* v = lookup(c, "fmi2SetInteger", vr[i], FMU_INTEGER);
    if (!v || !settable(c, "fmi2SetInteger", v)) return fmi2Error;
    if (plant_set_integer(c->plant, v, value[i])) return error(c, "fmi2SetInteger", "%s", plant_error(c->plant));
  }
  return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
  instance* c = (instance*)comp;
  (void)value;
  if (bad_call(c, "fmi2SetBoolean", S_SETTABLE)) return fmi2Error;
  if (nvr == 0) return fmi2OK;
  logmsg(c, fmi2Error, LOG_ERROR, "fmi2SetBoolean: value reference %u: this FMU has no Boolean variables",
         vr ? vr[0] : 0u);
  return fmi2Error;
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
  instance* c = (instance*)comp;
  (void)value;
  if (bad_call(c, "fmi2SetString", S_SETTABLE)) return fmi2Error;
  if (nvr == 0) return fmi2OK;
  logmsg(c, fmi2Error, LOG_ERROR, "fmi2SetString: value reference %u: this FMU has no String variables",
         vr ? vr[0] : 0u);
  return fmi2Error;
}

/* ---------------------------------------------------------------- FMU state */

/* An FMU state is one flat block, so serialising it is a copy.  The header ties it to
 * this model (GUID), layout (version) and interface; the plant writes the rest.  A
 * checksum over the whole block (its own field read as zero) catches a block damaged in
 * storage or transit; every value is checked again when the state is restored (a block
 * edited on purpose and sealed again must not crash or poison the instance either). */
#define STATE_MAGIC "PKMFMU2S"
#define STATE_VERSION 2u
typedef struct fmu_state {
  char magic[8];
  char guid[48];
  int32_t type;       /* fmi2Type of the instance it came from */
  int32_t mode;       /* state-machine state                   */
  uint64_t nplant;    /* doubles in plant[]                     */
  double start_time, stop_time, last_successful_time;
  int32_t stop_defined, terminated;
  uint32_t version;   /* STATE_VERSION                          */
  uint32_t reserved;  /* 0                                      */
  uint64_t checksum;  /* FNV-1a 64 of the block, this field as 0 */
  double plant[];
} fmu_state;

static size_t state_bytes(size_t nplant) { return sizeof(fmu_state) + nplant * sizeof(double); }

/* FNV-1a (64 bit) of the n bytes of a state block, its checksum field read as zero. */
static uint64_t state_checksum(const unsigned char* bytes, size_t n) {
  const size_t skip = offsetof(fmu_state, checksum);
  uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i < n; ++i) {
    const unsigned char b = (i >= skip && i < skip + sizeof(uint64_t)) ? 0 : bytes[i];
    h = (h ^ b) * 1099511628211ull;
  }
  return h;
}

/* The state-machine states a state of this interface can be taken in. */
static int mode_ok(fmi2Type type, int32_t mode) {
  const int common = S_INSTANTIATED | S_INIT | S_TERMINATED | S_ERROR;
  const int allowed = common | (type == fmi2CoSimulation ? S_STEP_COMPLETE | S_STEP_FAILED : S_EVENT | S_CONT);
  return mode > 0 && (mode & (mode - 1)) == 0 && (mode & allowed) != 0;
}

/* The header s of a state block (block: its bytes, size of them; size 0: the size the
 * header declares, for a block this FMU made in memory): magic, GUID, interface, layout version, the plant's
 * length against this model's, the checksum, and every header value in its range. */
static int state_ok(instance* c, const char* fn, const fmu_state* s, const void* block, size_t size) {
  size_t n = plant_snapshot_min_size(c->plant);
  if (!s || memcmp(s->magic, STATE_MAGIC, 8) != 0) {
    logmsg(c, fmi2Error, LOG_ERROR, "%s: not an FMU state of %s", fn, FMU_MODEL.identifier);
    return 0;
  }
  if (memchr(s->guid, 0, sizeof s->guid) == NULL || strcmp(s->guid, FMU_MODEL.guid) != 0 ||
      s->type != (int32_t)c->type || s->version != STATE_VERSION || s->reserved != 0) {
    logmsg(c, fmi2Error, LOG_ERROR,
           "%s: FMU state of another model, interface or layout (GUID %.40s, type %d, layout %u; this instance: %s, "
           "%d, %u)",
           fn, s->guid, (int)s->type, (unsigned)s->version, FMU_MODEL.guid, (int)c->type, STATE_VERSION);
    return 0;
  }
  if (s->nplant < n || s->nplant > n + (1u << 24) || (size && size != state_bytes(s->nplant))) {
    logmsg(c, fmi2Error, LOG_ERROR, "%s: FMU state of %zu bytes declares %llu plant values (this model: %zu + the "
           "integrator's): it is truncated or damaged", fn, size ? size : state_bytes(s->nplant),
           (unsigned long long)s->nplant, n);
    return 0;
  }
  const uint64_t sum = state_checksum((const unsigned char*)block, state_bytes(s->nplant));
  if (sum != s->checksum) {
    logmsg(c, fmi2Error, LOG_ERROR, "%s: FMU state checksum %016llx does not match its content (%016llx): the block "
           "was damaged or edited", fn, (unsigned long long)s->checksum, (unsigned long long)sum);
    return 0;
  }
  const char* bad = NULL;
  if (!mode_ok(c->type, s->mode))
    bad = "state-machine state";
  else if (!isfinite(s->start_time) || !isfinite(s->stop_time) || !isfinite(s->last_successful_time))
    bad = "start, stop or last successful time (not finite)";
  else if ((s->stop_defined != 0 && s->stop_defined != 1) || (s->terminated != 0 && s->terminated != 1))
    bad = "stop-defined or terminated flag";
  else if (s->stop_defined && !(s->stop_time >= s->start_time))
    bad = "stop time (before the start time)";
  if (bad) {
    logmsg(c, fmi2Error, LOG_ERROR, "%s: FMU state has an invalid %s (mode %d, start %g s, stop %g s, last successful "
           "%g s)", fn, bad, (int)s->mode, s->start_time, s->stop_time, s->last_successful_time);
    return 0;
  }
  return 1;
}

fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate* FMUstate) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetFMUstate", S_ANY)) return fmi2Error;
  if (!FMUstate) return error(c, "fmi2GetFMUstate", "FMUstate pointer is NULL");
  size_t n = plant_snapshot_size(c->plant);
  fmu_state* s = (fmu_state*)*FMUstate;
  /* A state handed back for overwriting is reused; anything else gets a new block. */
  if (!s || memcmp(s->magic, STATE_MAGIC, 8) != 0 || s->nplant != n) {
    s = (fmu_state*)calloc(1, state_bytes(n));
    if (!s) return error(c, "fmi2GetFMUstate", "out of memory");
  }
  memcpy(s->magic, STATE_MAGIC, 8);
  memset(s->guid, 0, sizeof s->guid);
  strncpy(s->guid, FMU_MODEL.guid, sizeof s->guid - 1);
  s->type = (int32_t)c->type;
  s->mode = c->state;
  s->nplant = n;
  s->start_time = c->start_time;
  s->stop_time = c->stop_time;
  s->last_successful_time = c->last_successful_time;
  s->stop_defined = c->stop_defined;
  s->terminated = c->terminated;
  s->version = STATE_VERSION;
  s->reserved = 0;
  plant_snapshot_save(c->plant, s->plant);
  s->checksum = state_checksum((const unsigned char*)s, state_bytes(n));
  *FMUstate = s;
  return fmi2OK;
}

/* Is the restored instance one the state machine can go on from?  Past initialization
 * the plant must be started (its model validated, its state checked); a Co-Simulation
 * step's last successful time is the plant's time. */
static const char* restored_inconsistency(const instance* c) {
  const int running = c->state & (S_EVENT | S_CONT | S_STEP_COMPLETE | S_STEP_FAILED);
  if (running && plant_dirty(c->plant))
    return "its state-machine state is past initialization but the model was not started";
  if ((c->state & (S_STEP_COMPLETE | S_STEP_FAILED)) && c->last_successful_time != plant_time(c->plant))
    return "its last successful time differs from the model's time";
  return NULL;
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2SetFMUstate", S_ANY)) return fmi2Error;
  const fmu_state* s = (const fmu_state*)FMUstate;
  if (!state_ok(c, "fmi2SetFMUstate", s, s, 0)) return fmi2Error;
  if (plant_snapshot_check(c->plant, s->plant, s->nplant)) {
    logmsg(c, fmi2Error, LOG_ERROR, "fmi2SetFMUstate: %s; the instance keeps its previous state",
           plant_error(c->plant));
    return fmi2Error;
  }
  /* What the core refuses while loading leaves the instance as it was too: keep what it
   * has now to put back. */
  instance before = *c;
  const size_t nkeep = plant_snapshot_size(c->plant);
  double* keep = (double*)malloc(nkeep * sizeof(double));
  if (!keep) return error(c, "fmi2SetFMUstate", "out of memory");
  plant_snapshot_save(c->plant, keep);
  const char* why = NULL;
  char msg[2600];
  if (plant_snapshot_load(c->plant, s->plant, s->nplant)) {
    snprintf(msg, sizeof msg, "%s", plant_error(c->plant));
    why = msg;
  } else {
    c->start_time = s->start_time;
    c->stop_time = s->stop_time;
    c->last_successful_time = s->last_successful_time;
    c->stop_defined = s->stop_defined;
    c->terminated = s->terminated;
    c->state = s->mode;
    if ((why = restored_inconsistency(c)) != NULL) {
      snprintf(msg, sizeof msg, "FMU state refused: %s", why);
      why = msg;
    }
  }
  if (why) {
    const int restored = plant_snapshot_load(c->plant, keep, nkeep) == 0;
    free(keep);
    *c = before;
    if (!restored) return error(c, "fmi2SetFMUstate", "%s (and the previous state could not be put back)", why);
    logmsg(c, fmi2Error, LOG_ERROR, "fmi2SetFMUstate: %s; the instance keeps its previous state", why);
    return fmi2Error;
  }
  free(keep);
  return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate* FMUstate) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2FreeFMUstate", S_ANY)) return fmi2Error;
  if (FMUstate) {
    free(*FMUstate);
    *FMUstate = NULL;
  }
  return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate, size_t* size) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2SerializedFMUstateSize", S_ANY)) return fmi2Error;
  const fmu_state* s = (const fmu_state*)FMUstate;
  if (!size || !state_ok(c, "fmi2SerializedFMUstateSize", s, s, 0)) return fmi2Error;
  *size = state_bytes(s->nplant);
  return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate, fmi2Byte bytes[], size_t size) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2SerializeFMUstate", S_ANY)) return fmi2Error;
  const fmu_state* s = (const fmu_state*)FMUstate;
  if (!bytes || !state_ok(c, "fmi2SerializeFMUstate", s, s, 0)) return fmi2Error;
  if (size < state_bytes(s->nplant)) {
    logmsg(c, fmi2Error, LOG_ERROR, "fmi2SerializeFMUstate: buffer of %zu bytes, %zu needed", size,
           state_bytes(s->nplant));
    return fmi2Error;
  }
  memcpy(bytes, s, state_bytes(s->nplant));
  return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte bytes[], size_t size, fmi2FMUstate* FMUstate) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2DeSerializeFMUstate", S_ANY)) return fmi2Error;
  if (!bytes || !FMUstate || size < sizeof(fmu_state)) {
    logmsg(c, fmi2Error, LOG_ERROR, "fmi2DeSerializeFMUstate: %zu bytes are too few for an FMU state", size);
    return fmi2Error;
  }
  fmu_state head;
  memcpy(&head, bytes, sizeof head); /* bytes need not be aligned */
  if (!state_ok(c, "fmi2DeSerializeFMUstate", &head, bytes, size)) return fmi2Error;
  /* A state of ours handed back for overwriting is reused (same model: same size). */
  fmu_state* s = (fmu_state*)*FMUstate;
  if (!s || memcmp(s->magic, STATE_MAGIC, 8) != 0 || s->nplant != head.nplant) {
    s = (fmu_state*)malloc(size);
    if (!s) return error(c, "fmi2DeSerializeFMUstate", "out of memory");
  }
  memcpy(s, bytes, size);
  *FMUstate = s;
  return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
  instance* c = (instance*)comp;
  (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
  if (!c) return fmi2Error;
  logmsg(c, fmi2Error, LOG_ERROR, "fmi2GetDirectionalDerivative: not provided (providesDirectionalDerivative=false)");
  return fmi2Error;
}

/* ----------------------------------------------------------- Model Exchange */

fmi2Status fmi2EnterEventMode(fmi2Component comp) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2EnterEventMode", S_EVENT | S_CONT)) return fmi2Error;
  c->state = S_EVENT;
  return fmi2OK;
}

/* Where a state event lands, the indicator is zero up to the importer's root finding. */
#define LIMIT_TOL 1e-9

/* In Model Exchange the importer owns time: at the edge of the usable workspace the
 * FMU can only ask it to stop (terminateSimulation), saying why, where and when. */
static int reached_limit(instance* c, const char* fn) {
  if (!plant_check_limits(c->plant, LIMIT_TOL)) return 0;
  c->terminated = 1;
  c->last_successful_time = plant_time(c->plant);
  logmsg(c, fmi2Warning, LOG_WARNING, "%s: stopping the simulation: %s", fn, plant_error(c->plant));
  return 1;
}

fmi2Status fmi2NewDiscreteStates(fmi2Component comp, fmi2EventInfo* info) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2NewDiscreteStates", S_EVENT)) return fmi2Error;
  if (!info) return error(c, "fmi2NewDiscreteStates", "eventInfo is NULL");
  /* The plant has no discrete states and no time events; a state event is a limit. */
  int stop = c->terminated || reached_limit(c, "fmi2NewDiscreteStates");
  info->newDiscreteStatesNeeded = fmi2False;
  info->terminateSimulation = stop ? fmi2True : fmi2False;
  info->nominalsOfContinuousStatesChanged = fmi2False;
  info->valuesOfContinuousStatesChanged = fmi2False;
  info->nextEventTimeDefined = fmi2False;
  info->nextEventTime = 0;
  return stop ? fmi2Warning : fmi2OK;
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component comp) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2EnterContinuousTimeMode", S_EVENT)) return fmi2Error;
  c->state = S_CONT;
  return fmi2OK;
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component comp, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean* enterEventMode, fmi2Boolean* terminateSimulation) {
  instance* c = (instance*)comp;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (bad_call(c, "fmi2CompletedIntegratorStep", S_CONT)) return fmi2Error;
  if (!enterEventMode || !terminateSimulation)
    return error(c, "fmi2CompletedIntegratorStep", "NULL output argument");
  *enterEventMode = fmi2False;
  /* Also catches an importer that steps past a limit without locating the event. */
  int stop = reached_limit(c, "fmi2CompletedIntegratorStep");
  *terminateSimulation = stop ? fmi2True : fmi2False;
  if (!stop) c->last_successful_time = plant_time(c->plant);
  return stop ? fmi2Warning : fmi2OK;
}

fmi2Status fmi2SetTime(fmi2Component comp, fmi2Real time) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2SetTime", S_EVENT | S_CONT)) return fmi2Error;
  if (!isfinite(time)) return error(c, "fmi2SetTime", "time %g is not finite", time);
  plant_set_time(c->plant, time);
  return fmi2OK;
}

fmi2Status fmi2SetContinuousStates(fmi2Component comp, const fmi2Real x[], size_t nx) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2SetContinuousStates", S_CONT)) return fmi2Error;
  if (!x) return error(c, "fmi2SetContinuousStates", "x is NULL");
  if (plant_set_states(c->plant, x, nx)) return error(c, "fmi2SetContinuousStates", "%s", plant_error(c->plant));
  return fmi2OK;
}

#define S_ME_VALUES (S_INIT | S_EVENT | S_CONT | S_TERMINATED | S_ERROR)


fmi2Status fmi2GetDerivatives(fmi2Component comp, fmi2Real derivatives[], size_t nx) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetDerivatives", S_ME_VALUES)) return fmi2Error;
  if (!derivatives) return error(c, "fmi2GetDerivatives", "derivatives is NULL");
  if (c->state == S_INIT && ensure_started(c, "fmi2GetDerivatives") != fmi2OK) return fmi2Error;
  int s = plant_get_derivatives(c->plant, derivatives, nx);
  if (s == PKM_OK) return finite_or_error(c, "fmi2GetDerivatives", "derivative", derivatives, nx);
  if (s == PKM_ERR_ARGUMENT || s == PKM_ERR_PARAMETER || s == PKM_ERR_INTERNAL)
    return error(c, "fmi2GetDerivatives", "%s", plant_error(c->plant));
  /* A singular pose: the solver may retry with a smaller step, or stop. */
  logmsg(c, fmi2Discard, LOG_DISCARD, "fmi2GetDerivatives: %s", plant_error(c->plant));
  return fmi2Discard;
}

fmi2Status fmi2GetEventIndicators(fmi2Component comp, fmi2Real eventIndicators[], size_t ni) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetEventIndicators", S_ME_VALUES)) return fmi2Error;
  if (!eventIndicators && ni > 0) return error(c, "fmi2GetEventIndicators", "eventIndicators is NULL");
  if (c->state == S_INIT && ensure_started(c, "fmi2GetEventIndicators") != fmi2OK) return fmi2Error;
  int s = plant_get_indicators(c->plant, eventIndicators, ni);
  if (s == PKM_OK) return finite_or_error(c, "fmi2GetEventIndicators", "event indicator", eventIndicators, ni);
  if (s == PKM_ERR_ARGUMENT || s == PKM_ERR_PARAMETER || s == PKM_ERR_INTERNAL)
    return error(c, "fmi2GetEventIndicators", "%s", plant_error(c->plant));
  logmsg(c, fmi2Discard, LOG_DISCARD, "fmi2GetEventIndicators: %s", plant_error(c->plant));
  return fmi2Discard;
}

fmi2Status fmi2GetContinuousStates(fmi2Component comp, fmi2Real x[], size_t nx) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetContinuousStates", S_ME_VALUES)) return fmi2Error;
  if (!x) return error(c, "fmi2GetContinuousStates", "x is NULL");
  if (c->state == S_INIT && ensure_started(c, "fmi2GetContinuousStates") != fmi2OK) return fmi2Error;
  if (plant_get_states(c->plant, x, nx))
    return error(c, "fmi2GetContinuousStates", "%zu states asked for, the model has %d", nx,
                 plant_nstates(c->plant));
  return finite_or_error(c, "fmi2GetContinuousStates", "continuous state", x, nx);
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component comp, fmi2Real x_nominal[], size_t nx) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetNominalsOfContinuousStates", S_INSTANTIATED | S_ME_VALUES)) return fmi2Error;
  if (!x_nominal || nx != (size_t)plant_nstates(c->plant))
    return error(c, "fmi2GetNominalsOfContinuousStates", "%zu nominals asked for, the model has %d states", nx,
                 plant_nstates(c->plant));
  for (size_t i = 0; i < nx; ++i) x_nominal[i] = 1.0;
  return fmi2OK;
}

/* -------------------------------------------------------------- Co-Simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  instance* c = (instance*)comp;
  (void)vr, (void)nvr, (void)order, (void)value;
  if (!c) return fmi2Error;
  return error(c, "fmi2SetRealInputDerivatives", "not provided (canInterpolateInputs=false)");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
  instance* c = (instance*)comp;
  (void)vr, (void)nvr, (void)order, (void)value;
  if (!c) return fmi2Error;
  return error(c, "fmi2GetRealOutputDerivatives", "not provided (maxOutputDerivativeOrder=0)");
}

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  instance* c = (instance*)comp;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (bad_call(c, "fmi2DoStep", S_STEP_COMPLETE)) return fmi2Error;
  double now = plant_time(c->plant);
  if (!isfinite(t) || !isfinite(h) || h < 0)
    return error(c, "fmi2DoStep", "communication point %g and step %g: need finite values and step >= 0", t, h);
  /* The importer keeps its own clock; accept its rounding, not a jump. */
  if (fabs(t - now) > 1e-9 * (1.0 + fabs(now)))
    return error(c, "fmi2DoStep", "communication point t = %.17g s differs from the FMU time %.17g s", t, now);
  double t_end = t + h;
  if (c->stop_defined && t_end > c->stop_time * (1 + 1e-12) + 1e-12)
    return error(c, "fmi2DoStep", "step to t = %.17g s goes past the stop time %.17g s", t_end, c->stop_time);
  if (h == 0) return fmi2OK;
  int s = plant_step(c->plant, t_end);
  if (s == PKM_OK) {
    c->last_successful_time = t_end;
    return fmi2OK;
  }
  if (s == PKM_ERR_SINGULAR || s == PKM_ERR_JOINT_LIMIT || s == PKM_ERR_UNREACHABLE || s == PKM_ERR_STEP_BUDGET) {
    /* The plant stopped at the event (or where its step budget ran out): the state there
     * is consistent and readable. */
    c->last_successful_time = plant_time(c->plant);
    c->terminated = 1;
    c->state = S_STEP_FAILED;
    logmsg(c, fmi2Discard, LOG_DISCARD, "fmi2DoStep from t = %.9g s to %.9g s: %s", t, t_end,
           plant_error(c->plant));
    return fmi2Discard;
  }
  return error(c, "fmi2DoStep", "from t = %.9g s to %.9g s: %s", t, t_end, plant_error(c->plant));
}

fmi2Status fmi2CancelStep(fmi2Component comp) {
  instance* c = (instance*)comp;
  if (!c) return fmi2Error;
  return error(c, "fmi2CancelStep", "fmi2DoStep never returns fmi2Pending in this FMU");
}

#define S_STATUS (S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED)

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status* value) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetStatus", S_STATUS)) return fmi2Error;
  if (s != fmi2DoStepStatus || !value) {
    logmsg(c, fmi2Error, LOG_ERROR, "fmi2GetStatus: status kind %d is not provided", (int)s);
    return fmi2Error;
  }
  *value = c->state == S_STEP_FAILED ? fmi2Discard : fmi2OK;
  return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real* value) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetRealStatus", S_STATUS)) return fmi2Error;
  if (s != fmi2LastSuccessfulTime || !value) {
    logmsg(c, fmi2Error, LOG_ERROR, "fmi2GetRealStatus: status kind %d is not provided", (int)s);
    return fmi2Error;
  }
  *value = c->last_successful_time;
  return finite_or_error(c, "fmi2GetRealStatus", "last successful time", value, 1);
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer* value) {
  instance* c = (instance*)comp;
  (void)value;
  if (bad_call(c, "fmi2GetIntegerStatus", S_STATUS)) return fmi2Error;
  logmsg(c, fmi2Error, LOG_ERROR, "fmi2GetIntegerStatus: status kind %d is not provided", (int)s);
  return fmi2Error;
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean* value) {
  instance* c = (instance*)comp;
  if (bad_call(c, "fmi2GetBooleanStatus", S_STATUS)) return fmi2Error;
  if (s != fmi2Terminated || !value) {
    logmsg(c, fmi2Error, LOG_ERROR, "fmi2GetBooleanStatus: status kind %d is not provided", (int)s);
    return fmi2Error;
  }
  *value = c->terminated ? fmi2True : fmi2False;
  return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String* value) {
  instance* c = (instance*)comp;
  (void)value;
  if (bad_call(c, "fmi2GetStringStatus", S_STATUS)) return fmi2Error;
  logmsg(c, fmi2Error, LOG_ERROR, "fmi2GetStringStatus: status kind %d is not provided", (int)s);
  return fmi2Error;
}
