/*
 * fmu_model.h -- the contract between the generic FMI layer (fmi2_functions.c,
 * fmi3_functions.c) and the model behind an FMU (robot.c for a robot, controller.c for a
 * controller), and the shape of the variable table that
 * fmu_gen writes for each model folder (fmu/<robot>/variables.txt -> <ID>_vars.h).
 *
 * Conventions:
 *  1. The model owns a pkm_model, a pkm_data and (Co-Simulation) a pkm_sim: one model
 *     per FMU instance, no global mutable state.
 *  2. Every model function returns a pkm status (PKM_OK or a negative pkm_status) and,
 *     on failure, leaves a message saying what and where in fmu_model_error().
 *  3. A variable is addressed by its row in the generated table: the table gives the
 *     channel (what the value means to the model) and the index within the channel.
 *  4. Parameter changes are pending until fmu_model_apply(): then they go through
 *     pkm_param_set + pkm_model_validate, so the core decides what is valid.
 */
#ifndef PKM_FMU_MODEL_H
#define PKM_FMU_MODEL_H

#include <math.h>
#include <stddef.h>

#include "pkm/pkm.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ------------------------------------------------------------ variable table */

typedef enum fmu_type { FMU_REAL = 0, FMU_INTEGER = 1 } fmu_type;

typedef enum fmu_causality {
  FMU_PARAMETER = 0, /* fixed, settable before fmi2ExitInitializationMode */
  FMU_INPUT = 1,
  FMU_OUTPUT = 2
} fmu_causality;

/* What a variable means to the model.  Indexed channels use fmu_var.index (0-based). */
typedef enum fmu_channel {
  FMU_CH_PARAM = 0,     /* core parameter number index (pkm_param_*)                   */
  FMU_CH_TAU,           /* actuator effort tau[index], input                            */
  FMU_CH_POSE,          /* pose x[index]: continuous state                              */
  FMU_CH_TWIST,         /* pose rate xd[index]: continuous state, der(pose[index])      */
  FMU_CH_ACCEL,         /* pose acceleration xdd[index] = der(twist[index])             */
  FMU_CH_Q,             /* joint position q[index]                                      */
  FMU_CH_QD,            /* joint velocity qd[index]                                     */
  FMU_CH_POSE0,         /* initial pose x0[index]                                       */
  FMU_CH_TWIST0,        /* initial pose rate xd0[index]                                 */
  FMU_CH_SING,          /* singularity measure index (0: inverse-kinematic, 1: direct)  */
  FMU_CH_ENERGY,        /* energy index (0: kinetic, 1: potential)                      */
  FMU_CH_SOLVER_METHOD, /* Integer: PKM_BDF or PKM_ADAMS                                */
  FMU_CH_SOLVER_RTOL,
  FMU_CH_SOLVER_ATOL,
  FMU_CH_SOLVER_MAX_STEP,
  FMU_CH_SOLVER_MAX_STEPS, /* Integer */
  FMU_CH_SOLVER_SING_MIN,
  FMU_CH_INPUT_GAIN,    /* effort on the joint per unit of input tau (model parameter)  */
  FMU_CH_Q_DRIVE,       /* drive-side position of joint index (drive.two_body), output  */
  FMU_CH_QD_DRIVE,      /* drive-side rate of joint index, output                       */
  /* controller FMUs (fmu/common/controller.c, pkm.h "control"): */
  FMU_CH_CTRL_Q,         /* joint reading q[index], input                                */
  FMU_CH_CTRL_QD,        /* joint rate reading qd[index], input                          */
  FMU_CH_CTRL_QREF,      /* reference qref[index], input                                 */
  FMU_CH_CTRL_QDREF,     /* reference rate, input                                        */
  FMU_CH_CTRL_QDDREF,    /* reference acceleration, input                                */
  FMU_CH_CTRL_TAU,       /* effort tau[index], output                                    */
  FMU_CH_CTRL_KIND,      /* Integer: pkm_ctrl_kind                                       */
  FMU_CH_CTRL_DT,        /* sample period [s]                                            */
  FMU_CH_CTRL_KP,        /* kp[i,j], index i nd + j                                      */
  FMU_CH_CTRL_KD,
  FMU_CH_CTRL_KI,
  FMU_CH_CTRL_TF,        /* derivative filter time constant [s]                          */
  FMU_CH_CTRL_SAT,       /* saturation[index] (0: none)                                  */
  FMU_CH_CTRL_GRAVITY_REF, /* Integer                                                    */
  FMU_CH_CTRL_GRAVITY_FF,  /* Integer                                                    */
  FMU_CH_CTRL_NX,        /* Integer: LTI states in use (<= the FMU's lti_states)         */
  FMU_CH_CTRL_A,         /* A[r,c], index r lti_states + c                               */
  FMU_CH_CTRL_B,         /* B[r,j], index r nd + j                                       */
  FMU_CH_CTRL_C,         /* C[i,c], index i lti_states + c                               */
  FMU_CH_CTRL_D,         /* D[i,j], index i nd + j                                       */
  FMU_CH_COUNT
} fmu_channel;

