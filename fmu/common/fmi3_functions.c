/*
 * fmi3_functions.c -- the FMI 3.0 functions (Model Exchange and Co-Simulation), written
 * once for every PKM FMU, over the same instance (fmu_instance.c) and model hooks as
 * the FMI 2.0 functions: the two interfaces refuse the same things with the same
 * messages and run the same model.
 *
 * What FMI 3.0 adds is translated here: array variables (an FMI 3.0 value reference
 * stands for consecutive rows of the generated table, fmu_vars3.h), time and the event
 * indicators as variables, the experiment given to fmi3EnterInitializationMode, the
 * results of fmi3DoStep and fmi3UpdateDiscreteStates as output arguments.  The
 * Co-Simulation interface has no event mode (hasEventMode="false"): a step that meets a
 * stroke limit or a singularity ends there, the FMI 3.0 way of a model that cannot go on
 * (FMI 3.0, 4.2.1 fmi3DoStep, and its example of a stop time the FMU cannot pass): OK with
 * terminateSimulation, lastSuccessfulTime the time of the stop, and earlyReturn where the
 * importer allowed an early return at instantiation (mightReturnEarlyFromDoStep="true";
 * otherwise false: the importer stops on terminateSimulation alone).  A step that runs out
 * of its wall-time budget is still Discarded (a shorter step may pass).  Scheduled
 * Execution, clocks, and the types this FMU has no variable of are refused.
 */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fmu_instance.h"
#include "fmu_vars3.h"

typedef struct instance {
  fmu_instance base;           /* first: an instance is an fmu_instance      */
  fmi3InstanceEnvironment env; /* the importer's, handed back to its logger */
  fmi3LogMessageCallback log;
  fmi3Boolean early_return_allowed; /* fmi3InstantiateCoSimulation's earlyReturnAllowed */
} instance;

#define BASE(comp) ((fmu_instance*)(comp))
#define STATUS(s) ((fmi3Status)(s))
#define STATE_MAGIC "PKMFMU3S"

static void emit(const fmu_instance* base, fmu_status st, const char* category, const char* msg) {
  const instance* c = (const instance*)base;
  if (c->log) c->log(c->env, (fmi3Status)st, category, msg);
}

/* ---------------------------------------------------------- common functions */

const char* fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance comp, fmi3Boolean loggingOn, size_t n, const fmi3String cats[]) {
  return STATUS(fmu_set_debug_logging(BASE(comp), "fmi3SetDebugLogging", loggingOn, n, cats));
}

static fmi3Instance instantiate(const char* fn, fmi3String name, fmi3String token, int cosimulation,
                                fmi3Boolean loggingOn, fmi3InstanceEnvironment env, fmi3LogMessageCallback log) {
  instance head;
  memset(&head, 0, sizeof head);
  head.env = env;
  head.log = log;
  head.base.emit = emit;
  head.base.token = FMU3_TOKEN;
  fmu_instance* c = fmu_instantiate(fn, &head.base, sizeof head, name, token, "instantiation token", cosimulation);
  if (c) c->log_mask = loggingOn ? ~0u : 0u;
  return c;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage) {
  (void)resourcePath, (void)visible;
  if (FMU_MODEL.lti_states > 0 || FMU_MODEL.nindicators == 0) {
    if (logMessage)
      logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                 "fmi3InstantiateModelExchange: a controller FMU is Co-Simulation only");
    return NULL;
  }
  return instantiate("fmi3InstantiateModelExchange", instanceName, instantiationToken, 0, loggingOn,
                     instanceEnvironment, logMessage);
}

