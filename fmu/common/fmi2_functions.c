/*
 * fmi2_functions.c -- the FMI 2.0 functions (Model Exchange and Co-Simulation), written
 * once for every PKM FMU.  A model folder supplies FMU_MODEL (its generated variable
 * table); the physics is in the model (robot.c, or controller.c for a controller FMU), which calls the reference core.
 *
 * What FMI 2.0 and FMI 3.0 share (the state machine, the checks, the messages, the FMU
 * state, the steps) is fmu_instance.c; this file translates the FMI 2.0 signatures and
 * adds what only FMI 2.0 has (fmi2SetupExperiment, fmi2EventInfo, the status getters).
 */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "fmu_instance.h"

typedef struct instance {
  fmu_instance base;        /* first: an instance is an fmu_instance                       */
  fmi2CallbackFunctions cb; /* copied: the importer's struct need not outlive the call    */
} instance;

#define BASE(comp) ((fmu_instance*)(comp))
#define STATUS(s) ((fmi2Status)(s))
#define STATE_MAGIC "PKMFMU2S"

/* The FMI 2.0 logger treats the message as a printf format: '%' is protected. */
static void emit(const fmu_instance* base, fmu_status st, const char* category, const char* msg) {
  const instance* c = (const instance*)base;
  if (!c->cb.logger) return;
  char esc[8192];
  size_t j = 0;
  for (size_t i = 0; msg[i] && j + 2 < sizeof esc; ++i) {
    if (msg[i] == '%') esc[j++] = '%';
    esc[j++] = msg[i];
  }
  esc[j] = '\0';
  c->cb.logger(c->cb.componentEnvironment, c->base.name, (fmi2Status)st, category, esc);
}

/* ---------------------------------------------------------- common functions */

const char* fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char* fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component comp, fmi2Boolean loggingOn, size_t n, const fmi2String cats[]) {
  return STATUS(fmu_set_debug_logging(BASE(comp), "fmi2SetDebugLogging", loggingOn, n, cats));
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation, const fmi2CallbackFunctions* functions,
                              fmi2Boolean visible, fmi2Boolean loggingOn) {
  (void)fmuResourceLocation;
  (void)visible;
  instance head;
  memset(&head, 0, sizeof head);
  if (functions) head.cb = *functions;
  head.base.emit = emit;
  head.base.token = FMU_MODEL.guid;
  if (fmuType != fmi2ModelExchange && fmuType != fmi2CoSimulation) {
    head.base.name = (char*)(instanceName ? instanceName : "?");
    fmu_log(&head.base, FMU_ERROR, LOG_ERROR, "fmi2Instantiate: unknown FMU type %d", (int)fmuType);
    return NULL;
  }
  fmu_instance* c = fmu_instantiate("fmi2Instantiate", &head.base, sizeof head, instanceName, fmuGUID, "GUID",
                                    fmuType == fmi2CoSimulation);
  if (c) c->log_mask = loggingOn ? ~0u : 0u;
  return c;
}

void fmi2FreeInstance(fmi2Component comp) { fmu_free(BASE(comp)); }

fmi2Status fmi2SetupExperiment(fmi2Component comp, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime) {
  fmu_instance* c = BASE(comp);
  if (fmu_bad_call(c, "fmi2SetupExperiment", S_INSTANTIATED)) return fmi2Error;
  return STATUS(fmu_setup(c, "fmi2SetupExperiment", toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime));
}

fmi2Status fmi2EnterInitializationMode(fmi2Component comp) {
  fmu_instance* c = BASE(comp);
  if (fmu_bad_call(c, "fmi2EnterInitializationMode", S_INSTANTIATED)) return fmi2Error;
  c->state = S_INIT;
  return fmi2OK;
}

fmi2Status fmi2ExitInitializationMode(fmi2Component comp) {
  return STATUS(fmu_exit_initialization(BASE(comp), "fmi2ExitInitializationMode"));
}

fmi2Status fmi2Terminate(fmi2Component comp) { return STATUS(fmu_terminate(BASE(comp), "fmi2Terminate")); }

fmi2Status fmi2Reset(fmi2Component comp) { return STATUS(fmu_reset(BASE(comp), "fmi2Reset")); }

