/*
 * fmu_robot.h -- what the two files of the robot FMU's hooks share (not part of the FMI layer):
 * robot.c (life of the model, values, outputs on demand, start, Co-Simulation step) and
 * robot_states.c (Model Exchange's continuous states and events, the snapshot of an FMU
 * state).  The model holds the state (t, x, xd), the input tau and the pending parameters of
 * one FMU instance; everything it computes is one core call (pkm.h).
 */
#ifndef PKM_FMU_ROBOT_H
#define PKM_FMU_ROBOT_H

#include "fmu_model.h"

/* Bits of fmu_model.valid: which outputs computed on demand are up to date. */
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

/* Name of the table row of a channel entry, for messages. */
const char* fmu_robot_var_name(const fmu_model* p, fmu_channel ch, int index);
/* Makes the outputs of valid bit `bit` up to date (what: the variable asked for, for messages). */
int fmu_robot_ensure(fmu_model* p, unsigned bit, const char* what);
/* Pending parameters into the core model, pending solver settings into a (new) sim. */
int fmu_robot_apply(fmu_model* p);

#endif /* PKM_FMU_ROBOT_H */
