// The explicit Runge-Kutta stepper of pkm_sim (methods PKM_ERK, the default, and PKM_ERK23):
// Dormand and Prince's embedded 5(4) pair (J. Comput. Appl. Math. 6, 1980), local extrapolation,
// an error-per-step controller, and stop conditions checked at every accepted step.
//
// Why a one-step method (docs/integration.md): under a controller the input changes at
// every communication point, and CVODE's multistep history restarts there, at order 1
// with a fresh initial step (12 steps per 1 ms).  A one-step method loses nothing at a
// restart: its whole state is (t, y) plus the step size it proposes next.  That step
// size is the stepper's block of the sim's state (pkm_sim_state_save), so a rollback followed by a
// re-advance repeats the same steps and reproduces the trajectory bit for bit.
//
// Under a controller the held input changes at every communication point, which breaks
// the first-same-as-last property of the pairs.  The accelerations are affine in the
// effort, so the last stage of a segment is evaluated split, f(y, 0) and B = d xdd / d tau
// (Robot::forward_dynamics_response, from the factorisation the forward dynamics make
// anyway), and the next segment's first stage is f(y, 0) + B tau for its new tau: six
// calls a millisecond instead of seven (DP5), three instead of four (BS3).
//
// Stop conditions, per accepted step: the joint limits from the inverse kinematics of
// the new state (cheap), and for the direct singularity the robot's cheap guard (a lower
// bound of the measure and the sign of det J from one LU); the exact measure (an SVD) is
// evaluated only when the bound is below kSingGuard x sing_min.  A violation inside a
// step is located by bisection on the cubic Hermite interpolant of the step.
#include <algorithm>
#include <cfloat>
#include <cmath>
#include <sstream>

#include "common/guard.hpp"
#include "integration/erk_pairs.hpp"
#include "integration/ode.hpp"
#include "integration/step_budget.hpp"
#include "integration/stepper.hpp"
#include "integration/stop_conditions.hpp"

namespace pkm {

using erk::kBS32;
using erk::kDP54;
using erk::Tableau;

namespace {

constexpr double kSafety = 0.9, kFacMin = 0.2, kFacMax = 5.0;
constexpr int kMaxN = 24;  // 4 x 6: pose, rates, and the drive bodies of two-body joints
// Stiffness detection: this many steps at the stability edge in one segment (Hairer's
// DOPRI5 uses 15), forgotten after kCalmSteps steps in a row away from it (6 there).
constexpr int kStiffHits = 15, kCalmSteps = 6;
constexpr long kStiffCheckFrom = 15;  // BS3 pays a call a step for the check after this many

// Cubic Hermite interpolant of a step at theta in [0, 1].
void hermite(int n, double theta, double h, const double* y0, const double* f0, const double* y1, const double* f1,
             double* y) {
  const double t = theta, t1 = theta - 1.0;
  for (int i = 0; i < n; ++i)
    y[i] = (1 - t) * y0[i] + t * y1[i] + t * t1 * ((1 - 2 * t) * (y1[i] - y0[i]) + t1 * h * f0[i] + t * h * f1[i]);
}

// The pair is a template argument: its coefficients are constants of the compiled steps.
template <const Tableau& kPair>
class ErkStepper final : public Stepper {
 public:
  ErkStepper(Ivp& ivp, bool stiff_fallback)
      : Stepper(ivp),
        nd_(ivp.ode.nd()),
        ny_(ivp.ode.ny()),
        stiff_fallback_(stiff_fallback) {
    fsal_f_.assign(ny_, 0.0);
    fsal_B_.assign((size_t)nd_ * nd_, 0.0);
    g_cached_.assign(stops_.nroots() + 1, 0.0);
    reuse_input_ = ode_.bodies().empty();  // a two-body joint's effort depends on the state
  }

  void restart() override {
    h_next_ = 0.0;  // a new start: the first step is chosen afresh
    guard_cached_ = false;
    fsal_valid_ = false;
  }

  // The stop values at the state the last segment ended on are kept from its last step.
  void start_values(double* g) override {
    if (!guard_cached_) {
      stops_.guard(y_.data(), g_cached_.data(), det_cached_, bound_cached_);
      guard_cached_ = true;
    }
    std::copy(g_cached_.begin(), g_cached_.begin() + stops_.nstop(), g);
  }

  bool advance(double t_end) override;

  // The block: the step size proposed for the next step (0: choose one).
  size_t state_size() const override { return 1; }
  void save(double* b) const override { b[0] = h_next_; }
  void check(const double* b, double t) const override { check_next_step(b[0], t); }
  void load(const double* b) override { h_next_ = b[0]; }

