/* What the core's integrator (c_core/src/integration/sim.cpp) declares from SUNDIALS CVODE,
 * for the FMU binaries of platforms where no SUNDIALS library can be linked (x86_64-windows,
 * aarch64-linux: Debian ships SUNDIALS for the build machine only).  With PKM_NO_CVODE the
 * core refuses PKM_BDF and PKM_ADAMS when a simulator is created (a clear error naming the
 * methods it has), so none of these functions is ever reached: each one fails if it is.
 * Only the declarations sim.cpp uses, with the SUNDIALS 6 signatures. */
#ifndef PKM_SUNDIALS_ABSENT_H
#define PKM_SUNDIALS_ABSENT_H

#ifdef __cplusplus
extern "C" {
#endif

typedef double sunrealtype;
typedef double realtype;
typedef long sunindextype;
typedef struct pkm_absent_nvector* N_Vector;
typedef struct pkm_absent_context* SUNContext;
typedef struct pkm_absent_matrix* SUNMatrix;
typedef struct pkm_absent_linsol* SUNLinearSolver;
typedef struct pkm_absent_nonlinsol* SUNNonlinearSolver;
typedef int (*CVRhsFn)(double t, N_Vector y, N_Vector ydot, void* user_data);
typedef int (*CVRootFn)(double t, N_Vector y, double* gout, void* user_data);
typedef void (*CVErrHandlerFn)(int code, const char* module, const char* function, char* msg, void* user_data);

enum {
  CV_SUCCESS = 0, CV_TSTOP_RETURN = 1, CV_ROOT_RETURN = 2, CV_TOO_MUCH_WORK = -1, CV_CONV_FAILURE = -4,
  CV_LSETUP_FAIL = -6,
  CV_RHSFUNC_FAIL = -8, CV_FIRST_RHSFUNC_ERR = -9, CV_REPTD_RHSFUNC_ERR = -10, CV_UNREC_RHSFUNC_ERR = -11,
  CV_RTFUNC_FAIL = -12, CV_NLS_FAIL = -13, CV_ADAMS = 1, CV_BDF = 2, CV_NORMAL = 1
};

int SUNContext_Create(void* comm, SUNContext* ctx);
int SUNContext_Free(SUNContext* ctx);
N_Vector N_VNew_Serial(sunindextype n, SUNContext ctx);
void N_VDestroy(N_Vector v);
double* N_VGetArrayPointer(N_Vector v);
SUNMatrix SUNDenseMatrix(sunindextype m, sunindextype n, SUNContext ctx);
int SUNMatDestroy(SUNMatrix A);
SUNLinearSolver SUNLinSol_Dense(N_Vector y, SUNMatrix A, SUNContext ctx);
int SUNLinSolFree(SUNLinearSolver s);
SUNNonlinearSolver SUNNonlinSol_FixedPoint(N_Vector y, int m, SUNContext ctx);
int SUNNonlinSolFree(SUNNonlinearSolver s);

void* CVodeCreate(int lmm, SUNContext ctx);
void CVodeFree(void** mem);
int CVodeInit(void* mem, CVRhsFn f, double t0, N_Vector y0);
int CVodeReInit(void* mem, double t0, N_Vector y0);
int CVodeSStolerances(void* mem, double rtol, double atol);
int CVodeSetErrHandlerFn(void* mem, CVErrHandlerFn fn, void* data);
int CVodeSetUserData(void* mem, void* data);
int CVodeSetLinearSolver(void* mem, SUNLinearSolver ls, SUNMatrix A);
int CVodeSetNonlinearSolver(void* mem, SUNNonlinearSolver nls);
int CVodeSetMaxStep(void* mem, double hmax);
int CVodeSetMaxNumSteps(void* mem, long mxsteps);
int CVodeSetStopTime(void* mem, double tstop);
int CVodeRootInit(void* mem, int nrtfn, CVRootFn g);
int CVodeSetRootDirection(void* mem, int* dir);
int CVodeSetNoInactiveRootWarn(void* mem);
int CVode(void* mem, double tout, N_Vector yout, double* tret, int itask);
int CVodeGetDky(void* mem, double t, int k, N_Vector dky);
int CVodeGetLastStep(void* mem, double* h);
int CVodeGetCurrentTime(void* mem, double* t);
int CVodeGetRootInfo(void* mem, int* found);
int CVodeGetNumSteps(void* mem, long* n);
int CVodeGetNumRhsEvals(void* mem, long* n);
int CVodeGetNumLinRhsEvals(void* mem, long* n);
int CVodeGetNumJacEvals(void* mem, long* n);
int CVodeGetNumErrTestFails(void* mem, long* n);
int CVodeGetNumNonlinSolvConvFails(void* mem, long* n);
char* CVodeGetReturnFlagName(long flag);

#ifdef __cplusplus
}
#endif
#endif