fmi3Instance fmi3InstantiateCoSimulation(fmi3String instanceName, fmi3String instantiationToken,
                                         fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                         fmi3Boolean eventModeUsed, fmi3Boolean earlyReturnAllowed,
                                         const fmi3ValueReference requiredIntermediateVariables[],
                                         size_t nRequiredIntermediateVariables,
                                         fmi3InstanceEnvironment instanceEnvironment,
                                         fmi3LogMessageCallback logMessage,
                                         fmi3IntermediateUpdateCallback intermediateUpdate) {
  (void)resourcePath, (void)visible, (void)requiredIntermediateVariables;
  (void)intermediateUpdate;
  if (eventModeUsed || nRequiredIntermediateVariables > 0) {
    if (logMessage)
      logMessage(instanceEnvironment, fmi3Error, "logStatusError",
                 "fmi3InstantiateCoSimulation: this FMU has no event mode and no intermediate update in "
                 "Co-Simulation (hasEventMode=\"false\", providesIntermediateUpdate=\"false\")");
    return NULL;
  }
  instance* c = (instance*)instantiate("fmi3InstantiateCoSimulation", instanceName, instantiationToken, 1, loggingOn,
                                       instanceEnvironment, logMessage);
  if (c) c->early_return_allowed = earlyReturnAllowed ? fmi3True : fmi3False;
  return c;
}

fmi3Instance fmi3InstantiateScheduledExecution(fmi3String instanceName, fmi3String instantiationToken,
                                               fmi3String resourcePath, fmi3Boolean visible, fmi3Boolean loggingOn,
                                               fmi3InstanceEnvironment instanceEnvironment,
                                               fmi3LogMessageCallback logMessage,
                                               fmi3ClockUpdateCallback clockUpdate,
                                               fmi3LockPreemptionCallback lockPreemption,
                                               fmi3UnlockPreemptionCallback unlockPreemption) {
  (void)instanceName, (void)instantiationToken, (void)resourcePath, (void)visible, (void)loggingOn;
  (void)clockUpdate, (void)lockPreemption, (void)unlockPreemption;
  if (logMessage)
    logMessage(instanceEnvironment, fmi3Error, "logStatusError",
               "fmi3InstantiateScheduledExecution: this FMU provides Model Exchange and Co-Simulation only");
  return NULL;
}

void fmi3FreeInstance(fmi3Instance comp) { fmu_free(BASE(comp)); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance comp, fmi3Boolean toleranceDefined, fmi3Float64 tolerance,
                                       fmi3Float64 startTime, fmi3Boolean stopTimeDefined, fmi3Float64 stopTime) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi3EnterInitializationMode";
  if (fmu_bad_call(c, fn, S_INSTANTIATED)) return fmi3Error;
  if (fmu_setup(c, fn, toleranceDefined, tolerance, startTime, stopTimeDefined, stopTime) != FMU_OK)
    return fmi3Error;
  c->state = S_INIT;
  return fmi3OK;
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance comp) {
  return STATUS(fmu_exit_initialization(BASE(comp), "fmi3ExitInitializationMode"));
}

fmi3Status fmi3EnterEventMode(fmi3Instance comp) {
  return STATUS(fmu_enter_event_mode(BASE(comp), "fmi3EnterEventMode"));
}

fmi3Status fmi3Terminate(fmi3Instance comp) { return STATUS(fmu_terminate(BASE(comp), "fmi3Terminate")); }

fmi3Status fmi3Reset(fmi3Instance comp) { return STATUS(fmu_reset(BASE(comp), "fmi3Reset")); }

/* ------------------------------------------------------------- get / set */

/* The FMI 3.0 variable vr of the given type, or NULL after logging why. */
static const fmu3_var* lookup3(fmu_instance* c, const char* fn, fmi3ValueReference vr, fmu_type type) {
  if (vr >= FMU3_NVARS) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: unknown value reference %u (0..%d)", fn, vr, FMU3_NVARS - 1);
    return NULL;
  }
  const fmu3_var* v = &FMU3_VARS[vr];
  if (v->type != type) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: value reference %u (%s) is not a%s", fn, vr, v->name,
            type == FMU_REAL ? " Float64" : "n Int32");
    return NULL;
  }
  return v;
}