  std::string budget_advice() const override {
    return "the dynamics are stiff here, use solver.method = BDF (PKM_BDF), or an input this large is not physical";
  }

 private:
  // f = (xd, FD(y, tau)), tau nullptr: zero effort; with B != nullptr also B = d xdd / d tau
  // when the robot offers it (else reuse_input_ turns false).  false: a trial state the
  // robot refuses (outside the workspace, non-finite), recorded in cb_*.
  bool rhs(double t, const double* y, double* f, const double* tau, double* B = nullptr);
  // A stage from its split: f = F + (0, B applied), F = f at zero effort.
  void stage(const double* F, const double* B, double* f) const;
  double initial_step(double t_end, const double* f0);
  // First violation of a stop condition inside the accepted step [t0, t0 + h] (Hermite
  // interpolant of y0, f0, y1, f1): stops there and throws.
  [[noreturn]] void stop_in_step(double t0, double h, const double* y0, const double* f0, const double* y1,
                                 const double* f1, double det0);

  // The pieces of advance(), in the order a step takes them.
  using Stages = double[7][kMaxN];
  // The first stage of a segment, f0 = f(y0) under the held input (from the kept split
  // when there is one).
  void first_stage(const double* y0, double* f0);
  // Throws when the step size hh has fallen below the clock's resolution (naming the
  // refused trial state that shrank it, if any).
  void check_step_size(double hh) const;
  // The stages k[1..s-1] and the new point y1 of a trial step hh from y0 (k[0] = f(y0));
  // ys: the state of the last intermediate stage.  A step that ends the segment (last)
  // evaluates its last stage split into F1 and B1 (B1_fresh).  false: a trial state refused.
  bool trial_step(double hh, bool last, const double* y0, Stages& k, double* ys, double* y1, double* F1,
                  double* B1, bool& B1_fresh);
  // The weighted RMS norm of the step's error estimate.
  double error_norm(double hh, const double* y0, const double* y1, const Stages& k) const;
  // The stop values g at the accepted point y1 (det1, bound1 updated): true when a stop
  // condition is violated there or det J changed sign from det0.
  bool stop_at(const double* y1, double* g, double det0, double& det1, double& bound1);
  // Steps in one segment at the edge of the stability region, and steps in a row away from it.
  struct StiffCount {
    int hits = 0, calm = 0;
  };
  // After an accepted step hh ending at y1: true when the stiffness detection hands the
  // rest of the segment to the stiff stepper.
  bool stiff_step(double hh, const double* y1, const double* ys, const Stages& k, StiffCount& count);

  const int nd_, ny_;
  const bool stiff_fallback_;  // a stiff stepper takes over a stiff stretch

