// The explicit Runge-Kutta path of pkm_sim (method PKM_ERK, the default): Dormand and
// Prince's embedded 5(4) pair (J. Comput. Appl. Math. 6, 1980), local extrapolation,
// an error-per-step controller, and stop conditions checked at every accepted step.
//
// Why a one-step method (docs/integration.md): under a controller the input changes at
// every communication point, and CVODE's multistep history restarts there, at order 1
// with a fresh initial step (12 steps per 1 ms).  A one-step method loses nothing at a
// restart: its whole state is (t, y) plus the step size it proposes next.  That step
// size is part of the sim's state (pkm_sim_state_save), so a rollback followed by a
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
#include "integration/sim.hpp"

namespace pkm {

namespace {

// An embedded explicit Runge-Kutta pair with the first-same-as-last property: stage s-1
// is f at the new point (and the next step's first stage when the input stays), the
// solution uses b over the first s-1 stages, the error estimate e = b - b_hat over all s.
struct Tableau {
  int s;
  double c[7];
  double a[7][7];
  double b[7];
  double e[7];
  double expo;  // step-size exponent: -1 / (order of the embedded estimate + 1)
  double stiff_bound;  // ~0.9 x where the stability region ends on the negative real axis
  bool last_two_at_end;  // the last two stages are both at the step's end (c = 1)
};

// Dormand and Prince's 5(4) pair (J. Comput. Appl. Math. 6, 1980).
constexpr Tableau kDP54{7,
                        {0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1, 1},
                        {{0},
                         {1.0 / 5},
                         {3.0 / 40, 9.0 / 40},
                         {44.0 / 45, -56.0 / 15, 32.0 / 9},
                         {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
                         {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
                         {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84}},
                        {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84, 0},
                        {71.0 / 57600, 0, -71.0 / 16695, 71.0 / 1920, -17253.0 / 339200, 22.0 / 525, -1.0 / 40},
                        -1.0 / 5,
                        3.25,
                        true};

// Bogacki and Shampine's 3(2) pair (Appl. Math. Lett. 2, 1989): three new stages a step.
constexpr Tableau kBS32{4,
                        {0, 1.0 / 2, 3.0 / 4, 1},
                        {{0}, {1.0 / 2}, {0, 3.0 / 4}, {2.0 / 9, 1.0 / 3, 4.0 / 9}},
                        {2.0 / 9, 1.0 / 3, 4.0 / 9, 0},
                        {2.0 / 9 - 7.0 / 24, 1.0 / 3 - 1.0 / 4, 4.0 / 9 - 1.0 / 3, -1.0 / 8},
                        -1.0 / 3,
                        2.25,
                        false};

constexpr double kSafety = 0.9, kFacMin = 0.2, kFacMax = 5.0;
constexpr double kSingGuard = 100.0;  // exact singularity measure only below this x sing_min
constexpr int kMaxN = 24;
// Stiffness detection: this many steps at the stability edge in one segment (Hairer's
// DOPRI5 uses 15), forgotten after kCalmSteps steps in a row away from it (6 there).
constexpr int kStiffHits = 15, kCalmSteps = 6;
constexpr long kStiffCheckFrom = 15;  // BS3 pays a call a step for the check after this many
#ifdef PKM_NO_CVODE
constexpr bool kCanHandOver = false;  // no BDF in this binary: the explicit method goes on, its budget bounds it
#else
constexpr bool kCanHandOver = true;
#endif  // 4 x 6: pose, rates, and the drive bodies of two-body joints

// Cubic Hermite interpolant of a step at theta in [0, 1].
void hermite(int n, double theta, double h, const double* y0, const double* f0, const double* y1, const double* f1,
             double* y) {
  const double t = theta, t1 = theta - 1.0;
  for (int i = 0; i < n; ++i)
    y[i] = (1 - t) * y0[i] + t * y1[i] + t * t1 * ((1 - 2 * t) * (y1[i] - y0[i]) + t1 * h * f0[i] + t * h * f1[i]);
}

}  // namespace

bool Sim::erk_rhs(double t, const double* y, double* f, const double* tau, double* B) {
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
    if (!B || !two_.empty() || !total_forward_dynamics_response(model_, data_, y, y + n, tau, f + n, B)) {
      if (B) reuse_input_ = false;  // this robot or drive has no cheap response: call FD each time
      dynamics(y, tau, f);
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

void Sim::erk_stage(const double* F, const double* B, double* f) const {
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
double Sim::erk_initial_step(double t_end, const double* f0) {
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
  if (!erk_rhs(t_ + h0, y1, f1, applied_.data())) {
    h1 = h0;
  } else {
    double d2 = 0;
    for (int i = 0; i < n2; ++i) {
      const double sc = opt_.atol + opt_.rtol * std::fabs(y_[i]);
      d2 += ((f1[i] - f0[i]) / sc) * ((f1[i] - f0[i]) / sc);
    }
    d2 = std::sqrt(d2 / n2) / h0;
    const double dm = std::max(d1, d2);
    h1 = dm <= 1e-15 ? std::max(1e-6, h0 * 1e-3) : std::pow(0.01 / dm, opt_.method == PKM_ERK23 ? 1.0 / 3 : 1.0 / 5);
  }
  ++stats_.rhs_evals;
  double h = std::min(100 * h0, h1);
  if (opt_.max_step > 0) h = std::min(h, opt_.max_step);
  return h;
}

void Sim::erk_guard(const double* y, double* g, double& det, double& bound) {
  int k = 0;
  if (!limits_.empty()) {
    robot_->ik(*rm_, *rd_, y, q_.data());
    for (const JointLimit& L : limits_) g[k++] = L.upper ? L.value - q_[L.joint] : q_[L.joint] - L.value;
  }
  det = 1.0;
  bound = 1.0;
  if (sing_root_) {
    robot_->direct_singularity_guard(*rm_, *rd_, y, &bound, &det);
    const double guard = std::min(0.5, kSingGuard * opt_.sing_min);
    g[k++] = bound >= guard ? bound - opt_.sing_min : measure_at(y) - opt_.sing_min;
  }
}

void Sim::erk_stop(double t0, double h, const double* y0, const double* f0, const double* y1, const double* f1,
                   double det0) {
  const int n2 = ny_;
  double y[kMaxN], g[64];
  // violated(theta): some stop margin <= 0 or det J of the other sign than at the start.
  auto violated = [&](double theta, int* which, bool* crossed) {
    hermite(n2, theta, h, y0, f0, y1, f1, y);
    double det = det0, bound = 0;
    try {
      erk_guard(y, g, det, bound);
    } catch (const Error&) {
      if (which) *which = -1;
      return true;  // outside the workspace: past the stop
    }
    for (int k = 0; k < nstop_; ++k)
      if (g[k] <= 0) {
        if (which) *which = k;
        return true;
      }
    if (sing_root_ && (det > 0) != (det0 > 0)) {
      if (which) *which = nstop_ - 1;
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
    erk_guard(y_.data(), g, det, bound);
  } catch (const Error&) {
    for (int k = 0; k < nroots_; ++k) g[k] = 0.0;
  }
  if (which < 0) which = nstop_ > 0 ? nstop_ - 1 : 0;
  const bool is_limit = which < (int)limits_.size();
  std::string msg = root_message(which, g, t_, false);
  if (crossed) msg += " (the motion crosses the singularity at t = " + num(t_hi) + " s)";
  throw Error(is_limit ? PKM_ERR_JOINT_LIMIT : PKM_ERR_SINGULAR, msg);
}

bool Sim::erk_segment(double t_end) {
  // An interval below ~1e-15 s (relative to max(1 s, t)) moves only the clock: the state
  // would change by less than its own rounding (a denormal step is a zero step).
  if (t_end - t_ < 4 * DBL_EPSILON * std::max({1.0, std::fabs(t_), std::fabs(t_end)})) {
    t_ = t_end;
    return true;
  }
  const int n2 = ny_;
  cb_status_ = 0;
  cb_msg_.clear();
  const Tableau& tb = opt_.method == PKM_ERK23 ? kBS32 : kDP54;
  double y0[kMaxN], k[7][kMaxN], y1[kMaxN], ys[kMaxN], g[64];
  double* f0 = k[0];
  for (int i = 0; i < n2; ++i) y0[i] = y_[i];
  const int n = nd_;
  if (reuse_input_ && !fsal_valid_) {  // after a reset or a load: the split of the last stage anew
    if (!erk_rhs(t_, y0, fsal_f_.data(), nullptr, fsal_B_.data()))
      throw Error(cb_status_, cb_msg_ + " at t = " + num(t_) + " s");
    ++stats_.rhs_evals;
    fsal_valid_ = reuse_input_;
  }
  if (reuse_input_) {
    erk_stage(fsal_f_.data(), fsal_B_.data(), f0);
  } else {
    if (!erk_rhs(t_, y0, f0, applied_.data())) throw Error(cb_status_, cb_msg_ + " at t = " + num(t_) + " s");
    ++stats_.rhs_evals;
  }
  fsal_valid_ = false;  // y_ changes below
  // The split (f at zero effort, B) at the end of a step that ends the segment.
  double F1[kMaxN], B1[36];
  bool B1_fresh = false;
  if (!guard_cached_) {
    erk_guard(y0, g_cached_.data(), det_cached_, bound_cached_);
    guard_cached_ = true;
  }
  double det0 = det_cached_, bound0 = bound_cached_;
  guard_cached_ = false;  // y_ changes below

  double h = h_next_ > 0 ? h_next_ : erk_initial_step(t_end, f0);
  if (opt_.max_step > 0) h = std::min(h, opt_.max_step);
  long steps = 0;
  int stiff_hits = 0, calm = 0;  // stiffness detection (see kStiffHits)
  while (t_ < t_end) {
    if (budget_ <= 0 || past_deadline()) budget_exceeded(t_end, budget_ > 0);
    --budget_;
    const double rest = t_end - t_;
    const bool last = h >= rest * (1 - 1e-12);
    const double hh = last ? rest : h;
    if (!(hh > 4 * DBL_EPSILON * std::max(1.0, std::fabs(t_)))) {
      std::string msg = "explicit Runge-Kutta: the step size fell to " + num(hh) + " s at t = " + num(t_) + " s";
      if (cb_status_ != 0) {
        msg = cb_msg_ + " at t = " + num(cb_time_) + " s (" + msg + ")";
        throw Error(cb_status_, msg);
      }
      throw Error(PKM_ERR_INTEGRATION, msg);
    }
    ++steps;
    bool ok = true;
    int evals = 0;
    for (int j = 1; ok && j < tb.s - 1; ++j) {
      for (int i = 0; i < n2; ++i) {
        double acc = 0;
        for (int l = 0; l < j; ++l) acc += tb.a[j][l] * k[l][i];
        ys[i] = y0[i] + hh * acc;
      }
      ok = erk_rhs(t_ + tb.c[j] * hh, ys, k[j], applied_.data());
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
        ok = erk_rhs(t_ + hh, y1, F1, nullptr, B1);
        B1_fresh = ok && reuse_input_;
        if (B1_fresh) erk_stage(F1, B1, k[tb.s - 1]);
      }
      if (!B1_fresh) ok = erk_rhs(t_ + hh, y1, k[tb.s - 1], applied_.data());
      ++evals;
    }
    stats_.rhs_evals += evals;
    if (!ok) {
      // A trial state outside the workspace (or a non-finite one): a smaller step.
      ++stats_.nonlin_conv_fails;
      h = hh * 0.25;
      continue;
    }
    double err = 0;
    for (int i = 0; i < n2; ++i) {
      double e = 0;
      for (int l = 0; l < tb.s; ++l) e += tb.e[l] * k[l][i];
      e *= hh;
      const double sc = opt_.atol + opt_.rtol * std::max(std::fabs(y0[i]), std::fabs(y1[i]));
      err += (e / sc) * (e / sc);
    }
    err = std::sqrt(err / n2);
    const double fac = err > 0 ? std::clamp(kSafety * std::pow(err, tb.expo), kFacMin, kFacMax) : kFacMax;
    if (!(err <= 1.0)) {
      ++stats_.error_test_fails;
      h = hh * std::min(1.0, fac);
      continue;
    }
    // Accepted: stop conditions at the new point.
    double det1 = det0, bound1 = bound0;
    bool stop = false;
    try {
      erk_guard(y1, g, det1, bound1);
      for (int k = 0; k < nstop_; ++k) stop = stop || g[k] <= 0;
      stop = stop || (sing_root_ && (det1 > 0) != (det0 > 0));
    } catch (const Error&) {
      stop = true;  // the new point is outside the workspace: locate where it left
    }
    ++stats_.steps;
    double* f1 = k[tb.s - 1];
    if (stop) erk_stop(t_, hh, y0, f0, y1, f1, det0);
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
    if (sing_root_ && bound1 < bound0) {
      const double reach = bound1 / ((bound0 - bound1) / hh);
      h = std::min(h, std::max(0.5 * reach, 1e-9));
    }
    det0 = det1;
    bound0 = bound1;
    // Stiffness (Hairer and Wanner, Solving ODEs II, IV.2): h times a local Lipschitz
    // estimate |f(ya) - f(yb)| / |ya - yb| near the edge of the method's stability region
    // means the step size is held by stability, not accuracy.  DP5's last two stages are
    // both at the step's end, so their difference is the error, which at the edge is the
    // stiff mode's (no extra call).  BS3 has no such pair (stages at another time differ
    // by the smooth motion too): from its 16th step in a segment it compares the solution
    // with the embedded one, at one extra call a step.  kStiffHits such steps in one
    // segment (forgotten after kCalmSteps in a row without) hand the rest to BDF.
    if (t_ < t_end && (tb.last_two_at_end || steps > kStiffCheckFrom)) {
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
        have = erk_rhs(t_, yh, fh, applied_.data());
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
        calm = 0;
        if (++stiff_hits >= kStiffHits && kCanHandOver) return false;
      } else if (++calm >= kCalmSteps) {
        stiff_hits = 0;
      }
    }
  }
  h_next_ = h;
  if (steps > 0 && B1_fresh) {
    std::copy(F1, F1 + n2, fsal_f_.begin());
    std::copy(B1, B1 + n * n, fsal_B_.begin());
    fsal_valid_ = true;
  }
  if (steps > 0) {
    std::copy(g, g + nroots_, g_cached_.begin());
    det_cached_ = det0;
    bound_cached_ = bound0;
    guard_cached_ = true;
  }
  return true;
}

// ------------------------------------------------------------------------ state

size_t Sim::state_size() const {
  // version, nd, t, y[ny] (2 nd; 4 nd with drive bodies), tau[nd], h_next, history count,
  // history entries (1 + nd each)
  size_t needed = 0;
  for (size_t k = 0; k < history_.size(); ++k)
    if (k + 1 == history_.size() || history_[k + 1].s > t_ - delay_) ++needed;
  return 5 + (size_t)ny_ + (size_t)nd_ + needed * (1 + (size_t)nd_);
}

void Sim::state_save(double* b) const {
  size_t k = 0;
  b[k++] = two_.empty() ? 1.0 : 2.0;  // layout version: 2 with the drive bodies' states
  b[k++] = nd_;
  b[k++] = t_;
  for (int i = 0; i < ny_; ++i) b[k++] = y_[i];
  for (int i = 0; i < nd_; ++i) b[k++] = tau_[i];
  b[k++] = h_next_;
  // Only the commands that can still act at or after t (the last one issued before
  // t - delay and every later one).
  size_t first = history_.size();
  for (size_t j = 0; j < history_.size(); ++j)
    if (j + 1 == history_.size() || history_[j + 1].s > t_ - delay_) {
      first = j;
      break;
    }
  b[k++] = (double)(history_.size() - first);
  for (size_t j = first; j < history_.size(); ++j) {
    b[k++] = history_[j].s;
    for (int i = 0; i < nd_; ++i) b[k++] = history_[j].tau[i];
  }
}

void Sim::state_load(const double* b, size_t n) {
  PKM_REQUIRE(b != nullptr, PKM_ERR_ARGUMENT, "state: buffer is NULL");
  const double version = two_.empty() ? 1.0 : 2.0;
  const size_t ny = (size_t)ny_, nd = (size_t)nd_;
  PKM_REQUIRE(n >= 5 + ny + nd && b[0] == version && b[1] == nd_, PKM_ERR_ARGUMENT,
          "state: not a pkm_sim state of this robot and drive layer (layout version " + num(version) + ", " +
              std::to_string(nd_) + " joints)");
  for (size_t k = 0; k < n; ++k)
    PKM_REQUIRE(std::isfinite(b[k]), PKM_ERR_ARGUMENT, "state: entry " + std::to_string(k) + " is not finite");
  const double nh_value = b[4 + ny + nd];
  PKM_REQUIRE(nh_value >= 0 && nh_value < 1e9 && nh_value == std::floor(nh_value), PKM_ERR_ARGUMENT,
          "state: a history length of " + num(nh_value) + " entries is not a count");
  const size_t nh = (size_t)nh_value;
  PKM_REQUIRE(n == 5 + ny + nd + nh * (1 + nd), PKM_ERR_ARGUMENT,
          "state: " + std::to_string(n) + " values do not match the history length it declares");
  const double t = b[2];
  // The next step size: 0 (choose one) or a step the explicit method can take from t.
  const double h = b[3 + ny + nd];
  PKM_REQUIRE(h == 0 || h > 4 * DBL_EPSILON * std::max(1.0, std::fabs(t)), PKM_ERR_ARGUMENT,
              "state: the next step size " + num(h) + " s is neither 0 nor a step that can be taken at t = " + num(t) +
                  " s");
  // The delay line: commands in the order they were issued, none after t.
  for (size_t j = 0; j < nh; ++j) {
    const double s = b[5 + ny + nd + j * (1 + nd)];
    PKM_REQUIRE(s <= t && (j == 0 || s >= b[5 + ny + nd + (j - 1) * (1 + nd)]), PKM_ERR_ARGUMENT,
                "state: delay-line command " + std::to_string(j) + " issued at t = " + num(s) +
                    " s is out of order or after the state's time " + num(t) + " s");
  }
  std::vector<double> x(b + 3, b + 3 + nd_), xd(b + 3 + nd_, b + 3 + 2 * nd_);
  reset(t, x.data(), xd.data());  // checks the state as any reset does; clears h_next_
  for (size_t i = 2 * nd; i < ny; ++i) y_[i] = b[3 + i];  // the drive bodies as saved
  for (int i = 0; i < nd_; ++i) tau_[i] = b[3 + ny + i];
  h_next_ = b[3 + ny + nd];
  history_.clear();
  size_t k = 5 + ny + nd;
  for (size_t j = 0; j < nh; ++j) {
    Command c{};
    c.s = b[k++];
    for (int i = 0; i < nd_; ++i) c.tau[i] = b[k++];
    history_.push_back(c);
  }
}

}  // namespace pkm