/* The number of values of the nvr variables (each an array or a scalar) must be nValues:
 * checked before any value is read or written. */
static int count_values(fmu_instance* c, const char* fn, const fmi3ValueReference vr[], size_t nvr, const void* values,
                        size_t nValues, fmu_type type) {
  if (nvr > 0 && (!vr || !values)) {
    fmu_error(c, fn, "NULL array for %zu variables", nvr);
    return 0;
  }
  size_t n = 0;
  for (size_t i = 0; i < nvr; ++i) {
    const fmu3_var* v = lookup3(c, fn, vr[i], type);
    if (!v) return 0;
    n += (size_t)v->count;
  }
  if (n != nValues) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: the %zu variables have %zu values, nValues is %zu", fn, nvr, n, nValues);
    return 0;
  }
  return 1;
}

fmi3Status fmi3GetFloat64(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 values[],
                          size_t nValues) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi3GetFloat64";
  if (fmu_bad_call(c, fn, S_INSTANTIATED | S_HAS_VALUES)) return fmi3Error;
  if (!count_values(c, fn, vr, nvr, values, nValues, FMU_REAL)) return fmi3Error;
  size_t at = 0;
  for (size_t i = 0; i < nvr; ++i) {
    const fmu3_var* v = &FMU3_VARS[vr[i]];
    if (v->kind == FMU3_TIME) {
      values[at] = fmu_model_time(c->model);
      if (fmu_finite_or_error(c, fn, "time", &values[at], 1) != FMU_OK) return fmi3Error;
    } else if (v->kind == FMU3_INDICATORS) {
      fmu_status s = fmu_get_indicators(c, fn, &values[at], (size_t)v->count);
      if (s != FMU_OK) return STATUS(s);
    } else {
      for (int k = 0; k < v->count; ++k)
        if (fmu_get_real(c, fn, &FMU_MODEL.vars[v->row + k], &values[at + (size_t)k]) != FMU_OK) return fmi3Error;
    }
    at += (size_t)v->count;
  }
  return fmi3OK;
}

fmi3Status fmi3GetInt32(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, fmi3Int32 values[],
                        size_t nValues) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi3GetInt32";
  if (fmu_bad_call(c, fn, S_INSTANTIATED | S_HAS_VALUES)) return fmi3Error;
  if (!count_values(c, fn, vr, nvr, values, nValues, FMU_INTEGER)) return fmi3Error;
  size_t at = 0;
  for (size_t i = 0; i < nvr; ++i) {
    const fmu3_var* v = &FMU3_VARS[vr[i]];
    for (int k = 0; k < v->count; ++k) {
      int x = 0;
      if (fmu_get_integer(c, fn, &FMU_MODEL.vars[v->row + k], &x) != FMU_OK) return fmi3Error;
      values[at++] = x;
    }
  }
  return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 values[],
                          size_t nValues) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi3SetFloat64";
  if (fmu_bad_call(c, fn, S_SETTABLE)) return fmi3Error;
  if (!count_values(c, fn, vr, nvr, values, nValues, FMU_REAL)) return fmi3Error;
  size_t at = 0;
  for (size_t i = 0; i < nvr; ++i) {
    const fmu3_var* v = &FMU3_VARS[vr[i]];
    if (v->kind != FMU3_ROWS) {
      fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: %s is computed by the FMU and cannot be set", fn, v->name);
      return fmi3Error;
    }
    for (int k = 0; k < v->count; ++k)
      if (fmu_set_real(c, fn, &FMU_MODEL.vars[v->row + k], values[at++]) != FMU_OK) return fmi3Error;
  }
  return fmi3OK;
}