typedef struct fmu_var {
  unsigned vr;          /* value reference (row + 1)                                    */
  const char* name;     /* Modelica-style name, as in modelDescription.xml              */
  fmu_type type;
  fmu_causality causality;
  fmu_channel channel;
  int index;
  double start;         /* start value (parameters, inputs)                             */
} fmu_var;

/* An FMI 3.0 variable (fmu_vars3.h): rows of the table above taken together as one
 * array (joint positions, efforts, the pose, gain matrices) or one scalar, or the two
 * values FMI 3.0 declares as variables and FMI 2.0 does not (time, event indicators). */
typedef enum fmu3_kind { FMU3_ROWS = 0, FMU3_TIME = 1, FMU3_INDICATORS = 2 } fmu3_kind;

typedef struct fmu3_var {
  unsigned vr;          /* FMI 3.0 value reference (its position in the table)          */
  const char* name;
  fmu_type type;        /* Float64 or Int32                                             */
  fmu3_kind kind;
  int row;              /* FMU3_ROWS: the first row (0-based) of the FMI 2.0 table       */
  int count;            /* values: rows (row-major over the dimensions), or indicators  */
} fmu3_var;

/* One FMU: written by each model folder's model.c from its generated header. */
typedef struct fmu_model_desc {
  const char* identifier; /* modelIdentifier, name of the .so                            */
  const char* guid;
  const char* robot;      /* pkm_model_create robot name                                 */
  const char* param_set;
  int ndof;
  int nparam;             /* core parameters in the table (all of them)                  */
  int nvars;
  const fmu_var* vars;    /* vars[k].vr == k + 1                                         */
  /* Core parameter numbers of each joint's lower / upper limit [ndof] (from the table's
   * @joint-limits line), or NULL: Model Exchange then has no stroke-limit events. */
  const int* qmin_param;
  const int* qmax_param;
  int nindicators;        /* 1 (singularity margin) + 2 ndof if limits are given          */
  int lti_states;         /* controller FMUs: room for LTI states (0 for robots)           */
  const char* description; /* a described robot's description text (docs/robots.md), or NULL */
} fmu_model_desc;

/* Defined by the model folder (fmu/<robot>/model.c). */
extern const fmu_model_desc FMU_MODEL;

/* --------------------------------------------------------------- the model */

typedef struct fmu_model fmu_model;

/* Creates the core model of desc->robot, checks that the table's parameter rows match
 * the core's parameter table (names and order), and sets every value to its start.
 * Returns NULL and writes the reason into err[errlen]. */
fmu_model* fmu_model_create(const fmu_model_desc* desc, int cosimulation, char* err, size_t errlen);
void fmu_model_destroy(fmu_model* p);
const char* fmu_model_error(const fmu_model* p);

/* How a hook fails (convention 2): formats the message (printf-style) into msg, the
 * buffer of size bytes that fmu_model_error() returns, and gives back status.  Both hook
 * sets (robot.c, controller.c) keep that buffer as p->msg and call it as
 * fail(p, status, fmt, ...).  Defined in fmu_instance.c, which every FMU compiles. */