/* ------------------------------------------------------------- get / set */

fmi2Status fmi2GetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Real value[]) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi2GetReal";
  if (fmu_bad_call(c, fn, S_INSTANTIATED | S_HAS_VALUES)) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return STATUS(fmu_error(c, fn, "NULL array for %zu values", nvr));
  for (size_t i = 0; i < nvr; ++i) {
    const fmu_var* v = fmu_lookup(c, fn, vr[i], FMU_REAL, "Real");
    if (!v || fmu_get_real(c, fn, v, &value[i]) != FMU_OK) return fmi2Error;
  }
  return fmi2OK;
}

fmi2Status fmi2GetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Integer value[]) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi2GetInteger";
  if (fmu_bad_call(c, fn, S_INSTANTIATED | S_HAS_VALUES)) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return STATUS(fmu_error(c, fn, "NULL array for %zu values", nvr));
  for (size_t i = 0; i < nvr; ++i) {
    const fmu_var* v = fmu_lookup(c, fn, vr[i], FMU_INTEGER, "Integer");
    int x = 0;
    if (!v || fmu_get_integer(c, fn, v, &x) != FMU_OK) return fmi2Error;
    value[i] = x;
  }
  return fmi2OK;
}

/* This FMU has no Boolean and no String variables: a call naming one is an error. */
static fmi2Status none_of_type(fmi2Component comp, const char* fn, int allowed, const fmi2ValueReference vr[],
                               size_t nvr, const char* type) {
  fmu_instance* c = BASE(comp);
  if (fmu_bad_call(c, fn, allowed)) return fmi2Error;
  if (nvr == 0) return fmi2OK;
  fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: value reference %u: this FMU has no %s variables", fn, vr ? vr[0] : 0u, type);
  return fmi2Error;
}

fmi2Status fmi2GetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2Boolean value[]) {
  (void)value;
  return none_of_type(comp, "fmi2GetBoolean", S_INSTANTIATED | S_HAS_VALUES, vr, nvr, "Boolean");
}

fmi2Status fmi2GetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, fmi2String value[]) {
  (void)value;
  return none_of_type(comp, "fmi2GetString", S_INSTANTIATED | S_HAS_VALUES, vr, nvr, "String");
}

fmi2Status fmi2SetReal(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Real value[]) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi2SetReal";
  if (fmu_bad_call(c, fn, S_SETTABLE)) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return STATUS(fmu_error(c, fn, "NULL array for %zu values", nvr));
  for (size_t i = 0; i < nvr; ++i) {
    const fmu_var* v = fmu_lookup(c, fn, vr[i], FMU_REAL, "Real");
    if (!v || fmu_set_real(c, fn, v, value[i]) != FMU_OK) return fmi2Error;
  }
  return fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Integer value[]) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi2SetInteger";
  if (fmu_bad_call(c, fn, S_SETTABLE)) return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return STATUS(fmu_error(c, fn, "NULL array for %zu values", nvr));
  for (size_t i = 0; i < nvr; ++i) {
    const fmu_var* v = fmu_lookup(c, fn, vr[i], FMU_INTEGER, "Integer");
    if (!v || fmu_set_integer(c, fn, v, value[i]) != FMU_OK) return fmi2Error;
  }
  return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2Boolean value[]) {
  (void)value;
  return none_of_type(comp, "fmi2SetBoolean", S_SETTABLE, vr, nvr, "Boolean");
}

fmi2Status fmi2SetString(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr, const fmi2String value[]) {
  (void)value;
  return none_of_type(comp, "fmi2SetString", S_SETTABLE, vr, nvr, "String");
}

/* ---------------------------------------------------------------- FMU state */

fmi2Status fmi2GetFMUstate(fmi2Component comp, fmi2FMUstate* FMUstate) {
  return STATUS(fmu_state_get(BASE(comp), "fmi2GetFMUstate", STATE_MAGIC, FMUstate));
}

fmi2Status fmi2SetFMUstate(fmi2Component comp, fmi2FMUstate FMUstate) {
  return STATUS(fmu_state_set(BASE(comp), "fmi2SetFMUstate", STATE_MAGIC, FMUstate));
}

