/* Every described robot's FMU: binds the generated variable table and the packed
 * description (fmu_vars.h, from variables.txt.in and the description file) to the generic
 * FMI layer.  All behaviour is in fmu/common; the robot is compiled by the core. */
#include "fmu_vars.h"

const fmu_model_desc FMU_MODEL = {FMU_IDENTIFIER,  FMU_GUID,       FMU_ROBOT, FMU_PARAM_SET,  FMU_NDOF,
                                  FMU_NPARAM,      FMU_NVARS,      FMU_VARS,  FMU_QMIN_PARAM, FMU_QMAX_PARAM,
                                  FMU_NINDICATORS, FMU_LTI_STATES, FMU_DESCRIPTION};
