// CVODE integration of the task-space state y = [x; xd] (2 nd values):
//   dy/dt = [xd; FD(x, xd, tau_applied)],
// FD the total forward dynamics (robot mechanics + drive friction and rotor inertia),
// tau_applied the saturated command held over an advance (zero-order hold), or with an
// actuator delay the command issued `delay` earlier.
//
// Design choices (docs/integration.md explains them at length):
//  * One SUNContext, vector, solver set and CVODE memory per Sim: no global state, so
//    any number of simulators may run in one process (one thread each).
//  * Every advance calls CVodeReInit from the committed state, so an advance is a pure
//    function of (t, x, xd, tau, options): rollback + re-advance is bit-for-bit equal.
//  * Stop conditions are CVODE root functions, found once at construction: the stroke /
//    joint limits named in the model parameters, the direct-singularity measure and the
//    sign of det J.  CVODE evaluates them once per step (not per RHS call) and locates
//    the crossing; the costly measure only near its threshold (see segment()).
//  * No exception crosses CVODE's C frames: callbacks catch, record the failure and
//    return CVODE's recoverable (1) or unrecoverable (-1) code.
//  * The RHS calls the total forward dynamics directly (arguments were checked on the
//    way in), with no allocation.
#include "integration/sim.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iomanip>
#include <sstream>

#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

#include "common/guard.hpp"
#include "kinematics/generic_kinematics.hpp"

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

// How far (in joint units, or in the singularity measure) a state given to reset may lie
// beyond a stop boundary: a state saved at a stop is there by round-off.
constexpr double kResetSlack = 1e-12;

// How far back (simulated seconds) the actuator delay line is kept for rollbacks.
constexpr double kHistory = 1.0;

// The singularity root is evaluated at every step only within kSingGuard x sing_min.
constexpr double kSingGuard = 100.0;

// With a time limit, the clock is read every this many steps or right-hand sides.
constexpr long kClockEvery = 32;

}  // namespace

// ----------------------------------------------------------------- construction

static void check_options(const pkm_sim_options& o) {
  auto bad = [](const std::string& what) { throw Error(PKM_ERR_ARGUMENT, "pkm_sim options: " + what); };
  if (o.method != PKM_BDF && o.method != PKM_ADAMS && o.method != PKM_ERK && o.method != PKM_ERK23)
    bad("method = " + std::to_string(o.method) + " is none of PKM_BDF (0), PKM_ADAMS (1), PKM_ERK (2), PKM_ERK23 (3)");
#ifdef PKM_NO_CVODE  // the FMU binaries of platforms without a SUNDIALS library (fmu/platform)
  if (o.method == PKM_BDF || o.method == PKM_ADAMS)
    bad("method = " + std::to_string(o.method) + (o.method == PKM_BDF ? " (BDF)" : " (Adams)") +
        " needs SUNDIALS CVODE, which this binary (" PKM_NO_CVODE ") does not carry: use PKM_ERK (2) or PKM_ERK23 (3)");
#endif
  if (!(std::isfinite(o.rtol) && o.rtol > 0 && o.rtol < 1))
    bad("rtol = " + num(o.rtol) + " must be in (0, 1)");
  if (!(std::isfinite(o.atol) && o.atol > 0)) bad("atol = " + num(o.atol) + " must be finite and > 0");
  if (!(std::isfinite(o.max_step) && o.max_step >= 0))
    bad("max_step = " + num(o.max_step) + " s must be finite and >= 0 (0 = unlimited)");
  if (o.max_steps <= 0 || o.max_steps > PKM_SIM_MAX_STEPS_LIMIT)
    bad("max_steps = " + std::to_string(o.max_steps) + " must be in [1, " + std::to_string(PKM_SIM_MAX_STEPS_LIMIT) +
        "]: it bounds the work of one advance (a call must return; docs/integration.md, Bounded work)");
  if (!(std::isfinite(o.sing_min) && o.sing_min >= 0 && o.sing_min < 1))
    bad("sing_min = " + num(o.sing_min) + " must be in [0, 1) (0 = no singularity stop)");
}

void Sim::check_cvode(int flag, const char* call) const {
  if (flag < 0)
    throw Error(PKM_ERR_INTEGRATION, std::string("CVODE set-up: ") + call + " failed with " + flag_name(flag) +
                                         (cv_msg_.empty() ? "" : ": " + cv_msg_));
}

