/*
 * fmu_instance.h -- what the FMI 2.0 layer (fmi2_functions.c) and the FMI 3.0 layer
 * (fmi3_functions.c) share: one FMU instance over the model hooks of fmu_model.h, its
 * state machine, its logging, the checks of every argument, the FMU state (saved,
 * validated, restored, serialised) and the Model Exchange and Co-Simulation steps.
 *
 * Each FMI layer translates its own function signatures to these calls and back; the
 * rules (what is refused, the messages, the statuses) are written once here.  Statuses
 * are the FMI ones (OK, Warning, Discard, Error, Fatal: the same numbers in FMI 2.0 and
 * 3.0).  A function named with its FMI name (fn) puts that name in front of its
 * messages.
 */
#ifndef PKM_FMU_INSTANCE_H
#define PKM_FMU_INSTANCE_H

#include <stddef.h>

#include "fmu_model.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum fmu_status { FMU_OK = 0, FMU_WARNING = 1, FMU_DISCARD = 2, FMU_ERROR = 3, FMU_FATAL = 4 } fmu_status;

/* The state machine's states (FMI 2.0 names; FMI 3.0's step mode is S_STEP_COMPLETE and a
 * discarded step leaves S_STEP_FAILED, where only values and the state can be read). */
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
#define S_SETTABLE (S_INSTANTIATED | S_INIT | S_EVENT | S_CONT | S_STEP_COMPLETE)
#define S_ME_VALUES (S_INIT | S_EVENT | S_CONT | S_TERMINATED | S_ERROR)

/* Log categories (modelDescription.xml <LogCategories>). */
enum { LOG_EVENTS = 1, LOG_WARNING = 2, LOG_DISCARD = 4, LOG_ERROR = 8, LOG_FATAL = 16, LOG_CALLS = 32 };

typedef struct fmu_instance fmu_instance;

/* Hands one finished message to the importer's logger (the FMI layer's callbacks). */
typedef void (*fmu_emit_fn)(const fmu_instance* c, fmu_status st, const char* category, const char* message);

struct fmu_instance {
  char* name;
  int cosimulation;      /* 1: Co-Simulation, 0: Model Exchange                        */
  fmu_emit_fn emit;      /* the FMI layer's logger: NULL logs nothing                   */
  const char* token;     /* GUID (FMI 2.0) or instantiation token (FMI 3.0) of the model */
  unsigned log_mask;     /* enabled categories (debug logging)                          */
  int state;
  fmu_model* model;
  double start_time, stop_time;
  int stop_defined;
  double last_successful_time;
  int terminated;
  int stopped;           /* the last Co-Simulation step ended at a stop of the model (a joint
                            limit, a singularity, an unreachable pose), not at its budget */
};

/* ----------------------------------------------------------------- logging */

void fmu_log(const fmu_instance* c, fmu_status st, int category, const char* fmt, ...);
/* Logs "<fn>: <message>" as an error and moves to the error state; returns FMU_ERROR. */
fmu_status fmu_error(fmu_instance* c, const char* fn, const char* fmt, ...);
/* FMU_OK if the n values are finite, else an error naming the first that is not. */
fmu_status fmu_finite_or_error(fmu_instance* c, const char* fn, const char* what, const double* v, size_t n);
/* 1 (and the call logged as an error, the instance unchanged) unless c is an instance in
 * one of the allowed states. */
int fmu_bad_call(fmu_instance* c, const char* fn, int allowed);
fmu_status fmu_set_debug_logging(fmu_instance* c, const char* fn, int on, size_t n, const char* const cats[]);

/* ------------------------------------------------------- life of an instance */

/* Checks the name and the token (against head->token; token_word names it in the
 * message: "GUID", "instantiation token"), creates the model and returns a new instance
 * of size bytes (the FMI layer's struct, which starts with an fmu_instance) copied from
 * head (emit, token and whatever the layer keeps after it already filled in), or NULL
 * after logging why through head. */
fmu_instance* fmu_instantiate(const char* fn, fmu_instance* head, size_t size, const char* name, const char* token,
                              const char* token_word, int cosimulation);
