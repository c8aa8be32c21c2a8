// The CVODE stepper of pkm_sim (methods PKM_BDF and PKM_ADAMS; BDF also takes the stiff
// stretches an explicit stepper hands over): SUNDIALS CVODE on the state y, with the
// stop conditions as root functions.
//
// Design choices (docs/integration.md explains them at length):
//  * One SUNContext, vector, solver set and CVODE memory per stepper: no global state, so
//    any number of simulators may run in one process (one thread each).
//  * Every segment calls CVodeReInit from the committed state, so an advance is a pure
//    function of (t, x, xd, tau, options): rollback + re-advance is bit-for-bit equal.
//  * Stop conditions are CVODE root functions: the stroke / joint limits, the
//    direct-singularity measure and the sign of det J.  CVODE evaluates them once per
//    step (not per RHS call) and locates the crossing; the costly measure only near its
//    threshold (see advance()).
//  * No exception crosses CVODE's C frames: callbacks catch, record the failure and
//    return CVODE's recoverable (1) or unrecoverable (-1) code.
//  * The RHS calls the total forward dynamics directly (arguments were checked on the
//    way in), with no allocation.
// Builds without SUNDIALS (PKM_NO_CVODE: the FMU binaries of fmu/platform, the source-code
// FMUs) compile this file to nothing; the table of integration/stepper.cpp then has no
// CVODE method.
#ifndef PKM_NO_CVODE

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>
#include <sundials/sundials_matrix.h>
#include <sundials/sundials_nonlinearsolver.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include "common/guard.hpp"
#include "integration/ode.hpp"
#include "integration/step_budget.hpp"
#include "integration/stepper.hpp"
#include "integration/stop_conditions.hpp"

namespace pkm {

namespace {

std::string flag_name(int flag) {
  char* s = CVodeGetReturnFlagName(flag);
  std::string out = s ? s : ("CVODE flag " + std::to_string(flag));
  std::free(s);
  return out;
}

// Robot failures a smaller step may avoid (a trial state just outside the workspace):
// CVODE is told to retry.  Anything else stops the integration at once.
bool recoverable(int status) {
  return status == PKM_ERR_UNREACHABLE || status == PKM_ERR_SINGULAR || status == PKM_ERR_NO_CONVERGENCE ||
         status == PKM_ERR_JOINT_LIMIT;
}

bool callback_flag(int flag) {
  return flag == CV_RHSFUNC_FAIL || flag == CV_FIRST_RHSFUNC_ERR || flag == CV_REPTD_RHSFUNC_ERR ||
         flag == CV_UNREC_RHSFUNC_ERR || flag == CV_RTFUNC_FAIL || flag == CV_CONV_FAILURE ||
         flag == CV_LSETUP_FAIL || flag == CV_NLS_FAIL;
}

class CvodeStepper final : public Stepper {
 public:
  // CVODE's objects for the linear multistep method lmm (PKM_BDF or PKM_ADAMS), with the
  // stop conditions as root functions.
  CvodeStepper(int lmm, Ivp& ivp);
  ~CvodeStepper() override { release(); }

  void restart() override {}  // nothing carried: every segment restarts CVODE
  void start_values(double* g) override { stops_.roots(y_.data(), g); }
  bool advance(double t_end) override;
  // The block: the explicit steppers' next step size, unused here (a state saved under
  // one method loads under another).
  size_t state_size() const override { return 1; }
  void save(double* b) const override { b[0] = 0.0; }
  void check(const double* b, double t) const override { check_next_step(b[0], t); }
  void load(const double*) override {}

  std::string budget_advice() const override {
    std::ostringstream os;
    os.precision(10);
    os << "the motion is too fast to resolve at rtol = " << opt_.rtol << ": a smaller input or communication step, "
       << "or a looser tolerance";
    return os.str();
  }

 private:
  static int rhs_cb(double t, N_Vector y, N_Vector ydot, void* self);
  static int root_cb(double t, N_Vector y, double* g, void* self);
  static void err_cb(int code, const char* module, const char* fn, char* msg, void* self);
  void release();  // frees the CVODE objects (idempotent)
  void check_cvode(int flag, const char* call) const;
  // Integrates one segment [t, b] with CVODE; throws on a stop.
  void integrate(double b);
  // Adds CVODE's counters of the last segment to the statistics and the step budget.
  void count_segment();
  // CVODE found a root at tret (state v): stops there and throws the stop's error.
  [[noreturn]] void stop_at_root(double tret, const double* v);
  void stop_inside(double t_start);
  void stop_before_singularity(double t_start);