Sim::Sim(const pkm_model* m, const pkm_sim_options& opt) {
  PKM_REQUIRE(m != nullptr, PKM_ERR_ARGUMENT, "model is NULL");
  check_options(opt);
  PKM_REQUIRE(m->compiled != nullptr, PKM_ERR_PARAMETER,
          "the model's parameters were changed and not validated: call pkm_model_validate before pkm_sim_create");
  opt_ = opt;
  try {
    model_ = pkm_model_copy(m);
    PKM_REQUIRE(model_ != nullptr, PKM_ERR_INTERNAL, "out of memory copying the model");
    robot_ = model_->robot;
    nd_ = robot_->ndof();
    find_limits();
    open_limits();
    data_ = pkm_data_create(model_);
    PKM_REQUIRE(data_ != nullptr, PKM_ERR_INTERNAL, "out of memory creating the work data");
    rm_ = &prepare(model_, data_);
    rd_ = data_->rd.get();
    if (model_->drive)
      for (int i = 0; i < nd_; ++i)
        if (model_->drive->two_body_joint(i)) two_.push_back(i);
    if (!two_.empty()) carriage_ = drive::carriage_side(*model_->drive);
    ny_ = two_.empty() ? 2 * nd_ : 4 * nd_;
    const int n2 = ny_;

    y_.assign(n2, 0.0);
    PKM_REQUIRE(nd_ <= 6, PKM_ERR_INTERNAL, "the simulator supports up to 6 actuated joints");
    tau_.assign(nd_, 0.0);
    applied_.assign(nd_, 0.0);
    external_.assign(nd_, 0.0);
    fsal_f_.assign(n2, 0.0);
    fsal_B_.assign((size_t)nd_ * nd_, 0.0);
    reuse_input_ = explicit_method() && two_.empty();  // a two-body joint's effort depends on the state
    delay_ = model_->drive ? model_->drive->actuator_delay : 0.0;
    q_.assign(nd_, 0.0);
    robot_->home(*rm_, y_.data());
    if (!two_.empty()) {  // the drive bodies at their joints, at rest
      robot_->ik(*rm_, *rd_, y_.data(), q_.data());
      for (int i : two_) y_[2 * nd_ + i] = q_[i];
    }
    if (opt_.sing_min > 0) {
      double meas[2];
      try {
        robot_->singularity(*rm_, *rd_, y_.data(), meas);
        sing_root_ = true;
      } catch (const Error& e) {
        if (e.status != PKM_ERR_UNSUPPORTED) throw;
      }
    }
    // Roots: the stroke margins, the singularity measure above sing_min, and the sign of
    // det J, which flips when the motion passes through a direct singularity (a dip of
    // the measure below sing_min and back within one CVODE step shows no sign change of
    // the measure itself).
    nstop_ = (int)limits_.size() + (sing_root_ ? 1 : 0);
    nroots_ = nstop_ + (sing_root_ ? 1 : 0);
    g_.assign(nroots_, 0.0);
    g_cached_.assign(nroots_ + 1, 0.0);

    // The explicit methods need no CVODE objects until a stiff stretch hands a segment to
    // BDF (erk_segment); the CVODE methods create theirs now.
    if (!explicit_method()) cvode_create(opt_.method);
  } catch (...) {
    release();
    throw;
  }
}

// CVODE's objects for the linear multistep method lmm (PKM_BDF or PKM_ADAMS), with the
// stop conditions as root functions.
void Sim::cvode_create(int lmm) {
  const int n2 = ny_;
  cvode_lmm_ = lmm;
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
  if (nroots_ > 0) {
    check_cvode(CVodeRootInit(cvode_, nroots_, root_cb), "CVodeRootInit");
    // Only a margin going from positive to negative is a stop; moving back inside is not.
    std::vector<int> dir(nroots_, -1);
    if (sing_root_) dir[nroots_ - 1] = 0;  // det J may change sign either way
    check_cvode(CVodeSetRootDirection(cvode_, dir.data()), "CVodeSetRootDirection");
    check_cvode(CVodeSetNoInactiveRootWarn(cvode_), "CVodeSetNoInactiveRootWarn");
  }
}

Sim::~Sim() { release(); }