void fmu_free(fmu_instance* c);
fmu_status fmu_reset(fmu_instance* c, const char* fn);
/* The experiment (FMI 2.0 fmi2SetupExperiment, FMI 3.0 fmi3EnterInitializationMode). */
fmu_status fmu_setup(fmu_instance* c, const char* fn, int tolerance_defined, double tolerance, double start_time,
                     int stop_defined, double stop_time);
fmu_status fmu_exit_initialization(fmu_instance* c, const char* fn);
fmu_status fmu_terminate(fmu_instance* c, const char* fn);

/* ------------------------------------------------------------ variable values */

/* The row of value reference vr (1-based) of the variable table, of the given type, or
 * NULL after logging why. */
const fmu_var* fmu_lookup(fmu_instance* c, const char* fn, unsigned vr, fmu_type type, const char* type_name);
/* One value of the variable in row v, computed from the current state (in
 * initialization mode, from the pending start values). */
fmu_status fmu_get_real(fmu_instance* c, const char* fn, const fmu_var* v, double* value);
fmu_status fmu_get_integer(fmu_instance* c, const char* fn, const fmu_var* v, int* value);
/* Sets one value: parameters before the end of initialization, inputs any time. */
fmu_status fmu_set_real(fmu_instance* c, const char* fn, const fmu_var* v, double value);
fmu_status fmu_set_integer(fmu_instance* c, const char* fn, const fmu_var* v, int value);

/* ------------------------------------------------------ FMU state (fmu_state.c) */

/* An FMU state is one flat block (header + the model's snapshot): serialising it is a copy.
 * magic tells the FMI layer's blocks apart ("PKMFMU2S", "PKMFMU3S"). */
fmu_status fmu_state_get(fmu_instance* c, const char* fn, const char* magic, void** state);
fmu_status fmu_state_set(fmu_instance* c, const char* fn, const char* magic, const void* state);
fmu_status fmu_state_free(fmu_instance* c, const char* fn, void** state);
fmu_status fmu_state_size(fmu_instance* c, const char* fn, const char* magic, const void* state, size_t* size);
fmu_status fmu_state_serialize(fmu_instance* c, const char* fn, const char* magic, const void* state,
                               unsigned char* bytes, size_t size);
fmu_status fmu_state_deserialize(fmu_instance* c, const char* fn, const char* magic, const unsigned char* bytes,
                                 size_t size, void** state);

/* ------------------------------------------------------------ Model Exchange */

fmu_status fmu_enter_event_mode(fmu_instance* c, const char* fn);
fmu_status fmu_enter_continuous_time_mode(fmu_instance* c, const char* fn);
/* The model has no discrete states and no time events; a state event is the edge of the
 * usable workspace, where the FMU asks the importer to stop (*terminate = 1, Warning). */
fmu_status fmu_update_discrete_states(fmu_instance* c, const char* fn, int* terminate);
fmu_status fmu_completed_integrator_step(fmu_instance* c, const char* fn, int* enter_event_mode, int* terminate);
fmu_status fmu_set_time(fmu_instance* c, const char* fn, double time);
fmu_status fmu_set_states(fmu_instance* c, const char* fn, const double* x, size_t nx);
fmu_status fmu_get_states(fmu_instance* c, const char* fn, double* x, size_t nx);
fmu_status fmu_get_derivatives(fmu_instance* c, const char* fn, double* dx, size_t nx);
fmu_status fmu_get_indicators(fmu_instance* c, const char* fn, double* z, size_t nz);
fmu_status fmu_get_nominals(fmu_instance* c, const char* fn, double* nominals, size_t nx);

/* ------------------------------------------------------------- Co-Simulation */

/* One communication step from t to t + h with the inputs held.  FMU_DISCARD: the model
 * stopped at an event (stroke limit, singularity, step budget), its state at that time
 * (c->last_successful_time), c->terminated set. */
fmu_status fmu_do_step(fmu_instance* c, const char* fn, double t, double h);

#ifdef __cplusplus
}
#endif
#endif /* PKM_FMU_INSTANCE_H */