fmi2Status fmi2FreeFMUstate(fmi2Component comp, fmi2FMUstate* FMUstate) {
  return STATUS(fmu_state_free(BASE(comp), "fmi2FreeFMUstate", FMUstate));
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component comp, fmi2FMUstate FMUstate, size_t* size) {
  return STATUS(fmu_state_size(BASE(comp), "fmi2SerializedFMUstateSize", STATE_MAGIC, FMUstate, size));
}

fmi2Status fmi2SerializeFMUstate(fmi2Component comp, fmi2FMUstate FMUstate, fmi2Byte bytes[], size_t size) {
  return STATUS(
      fmu_state_serialize(BASE(comp), "fmi2SerializeFMUstate", STATE_MAGIC, FMUstate, (unsigned char*)bytes, size));
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component comp, const fmi2Byte bytes[], size_t size, fmi2FMUstate* FMUstate) {
  return STATUS(fmu_state_deserialize(BASE(comp), "fmi2DeSerializeFMUstate", STATE_MAGIC,
                                      (const unsigned char*)bytes, size, FMUstate));
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component comp, const fmi2ValueReference vUnknown_ref[], size_t nUnknown,
                                        const fmi2ValueReference vKnown_ref[], size_t nKnown,
                                        const fmi2Real dvKnown[], fmi2Real dvUnknown[]) {
  (void)vUnknown_ref, (void)nUnknown, (void)vKnown_ref, (void)nKnown, (void)dvKnown, (void)dvUnknown;
  if (!comp) return fmi2Error;
  fmu_log(BASE(comp), FMU_ERROR, LOG_ERROR,
          "fmi2GetDirectionalDerivative: not provided (providesDirectionalDerivative=false)");
  return fmi2Error;
}

/* ----------------------------------------------------------- Model Exchange */

fmi2Status fmi2EnterEventMode(fmi2Component comp) {
  return STATUS(fmu_enter_event_mode(BASE(comp), "fmi2EnterEventMode"));
}

fmi2Status fmi2NewDiscreteStates(fmi2Component comp, fmi2EventInfo* info) {
  fmu_instance* c = BASE(comp);
  if (c && !info) {
    if (fmu_bad_call(c, "fmi2NewDiscreteStates", S_EVENT)) return fmi2Error;
    return STATUS(fmu_error(c, "fmi2NewDiscreteStates", "eventInfo is NULL"));
  }
  int stop = 0;
  fmu_status st = fmu_update_discrete_states(c, "fmi2NewDiscreteStates", &stop);
  if (st == FMU_ERROR) return fmi2Error;
  info->newDiscreteStatesNeeded = fmi2False;
  info->terminateSimulation = stop ? fmi2True : fmi2False;
  info->nominalsOfContinuousStatesChanged = fmi2False;
  info->valuesOfContinuousStatesChanged = fmi2False;
  info->nextEventTimeDefined = fmi2False;
  info->nextEventTime = 0;
  return STATUS(st);
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component comp) {
  return STATUS(fmu_enter_continuous_time_mode(BASE(comp), "fmi2EnterContinuousTimeMode"));
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component comp, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean* enterEventMode, fmi2Boolean* terminateSimulation) {
  (void)noSetFMUStatePriorToCurrentPoint;
  int enter = 0, stop = 0;
  fmu_status st = fmu_completed_integrator_step(BASE(comp), "fmi2CompletedIntegratorStep",
                                                enterEventMode ? &enter : NULL, terminateSimulation ? &stop : NULL);
  if (st == FMU_ERROR) return fmi2Error;
  *enterEventMode = enter ? fmi2True : fmi2False;
  *terminateSimulation = stop ? fmi2True : fmi2False;
  return STATUS(st);
}

fmi2Status fmi2SetTime(fmi2Component comp, fmi2Real time) {
  return STATUS(fmu_set_time(BASE(comp), "fmi2SetTime", time));
}

fmi2Status fmi2SetContinuousStates(fmi2Component comp, const fmi2Real x[], size_t nx) {
  return STATUS(fmu_set_states(BASE(comp), "fmi2SetContinuousStates", x, nx));
}

fmi2Status fmi2GetDerivatives(fmi2Component comp, fmi2Real derivatives[], size_t nx) {
  return STATUS(fmu_get_derivatives(BASE(comp), "fmi2GetDerivatives", derivatives, nx));
}