void Sim::release() {
  if (cvode_) CVodeFree(&cvode_);
  if (nls_) SUNNonlinSolFree(nls_);
  if (ls_) SUNLinSolFree(ls_);
  if (A_) SUNMatDestroy(A_);
  if (nv_) N_VDestroy(nv_);
  if (nv_back_) N_VDestroy(nv_back_);
  if (ctx_) SUNContext_Free(&ctx_);
  if (data_) pkm_data_destroy(data_);
  if (model_) pkm_model_destroy(model_);
  cvode_ = nullptr;
  nls_ = nullptr;
  ls_ = nullptr;
  A_ = nullptr;
  nv_ = nullptr;
  nv_back_ = nullptr;
  ctx_ = nullptr;
  data_ = nullptr;
  model_ = nullptr;
}

// The limits are the robot's own (Robot::joint_limit_param, the same the FMUs and the
// Python package read through pkm_model_joint_limits); a limit set to a huge value means
// "no limit".
void Sim::find_limits() {
  for (int j = 0; j < nd_; ++j) {
    int idx[2] = {-1, -1};
    pkm_model_joint_limits(model_, j, &idx[0], &idx[1]);
    for (int upper = 0; upper < 2; ++upper) {
      if (idx[upper] < 0) continue;
      const double v = pkm_param_get(model_, idx[upper]);
      if (std::isfinite(v) && std::fabs(v) < 1e100)
        limits_.push_back({j, upper != 0, v, pkm_param_name(model_, idx[upper]), pkm_param_unit(model_, idx[upper]),
                           robot_->limb_noun()});
    }
  }
}

// The sim enforces the limits itself, as root functions that locate the crossing time.
// A robot's inverse kinematics may refuse strokes outside [qmin, qmax] (the 6-PUS does);
// the root function must see the stroke just past the limit to find the crossing, and a
// trial step of CVODE may go there too.  So the sim's private model copy gets each limit
// parameter opened to the end of its valid range; the limits found above stay the stops.
void Sim::open_limits() {
  if (limits_.empty()) return;
  std::vector<double> saved = model_->values;
  for (const JointLimit& L : limits_) {
    const int idx = pkm_param_index(model_, L.param.c_str());
    const ParamSpec& spec = model_->specs[idx];
    const double wide = L.upper ? std::min(spec.hi, 1e6) : std::max(spec.lo, -1e6);
    model_->values[idx] = wide;
  }
  char err[512];
  if (pkm_model_validate(model_, err, sizeof err) != PKM_OK) {
    // The robot does not accept open limits: keep them; a crossing may then be reported
    // as the robot's own joint-limit error from inside the step instead of a root.
    model_->values = saved;
    if (pkm_model_validate(model_, err, sizeof err) != PKM_OK)
      throw Error(PKM_ERR_PARAMETER, std::string("the model copy does not validate: ") + err);
  }
}

// ------------------------------------------------------------------- callbacks