  double h_next_ = 0.0;  // step size proposed for the next step (0: choose one)
  // Stop-condition values and det J at the state the last segment ended on (valid until
  // the state changes otherwise), so the next advance need not recompute them.
  bool guard_cached_ = false;
  double det_cached_ = 1.0, bound_cached_ = 1.0;
  std::vector<double> g_cached_;
  // The last stage of a segment split as f(y, 0) (fsal_f_) and B = d xdd / d tau
  // (fsal_B_).  The accelerations are affine in the effort, so the first stage of the
  // next segment is fsal_f_ + B applied whatever its input: a 6x6 product instead of a
  // forward-dynamics call.  The split depends on y alone, so after a reset or a load it
  // is recomputed to the same bits: a rollback (and a reset to a saved state) repeats
  // the trajectory bit for bit.
  bool reuse_input_ = false;  // the robot offers B and no joint is two bodies
  bool fsal_valid_ = false;   // fsal_f_ and fsal_B_ belong to the current y
  std::vector<double> fsal_f_, fsal_B_;
  // Failure recorded by rhs (a trial state refused: a smaller step may avoid it).
  int cb_status_ = 0;
  double cb_time_ = 0.0;
  std::string cb_msg_;
};


template <const Tableau& kPair>
bool ErkStepper<kPair>::rhs(double t, const double* y, double* f, const double* tau, double* B) {
  const int n = nd_;
  for (int i = 0; i < ny_; ++i)
    if (!std::isfinite(y[i])) {
      cb_status_ = PKM_ERR_INTEGRATION;
      cb_time_ = t;
      cb_msg_ = "the trial state y[" + std::to_string(i) + "] is not finite";
      return false;
    }
  for (int i = 0; i < n; ++i) f[i] = y[n + i];
  try {
    static const double zero[6] = {0, 0, 0, 0, 0, 0};
    if (!tau) tau = zero;
    ode_.trends_at(t);  // the parameters' trends at the stage's time (pkm_param_set_course)
    if (!B || !ode_.rates_response(y, tau, f, B)) {
      if (B) reuse_input_ = false;  // this robot or drive has no cheap response: call FD each time
      ode_.rates(y, tau, f);
    }
  } catch (const Error& e) {
    cb_status_ = e.status;
    cb_time_ = t;
    cb_msg_ = std::string("forward dynamics: ") + e.what();
    if (e.status == PKM_ERR_UNREACHABLE || e.status == PKM_ERR_SINGULAR || e.status == PKM_ERR_NO_CONVERGENCE ||
        e.status == PKM_ERR_JOINT_LIMIT)
      return false;
    throw Error(e.status, cb_msg_ + " at t = " + num(t) + " s");
  }
  for (int i = 0; i < ny_ - n; ++i)
    if (!std::isfinite(f[n + i])) {
      cb_status_ = PKM_ERR_SINGULAR;
      cb_time_ = t;
      cb_msg_ = "forward dynamics returned a non-finite acceleration xdd[" + std::to_string(i) + "]";
      return false;
    }
  return true;
}

template <const Tableau& kPair>
void ErkStepper<kPair>::stage(const double* F, const double* B, double* f) const {
  const int n = nd_;
  for (int i = 0; i < n; ++i) {
    double acc = 0;
    for (int j = 0; j < n; ++j) acc += B[i * n + j] * applied_[j];
    f[i] = F[i];
    f[n + i] = F[n + i] + acc;
    if (!std::isfinite(f[n + i])) {
      double big = 0;
      for (int j = 0; j < n; ++j) big = std::fmax(big, std::fabs(applied_[j]));
      throw Error(PKM_ERR_ARGUMENT, "the acceleration xdd[" + std::to_string(i) + "] is not finite at t = " + num(t_) +
                                        " s for finite inputs: an input is too large (largest |tau| = " + num(big, 3) +
                                        ")");
    }
  }
}

// Hairer, Norsett and Wanner's starting step (Solving ODEs I, II.4): from the sizes of y,
// f and an estimate of f's change, capped by the segment and max_step.
template <const Tableau& kPair>
double ErkStepper<kPair>::initial_step(double t_end, const double* f0) {
  const int n2 = ny_;
  double d0 = 0, d1 = 0;
  for (int i = 0; i < n2; ++i) {
    const double sc = opt_.atol + opt_.rtol * std::fabs(y_[i]);
    d0 += (y_[i] / sc) * (y_[i] / sc);
    d1 += (f0[i] / sc) * (f0[i] / sc);
  }
  d0 = std::sqrt(d0 / n2);
  d1 = std::sqrt(d1 / n2);
  double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
  h0 = std::min(h0, t_end - t_);
  double y1[kMaxN] = {}, f1[kMaxN];
  for (int i = 0; i < n2; ++i) y1[i] = y_[i] + h0 * f0[i];
  double h1;
  if (!rhs(t_ + h0, y1, f1, applied_.data())) {
    h1 = h0;
  } else {
    double d2 = 0;
    for (int i = 0; i < n2; ++i) {
      const double sc = opt_.atol + opt_.rtol * std::fabs(y_[i]);
      d2 += ((f1[i] - f0[i]) / sc) * ((f1[i] - f0[i]) / sc);
    }
    d2 = std::sqrt(d2 / n2) / h0;
    const double dm = std::max(d1, d2);
    h1 = dm <= 1e-15 ? std::max(1e-6, h0 * 1e-3) : std::pow(0.01 / dm, kPair.start_expo);
  }
  ++stats_.rhs_evals;
  double h = std::min(100 * h0, h1);
  if (opt_.max_step > 0) h = std::min(h, opt_.max_step);
  return h;
}

template <const Tableau& kPair>
void ErkStepper<kPair>::stop_in_step(double t0, double h, const double* y0, const double* f0, const double* y1,
                              const double* f1, double det0) {
  const int n2 = ny_;
  double y[kMaxN], g[64];
  // violated(theta): some stop margin <= 0 or det J of the other sign than at the start.
  int thrown = PKM_OK;  // the status of the robot's refusal of the state at the stop, if any
  auto violated = [&](double theta, int* which, bool* crossed) {
    hermite(n2, theta, h, y0, f0, y1, f1, y);
    double det = det0, bound = 0;
    try {
      stops_.guard(y, g, det, bound);
    } catch (const Error& e) {
      if (which) *which = -1, thrown = e.status;
      return true;  // outside the workspace: past the stop
    }
    for (int k = 0; k < stops_.nstop(); ++k)
      if (g[k] <= 0) {
        if (which) *which = k;
        return true;
      }
    if (stops_.singularity() && (det > 0) != (det0 > 0)) {
      if (which) *which = stops_.nstop() - 1;
      if (crossed) *crossed = true;
      return true;
    }
    return false;
  };
  double lo = 0.0, hi = 1.0;
  for (int it = 0; it < 200 && (hi - lo) * h > 4 * DBL_EPSILON * std::max(1.0, std::fabs(t0 + h)); ++it) {
    const double mid = 0.5 * (lo + hi);
    if (violated(mid, nullptr, nullptr))
      hi = mid;
    else
      lo = mid;
  }
  int which = -1;
  bool crossed = false;
  violated(hi, &which, &crossed);
  const double t_hi = t0 + hi * h;
  // The state kept is the last one inside every limit.
  hermite(n2, lo, h, y0, f0, y1, f1, y);
  for (int i = 0; i < n2; ++i) y_[i] = y[i];
  t_ = t0 + lo * h;
  double det = det0, bound = 0;
  try {
    stops_.guard(y_.data(), g, det, bound);
  } catch (const Error&) {
    for (int k = 0; k < stops_.nroots(); ++k) g[k] = 0.0;
  }
  if (which < 0 && thrown == PKM_ERR_JOINT_LIMIT && stops_.nlimits() > 0) {
    // Past the stop the robot refused a joint beyond its limit (a fast motion: the step
    // jumped over the limit's zero into where the joint cannot be computed): the stop is that
    // limit, the one with the least margin at the last state inside, not a singularity.
    which = 0;
    for (int k = 1; k < stops_.nlimits(); ++k)
      if (g[k] < g[which]) which = k;
  }
  if (which < 0) which = stops_.nstop() > 0 ? stops_.nstop() - 1 : 0;
  const bool is_limit = which < stops_.nlimits();
  std::string msg = stops_.message(which, g, t_, false);
  if (crossed) msg += " (the motion crosses the singularity at t = " + num(t_hi) + " s)";
  throw Error(is_limit ? PKM_ERR_JOINT_LIMIT : PKM_ERR_SINGULAR, msg);
}

template <const Tableau& kPair>
void ErkStepper<kPair>::first_stage(const double* y0, double* f0) {
  if (reuse_input_ && !fsal_valid_) {  // after a reset or a load: the split of the last stage anew
    if (!rhs(t_, y0, fsal_f_.data(), nullptr, fsal_B_.data()))
      throw Error(cb_status_, cb_msg_ + " at t = " + num(t_) + " s");
    ++stats_.rhs_evals;
    fsal_valid_ = reuse_input_;
  }
  if (reuse_input_) {
    stage(fsal_f_.data(), fsal_B_.data(), f0);
  } else {
    if (!rhs(t_, y0, f0, applied_.data())) throw Error(cb_status_, cb_msg_ + " at t = " + num(t_) + " s");
    ++stats_.rhs_evals;
  }
}

template <const Tableau& kPair>
void ErkStepper<kPair>::check_step_size(double hh) const {
  if (hh > 4 * DBL_EPSILON * std::max(1.0, std::fabs(t_))) return;
  std::string msg = "explicit Runge-Kutta: the step size fell to " + num(hh) + " s at t = " + num(t_) + " s";
  if (cb_status_ != 0) {
    msg = cb_msg_ + " at t = " + num(cb_time_) + " s (" + msg + ")";
    throw Error(cb_status_, msg);
  }
  throw Error(PKM_ERR_INTEGRATION, msg);
}

template <const Tableau& kPair>
bool ErkStepper<kPair>::trial_step(double hh, bool last, const double* y0, Stages& k, double* ys, double* y1,
                                   double* F1, double* B1, bool& B1_fresh) {
  const Tableau& tb = kPair;
  const int n2 = ny_;
  bool ok = true;
  int evals = 0;
  for (int j = 1; ok && j < tb.s - 1; ++j) {
    for (int i = 0; i < n2; ++i) {
      double acc = 0;
      for (int l = 0; l < j; ++l) acc += tb.a[j][l] * k[l][i];
      ys[i] = y0[i] + hh * acc;
    }
    ok = rhs(t_ + tb.c[j] * hh, ys, k[j], applied_.data());
    ++evals;
  }
  if (ok) {
    for (int i = 0; i < n2; ++i) {
      double acc = 0;
      for (int l = 0; l < tb.s - 1; ++l) acc += tb.b[l] * k[l][i];
      y1[i] = y0[i] + hh * acc;
    }
    // A step that ends the segment evaluates its last stage split, f(y1, 0) + B tau, so
    // that the next segment starts from it whatever its input.
    B1_fresh = last && reuse_input_;
    if (B1_fresh) {
      ok = rhs(t_ + hh, y1, F1, nullptr, B1);
      B1_fresh = ok && reuse_input_;
      if (B1_fresh) stage(F1, B1, k[tb.s - 1]);
    }
    if (!B1_fresh) ok = rhs(t_ + hh, y1, k[tb.s - 1], applied_.data());
    ++evals;
  }
  stats_.rhs_evals += evals;
  return ok;
}

template <const Tableau& kPair>
double ErkStepper<kPair>::error_norm(double hh, const double* y0, const double* y1, const Stages& k) const {
  const Tableau& tb = kPair;
  const int n2 = ny_;
  double err = 0;
  for (int i = 0; i < n2; ++i) {
    double e = 0;
    for (int l = 0; l < tb.s; ++l) e += tb.e[l] * k[l][i];
    e *= hh;
    const double sc = opt_.atol + opt_.rtol * std::max(std::fabs(y0[i]), std::fabs(y1[i]));
    err += (e / sc) * (e / sc);
  }
  return std::sqrt(err / n2);
}

template <const Tableau& kPair>
bool ErkStepper<kPair>::stop_at(const double* y1, double* g, double det0, double& det1, double& bound1) {
  bool stop = false;
  try {
    stops_.guard(y1, g, det1, bound1);
    for (int k = 0; k < stops_.nstop(); ++k) stop = stop || g[k] <= 0;
    stop = stop || (stops_.singularity() && (det1 > 0) != (det0 > 0));
  } catch (const Error&) {
    stop = true;  // the new point is outside the workspace: locate where it left
  }
  return stop;
}

// Stiffness (Hairer and Wanner, Solving ODEs II, IV.2): h times a local Lipschitz
// estimate |f(ya) - f(yb)| / |ya - yb| near the edge of the method's stability region
// means the step size is held by stability, not accuracy.  DP5's last two stages are
// both at the step's end, so their difference is the error, which at the edge is the
// stiff mode's (no extra call).  BS3 has no such pair (stages at another time differ
// by the smooth motion too): from its 16th step in a segment it compares the solution
// with the embedded one, at one extra call a step.  kStiffHits such steps in one
// segment (forgotten after kCalmSteps in a row without) hand the rest to BDF.
template <const Tableau& kPair>
bool ErkStepper<kPair>::stiff_step(double hh, const double* y1, const double* ys, const Stages& k,
                                   StiffCount& count) {
  const Tableau& tb = kPair;
  const int n2 = ny_;
  const double* fa = k[tb.s - 1];
  const double* fb = k[tb.s - 2];
  const double* yb = ys;
  double yh[kMaxN], fh[kMaxN];
  bool have = true;
  if (!tb.last_two_at_end) {
    for (int i = 0; i < n2; ++i) {
      double e = 0;
      for (int l = 0; l < tb.s; ++l) e += tb.e[l] * k[l][i];
      yh[i] = y1[i] - hh * e;
    }
    have = rhs(t_, yh, fh, applied_.data());
    ++stats_.rhs_evals;
    fb = fh;
    yb = yh;
  }
  double num2 = 0, den2 = 0;
  for (int i = 0; have && i < n2; ++i) {
    const double df = fa[i] - fb[i], dy = y1[i] - yb[i];
    num2 += df * df;
    den2 += dy * dy;
  }
  if (have && den2 > 0 && hh * std::sqrt(num2 / den2) > tb.stiff_bound) {
    count.calm = 0;
    if (++count.hits >= kStiffHits && stiff_fallback_) return true;
  } else if (++count.calm >= kCalmSteps) {
    count.hits = 0;
  }
  return false;
}

template <const Tableau& kPair>
bool ErkStepper<kPair>::advance(double t_end) {
  // An interval below ~1e-15 s (relative to max(1 s, t)) moves only the clock: the state
  // would change by less than its own rounding (a denormal step is a zero step).
  if (t_end - t_ < 4 * DBL_EPSILON * std::max({1.0, std::fabs(t_), std::fabs(t_end)})) {
    t_ = t_end;
    return true;
  }
  const int n2 = ny_;
  cb_status_ = 0;
  cb_msg_.clear();
  const Tableau& tb = kPair;
  double y0[kMaxN], k[7][kMaxN], y1[kMaxN], ys[kMaxN], g[64];
  double* f0 = k[0];
  for (int i = 0; i < n2; ++i) y0[i] = y_[i];
  const int n = nd_;
  first_stage(y0, f0);
  fsal_valid_ = false;  // y_ changes below
  // The split (f at zero effort, B) at the end of a step that ends the segment.
  double F1[kMaxN], B1[36];
  bool B1_fresh = false;
  if (!guard_cached_) {
    stops_.guard(y0, g_cached_.data(), det_cached_, bound_cached_);
    guard_cached_ = true;
  }
  double det0 = det_cached_, bound0 = bound_cached_;
  guard_cached_ = false;  // y_ changes below

  double h = h_next_ > 0 ? h_next_ : initial_step(t_end, f0);
  if (opt_.max_step > 0) h = std::min(h, opt_.max_step);
  long steps = 0;
  StiffCount stiff;  // stiffness detection (see kStiffHits)
  while (t_ < t_end) {
    if (budget_.left() <= 0 || budget_.past_deadline()) budget_.exceeded(t_, t_end, budget_.left() > 0);
    budget_.spend(1);
    const double rest = t_end - t_;
    const bool last = h >= rest * (1 - 1e-12);
    const double hh = last ? rest : h;
    check_step_size(hh);
    ++steps;
    if (!trial_step(hh, last, y0, k, ys, y1, F1, B1, B1_fresh)) {
      // A trial state outside the workspace (or a non-finite one): a smaller step.
      ++stats_.nonlin_conv_fails;
      h = hh * 0.25;
      continue;
    }
    const double err = error_norm(hh, y0, y1, k);
    const double fac = err > 0 ? std::clamp(kSafety * std::pow(err, tb.expo), kFacMin, kFacMax) : kFacMax;
    if (!(err <= 1.0)) {
      ++stats_.error_test_fails;
      h = hh * std::min(1.0, fac);
      continue;
    }
    // Accepted: stop conditions at the new point.
    double det1 = det0, bound1 = bound0;
    const bool stop = stop_at(y1, g, det0, det1, bound1);
    ++stats_.steps;
    double* f1 = k[tb.s - 1];
    if (stop) stop_in_step(t_, hh, y0, f0, y1, f1, det0);
    t_ = last ? t_end : t_ + hh;
    for (int i = 0; i < n2; ++i) {
      y0[i] = y1[i];
      f0[i] = f1[i];
      y_[i] = y1[i];  // the committed state is always the last accepted one
    }
    // A step shortened to land on t_end says little about the next one: keep the larger.
    const double h_new = hh * fac;
    h = last ? std::max(h, h_new) : h_new;
    if (opt_.max_step > 0) h = std::min(h, opt_.max_step);
    // Approaching a direct singularity, no step may skip over it (det J could change
    // sign twice within one step): while the singularity bound falls, the next step
    // covers at most half the time the bound would take to reach zero at its last rate.
    if (stops_.singularity() && bound1 < bound0) {
      const double reach = bound1 / ((bound0 - bound1) / hh);
      h = std::min(h, std::max(0.5 * reach, 1e-9));
    }
    det0 = det1;
    bound0 = bound1;
    if (t_ < t_end && (tb.last_two_at_end || steps > kStiffCheckFrom) && stiff_step(hh, y1, ys, k, stiff))
      return false;
  }
  h_next_ = h;
  if (steps > 0 && B1_fresh) {
    std::copy(F1, F1 + n2, fsal_f_.begin());
    std::copy(B1, B1 + n * n, fsal_B_.begin());
    fsal_valid_ = true;
  }
  if (steps > 0) {
    std::copy(g, g + stops_.nroots(), g_cached_.begin());
    det_cached_ = det0;
    bound_cached_ = bound0;
    guard_cached_ = true;
  }
  return true;
}

}  // namespace

std::unique_ptr<Stepper> make_erk_stepper(int method, Ivp& ivp, bool stiff_fallback) {
  if (method == PKM_ERK23) return std::make_unique<ErkStepper<kBS32>>(ivp, stiff_fallback);
  return std::make_unique<ErkStepper<kDP54>>(ivp, stiff_fallback);
}

}  // namespace pkm