fmi3Status fmi3SetInt32(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, const fmi3Int32 values[],
                        size_t nValues) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi3SetInt32";
  if (fmu_bad_call(c, fn, S_SETTABLE)) return fmi3Error;
  if (!count_values(c, fn, vr, nvr, values, nValues, FMU_INTEGER)) return fmi3Error;
  size_t at = 0;
  for (size_t i = 0; i < nvr; ++i) {
    const fmu3_var* v = &FMU3_VARS[vr[i]];
    for (int k = 0; k < v->count; ++k)
      if (fmu_set_integer(c, fn, &FMU_MODEL.vars[v->row + k], values[at++]) != FMU_OK) return fmi3Error;
  }
  return fmi3OK;
}

/* This FMU has only Float64 and Int32 variables: a call naming a variable of another type
 * is an error. */
static fmi3Status none_of_type(fmi3Instance comp, const char* fn, int allowed, const fmi3ValueReference vr[],
                               size_t nvr, const char* type) {
  fmu_instance* c = BASE(comp);
  if (fmu_bad_call(c, fn, allowed)) return fmi3Error;
  if (nvr == 0) return fmi3OK;
  fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: value reference %u: this FMU has no %s variables", fn, vr ? vr[0] : 0u, type);
  return fmi3Error;
}

#define NO_GETTER(T, name)                                                                                   \
  fmi3Status fmi3Get##T(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, fmi3##T values[],     \
                        size_t nValues) {                                                                    \
    (void)values, (void)nValues;                                                                             \
    return none_of_type(comp, "fmi3Get" #T, S_INSTANTIATED | S_HAS_VALUES, vr, nvr, name);                   \
  }                                                                                                          \
  fmi3Status fmi3Set##T(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, const fmi3##T values[], \
                        size_t nValues) {                                                                    \
    (void)values, (void)nValues;                                                                             \
    return none_of_type(comp, "fmi3Set" #T, S_SETTABLE, vr, nvr, name);                                      \
  }
NO_GETTER(Float32, "Float32")
NO_GETTER(Int8, "Int8")
NO_GETTER(UInt8, "UInt8")
NO_GETTER(Int16, "Int16")
NO_GETTER(UInt16, "UInt16")
NO_GETTER(UInt32, "UInt32")
NO_GETTER(Int64, "Int64")
NO_GETTER(UInt64, "UInt64")
NO_GETTER(Boolean, "Boolean")
NO_GETTER(String, "String")

fmi3Status fmi3GetBinary(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, size_t valueSizes[],
                         fmi3Binary values[], size_t nValues) {
  (void)valueSizes, (void)values, (void)nValues;
  return none_of_type(comp, "fmi3GetBinary", S_INSTANTIATED | S_HAS_VALUES, vr, nvr, "Binary");
}

fmi3Status fmi3SetBinary(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues) {
  (void)valueSizes, (void)values, (void)nValues;
  return none_of_type(comp, "fmi3SetBinary", S_SETTABLE, vr, nvr, "Binary");
}

fmi3Status fmi3GetClock(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, fmi3Clock values[]) {
  (void)values;
  return none_of_type(comp, "fmi3GetClock", S_ANY, vr, nvr, "Clock");
}

fmi3Status fmi3SetClock(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, const fmi3Clock values[]) {
  (void)values;
  return none_of_type(comp, "fmi3SetClock", S_ANY, vr, nvr, "Clock");
}

/* A function of an optional capability this FMU does not declare: an error, logged. */
static fmi3Status not_provided(fmi3Instance comp, const char* fn, const char* why) {
  if (!comp) return fmi3Error;
  fmu_log(BASE(comp), FMU_ERROR, LOG_ERROR, "%s: not provided (%s)", fn, why);
  return fmi3Error;
}

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance comp, fmi3ValueReference valueReference,
                                               size_t* nDependencies) {
  (void)valueReference, (void)nDependencies;
  return not_provided(comp, "fmi3GetNumberOfVariableDependencies", "providesPerElementDependencies=false");
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance comp, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[], fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[],
                                       size_t nDependencies) {
  (void)dependent, (void)elementIndicesOfDependent, (void)independents, (void)elementIndicesOfIndependents;
  (void)dependencyKinds, (void)nDependencies;
  return not_provided(comp, "fmi3GetVariableDependencies", "providesPerElementDependencies=false");
}

