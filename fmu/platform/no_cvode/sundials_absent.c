/* The CVODE functions of sundials_absent.h, each failing: never reached, since the core
 * built with PKM_NO_CVODE refuses PKM_BDF and PKM_ADAMS before it creates any of them. */
#include <stdlib.h>
#include <string.h>

#include "sundials_absent.h"

enum { ABSENT = -99 };

int SUNContext_Create(void* comm, SUNContext* ctx) { (void)comm; *ctx = NULL; return ABSENT; }
int SUNContext_Free(SUNContext* ctx) { (void)ctx; return 0; }
N_Vector N_VNew_Serial(sunindextype n, SUNContext ctx) { (void)n; (void)ctx; return NULL; }
void N_VDestroy(N_Vector v) { (void)v; }
double* N_VGetArrayPointer(N_Vector v) { (void)v; return NULL; }
SUNMatrix SUNDenseMatrix(sunindextype m, sunindextype n, SUNContext ctx) { (void)m; (void)n; (void)ctx; return NULL; }
int SUNMatDestroy(SUNMatrix A) { (void)A; return 0; }
SUNLinearSolver SUNLinSol_Dense(N_Vector y, SUNMatrix A, SUNContext ctx) { (void)y; (void)A; (void)ctx; return NULL; }
int SUNLinSolFree(SUNLinearSolver s) { (void)s; return 0; }
SUNNonlinearSolver SUNNonlinSol_FixedPoint(N_Vector y, int m, SUNContext ctx) { (void)y; (void)m; (void)ctx; return NULL; }
int SUNNonlinSolFree(SUNNonlinearSolver s) { (void)s; return 0; }

void* CVodeCreate(int lmm, SUNContext ctx) { (void)lmm; (void)ctx; return NULL; }
void CVodeFree(void** mem) { *mem = NULL; }
int CVodeInit(void* mem, CVRhsFn f, double t0, N_Vector y0) { (void)mem; (void)f; (void)t0; (void)y0; return ABSENT; }
int CVodeReInit(void* mem, double t0, N_Vector y0) { (void)mem; (void)t0; (void)y0; return ABSENT; }
int CVodeSStolerances(void* mem, double rtol, double atol) { (void)mem; (void)rtol; (void)atol; return ABSENT; }
int CVodeSetErrHandlerFn(void* mem, CVErrHandlerFn fn, void* data) { (void)mem; (void)fn; (void)data; return ABSENT; }
int CVodeSetUserData(void* mem, void* data) { (void)mem; (void)data; return ABSENT; }
int CVodeSetLinearSolver(void* mem, SUNLinearSolver ls, SUNMatrix A) { (void)mem; (void)ls; (void)A; return ABSENT; }
int CVodeSetNonlinearSolver(void* mem, SUNNonlinearSolver nls) { (void)mem; (void)nls; return ABSENT; }
int CVodeSetMaxStep(void* mem, double hmax) { (void)mem; (void)hmax; return ABSENT; }
int CVodeSetMaxNumSteps(void* mem, long mxsteps) { (void)mem; (void)mxsteps; return ABSENT; }
int CVodeSetStopTime(void* mem, double tstop) { (void)mem; (void)tstop; return ABSENT; }
int CVodeRootInit(void* mem, int nrtfn, CVRootFn g) { (void)mem; (void)nrtfn; (void)g; return ABSENT; }
int CVodeSetRootDirection(void* mem, int* dir) { (void)mem; (void)dir; return ABSENT; }
int CVodeSetNoInactiveRootWarn(void* mem) { (void)mem; return ABSENT; }
int CVode(void* mem, double tout, N_Vector yout, double* tret, int itask) { (void)mem; (void)tout; (void)yout; (void)tret; (void)itask; return ABSENT; }
int CVodeGetDky(void* mem, double t, int k, N_Vector dky) { (void)mem; (void)t; (void)k; (void)dky; return ABSENT; }
int CVodeGetLastStep(void* mem, double* h) { (void)mem; *h = 0; return ABSENT; }
int CVodeGetCurrentTime(void* mem, double* t) { (void)mem; *t = 0; return ABSENT; }
int CVodeGetRootInfo(void* mem, int* found) { (void)mem; (void)found; return ABSENT; }
int CVodeGetNumSteps(void* mem, long* n) { (void)mem; *n = 0; return ABSENT; }
int CVodeGetNumRhsEvals(void* mem, long* n) { (void)mem; *n = 0; return ABSENT; }
int CVodeGetNumLinRhsEvals(void* mem, long* n) { (void)mem; *n = 0; return ABSENT; }
int CVodeGetNumJacEvals(void* mem, long* n) { (void)mem; *n = 0; return ABSENT; }
int CVodeGetNumErrTestFails(void* mem, long* n) { (void)mem; *n = 0; return ABSENT; }
int CVodeGetNumNonlinSolvConvFails(void* mem, long* n) { (void)mem; *n = 0; return ABSENT; }
char* CVodeGetReturnFlagName(long flag) {
  (void)flag;
  const char text[] = "CVODE is not in this build";
  char* s = (char*)malloc(sizeof text);
  if (s) memcpy(s, text, sizeof text);
  return s;
}