int fmu_model_fail(char* msg, size_t size, int status, const char* fmt, ...);
#define fail(p, status, ...) fmu_model_fail((p)->msg, sizeof (p)->msg, (status), __VA_ARGS__)

/* Back to the start values of every variable (fmi2Reset). */
int fmu_model_reset(fmu_model* p);

/* Pending values: parameters, initial state, solver settings, inputs. */
int fmu_model_set_real(fmu_model* p, const fmu_var* v, double value);
int fmu_model_set_integer(fmu_model* p, const fmu_var* v, int value);
/* Values, computing outputs on demand (kinematics, dynamics) from the current state. */
int fmu_model_get_real(fmu_model* p, const fmu_var* v, double* value);
int fmu_model_get_integer(fmu_model* p, const fmu_var* v, int* value);

/* Relative tolerance imposed by the importer (fmi2SetupExperiment), <= 0 for none. */
void fmu_model_set_tolerance(fmu_model* p, double rtol);
/* Applies pending parameters and solver settings (pkm_param_set + pkm_model_validate),
 * then puts the state at (t0, x0, xd0) and checks it (reachable, not singular). */
int fmu_model_start(fmu_model* p, double t0);
/* 1 if parameters or the initial state changed since the last plant_start. */
int fmu_model_dirty(const fmu_model* p);

/* Co-Simulation: integrates to t_end with the input held.  On a stroke limit, a
 * singularity or a CVODE failure the state is left at the event time. */
int fmu_model_step(fmu_model* p, double t_end);
double fmu_model_time(const fmu_model* p);

/* Model Exchange: states s = (x, xd), derivatives ds = (xd, xdd); n = 2 * ndof. */
int fmu_model_nstates(const fmu_model* p);
void fmu_model_set_time(fmu_model* p, double t);
int fmu_model_set_states(fmu_model* p, const double* s, size_t n);
int fmu_model_get_states(const fmu_model* p, double* s, size_t n);
int fmu_model_get_derivatives(fmu_model* p, double* ds, size_t n);
/* Event indicators z[nindicators], each > 0 inside the usable workspace:
 * z[0] = singularity.direct - solver.singMin, then per joint i q_i - qmin_i, qmax_i - q_i. */
int fmu_model_get_indicators(fmu_model* p, double* z, size_t n);
/* PKM_OK, or the status (PKM_ERR_SINGULAR, PKM_ERR_JOINT_LIMIT, the core's IK status)
 * and a message naming the joint, the limit and the time when an indicator is <= tol:
 * the pose reached the edge of the usable workspace and the importer should stop. */
int fmu_model_check_limits(fmu_model* p, double tol);

/* Snapshot of everything that determines the future of the model (fmi2GetFMUstate),
 * the integrator's own state included.  Its size (in doubles) varies with that state
 * (the actuator-delay history): plant_snapshot_size now, never below
 * plant_snapshot_min_size. */
size_t fmu_model_snapshot_size(const fmu_model* p);
size_t fmu_model_snapshot_min_size(const fmu_model* p);
void fmu_model_snapshot_save(const fmu_model* p, double* buf);
/* plant_snapshot_check validates the n values (length, every value finite, flags, counts
 * and enumerations in range) and changes nothing; plant_snapshot_load loads a checked
 * snapshot, putting parameters and the integrator's or law's state through the core, and
 * may leave the model changed when the core refuses them (the caller restores). */
int fmu_model_snapshot_check(fmu_model* p, const double* buf, size_t n);
int fmu_model_snapshot_load(fmu_model* p, const double* buf, size_t n);

/* 1 if v, a value read back from an FMU state, is a whole number in [lo, hi]: a flag, a
 * count or an enumeration that may be converted to an integer (a conversion of a value
 * out of its type's range is undefined behaviour in C). */
static inline int fmu_whole(double v, double lo, double hi) { return v >= lo && v <= hi && v == floor(v); }

#ifdef __cplusplus
}
#endif
#endif /* PKM_FMU_MODEL_H */