/* ---------------------------------------------------------------- FMU state */

fmi3Status fmi3GetFMUState(fmi3Instance comp, fmi3FMUState* FMUState) {
  return STATUS(fmu_state_get(BASE(comp), "fmi3GetFMUState", STATE_MAGIC, FMUState));
}

fmi3Status fmi3SetFMUState(fmi3Instance comp, fmi3FMUState FMUState) {
  return STATUS(fmu_state_set(BASE(comp), "fmi3SetFMUState", STATE_MAGIC, FMUState));
}

fmi3Status fmi3FreeFMUState(fmi3Instance comp, fmi3FMUState* FMUState) {
  return STATUS(fmu_state_free(BASE(comp), "fmi3FreeFMUState", FMUState));
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance comp, fmi3FMUState FMUState, size_t* size) {
  return STATUS(fmu_state_size(BASE(comp), "fmi3SerializedFMUStateSize", STATE_MAGIC, FMUState, size));
}

fmi3Status fmi3SerializeFMUState(fmi3Instance comp, fmi3FMUState FMUState, fmi3Byte serializedState[], size_t size) {
  return STATUS(fmu_state_serialize(BASE(comp), "fmi3SerializeFMUState", STATE_MAGIC, FMUState, serializedState, size));
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance comp, const fmi3Byte serializedState[], size_t size,
                                   fmi3FMUState* FMUState) {
  return STATUS(
      fmu_state_deserialize(BASE(comp), "fmi3DeserializeFMUState", STATE_MAGIC, serializedState, size, FMUState));
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance comp, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                        const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                        size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
  (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
  (void)nSensitivity;
  return not_provided(comp, "fmi3GetDirectionalDerivative", "providesDirectionalDerivatives=false");
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance comp, const fmi3ValueReference unknowns[], size_t nUnknowns,
                                    const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[],
                                    size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity) {
  (void)unknowns, (void)nUnknowns, (void)knowns, (void)nKnowns, (void)seed, (void)nSeed, (void)sensitivity;
  (void)nSensitivity;
  return not_provided(comp, "fmi3GetAdjointDerivative", "providesAdjointDerivatives=false");
}

/* ------------------------------------------- configuration mode and clocks */

#define NO_STRUCTURAL "this FMU has no structural parameters"
#define NO_CLOCKS "this FMU has no clocks"

fmi3Status fmi3EnterConfigurationMode(fmi3Instance comp) {
  return not_provided(comp, "fmi3EnterConfigurationMode", NO_STRUCTURAL);
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance comp) {
  return not_provided(comp, "fmi3ExitConfigurationMode", NO_STRUCTURAL);
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 i[],
                                  fmi3IntervalQualifier q[]) {
  (void)vr, (void)nvr, (void)i, (void)q;
  return not_provided(comp, "fmi3GetIntervalDecimal", NO_CLOCKS);
}
fmi3Status fmi3GetIntervalFraction(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, fmi3UInt64 c[],
                                   fmi3UInt64 r[], fmi3IntervalQualifier q[]) {
  (void)vr, (void)nvr, (void)c, (void)r, (void)q;
  return not_provided(comp, "fmi3GetIntervalFraction", NO_CLOCKS);
}
fmi3Status fmi3GetShiftDecimal(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, fmi3Float64 s[]) {
  (void)vr, (void)nvr, (void)s;
  return not_provided(comp, "fmi3GetShiftDecimal", NO_CLOCKS);
}
fmi3Status fmi3GetShiftFraction(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, fmi3UInt64 c[],
                                fmi3UInt64 r[]) {
  (void)vr, (void)nvr, (void)c, (void)r;
  return not_provided(comp, "fmi3GetShiftFraction", NO_CLOCKS);
}
fmi3Status fmi3SetIntervalDecimal(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr,
                                  const fmi3Float64 i[]) {
  (void)vr, (void)nvr, (void)i;
  return not_provided(comp, "fmi3SetIntervalDecimal", NO_CLOCKS);
}
fmi3Status fmi3SetIntervalFraction(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr,
                                   const fmi3UInt64 c[], const fmi3UInt64 r[]) {
  (void)vr, (void)nvr, (void)c, (void)r;
  return not_provided(comp, "fmi3SetIntervalFraction", NO_CLOCKS);
}
fmi3Status fmi3SetShiftDecimal(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, const fmi3Float64 s[]) {
  (void)vr, (void)nvr, (void)s;
  return not_provided(comp, "fmi3SetShiftDecimal", NO_CLOCKS);
}
fmi3Status fmi3SetShiftFraction(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr, const fmi3UInt64 c[],
                                const fmi3UInt64 r[]) {
  (void)vr, (void)nvr, (void)c, (void)r;
  return not_provided(comp, "fmi3SetShiftFraction", NO_CLOCKS);
}
fmi3Status fmi3ActivateModelPartition(fmi3Instance comp, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime) {
  (void)clockReference, (void)activationTime;
  return not_provided(comp, "fmi3ActivateModelPartition", "Scheduled Execution");
}

/* ------------------------------------------------------- discrete states, events */

/* No discrete states: nothing to evaluate. */
fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance comp) {
  return fmu_bad_call(BASE(comp), "fmi3EvaluateDiscreteStates", S_INIT | S_EVENT) ? fmi3Error : fmi3OK;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance comp, fmi3Boolean* discreteStatesNeedUpdate,
                                    fmi3Boolean* terminateSimulation, fmi3Boolean* nominalsOfContinuousStatesChanged,
                                    fmi3Boolean* valuesOfContinuousStatesChanged, fmi3Boolean* nextEventTimeDefined,
                                    fmi3Float64* nextEventTime) {
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi3UpdateDiscreteStates";
  if (c && (!discreteStatesNeedUpdate || !terminateSimulation || !nominalsOfContinuousStatesChanged ||
            !valuesOfContinuousStatesChanged || !nextEventTimeDefined || !nextEventTime)) {
    if (fmu_bad_call(c, fn, S_EVENT)) return fmi3Error;
    return STATUS(fmu_error(c, fn, "NULL output argument"));
  }
  int stop = 0;
  fmu_status st = fmu_update_discrete_states(c, fn, &stop);
  if (st == FMU_ERROR) return fmi3Error;
  *discreteStatesNeedUpdate = fmi3False;
  *terminateSimulation = stop ? fmi3True : fmi3False;
  *nominalsOfContinuousStatesChanged = fmi3False;
  *valuesOfContinuousStatesChanged = fmi3False;
  *nextEventTimeDefined = fmi3False;
  *nextEventTime = 0;
  return STATUS(st);
}