int Sim::rhs_cb(double t, N_Vector y, N_Vector ydot, void* self) {
  Sim& s = *static_cast<Sim*>(self);
  const double* Y = N_VGetArrayPointer(y);
  double* F = N_VGetArrayPointer(ydot);
  const int n = s.nd_;
  if (s.past_deadline()) {  // CVODE cannot be interrupted otherwise: an unrecoverable failure
    s.cb_status_ = PKM_ERR_STEP_BUDGET;
    s.cb_time_ = t;
    s.cb_msg_ = s.budget_message(s.budget_end_, true);
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
    s.dynamics(Y, s.applied_.data(), F);
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

void Sim::dynamics(const double* y, const double* u, double* f) {
  const int n = nd_;
  for (int i = 0; i < n; ++i) f[i] = y[n + i];
  if (two_.empty()) {
    total_forward_dynamics(model_, data_, y, y + n, u, f + n);
    return;
  }
  // Two-body joints: the carriage feels the transmitted effort, the drive body the command
  // less that effort and its own friction.
  double q[6], qd[6], eff[6], fr[6];
  joints_of(y, q, qd);
  const drive::Params& dp = *model_->drive;
  const double* th = y + 2 * n;
  const double* thd = y + 3 * n;
  for (int i = 0; i < n; ++i) eff[i] = u[i];
  drive::friction(dp, thd, fr);
  for (int i = 0; i < n; ++i) f[2 * n + i] = 0.0, f[3 * n + i] = 0.0;
  for (int i : two_) {
    const double t = drive::transmitted_effort(dp, i, th[i] - q[i], thd[i] - qd[i]);
    eff[i] = t;
    f[2 * n + i] = thd[i];
    f[3 * n + i] = (u[i] - t - fr[i]) / dp.rotor[i];
  }
  total_forward_dynamics(model_, *carriage_, data_, y, y + n, eff, f + n);
}

void Sim::joints_of(const double* y, double* q, double* qd) {
  robot_->ik(*rm_, *rd_, y, q);
  joint_velocity(*robot_, *rm_, *rd_, y, y + nd_, qd);
}

void Sim::acceleration(const double* tau, double* xdd) {
  check_finite(tau, nd_, "acceleration: tau");
  double u[6], f[24];
  if (model_->drive)
    actuator_effort(*model_->drive, tau, u);
  else
    for (int i = 0; i < nd_; ++i) u[i] = tau[i];
  dynamics(y_.data(), u, f);
  for (int i = 0; i < nd_; ++i) xdd[i] = f[nd_ + i];
}

void Sim::drive_state(double* theta, double* theta_d) {
  const int n = nd_;
  if (two_.size() < (size_t)n) {
    double q[6], qd[6];
    joints_of(y_.data(), q, qd);
    for (int i = 0; i < n; ++i) {
      if (theta) theta[i] = q[i];
      if (theta_d) theta_d[i] = qd[i];
    }
  }
  for (int i : two_) {
    if (theta) theta[i] = y_[2 * n + i];
    if (theta_d) theta_d[i] = y_[3 * n + i];
  }
}

void Sim::roots(const double* y, double* g) {
  int k = 0;
  if (!limits_.empty()) {
    robot_->ik(*rm_, *rd_, y, q_.data());
    for (const JointLimit& L : limits_) g[k++] = L.upper ? L.value - q_[L.joint] : q_[L.joint] - L.value;
  }
  if (sing_root_) {
    if (sing_exact_) {
      double meas[2];
      robot_->singularity(*rm_, *rd_, y, meas);
      g[k++] = meas[1] - opt_.sing_min;
    } else {
      g[k++] = 1.0;  // far from the threshold for this segment (see segment())
    }
    g[k++] = det_j(y);
  }
}

double Sim::det_j(const double* y) {
  using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 6, 6>;
  Mat J(nd_, nd_);
  robot_->jacobians(*rm_, *rd_, y, nullptr, nullptr, J.data());
  return Eigen::PartialPivLU<Mat>(J).determinant();
}

int Sim::root_cb(double t, N_Vector y, double* g, void* self) {
  Sim& s = *static_cast<Sim*>(self);
  try {
    s.roots(N_VGetArrayPointer(y), g);
  } catch (const Error& e) {
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
  for (int k = 0; k < s.nroots_; ++k)
    if (!std::isfinite(g[k])) {
      s.cb_status_ = PKM_ERR_SINGULAR;
      s.cb_time_ = t;
      s.cb_msg_ = "stop-condition check: a joint value or singularity measure is not finite";
      return -1;
    }
  return 0;
}

void Sim::err_cb(int code, const char* module, const char* fn, char* msg, void* self) {
  if (code >= 0) return;  // warnings (e.g. t + h == t) are not failures
  Sim& s = *static_cast<Sim*>(self);
  try {
    s.cv_msg_ = std::string(module ? module : "CVODE") + "/" + (fn ? fn : "?") + ": " + (msg ? msg : "");
  } catch (...) {
  }
}

// -------------------------------------------------------------------- messages

std::string Sim::root_message(int k, const double* g, double t, bool at_start) const {
  std::ostringstream os;
  os.precision(10);
  if (k < (int)limits_.size()) {
    const JointLimit& L = limits_[k];
    const double q = L.upper ? L.value - g[k] : L.value + g[k];
    const char* kind = robot_->joints_angular() ? "joint limit" : "stroke limit";
    os << L.noun << " " << (L.joint + 1) << (at_start ? " is at or beyond its " : " reached its ") << kind << " "
       << L.param << " = " << L.value << " " << L.unit << " at t = " << t << " s (q" << (L.joint + 1) << " = " << q
       << " " << L.unit << ")";
  } else {
    const double meas = g[k] + opt_.sing_min;
    if (at_start)
      os << "direct (type 2) singularity: measure " << std::setprecision(4) << meas << " <= sing_min = " << opt_.sing_min
         << std::setprecision(10) << " at t = " << t << " s";
    else
      os << "direct (type 2) singularity: measure " << std::scientific << std::setprecision(6) << meas
         << std::defaultfloat << std::setprecision(10) << " reached sing_min = " << opt_.sing_min << " at t = " << t << " s";
  }
  if (at_start) os << "; the simulation cannot go on from this state: reset it to one inside the limits";
  return os.str();
}

static int root_status(const Sim&, bool is_limit) { return is_limit ? PKM_ERR_JOINT_LIMIT : PKM_ERR_SINGULAR; }

// -------------------------------------------------------------------- the API

void Sim::reset(double t0, const double* x, const double* xd) {
  PKM_REQUIRE(std::isfinite(t0), PKM_ERR_ARGUMENT, "reset: t0 = " + num(t0) + " is not finite");
  check_finite(x, nd_, "reset: pose x");
  check_finite(xd, nd_, "reset: pose velocity xd");
  std::vector<double> y(ny_, 0.0);
  for (int i = 0; i < nd_; ++i) {
    y[i] = x[i];
    y[nd_ + i] = xd[i];
  }
  try {
    roots(y.data(), g_.data());
  } catch (const Error& e) {
    throw Error(e.status, std::string("reset: ") + e.what());
  }
  for (int k = 0; k < nstop_; ++k) {
    if (g_[k] < -kResetSlack) {
      const bool lim = k < (int)limits_.size();
      std::ostringstream os;
      os.precision(10);
      if (lim) {
        const JointLimit& L = limits_[k];
        os << "reset: " << L.noun << " " << (L.joint + 1) << " stroke q" << (L.joint + 1) << " = "
           << (L.upper ? L.value - g_[k] : L.value + g_[k]) << " " << L.unit << " is beyond its limit " << L.param
           << " = " << L.value << " " << L.unit;
      } else {
        os << "reset: the pose is too close to a direct (type 2) singularity (measure " << std::setprecision(3)
           << g_[k] + opt_.sing_min << " < sing_min = " << opt_.sing_min << ")";
      }
      throw Error(root_status(*this, lim), os.str());
    }
  }
  // A start whose energy overflows (a rate of 1e200 m/s) is no state of a robot.
  double kinetic = 0, potential = 0;
  try {
    total_energy(model_, data_, y.data(), y.data() + nd_, &kinetic, &potential);
    if (!two_.empty()) {  // the drive bodies start at their joints, with their rates
      double q[6], qd[6];
      joints_of(y.data(), q, qd);
      for (int i : two_) y[2 * nd_ + i] = q[i], y[3 * nd_ + i] = qd[i];
    }
  } catch (const Error& e) {
    throw Error(e.status, std::string("reset: ") + e.what());
  }
  t_ = t0;
  y_.swap(y);
  h_next_ = 0.0;  // a new start: the explicit method chooses its first step afresh
  guard_cached_ = false;
  fsal_valid_ = false;
  // Commands issued at or after t0 belong to the future being rolled back.
  while (!history_.empty() && history_.back().s >= t0) history_.pop_back();
  while (!readings.empty() && readings.back().t >= t0) readings.pop_back();
}

void Sim::delayed_reading(double t, double* q, double* qd) {
  const double d = model_->drive ? model_->drive->sensor_delay : 0.0;
  if (!(d > 0)) return;
  Reading r{};
  r.t = t;
  for (int i = 0; i < nd_; ++i) r.q[i] = q[i], r.qd[i] = qd[i];
  readings.push_back(r);
  const double s = t - d;
  // Keep one sample at or before the oldest time a later call can ask for (s grows).
  size_t drop = 0;
  while (drop + 1 < readings.size() && readings[drop + 1].t <= s) ++drop;
  if (drop > 0) readings.erase(readings.begin(), readings.begin() + (long)drop);
  const Reading& a = readings.front();
  if (s <= a.t || readings.size() == 1) {
    for (int i = 0; i < nd_; ++i) q[i] = a.q[i], qd[i] = a.qd[i];
    return;
  }
  const Reading& b = readings[1];
  const double f = (s - a.t) / (b.t - a.t);
  for (int i = 0; i < nd_; ++i) {
    q[i] = a.q[i] * (1 - f) + b.q[i] * f;
    qd[i] = a.qd[i] * (1 - f) + b.qd[i] * f;
  }
}

void Sim::set_input(const double* tau) {
  check_finite(tau, nd_, "input tau");
  double sat[6];
  // Saturation (drive parameters <j>[i].effort_max) acts on the command itself.
  if (model_->drive)
    actuator_effort(*model_->drive, tau, sat);
  else
    for (int i = 0; i < nd_; ++i) sat[i] = tau[i];
  for (int i = 0; i < nd_; ++i) tau_[i] = sat[i];
}

void Sim::command_at(double t, double* tau) const {
  if (history_.empty() || t < history_.front().s) {
    // Before the first recorded command (the start of the run) nothing was commanded.
    for (int i = 0; i < nd_; ++i) tau[i] = 0.0;
    return;
  }
  size_t k = history_.size() - 1;
  while (k > 0 && history_[k].s > t) --k;
  for (int i = 0; i < nd_; ++i) tau[i] = history_[k].tau[i];
}

void Sim::set_external(const double* f) {
  check_finite(f, nd_, "external effort");
  for (int i = 0; i < nd_; ++i) external_[i] = f[i];
}

void Sim::applied_effort(double* tau) const {
  if (!(delay_ > 0)) {
    for (int i = 0; i < nd_; ++i) tau[i] = tau_[i];
    return;
  }
  // A command whose delayed start falls on t (a delay of whole periods) acts from t on:
  // the sample time and the history's start times are sums of periods, equal to rounding.
  command_at(t_ - delay_ + 1e-12, tau);
}

void Sim::get_state(double* t, double* x, double* xd) const {
  if (t) *t = t_;
  for (int i = 0; i < nd_; ++i) {
    if (x) x[i] = y_[i];
    if (xd) xd[i] = y_[nd_ + i];
  }
}

// CVODE reports a root at the near side of its final bracket, where the margin has
// already turned <= 0 (a stroke a few 1e-16 m past its limit).  Stepping back by CVODE's
// root tolerance, on the interpolant of the last step, gives a state still inside every
// limit, so that the caller's inverse kinematics, a reset to it and the recorded q all
// work there.  The stop time moves by ~1e-14 s.
void Sim::stop_inside(double t_start) {
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
      roots(b, g_.data());
    } catch (const Error&) {
      continue;
    }
    bool inside = true;
    for (int k = 0; k < nstop_; ++k) inside = inside && g_[k] > 0;
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
void Sim::stop_before_singularity(double t_start) {
  double h = 0, tcur = t_;
  CVodeGetLastStep(cvode_, &h);
  CVodeGetCurrentTime(cvode_, &tcur);
  double lo = std::max(t_start, tcur - std::fabs(h)), hi = t_;
  const double* b = N_VGetArrayPointer(nv_back_);
  auto above = [&](double t) {
    if (CVodeGetDky(cvode_, t, 0, nv_back_) != CV_SUCCESS) return false;
    try {
      return measure_at(b) > opt_.sing_min;
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

void Sim::advance(double t_end) {
  PKM_REQUIRE(std::isfinite(t_end), PKM_ERR_ARGUMENT, "advance: t_end = " + num(t_end) + " is not finite");
  PKM_REQUIRE(t_end >= t_, PKM_ERR_ARGUMENT,
          "advance: t_end = " + num(t_end, 17) + " s is before the current time t = " + num(t_, 17) + " s");
  if (t_end == t_) return;
  budget_ = opt_.max_steps;
  budget_t0_ = t_;
  budget_end_ = t_end;
  if (time_limit_ > 0)
    deadline_ = std::chrono::steady_clock::now() +
                std::chrono::duration_cast<std::chrono::steady_clock::duration>(std::chrono::duration<double>(time_limit_));

  // A state on or beyond a stop boundary cannot be advanced: CVODE only sees sign
  // changes, so it would miss a crossing that already happened.  (The explicit method
  // checked the state it ended on already: its guard values are kept.)
  try {
    if (explicit_method()) {
      if (!guard_cached_) {
        erk_guard(y_.data(), g_cached_.data(), det_cached_, bound_cached_);
        guard_cached_ = true;
      }
      std::copy(g_cached_.begin(), g_cached_.begin() + nstop_, g_.begin());
    } else {
      roots(y_.data(), g_.data());
    }
  } catch (const Error& e) {
    throw Error(e.status, std::string(e.what()) + " at t = " + num(t_) + " s");
  }
  for (int k = 0; k < nstop_; ++k)
    if (g_[k] <= 0) throw Error(root_status(*this, k < (int)limits_.size()), root_message(k, g_.data(), t_, true));

  if (!(delay_ > 0)) {
    applied_ = tau_;
    add_external();
    segment(t_end);
    return;
  }

  // With an actuator delay the applied effort switches wherever a past command's start
  // plus the delay falls inside the interval: integrate piecewise, restarting CVODE at
  // each switch so no step straddles a discontinuity.
  while (!history_.empty() && history_.back().s >= t_) history_.pop_back();
  Command c;
  c.s = t_;
  for (int i = 0; i < nd_; ++i) c.tau[i] = tau_[i];
  history_.push_back(c);
  while (t_ < t_end) {
    double b = t_end;
    for (const Command& h : history_) {
      const double sw = h.s + delay_;
      if (sw > t_ && sw < b) b = sw;
    }
    command_at(0.5 * (t_ + b) - delay_, applied_.data());
    add_external();
    segment(b);
  }
  // Forget commands no rollback within kHistory seconds can need.
  const double keep_from = t_ - delay_ - kHistory;
  size_t first = 0;
  while (first + 1 < history_.size() && history_[first + 1].s <= keep_from) ++first;
  if (first > 0) history_.erase(history_.begin(), history_.begin() + first);
}

// The singularity measure costs an SVD, more than the forward dynamics; as a root
// function it is evaluated at every CVODE step.  Far from the threshold it is not
// needed there: a segment that starts with the measure above kSingGuard x sing_min runs
// with the singularity root switched off, and if it ends (or stops) below that guard it
// is run again from the same start with the root on, which then locates a crossing
// exactly.  Both runs are deterministic functions of (t, x, xd, tau, options), so the
// reproducibility guarantee holds.  A pass through a singularity inside the segment is
// still caught by the det J root, which stays on; what goes unseen is a dip of the
// measure below sing_min without J changing sign, back above the guard within a segment.
void Sim::segment(double t_end) {
  if (explicit_method()) {
    if (erk_segment(t_end)) return;
    // A stiff stretch: the explicit method stopped at its last accepted step; BDF takes
    // the rest of the segment, and the next advance starts explicit again.
    if (!cvode_) cvode_create(PKM_BDF);
    h_next_ = 0.0;
    guard_cached_ = false;
    fsal_valid_ = false;
  }
  if (!sing_root_) {
    integrate(t_end);
    return;
  }
  struct Restore {
    bool& flag;
    ~Restore() { flag = true; }
  } restore{sing_exact_};
  const double guard = std::min(0.5, kSingGuard * opt_.sing_min);
  sing_exact_ = true;
  double meas_start = measure_at(y_.data());
  if (meas_start < guard) {
    integrate(t_end);
    return;
  }
  const double t0 = t_;
  std::vector<double>& y0 = y_save_;
  y0 = y_;
  sing_exact_ = false;
  bool again = false;
  try {
    integrate(t_end);
    again = measure_at(y_.data()) < guard;
  } catch (const Error&) {
    // A stop or failure with the root off: if it happened near the threshold, a missed
    // singularity may be the cause; otherwise the stop stands.
    double m_end = -1.0;
    try {
      m_end = measure_at(y_.data());
    } catch (const Error&) {
    }
    if (m_end >= guard) {
      sing_exact_ = true;
      throw;
    }
    again = true;
  }
  sing_exact_ = true;
  if (!again) return;
  t_ = t0;
  y_ = y0;
  integrate(t_end);
}

std::string Sim::budget_message(double t_end, bool clock) const {
  std::ostringstream os;
  os.precision(10);
  os << "step budget exceeded at t = " << t_ << " s: ";
  if (clock)
    os << "in its time limit of " << time_limit_ << " s (wall clock) the advance from t = " << budget_t0_
       << " s went only ";
  else
    os << "max_steps = " << opt_.max_steps << " internal steps took the advance from t = " << budget_t0_ << " s only ";
  os << (t_ - budget_t0_) << " s of the " << (t_end - budget_t0_) << " s to t = " << t_end << " s; ";
  if (explicit_method())
    os << "the dynamics are stiff here, use solver.method = BDF (PKM_BDF), or an input this large is not physical";
  else
    os << "the motion is too fast to resolve at rtol = " << opt_.rtol << ": a smaller input or communication step, "
       << "or a looser tolerance";
  return os.str();
}

void Sim::budget_exceeded(double t_end, bool clock) const { throw Error(PKM_ERR_STEP_BUDGET, budget_message(t_end, clock)); }

void Sim::set_time_limit(double seconds) {
  PKM_REQUIRE(std::isfinite(seconds) && seconds >= 0, PKM_ERR_ARGUMENT,
              "time limit = " + num(seconds) + " s must be finite and >= 0 (0 = none)");
  time_limit_ = seconds;
}

bool Sim::past_deadline() {
  // The clock is read every kClockEvery calls (~50 ns a read, a step costs microseconds).
  if (!(time_limit_ > 0) || ++clock_calls_ % kClockEvery != 0) return false;
  return std::chrono::steady_clock::now() > deadline_;
}

double Sim::measure_at(const double* y) {
  double meas[2];
  robot_->singularity(*rm_, *rd_, y, meas);
  return meas[1];
}

void Sim::integrate(double t_end) {
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
  if (budget_ <= 0) budget_exceeded(t_end, false);
  check_cvode(CVodeSetMaxNumSteps(cvode_, budget_), "CVodeSetMaxNumSteps");

  double tret = t_;
  const int flag = CVode(cvode_, t_end, nv_, &tret, CV_NORMAL);

  long nst = 0, nfe = 0, nfeLS = 0, nje = 0, netf = 0, nncf = 0;
  CVodeGetNumSteps(cvode_, &nst);
  CVodeGetNumRhsEvals(cvode_, &nfe);
  CVodeGetNumErrTestFails(cvode_, &netf);
  CVodeGetNumNonlinSolvConvFails(cvode_, &nncf);
  if (cvode_lmm_ == PKM_BDF) {
    CVodeGetNumLinRhsEvals(cvode_, &nfeLS);
    CVodeGetNumJacEvals(cvode_, &nje);
  }
  stats_.steps += nst;
  stats_.rhs_evals += nfe + nfeLS;
  stats_.jac_evals += nje;
  stats_.error_test_fails += netf;
  stats_.nonlin_conv_fails += nncf;
  budget_ -= nst;

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
    std::vector<int> found(nroots_, 0);
    CVodeGetRootInfo(cvode_, found.data());
    int k = 0;
    while (k < nroots_ && found[k] == 0) ++k;
    if (k == nroots_) k = 0;
    const double t_start = t_;
    for (int i = 0; i < n2; ++i) y_[i] = v[i];
    t_ = tret;
    if (k == nstop_) {
      // det J changed sign: the motion crossed a direct singularity inside the last step.
      // Stop where the measure first reached sing_min, found on CVODE's interpolant.
      const double t_cross = t_;
      stop_before_singularity(t_start);
      k = nstop_ - 1;
      try {
        roots(y_.data(), g_.data());
      } catch (const Error&) {
        for (int j = 0; j < nroots_; ++j) g_[j] = 0.0;
      }
      throw Error(PKM_ERR_SINGULAR, root_message(k, g_.data(), t_, false) + " (the motion crosses the singularity at t = " +
                                        num(t_cross) + " s)");
    }
    stop_inside(t_start);
    try {
      roots(y_.data(), g_.data());
    } catch (const Error&) {
      // The root values at the stop are only for the message; keep CVODE's crossing.
      for (int j = 0; j < nroots_; ++j) g_[j] = 0.0;
    }
    throw Error(root_status(*this, k < (int)limits_.size()), root_message(k, g_.data(), t_, false));
  }

  // A failure: keep the farthest state CVODE reached, if it is a valid one.
  if (finite && tret > t_ && tret <= t_end) {
    for (int i = 0; i < n2; ++i) y_[i] = v[i];
    t_ = tret;
  }
  if (flag == CV_TOO_MUCH_WORK) budget_exceeded(t_end, false);
  const std::string name = flag_name(flag);
  if (cb_status_ == PKM_ERR_STEP_BUDGET) budget_exceeded(t_end, true);  // the message with the time reached
  if (cb_status_ != 0 && callback_flag(flag)) {
    throw Error(cb_status_, cb_msg_ + " at t = " + num(cb_time_) + " s (CVODE stopped with " + name +
                                "; state kept at t = " + num(t_) + " s)");
  }
  std::string msg = "CVODE failed with " + name + " at t = " + num(t_) + " s";
  if (!cv_msg_.empty()) msg += ": " + cv_msg_;
  if (cb_status_ != 0) msg += " (last callback failure: " + cb_msg_ + " at t = " + num(cb_time_) + " s)";
  throw Error(PKM_ERR_INTEGRATION, msg);
}

}  // namespace pkm