fmi2Status fmi2GetEventIndicators(fmi2Component comp, fmi2Real eventIndicators[], size_t ni) {
  return STATUS(fmu_get_indicators(BASE(comp), "fmi2GetEventIndicators", eventIndicators, ni));
}

fmi2Status fmi2GetContinuousStates(fmi2Component comp, fmi2Real x[], size_t nx) {
  return STATUS(fmu_get_states(BASE(comp), "fmi2GetContinuousStates", x, nx));
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component comp, fmi2Real x_nominal[], size_t nx) {
  return STATUS(fmu_get_nominals(BASE(comp), "fmi2GetNominalsOfContinuousStates", x_nominal, nx));
}

/* -------------------------------------------------------------- Co-Simulation */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[]) {
  (void)vr, (void)nvr, (void)order, (void)value;
  if (!comp) return fmi2Error;
  return STATUS(fmu_error(BASE(comp), "fmi2SetRealInputDerivatives", "not provided (canInterpolateInputs=false)"));
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component comp, const fmi2ValueReference vr[], size_t nvr,
                                        const fmi2Integer order[], fmi2Real value[]) {
  (void)vr, (void)nvr, (void)order, (void)value;
  if (!comp) return fmi2Error;
  return STATUS(fmu_error(BASE(comp), "fmi2GetRealOutputDerivatives", "not provided (maxOutputDerivativeOrder=0)"));
}

fmi2Status fmi2DoStep(fmi2Component comp, fmi2Real t, fmi2Real h, fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  (void)noSetFMUStatePriorToCurrentPoint;
  return STATUS(fmu_do_step(BASE(comp), "fmi2DoStep", t, h));
}

fmi2Status fmi2CancelStep(fmi2Component comp) {
  if (!comp) return fmi2Error;
  return STATUS(fmu_error(BASE(comp), "fmi2CancelStep", "fmi2DoStep never returns fmi2Pending in this FMU"));
}

#define S_STATUS (S_STEP_COMPLETE | S_STEP_FAILED | S_TERMINATED)

/* A status kind this FMU does not report. */
static fmi2Status no_status(fmi2Component comp, const char* fn, fmi2StatusKind s) {
  fmu_instance* c = BASE(comp);
  if (fmu_bad_call(c, fn, S_STATUS)) return fmi2Error;
  fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: status kind %d is not provided", fn, (int)s);
  return fmi2Error;
}

fmi2Status fmi2GetStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Status* value) {
  fmu_instance* c = BASE(comp);
  if (s != fmi2DoStepStatus || !value) return no_status(comp, "fmi2GetStatus", s);
  if (fmu_bad_call(c, "fmi2GetStatus", S_STATUS)) return fmi2Error;
  *value = c->state == S_STEP_FAILED ? fmi2Discard : fmi2OK;
  return fmi2OK;
}

fmi2Status fmi2GetRealStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Real* value) {
  fmu_instance* c = BASE(comp);
  if (s != fmi2LastSuccessfulTime || !value) return no_status(comp, "fmi2GetRealStatus", s);
  if (fmu_bad_call(c, "fmi2GetRealStatus", S_STATUS)) return fmi2Error;
  *value = c->last_successful_time;
  return STATUS(fmu_finite_or_error(c, "fmi2GetRealStatus", "last successful time", value, 1));
}

fmi2Status fmi2GetIntegerStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Integer* value) {
  (void)value;
  return no_status(comp, "fmi2GetIntegerStatus", s);
}

fmi2Status fmi2GetBooleanStatus(fmi2Component comp, const fmi2StatusKind s, fmi2Boolean* value) {
  fmu_instance* c = BASE(comp);
  if (s != fmi2Terminated || !value) return no_status(comp, "fmi2GetBooleanStatus", s);
  if (fmu_bad_call(c, "fmi2GetBooleanStatus", S_STATUS)) return fmi2Error;
  *value = c->terminated ? fmi2True : fmi2False;
  return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component comp, const fmi2StatusKind s, fmi2String* value) {
  (void)value;
  return no_status(comp, "fmi2GetStringStatus", s);
}