/* ----------------------------------------------------------- Model Exchange */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance comp) {
  return STATUS(fmu_enter_continuous_time_mode(BASE(comp), "fmi3EnterContinuousTimeMode"));
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance comp, fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean* enterEventMode, fmi3Boolean* terminateSimulation) {
  (void)noSetFMUStatePriorToCurrentPoint;
  int enter = 0, stop = 0;
  fmu_status st = fmu_completed_integrator_step(BASE(comp), "fmi3CompletedIntegratorStep",
                                                enterEventMode ? &enter : NULL, terminateSimulation ? &stop : NULL);
  if (st == FMU_ERROR) return fmi3Error;
  *enterEventMode = enter ? fmi3True : fmi3False;
  *terminateSimulation = stop ? fmi3True : fmi3False;
  return STATUS(st);
}

fmi3Status fmi3SetTime(fmi3Instance comp, fmi3Float64 time) {
  return STATUS(fmu_set_time(BASE(comp), "fmi3SetTime", time));
}

fmi3Status fmi3SetContinuousStates(fmi3Instance comp, const fmi3Float64 x[], size_t nx) {
  return STATUS(fmu_set_states(BASE(comp), "fmi3SetContinuousStates", x, nx));
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance comp, fmi3Float64 derivatives[], size_t nx) {
  return STATUS(fmu_get_derivatives(BASE(comp), "fmi3GetContinuousStateDerivatives", derivatives, nx));
}