  const int nd_, ny_;
  const int lmm_;

  bool sing_exact_ = true;      // the singularity root is evaluated (else reported far away)
  std::vector<double> y_save_;  // segment start, for a re-run with the singularity root on
  std::vector<double> g_;       // work buffer for root values
  std::vector<double> g_prev_;  // the root values of the last state the stops could be computed at

  // Failure recorded inside a CVODE callback (no exception may cross CVODE's C frames).
  int cb_status_ = 0;
  double cb_time_ = 0.0;
  std::string cb_msg_;
  std::string cv_msg_;  // last message of CVODE's error handler

  SUNContext ctx_ = nullptr;
  N_Vector nv_ = nullptr;
  N_Vector nv_back_ = nullptr;  // state interpolated just before a root
  SUNMatrix A_ = nullptr;
  SUNLinearSolver ls_ = nullptr;
  SUNNonlinearSolver nls_ = nullptr;
  void* cvode_ = nullptr;
};

void CvodeStepper::check_cvode(int flag, const char* call) const {
  if (flag < 0)
    throw Error(PKM_ERR_INTEGRATION, std::string("CVODE set-up: ") + call + " failed with " + flag_name(flag) +
                                         (cv_msg_.empty() ? "" : ": " + cv_msg_));
}

CvodeStepper::CvodeStepper(int lmm, Ivp& ivp)
    : Stepper(ivp),
      nd_(ivp.ode.nd()),
      ny_(ivp.ode.ny()),
      lmm_(lmm) {
  const int n2 = ny_;
  const int nroots = stops_.nroots();
  g_.assign(nroots, 0.0);
  try {
    if (SUNContext_Create(nullptr, &ctx_) != 0 || !ctx_)
      throw Error(PKM_ERR_INTEGRATION, "CVODE set-up: SUNContext_Create failed");
    nv_ = N_VNew_Serial(n2, ctx_);
    nv_back_ = N_VNew_Serial(n2, ctx_);
    PKM_REQUIRE(nv_ != nullptr && nv_back_ != nullptr, PKM_ERR_INTERNAL,
                "CVODE set-up: N_VNew_Serial failed (out of memory)");
    double* v = N_VGetArrayPointer(nv_);
    for (int i = 0; i < n2; ++i) v[i] = y_[i];

    cvode_ = CVodeCreate(lmm == PKM_BDF ? CV_BDF : CV_ADAMS, ctx_);
    PKM_REQUIRE(cvode_ != nullptr, PKM_ERR_INTERNAL, "CVODE set-up: CVodeCreate failed (out of memory)");
    check_cvode(CVodeSetErrHandlerFn(cvode_, err_cb, this), "CVodeSetErrHandlerFn");
    check_cvode(CVodeInit(cvode_, rhs_cb, 0.0, nv_), "CVodeInit");
    check_cvode(CVodeSetUserData(cvode_, this), "CVodeSetUserData");
    check_cvode(CVodeSStolerances(cvode_, opt_.rtol, opt_.atol), "CVodeSStolerances");
    if (lmm == PKM_BDF) {
      // Newton iteration with a dense direct solver; no Jacobian function is given, so
      // CVODE builds it by difference quotients of the RHS (2 nd extra RHS calls).
      A_ = SUNDenseMatrix(n2, n2, ctx_);
      PKM_REQUIRE(A_ != nullptr, PKM_ERR_INTERNAL, "CVODE set-up: SUNDenseMatrix failed");
      ls_ = SUNLinSol_Dense(nv_, A_, ctx_);
      PKM_REQUIRE(ls_ != nullptr, PKM_ERR_INTERNAL, "CVODE set-up: SUNLinSol_Dense failed");
      check_cvode(CVodeSetLinearSolver(cvode_, ls_, A_), "CVodeSetLinearSolver");
    } else {
      // Adams for non-stiff motion: fixed-point (functional) iteration needs no Jacobian.
      nls_ = SUNNonlinSol_FixedPoint(nv_, 0, ctx_);
      PKM_REQUIRE(nls_ != nullptr, PKM_ERR_INTERNAL, "CVODE set-up: SUNNonlinSol_FixedPoint failed");
      check_cvode(CVodeSetNonlinearSolver(cvode_, nls_), "CVodeSetNonlinearSolver");
    }
    check_cvode(CVodeSetMaxStep(cvode_, opt_.max_step), "CVodeSetMaxStep");
    check_cvode(CVodeSetMaxNumSteps(cvode_, opt_.max_steps), "CVodeSetMaxNumSteps");
    if (nroots > 0) {
      check_cvode(CVodeRootInit(cvode_, nroots, root_cb), "CVodeRootInit");
      // Only a margin going from positive to negative is a stop; moving back inside is not.
      std::vector<int> dir(nroots, -1);
      if (stops_.singularity()) dir[nroots - 1] = 0;  // det J may change sign either way
      check_cvode(CVodeSetRootDirection(cvode_, dir.data()), "CVodeSetRootDirection");
      check_cvode(CVodeSetNoInactiveRootWarn(cvode_), "CVodeSetNoInactiveRootWarn");
    }
  } catch (...) {
    release();
    throw;
  }
}

void CvodeStepper::release() {
  if (cvode_) CVodeFree(&cvode_);
  if (nls_) SUNNonlinSolFree(nls_);
  if (ls_) SUNLinSolFree(ls_);
  if (A_) SUNMatDestroy(A_);
  if (nv_) N_VDestroy(nv_);
  if (nv_back_) N_VDestroy(nv_back_);
  if (ctx_) SUNContext_Free(&ctx_);
  cvode_ = nullptr;
  nls_ = nullptr;
  ls_ = nullptr;
  A_ = nullptr;
  nv_ = nullptr;
  nv_back_ = nullptr;
  ctx_ = nullptr;
}

// ------------------------------------------------------------------- callbacks

int CvodeStepper::rhs_cb(double t, N_Vector y, N_Vector ydot, void* self) {
  CvodeStepper& s = *static_cast<CvodeStepper*>(self);
  const double* Y = N_VGetArrayPointer(y);
  double* F = N_VGetArrayPointer(ydot);
  const int n = s.nd_;
  if (s.budget_.past_deadline()) {  // CVODE cannot be interrupted otherwise: an unrecoverable failure
    s.cb_status_ = PKM_ERR_STEP_BUDGET;
    s.cb_time_ = t;
    s.cb_msg_ = s.budget_.message(s.t_, s.budget_.t_end(), true);
    return -1;
  }
  for (int i = 0; i < s.ny_; ++i) {
    if (!std::isfinite(Y[i])) {
      s.cb_status_ = PKM_ERR_INTEGRATION;
      s.cb_time_ = t;
      s.cb_msg_ = "the trial state y[" + std::to_string(i) + "] is not finite";
      return 1;
    }
  }
  try {
    // Mechanics plus the drive layer (joint friction, rotor inertia, two-body joints).
    s.ode_.trends_at(t);  // the parameters' trends at the stage's time (pkm_param_set_course)
    s.ode_.rates(Y, s.applied_.data(), F);
  } catch (const Error& e) {
    s.cb_status_ = e.status;
    s.cb_time_ = t;
    s.cb_msg_ = std::string("forward dynamics: ") + e.what();
    return recoverable(e.status) ? 1 : -1;
  } catch (const std::exception& e) {
    s.cb_status_ = PKM_ERR_INTERNAL;
    s.cb_time_ = t;
    s.cb_msg_ = std::string("forward dynamics: internal error: ") + e.what();
    return -1;
  } catch (...) {
    s.cb_status_ = PKM_ERR_INTERNAL;
    s.cb_time_ = t;
    s.cb_msg_ = "forward dynamics: unknown exception";
    return -1;
  }
  for (int i = 0; i < s.ny_ - n; ++i) {
    if (!std::isfinite(F[n + i])) {
      s.cb_status_ = PKM_ERR_SINGULAR;
      s.cb_time_ = t;
      s.cb_msg_ = "forward dynamics returned a non-finite acceleration xdd[" + std::to_string(i) + "]";
      return 1;
    }
  }
  return 0;
}

int CvodeStepper::root_cb(double t, N_Vector y, double* g, void* self) {
  CvodeStepper& s = *static_cast<CvodeStepper*>(self);
  try {
    s.stops_.roots(N_VGetArrayPointer(y), g, s.sing_exact_);
  } catch (const Error& e) {
    const int nr = s.stops_.nroots();
    if (e.status == PKM_ERR_JOINT_LIMIT && s.stops_.nlimits() > 0 && (int)s.g_prev_.size() == nr) {
      // The robot refuses a joint past its limit (a fast motion: the trial state is past
      // it): every limit margin negative, the other roots as they were, so that CVODE
      // brackets the crossing and stops there as a joint limit (named at the stop).
      for (int k = 0; k < nr; ++k) g[k] = k < s.stops_.nlimits() ? -1.0 : s.g_prev_[k];
      return 0;
    }
    s.cb_status_ = e.status;
    s.cb_time_ = t;
    s.cb_msg_ = std::string("stop-condition check: ") + e.what();
    return -1;
  } catch (...) {
    s.cb_status_ = PKM_ERR_INTERNAL;
    s.cb_time_ = t;
    s.cb_msg_ = "stop-condition check: unknown exception";
    return -1;
  }
  for (int k = 0; k < s.stops_.nroots(); ++k)
    if (!std::isfinite(g[k])) {
      s.cb_status_ = PKM_ERR_SINGULAR;
      s.cb_time_ = t;
      s.cb_msg_ = "stop-condition check: a joint value or singularity measure is not finite";
      return -1;
    }
  s.g_prev_.assign(g, g + s.stops_.nroots());
  return 0;
}

void CvodeStepper::err_cb(int code, const char* module, const char* fn, char* msg, void* self) {
  if (code >= 0) return;  // warnings (e.g. t + h == t) are not failures
  CvodeStepper& s = *static_cast<CvodeStepper*>(self);
  try {
    s.cv_msg_ = std::string(module ? module : "CVODE") + "/" + (fn ? fn : "?") + ": " + (msg ? msg : "");
  } catch (...) {
  }
}

// -------------------------------------------------------------------- segments

// CVODE reports a root at the near side of its final bracket, where the margin has
// already turned <= 0 (a stroke a few 1e-16 m past its limit).  Stepping back by CVODE's
// root tolerance, on the interpolant of the last step, gives a state still inside every
// limit, so that the caller's inverse kinematics, a reset to it and the recorded q all
// work there.  The stop time moves by ~1e-14 s.
void CvodeStepper::stop_inside(double t_start) {
  double h = 0, tcur = t_;
  CVodeGetLastStep(cvode_, &h);
  CVodeGetCurrentTime(cvode_, &tcur);
  const double ttol = (std::fabs(t_) + std::fabs(h)) * DBL_EPSILON * 100;
  const double* b = N_VGetArrayPointer(nv_back_);
  for (int j = 0; j < 8; ++j) {
    const double tb = t_ - ttol * double(1 << j);
    if (!(tb > t_start) || tb < tcur - std::fabs(h)) return;
    if (CVodeGetDky(cvode_, tb, 0, nv_back_) != CV_SUCCESS) return;
    try {
      stops_.roots(b, g_.data(), sing_exact_);
    } catch (const Error&) {
      continue;
    }
    bool inside = true;
    for (int k = 0; k < stops_.nstop(); ++k) inside = inside && g_[k] > 0;
    if (inside) {
      for (int i = 0; i < ny_; ++i) inside = inside && std::isfinite(b[i]);
      if (!inside) return;
      for (int i = 0; i < ny_; ++i) y_[i] = b[i];
      t_ = tb;
      return;
    }
  }
}

// Bisection on the interpolant of the last step for the first time the measure falls
// to sing_min before the det J root at t_: the stop state is then the last one with
// measure > sing_min, like a stop found by the measure's own root.
void CvodeStepper::stop_before_singularity(double t_start) {
  double h = 0, tcur = t_;
  CVodeGetLastStep(cvode_, &h);
  CVodeGetCurrentTime(cvode_, &tcur);
  double lo = std::max(t_start, tcur - std::fabs(h)), hi = t_;
  const double* b = N_VGetArrayPointer(nv_back_);
  auto above = [&](double t) {
    if (CVodeGetDky(cvode_, t, 0, nv_back_) != CV_SUCCESS) return false;
    try {
      return stops_.measure(b) > stops_.sing_min();
    } catch (const Error&) {
      return false;
    }
  };
  if (!above(lo)) return;  // keep CVODE's crossing point
  for (int it = 0; it < 200 && hi - lo > 4 * DBL_EPSILON * std::max(1.0, std::fabs(hi)); ++it) {
    const double mid = 0.5 * (lo + hi);
    if (above(mid))
      lo = mid;
    else
      hi = mid;
  }
  if (CVodeGetDky(cvode_, lo, 0, nv_back_) != CV_SUCCESS) return;
  for (int i = 0; i < ny_; ++i)
    if (!std::isfinite(b[i])) return;
  for (int i = 0; i < ny_; ++i) y_[i] = b[i];
  t_ = lo;
}

// The singularity measure costs an SVD, more than the forward dynamics; as a root
// function it is evaluated at every CVODE step.  Far from the threshold it is not
// needed there: a segment that starts with the measure above StopConditions::kSingGuard x sing_min runs
// with the singularity root switched off, and if it ends (or stops) below that guard it
// is run again from the same start with the root on, which then locates a crossing
// exactly.  Both runs are deterministic functions of (t, x, xd, tau, options), so the
// reproducibility guarantee holds.  A pass through a singularity inside the segment is
// still caught by the det J root, which stays on; what goes unseen is a dip of the
// measure below sing_min without J changing sign, back above the guard within a segment.
bool CvodeStepper::advance(double t_end) {
  if (!stops_.singularity()) {
    integrate(t_end);
    return true;
  }
  struct Restore {
    bool& flag;
    ~Restore() { flag = true; }
  } restore{sing_exact_};
  const double guard = stops_.sing_guard();
  sing_exact_ = true;
  double meas_start = stops_.measure(y_.data());
  if (meas_start < guard) {
    integrate(t_end);
    return true;
  }
  const double t0 = t_;
  std::vector<double>& y0 = y_save_;
  y0 = y_;
  sing_exact_ = false;
  bool again = false;
  try {
    integrate(t_end);
    again = stops_.measure(y_.data()) < guard;
  } catch (const Error&) {
    // A stop or failure with the root off: if it happened near the threshold, a missed
    // singularity may be the cause; otherwise the stop stands.
    double m_end = -1.0;
    try {
      m_end = stops_.measure(y_.data());
    } catch (const Error&) {
    }
    if (m_end >= guard) {
      sing_exact_ = true;
      throw;
    }
    again = true;
  }
  sing_exact_ = true;
  if (!again) return true;
  t_ = t0;
  y_ = y0;
  integrate(t_end);
  return true;
}

void CvodeStepper::count_segment() {
  long nst = 0, nfe = 0, nfeLS = 0, nje = 0, netf = 0, nncf = 0;
  CVodeGetNumSteps(cvode_, &nst);
  CVodeGetNumRhsEvals(cvode_, &nfe);
  CVodeGetNumErrTestFails(cvode_, &netf);
  CVodeGetNumNonlinSolvConvFails(cvode_, &nncf);
  if (lmm_ == PKM_BDF) {
    CVodeGetNumLinRhsEvals(cvode_, &nfeLS);
    CVodeGetNumJacEvals(cvode_, &nje);
  }
  stats_.steps += nst;
  stats_.rhs_evals += nfe + nfeLS;
  stats_.jac_evals += nje;
  stats_.error_test_fails += netf;
  stats_.nonlin_conv_fails += nncf;
  budget_.spend(nst);
}

void CvodeStepper::stop_at_root(double tret, const double* v) {
  const int n2 = ny_;
  std::vector<int> found(stops_.nroots(), 0);
  CVodeGetRootInfo(cvode_, found.data());
  int k = 0;
  while (k < stops_.nroots() && found[k] == 0) ++k;
  if (k == stops_.nroots()) k = 0;
  const double t_start = t_;
  for (int i = 0; i < n2; ++i) y_[i] = v[i];
  t_ = tret;
  if (k == stops_.nstop()) {
    // det J changed sign: the motion crossed a direct singularity inside the last step.
    // Stop where the measure first reached sing_min, found on CVODE's interpolant.
    const double t_cross = t_;
    stop_before_singularity(t_start);
    k = stops_.nstop() - 1;
    try {
      stops_.roots(y_.data(), g_.data(), sing_exact_);
    } catch (const Error&) {
      for (int j = 0; j < stops_.nroots(); ++j) g_[j] = 0.0;
    }
    throw Error(PKM_ERR_SINGULAR, stops_.message(k, g_.data(), t_, false) + " (the motion crosses the singularity at t = " +
                                      num(t_cross) + " s)");
  }
  stop_inside(t_start);
  try {
    stops_.roots(y_.data(), g_.data(), sing_exact_);
    // Several limits found at once (their margins set negative past a joint the robot
    // refused, root_cb): the stop is the one with the least margin here.
    for (int j = 0; j < stops_.nlimits(); ++j)
      if (found[j] != 0 && k < stops_.nlimits() && g_[j] < g_[k]) k = j;
  } catch (const Error&) {
    // The root values at the stop are only for the message; keep CVODE's crossing.
    for (int j = 0; j < stops_.nroots(); ++j) g_[j] = 0.0;
  }
  throw Error(stops_.status(k), stops_.message(k, g_.data(), t_, false));
}

void CvodeStepper::integrate(double t_end) {
  // An interval CVODE cannot resolve (tout too close to t0) only moves the clock: the
  // state changes by |xd| * dt ~ 1e-16 relative, below any tolerance.
  if (t_end - t_ < 4 * DBL_EPSILON * std::max({1.0, std::fabs(t_), std::fabs(t_end)})) {
    t_ = t_end;
    return;
  }

  const int n2 = ny_;
  double* v = N_VGetArrayPointer(nv_);
  for (int i = 0; i < n2; ++i) v[i] = y_[i];
  cb_status_ = 0;
  cb_msg_.clear();
  cv_msg_.clear();
  check_cvode(CVodeReInit(cvode_, t_, nv_), "CVodeReInit");
  check_cvode(CVodeSetStopTime(cvode_, t_end), "CVodeSetStopTime");
  if (budget_.left() <= 0) budget_.exceeded(t_, t_end, false);
  check_cvode(CVodeSetMaxNumSteps(cvode_, budget_.left()), "CVodeSetMaxNumSteps");

  double tret = t_;
  const int flag = CVode(cvode_, t_end, nv_, &tret, CV_NORMAL);

  count_segment();
  v = N_VGetArrayPointer(nv_);
  bool finite = true;
  for (int i = 0; i < n2; ++i) finite = finite && std::isfinite(v[i]);

  if (flag == CV_SUCCESS || flag == CV_TSTOP_RETURN) {
    PKM_REQUIRE(finite, PKM_ERR_INTERNAL, "advance: CVODE returned a non-finite state at t = " + num(t_end) + " s");
    for (int i = 0; i < n2; ++i) y_[i] = v[i];
    t_ = t_end;
    return;
  }

  if (flag == CV_ROOT_RETURN) {
    PKM_REQUIRE(finite, PKM_ERR_INTERNAL, "advance: CVODE returned a non-finite state at t = " + num(tret) + " s");
    stop_at_root(tret, v);
  }

  // A failure: keep the farthest state CVODE reached, if it is a valid one.
  if (finite && tret > t_ && tret <= t_end) {
    for (int i = 0; i < n2; ++i) y_[i] = v[i];
    t_ = tret;
  }
  if (flag == CV_TOO_MUCH_WORK) budget_.exceeded(t_, t_end, false);
  const std::string name = flag_name(flag);
  if (cb_status_ == PKM_ERR_STEP_BUDGET) budget_.exceeded(t_, t_end, true);  // the message with the time reached
  if (cb_status_ != 0 && callback_flag(flag)) {
    throw Error(cb_status_, cb_msg_ + " at t = " + num(cb_time_) + " s (CVODE stopped with " + name +
                                "; state kept at t = " + num(t_) + " s)");
  }
  std::string msg = "CVODE failed with " + name + " at t = " + num(t_) + " s";
  if (!cv_msg_.empty()) msg += ": " + cv_msg_;
  if (cb_status_ != 0) msg += " (last callback failure: " + cb_msg_ + " at t = " + num(cb_time_) + " s)";
  throw Error(PKM_ERR_INTEGRATION, msg);
}

}  // namespace

std::unique_ptr<Stepper> make_cvode_stepper(int method, Ivp& ivp) { return std::make_unique<CvodeStepper>(method, ivp); }

}  // namespace pkm

#endif  // PKM_NO_CVODE
