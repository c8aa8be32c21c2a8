/* The quattro controller FMU: binds the generated variable table and the packed description
 * the core serves the robot from (robots/quattro.toml) to the generic FMI layer and the
 * controller hooks (fmu/common/controller.c). */
#include "fmu_vars.h"

const fmu_model_desc FMU_MODEL = {FMU_IDENTIFIER, FMU_GUID,  FMU_ROBOT,      FMU_PARAM_SET,  FMU_NDOF,
                                  FMU_NPARAM,     FMU_NVARS, FMU_VARS,       FMU_QMIN_PARAM, FMU_QMAX_PARAM,
                                  FMU_NINDICATORS, FMU_LTI_STATES, FMU_DESCRIPTION};