fmi3Status fmi3GetEventIndicators(fmi3Instance comp, fmi3Float64 eventIndicators[], size_t nz) {
  return STATUS(fmu_get_indicators(BASE(comp), "fmi3GetEventIndicators", eventIndicators, nz));
}

fmi3Status fmi3GetContinuousStates(fmi3Instance comp, fmi3Float64 x[], size_t nx) {
  return STATUS(fmu_get_states(BASE(comp), "fmi3GetContinuousStates", x, nx));
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance comp, fmi3Float64 nominals[], size_t nx) {
  return STATUS(fmu_get_nominals(BASE(comp), "fmi3GetNominalsOfContinuousStates", nominals, nx));
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance comp, size_t* nEventIndicators) {
  fmu_instance* c = BASE(comp);
  if (fmu_bad_call(c, "fmi3GetNumberOfEventIndicators", S_ANY)) return fmi3Error;
  if (!nEventIndicators) return STATUS(fmu_error(c, "fmi3GetNumberOfEventIndicators", "NULL output argument"));
  *nEventIndicators = (size_t)FMU_MODEL.nindicators;
  return fmi3OK;
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance comp, size_t* nContinuousStates) {
  fmu_instance* c = BASE(comp);
  if (fmu_bad_call(c, "fmi3GetNumberOfContinuousStates", S_ANY)) return fmi3Error;
  if (!nContinuousStates) return STATUS(fmu_error(c, "fmi3GetNumberOfContinuousStates", "NULL output argument"));
  *nContinuousStates = (size_t)fmu_model_nstates(c->model);
  return fmi3OK;
}

/* -------------------------------------------------------------- Co-Simulation */

fmi3Status fmi3EnterStepMode(fmi3Instance comp) {
  return not_provided(comp, "fmi3EnterStepMode", "hasEventMode=false: the instance is in step mode after initialization");
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance comp, const fmi3ValueReference vr[], size_t nvr,
                                    const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues) {
  (void)vr, (void)nvr, (void)orders, (void)values, (void)nValues;
  return not_provided(comp, "fmi3GetOutputDerivatives", "maxOutputDerivativeOrder=0");
}

fmi3Status fmi3DoStep(fmi3Instance comp, fmi3Float64 currentCommunicationPoint, fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* eventHandlingNeeded,
                      fmi3Boolean* terminateSimulation, fmi3Boolean* earlyReturn, fmi3Float64* lastSuccessfulTime) {
  (void)noSetFMUStatePriorToCurrentPoint;
  fmu_instance* c = BASE(comp);
  const char* fn = "fmi3DoStep";
  if (c && (!eventHandlingNeeded || !terminateSimulation || !earlyReturn || !lastSuccessfulTime)) {
    if (fmu_bad_call(c, fn, S_STEP_COMPLETE)) return fmi3Error;
    return STATUS(fmu_error(c, fn, "NULL output argument"));
  }
  fmu_status st = fmu_do_step(c, fn, currentCommunicationPoint, communicationStepSize);
  if (!c || st == FMU_ERROR) return fmi3Error;
  *eventHandlingNeeded = fmi3False;
  *earlyReturn = fmi3False;
  *terminateSimulation = st == FMU_DISCARD ? fmi3True : fmi3False;
  *lastSuccessfulTime = c->last_successful_time;
  if (st == FMU_DISCARD && c->stopped) {
    *earlyReturn = ((instance*)c)->early_return_allowed;
    return fmi3OK;
  }
  return STATUS(st);
}
