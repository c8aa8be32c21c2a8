// Sampled joint-space controllers (pkm.h "control"): the laws of cosim.controllers in
// C++, so that a closed loop can run without leaving the core (pkm_sim_run_loop) and a
// controller FMU can carry the same law.  The model-based parts (gravity load, forward
// kinematics of the measured joints, inverse dynamics) call the core's own C API on a
// private model copy and work data, so the controller believes in exactly the physics
// the plant has, unless the caller gives it another model.
#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

#include "common/guard.hpp"

using namespace pkm;

namespace {

constexpr int kMaxStates = 64;

const char* kind_name(int kind) {
  switch (kind) {
    case PKM_CTRL_PD: return "pd";
    case PKM_CTRL_PD_GRAVITY: return "pd_gravity";
    case PKM_CTRL_COMPUTED_TORQUE: return "computed_torque";
    case PKM_CTRL_PID: return "pid";
    case PKM_CTRL_LTI: return "lti";
    case PKM_CTRL_DISCRETE: return "discrete";
    default: return "?";
  }
}

using MatX = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using VecX = Eigen::VectorXd;

MatX copy_matrix(const double* p, int rows, int cols, const char* field, bool required) {
  if (!p) {
    if (required) throw Error(PKM_ERR_ARGUMENT, std::string("controller spec: ") + field + " is NULL");
    return MatX::Zero(rows, cols);
  }
  MatX out = Eigen::Map<const MatX>(p, rows, cols);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j)
      if (!std::isfinite(out(i, j)))
        throw Error(PKM_ERR_ARGUMENT, std::string("controller spec: ") + field + "[" + std::to_string(i) + "," +
                                          std::to_string(j) + "] is not finite (" + num(out(i, j)) + ")");
  return out;
}

void check_gain(const MatX& g, const char* field) {
  for (int i = 0; i < g.rows(); ++i)
    if (g(i, i) < 0)
      throw Error(PKM_ERR_ARGUMENT, std::string("controller spec: ") + field + " of joint " + std::to_string(i + 1) +
                                        " is negative (" + num(g(i, i)) + "): the loop would be unstable");
}

// A discrete filter y_k = (sum_i b_i x_{k-i} - sum_{i>=1} a_i y_{k-i}) / a_0, one per
// joint, its past inputs and outputs kept newest first.
struct Filter {
  std::vector<double> b, a;  // empty: the identity
  int nd = 0;
  std::vector<double> xin, yout;  // [nd * (nb - 1)], [nd * (na - 1)]

  static Filter make(const double* b, int nb, const double* a, int na, int nd, const char* name) {
    Filter f;
    f.nd = nd;
    if (nb == 0 && na == 0) return f;
    PKM_REQUIRE(nb >= 1 && nb <= PKM_CTRL_MAX_TAPS && b != nullptr, PKM_ERR_ARGUMENT,
                std::string("controller spec: ") + name + ".b needs 1 to " + std::to_string(PKM_CTRL_MAX_TAPS) +
                    " coefficients, got " + std::to_string(nb));
    PKM_REQUIRE(na >= 1 && na <= PKM_CTRL_MAX_TAPS && a != nullptr, PKM_ERR_ARGUMENT,
                std::string("controller spec: ") + name + ".a needs 1 to " + std::to_string(PKM_CTRL_MAX_TAPS) +
                    " coefficients, got " + std::to_string(na));
    for (int i = 0; i < nb; ++i)
      PKM_REQUIRE(std::isfinite(b[i]), PKM_ERR_ARGUMENT,
                  std::string("controller spec: ") + name + ".b[" + std::to_string(i) + "] is not finite");
    for (int i = 0; i < na; ++i)
      PKM_REQUIRE(std::isfinite(a[i]), PKM_ERR_ARGUMENT,
                  std::string("controller spec: ") + name + ".a[" + std::to_string(i) + "] is not finite");
    PKM_REQUIRE(a[0] != 0, PKM_ERR_ARGUMENT, std::string("controller spec: ") + name + ".a[0] must not be 0");
    f.b.assign(b, b + nb);
    f.a.assign(a, a + na);
    f.xin.assign((size_t)nd * (nb - 1), 0.0);
    f.yout.assign((size_t)nd * (na - 1), 0.0);
    return f;
  }
  bool identity() const { return b.empty(); }
  int nx() const { return identity() ? 0 : (int)b.size() - 1; }
  int ny() const { return identity() ? 0 : (int)a.size() - 1; }
  // At rest with input x on joint i: past inputs x, past outputs the DC gain times x.
  // Returns the output at rest.
  double rest(int i, double x) {
    if (identity()) return x;
    double sb = 0, sa = 0;
    for (double v : b) sb += v;
    for (double v : a) sa += v;
    const double y = sa != 0 ? x * sb / sa : 0.0;
    for (int k = 0; k < nx(); ++k) xin[(size_t)i * nx() + k] = x;
    for (int k = 0; k < ny(); ++k) yout[(size_t)i * ny() + k] = y;
    return y;
  }
  double step(int i, double x) {
    if (identity()) return x;
    double* xi = xin.data() + (size_t)i * nx();
    double* yi = yout.data() + (size_t)i * ny();
    double y = b[0] * x;
    for (int k = 0; k < nx(); ++k) y += b[k + 1] * xi[k];
    for (int k = 0; k < ny(); ++k) y -= a[k + 1] * yi[k];
    y /= a[0];
    for (int k = nx() - 1; k > 0; --k) xi[k] = xi[k - 1];
    if (nx() > 0) xi[0] = x;
    for (int k = ny() - 1; k > 0; --k) yi[k] = yi[k - 1];
    if (ny() > 0) yi[0] = y;
    return y;
  }
};

// A state block's values, appended in order and read back in the same order.
struct Writer {
  double* b;
  size_t k = 0;
  void put(double v) { b[k++] = v; }
  void put(const std::vector<double>& v) {
    for (double x : v) b[k++] = x;
  }
};
struct Reader {
  const double* b;
  size_t k = 0;
  double get() { return b[k++]; }
  void get(std::vector<double>& v) {
    for (double& x : v) x = b[k++];
  }
};

}  // namespace

struct pkm_ctrl {
  pkm_model* model = nullptr;
  pkm_data* data = nullptr;
  int nd = 0;
  int kind = PKM_CTRL_PD;
  double dt = 0;
  MatX kp, kd, ki, A, B, C, D;
  VecX sat;  // empty: no saturation
  double tf = 0;
  bool gravity_ref = false, gravity_ff = false;
  int nx = 0;
  // DISCRETE
  int law = PKM_LAW_CASCADE_PP;
  MatX kv;
  Filter pos, vel;
  bool measured_rate = false;
  VecX u_min, u_max, gain;  // u_min/u_max empty: no limits
  int delay = 0;
  // DISCRETE state: previous filtered position, the outputs waiting out the delay (oldest
  // first), whether the filters have been started at rest.
  std::vector<double> qf_prev, queue;
  bool started = false;

  // The signal injected at this update (pkm_ctrl_update_injected): its point and values
  // [nd], set for one update only.  inj_queue holds the injected parts of the outputs
  // waiting out the delay and inj_part that of the last output: a record (what the
  // signal added to tau), not state, since no future output depends on it.
  int inj_point = PKM_INJECT_NONE;
  const double* inj = nullptr;
  std::vector<double> inj_queue;
  VecX inj_part, pre_part;

  // state
  VecX integral, deriv, e_prev, xc, x_guess;
  bool have_prev = false, have_guess = false;
  long saturated = 0;
  std::string error;

  ~pkm_ctrl() {
    if (data) pkm_data_destroy(data);
    if (model) pkm_model_destroy(model);
  }

  void fail_core(int s, double t, const std::string& what) {
    throw Error(s, std::string(kind_name(kind)) + " at t = " + num(t) + " s: " + what + ": " + pkm_data_error(data));
  }

  // Pose of the measured joints by forward kinematics from the last pose (or the
  // reference pose, or home), as cosim.controllers.PDGravity.pose.
  void measured_pose(double t, const double* q, const double* xref, double* x) {
    std::vector<double> guess(nd);
    if (have_guess)
      for (int i = 0; i < nd; ++i) guess[i] = x_guess[i];
    else if (xref)
      for (int i = 0; i < nd; ++i) guess[i] = xref[i];
    else
      pkm_model_home(model, guess.data());
    const int s = pkm_fk(model, data, q, guess.data(), nullptr, x, nullptr);
    if (s != PKM_OK) fail_core(s, t, "forward kinematics of the measured joints failed");
    for (int i = 0; i < nd; ++i) x_guess[i] = x[i];
    have_guess = true;
  }

  void add_gravity(double t, const double* x, double* tau) {
    std::vector<double> g(nd);
    const int s = pkm_gravity_load(model, data, x, g.data());
    if (s != PKM_OK) fail_core(s, t, "gravity load");
    for (int i = 0; i < nd; ++i) tau[i] += g[i];
  }

  void discrete(const double* q, const double* qd, const double* qref, const double* qdref, VecX& tau) {
    if (!started) {
      for (int i = 0; i < nd; ++i) {
        qf_prev[i] = pos.rest(i, q[i]);
        vel.rest(i, measured_rate ? qd[i] : 0.0);
      }
      started = true;
    }
    VecX e(nd), v(nd);
    for (int i = 0; i < nd; ++i) {
      const double qf = pos.step(i, q[i]);
      const double raw = measured_rate ? qd[i] : (qf - qf_prev[i]) / dt;
      qf_prev[i] = qf;
      v[i] = vel.step(i, raw);
      e[i] = qref[i] - qf;
    }
    VecX u(nd);
    VecX trial_integral;
    if (law == PKM_LAW_CASCADE_PP) {
      u = kv * (kp * e - v);
    } else {
      trial_integral = integral + dt * e;
      VecX ed = -v;
      for (int i = 0; i < nd; ++i) ed[i] += qdref[i];
      u = kp * e + ki * trial_integral + kd * ed;
      VecX next = trial_integral;
      if (u_min.size())
        for (int i = 0; i < nd; ++i)
          if ((u[i] > u_max[i] && e[i] > 0) || (u[i] < u_min[i] && e[i] < 0)) next[i] = integral[i];
      if (next != trial_integral) u = kp * e + ki * next + kd * ed;
      integral = next;
    }
    // An injected command signal w [effort] is w / gain in controller units, added to u
    // before its clamp (PKM_INJECT_COMMAND) or after it (_COMMAND_AFTER_SAT); part: what
    // it adds to the output.
    const bool before = inj_point == PKM_INJECT_COMMAND, after = inj_point == PKM_INJECT_COMMAND_AFTER_SAT;
    VecX part = VecX::Zero(nd);
    bool clipped = false;
    for (int i = 0; i < nd; ++i) {
      const double w = (before || after) ? inj[i] / gain[i] : 0.0;
      double c = u[i] + (before ? w : 0.0), c0 = u[i];
      if (u_min.size()) {
        const double cc = std::clamp(c, u_min[i], u_max[i]);
        clipped = clipped || cc != c;
        c = cc;
        c0 = std::clamp(c0, u_min[i], u_max[i]);
      }
      if (after) c += w;
      u[i] = c * gain[i];
      part[i] = (c - c0) * gain[i];
    }
    if (clipped) ++saturated;
    if (delay == 0) {
      tau = u;
      pre_part = part;
      return;
    }
    for (int i = 0; i < nd; ++i) tau[i] = queue[i], pre_part[i] = inj_queue[i];
    queue.erase(queue.begin(), queue.begin() + nd);
    inj_queue.erase(inj_queue.begin(), inj_queue.begin() + nd);
    for (int i = 0; i < nd; ++i) queue.push_back(u[i]), inj_queue.push_back(part[i]);
  }

  void update(double t, const double* q, const double* qd, const double* qref, const double* qdref,
              const double* qddref, const double* xref, double* tau) {
    const char* kn = kind_name(kind);
    auto check = [&](const double* v, const char* name, bool required) {
      if (!v) {
        if (required) throw Error(PKM_ERR_ARGUMENT, std::string(kn) + " at t = " + num(t) + " s: " + name + " is NULL");
        return;
      }
      for (int i = 0; i < nd; ++i)
        if (!std::isfinite(v[i]))
          throw Error(PKM_ERR_ARGUMENT, std::string(kn) + " at t = " + num(t) + " s: " + name + " of joint " +
                                            std::to_string(i + 1) + " is " + num(v[i]));
    };
    PKM_REQUIRE(std::isfinite(t), PKM_ERR_ARGUMENT, std::string(kn) + ": sample time t is not finite");
    check(q, "q", true);
    check(qd, "qd", true);
    check(qref, "qref", true);
    check(qdref, "qdref", true);
    check(qddref, "qddref", false);
    check(xref, "xref", false);
    check_out(tau, "tau");
    // A signal injected at the reference or the reading: the law sees qref + w or q + w.
    std::vector<double> shifted;
    if (inj_point == PKM_INJECT_REFERENCE || inj_point == PKM_INJECT_MEASUREMENT) {
      const double* base = inj_point == PKM_INJECT_REFERENCE ? qref : q;
      shifted.assign(base, base + nd);
      for (int i = 0; i < nd; ++i) shifted[i] += inj[i];
      (inj_point == PKM_INJECT_REFERENCE ? qref : q) = shifted.data();
    }
    pre_part.setZero(nd);
    Eigen::Map<const VecX> Q(q, nd), QD(qd, nd), QR(qref, nd), QDR(qdref, nd);
    const VecX e = QR - Q, ed = QDR - QD;
    VecX u(nd);
    std::vector<double> x(nd);
    switch (kind) {
      case PKM_CTRL_PD:
        u = kp * e + kd * ed;
        break;
      case PKM_CTRL_PD_GRAVITY:
        u = kp * e + kd * ed;
        if (gravity_ref) {
          PKM_REQUIRE(xref != nullptr, PKM_ERR_ARGUMENT,
                  std::string(kn) + " at t = " + num(t) + " s: gravity at the reference pose needs xref");
          for (int i = 0; i < nd; ++i) x[i] = xref[i];
        } else {
          measured_pose(t, q, xref, x.data());
        }
        add_gravity(t, x.data(), u.data());
        break;
      case PKM_CTRL_COMPUTED_TORQUE: {
        measured_pose(t, q, xref, x.data());
        VecX qdd = kd * ed + kp * e;
        if (qddref) qdd += Eigen::Map<const VecX>(qddref, nd);
        std::vector<double> xd(nd), xdd(nd);
        int s = pkm_pose_velocity(model, data, x.data(), qd, xd.data());
        if (s != PKM_OK) fail_core(s, t, "pose velocity");
        s = pkm_pose_acceleration(model, data, x.data(), xd.data(), qdd.data(), xdd.data());
        if (s != PKM_OK) fail_core(s, t, "pose acceleration");
        s = pkm_inverse_dynamics(model, data, x.data(), xd.data(), xdd.data(), u.data());
        if (s != PKM_OK) fail_core(s, t, "inverse dynamics");
        break;
      }
      case PKM_CTRL_PID: {
        if (have_prev)
          deriv = (tf * deriv + (e - e_prev)) / (tf + dt);
        else
          deriv.setZero();
        const VecX trial_integral = integral + dt * e;
        u = kp * e + ki * trial_integral + kd * deriv;
        if (gravity_ff) {
          measured_pose(t, q, xref, x.data());
          add_gravity(t, x.data(), u.data());
        }
        // Anti-windup (conditional integration): a joint whose output is saturated keeps
        // its integral where the error would drive it further into the limit.
        VecX next = trial_integral;
        if (sat.size())
          for (int i = 0; i < nd; ++i)
            if ((u[i] > sat[i] && e[i] > 0) || (u[i] < -sat[i] && e[i] < 0)) next[i] = integral[i];
        if (sat.size() && next != trial_integral) {
          u = kp * e + ki * next + kd * deriv;
          if (gravity_ff) add_gravity(t, x.data(), u.data());
        }
        integral = next;
        e_prev = e;
        have_prev = true;
        break;
      }
      case PKM_CTRL_LTI: {
        u = D * e;
        if (nx > 0) {
          u += C * xc;
          xc = (A * xc + B * e).eval();
        }
        if (gravity_ff) {
          measured_pose(t, q, xref, x.data());
          add_gravity(t, x.data(), u.data());
        }
        break;
      }
      case PKM_CTRL_DISCRETE:
        discrete(q, qd, qref, qdref, u);
        break;
      default:
        throw Error(PKM_ERR_INTERNAL, "unknown controller kind");
    }
    // The injected command (a DISCRETE controller has added it in its own units above):
    // before the saturation, or after it; inj_part = tau - what tau would be without it.
    const bool own = kind != PKM_CTRL_DISCRETE;
    if (own && inj_point == PKM_INJECT_COMMAND)
      for (int i = 0; i < nd; ++i) u[i] += inj[i], pre_part[i] = inj[i];
    bool clipped = false;
    for (int i = 0; i < nd; ++i) {
      double v = u[i], v0 = u[i] - pre_part[i];
      if (sat.size()) {
        const double c = std::clamp(v, -sat[i], sat[i]);
        clipped = clipped || c != v;
        v = c;
        v0 = std::clamp(v0, -sat[i], sat[i]);
      }
      if (own && inj_point == PKM_INJECT_COMMAND_AFTER_SAT) v += inj[i];
      if (!std::isfinite(v))
        throw Error(PKM_ERR_ARGUMENT, std::string(kn) + " at t = " + num(t) + " s: the effort of joint " +
                                          std::to_string(i + 1) + " is not finite (" + num(v) + ")");
      tau[i] = v;
      inj_part[i] = v - v0;
    }
    if (clipped) ++saturated;
  }

  // update() with a signal injected at point (pkm_inject_point), w [nd] (NULL: none).
  void update_injected(double t, const double* q, const double* qd, const double* qref, const double* qdref,
                       const double* qddref, const double* xref, int point, const double* w, double* tau) {
    PKM_REQUIRE(point >= PKM_INJECT_NONE && point <= PKM_INJECT_MEASUREMENT, PKM_ERR_ARGUMENT,
                std::string(kind_name(kind)) + ": injection point " + std::to_string(point) +
                    " is not PKM_INJECT_NONE (0), _COMMAND (1), _COMMAND_AFTER_SAT (2), _REFERENCE (3) or "
                    "_MEASUREMENT (4)");
    if (point != PKM_INJECT_NONE) {
      PKM_REQUIRE(w != nullptr, PKM_ERR_ARGUMENT,
                  std::string(kind_name(kind)) + " at t = " + num(t) + " s: the injected signal is NULL");
      for (int i = 0; i < nd; ++i)
        PKM_REQUIRE(std::isfinite(w[i]), PKM_ERR_ARGUMENT,
                    std::string(kind_name(kind)) + " at t = " + num(t) + " s: the injected signal of joint " +
                        std::to_string(i + 1) + " is " + num(w[i]));
    }
    inj_point = w ? point : PKM_INJECT_NONE;
    inj = w;
    try {
      update(t, q, qd, qref, qdref, qddref, xref, tau);
    } catch (...) {
      inj_point = PKM_INJECT_NONE, inj = nullptr;
      throw;
    }
    inj_point = PKM_INJECT_NONE, inj = nullptr;
  }

  void reset(const double* x0) {
    integral.setZero(nd);
    deriv.setZero(nd);
    e_prev.setZero(nd);
    xc.setZero(nx);
    x_guess.setZero(nd);
    have_prev = false;
    have_guess = false;
    saturated = 0;
    qf_prev.assign(nd, 0.0);
    queue.assign((size_t)nd * delay, 0.0);
    inj_queue.assign((size_t)nd * delay, 0.0);
    inj_part.setZero(nd);
    pre_part.setZero(nd);
    std::fill(pos.xin.begin(), pos.xin.end(), 0.0);
    std::fill(pos.yout.begin(), pos.yout.end(), 0.0);
    std::fill(vel.xin.begin(), vel.xin.end(), 0.0);
    std::fill(vel.yout.begin(), vel.yout.end(), 0.0);
    started = false;
    if (x0) {
      check_finite(x0, nd, "reset: pose x0");
      for (int i = 0; i < nd; ++i) x_guess[i] = x0[i];
      have_guess = true;
    }
  }

  // Layout: integral[nd], deriv[nd], e_prev[nd], x_guess[nd], xc[nx], have_prev,
  // have_guess, saturated; for DISCRETE then its block: the layout (kDiscreteTag, nd,
  // position filter's past inputs and outputs per joint, the velocity filter's, delay),
  // started, qf_prev[nd], the filters' histories, the delay queue[delay nd].
  static constexpr double kDiscreteTag = 5001.0;
  std::vector<double> discrete_layout() const {
    return {kDiscreteTag, (double)nd, (double)pos.nx(), (double)pos.ny(), (double)vel.nx(), (double)vel.ny(),
            (double)delay};
  }
  size_t discrete_size() const {
    if (kind != PKM_CTRL_DISCRETE) return 0;
    return discrete_layout().size() + 1 + qf_prev.size() + pos.xin.size() + pos.yout.size() + vel.xin.size() +
           vel.yout.size() + queue.size();
  }
  size_t state_size() const { return 4 * (size_t)nd + nx + 3 + discrete_size(); }
  void save(double* b) const {
    size_t k = 0;
    for (const VecX* v : {&integral, &deriv, &e_prev, &x_guess, &xc})
      for (int i = 0; i < v->size(); ++i) b[k++] = (*v)[i];
    b[k++] = have_prev ? 1.0 : 0.0;
    b[k++] = have_guess ? 1.0 : 0.0;
    b[k++] = (double)saturated;
    if (kind != PKM_CTRL_DISCRETE) return;
    Writer w{b + k};
    w.put(discrete_layout());
    w.put(started ? 1.0 : 0.0);
    for (const std::vector<double>* v : {&qf_prev, &pos.xin, &pos.yout, &vel.xin, &vel.yout, &queue}) w.put(*v);
  }
  void load(const double* b) {
    const size_t n = state_size();
    size_t k = 4 * (size_t)nd + nx + 3;
    if (kind == PKM_CTRL_DISCRETE) {
      // The layout first: a state of another controller is refused before any value is read.
      const std::vector<double> want = discrete_layout();
      const char* what[] = {"tag", "joints", "position filter inputs", "position filter outputs",
                            "velocity filter inputs", "velocity filter outputs", "delay samples"};
      for (size_t i = 0; i < want.size(); ++i)
        PKM_REQUIRE(b[k + i] == want[i], PKM_ERR_ARGUMENT,
                    std::string("controller state: the discrete block's ") + what[i] + " is " + num(b[k + i]) +
                        ", this controller's " + num(want[i]) + ": a state of another controller");
    }
    for (size_t j = 0; j < n; ++j)
      PKM_REQUIRE(std::isfinite(b[j]), PKM_ERR_ARGUMENT, "controller state: entry " + std::to_string(j) + " is not finite");
    k = 0;
    for (VecX* v : {&integral, &deriv, &e_prev, &x_guess, &xc})
      for (int i = 0; i < v->size(); ++i) (*v)[i] = b[k++];
    // The flags and the counter must be what save() writes: 0 or 1, and a whole count
    // (a conversion of a double out of long's range is undefined behaviour).
    for (size_t f = k; f < k + 2; ++f)
      PKM_REQUIRE(b[f] == 0.0 || b[f] == 1.0, PKM_ERR_ARGUMENT,
                  "controller state: entry " + std::to_string(f) + " is a flag (0 or 1), got " + num(b[f]));
    PKM_REQUIRE(b[k + 2] >= 0 && b[k + 2] <= 9e15 && b[k + 2] == std::floor(b[k + 2]), PKM_ERR_ARGUMENT,
                "controller state: the saturation count " + num(b[k + 2]) + " is not a count");
    have_prev = b[k++] != 0.0;
    have_guess = b[k++] != 0.0;
    saturated = (long)b[k++];
    if (kind != PKM_CTRL_DISCRETE) return;
    Reader r{b + k + discrete_layout().size()};
    started = r.get() != 0.0;
    for (std::vector<double>* v : {&qf_prev, &pos.xin, &pos.yout, &vel.xin, &vel.yout, &queue}) r.get(*v);
  }
};

extern "C" {

pkm_ctrl* pkm_ctrl_create(const pkm_model* m, const pkm_ctrl_spec* spec, char* err, size_t errlen) {
  pkm_ctrl* out = nullptr;
  guard_err(err, errlen, [&] {
    PKM_REQUIRE(m != nullptr, PKM_ERR_ARGUMENT, "controller: model is NULL");
    PKM_REQUIRE(spec != nullptr, PKM_ERR_ARGUMENT, "controller: spec is NULL");
    PKM_REQUIRE(m->compiled != nullptr, PKM_ERR_PARAMETER,
            "controller: the model's parameters were changed and not validated: call pkm_model_validate first");
    const pkm_ctrl_spec& s = *spec;
    PKM_REQUIRE(s.kind >= PKM_CTRL_PD && s.kind <= PKM_CTRL_DISCRETE, PKM_ERR_ARGUMENT,
            "controller spec: kind = " + std::to_string(s.kind) +
                " is not one of PKM_CTRL_PD (0), _PD_GRAVITY (1), _COMPUTED_TORQUE (2), _PID (3), _LTI (4), "
                "_DISCRETE (5)");
    PKM_REQUIRE(std::isfinite(s.dt) && s.dt > 0, PKM_ERR_ARGUMENT,
            "controller spec: dt = " + num(s.dt) + " s must be finite and > 0");
    auto c = std::make_unique<pkm_ctrl>();
    const int nd = pkm_model_ndof(m);
    c->nd = nd;
    c->kind = s.kind;
    c->dt = s.dt;
    const bool lti = s.kind == PKM_CTRL_LTI, disc = s.kind == PKM_CTRL_DISCRETE;
    c->kp = copy_matrix(s.kp, nd, nd, "kp", !lti);
    c->kd = copy_matrix(s.kd, nd, nd, "kd", !lti && !disc);
    c->ki = copy_matrix(s.ki, nd, nd, "ki", false);
    if (!lti) {
      check_gain(c->kp, "kp");
      check_gain(c->kd, "kd");
      check_gain(c->ki, "ki");
    }
    PKM_REQUIRE(std::isfinite(s.deriv_filter) && s.deriv_filter >= 0, PKM_ERR_ARGUMENT,
            "controller spec: deriv_filter = " + num(s.deriv_filter) + " s must be finite and >= 0");
    c->tf = s.deriv_filter;
    if (s.saturation) {
      c->sat.resize(nd);
      for (int i = 0; i < nd; ++i) {
        PKM_REQUIRE(std::isfinite(s.saturation[i]) && s.saturation[i] > 0, PKM_ERR_ARGUMENT,
                "controller spec: saturation of joint " + std::to_string(i + 1) + " must be a positive effort, got " +
                    num(s.saturation[i]));
        c->sat[i] = s.saturation[i];
      }
    }
    c->gravity_ref = s.gravity_at_reference != 0;
    c->gravity_ff = s.gravity_feedforward != 0;
    if (lti) {
      PKM_REQUIRE(s.nx >= 0 && s.nx <= kMaxStates, PKM_ERR_ARGUMENT,
              "controller spec: nx = " + std::to_string(s.nx) + " must be in [0, " + std::to_string(kMaxStates) + "]");
      c->nx = s.nx;
      c->A = copy_matrix(s.A, s.nx, s.nx, "A", s.nx > 0);
      c->B = copy_matrix(s.B, s.nx, nd, "B", s.nx > 0);
      c->C = copy_matrix(s.C, nd, s.nx, "C", s.nx > 0);
      c->D = copy_matrix(s.D, nd, nd, "D", false);
    }
    if (disc) {
      PKM_REQUIRE(s.law == PKM_LAW_CASCADE_PP || s.law == PKM_LAW_PID, PKM_ERR_ARGUMENT,
                  "controller spec: law = " + std::to_string(s.law) +
                      " is not PKM_LAW_CASCADE_PP (0) or PKM_LAW_PID (1)");
      c->law = s.law;
      c->kv = copy_matrix(s.kv, nd, nd, "kv", s.law == PKM_LAW_CASCADE_PP);
      check_gain(c->kv, "kv");
      c->pos = Filter::make(s.pos_b, s.pos_nb, s.pos_a, s.pos_na, nd, "position_filter");
      c->vel = Filter::make(s.vel_b, s.vel_nb, s.vel_a, s.vel_na, nd, "velocity_filter");
      PKM_REQUIRE(s.velocity_source == 0 || s.velocity_source == 1, PKM_ERR_ARGUMENT,
                  "controller spec: velocity_source = " + std::to_string(s.velocity_source) +
                      " is not 0 (backward difference) or 1 (the reading qd)");
      c->measured_rate = s.velocity_source == 1;
      PKM_REQUIRE((s.u_min == nullptr) == (s.u_max == nullptr), PKM_ERR_ARGUMENT,
                  "controller spec: u_min and u_max go together");
      if (s.u_min) {
        c->u_min = Eigen::Map<const VecX>(s.u_min, nd);
        c->u_max = Eigen::Map<const VecX>(s.u_max, nd);
        for (int i = 0; i < nd; ++i)
          PKM_REQUIRE(std::isfinite(c->u_min[i]) && std::isfinite(c->u_max[i]) && c->u_min[i] < c->u_max[i],
                      PKM_ERR_ARGUMENT,
                      "controller spec: the output limits of joint " + std::to_string(i + 1) + " [" +
                          num(c->u_min[i]) + ", " + num(c->u_max[i]) + "] must be finite with min < max");
      }
      c->gain = VecX::Ones(nd);
      if (s.output_gain)
        for (int i = 0; i < nd; ++i) {
          PKM_REQUIRE(std::isfinite(s.output_gain[i]) && s.output_gain[i] != 0, PKM_ERR_ARGUMENT,
                      "controller spec: output_gain of joint " + std::to_string(i + 1) + " must be finite and "
                      "non-zero, got " + num(s.output_gain[i]));
          c->gain[i] = s.output_gain[i];
        }
      PKM_REQUIRE(s.delay_samples >= 0 && s.delay_samples <= PKM_CTRL_MAX_DELAY, PKM_ERR_ARGUMENT,
                  "controller spec: delay_samples = " + std::to_string(s.delay_samples) + " must be in [0, " +
                      std::to_string(PKM_CTRL_MAX_DELAY) + "]");
      c->delay = s.delay_samples;
    }
    c->model = pkm_model_copy(m);
    PKM_REQUIRE(c->model != nullptr, PKM_ERR_INTERNAL, "controller: out of memory copying the model");
    c->data = pkm_data_create(c->model);
    PKM_REQUIRE(c->data != nullptr, PKM_ERR_INTERNAL, "controller: out of memory creating the work data");
    c->reset(nullptr);
    out = c.release();
  });
  return out;
}

void pkm_ctrl_destroy(pkm_ctrl* c) { delete c; }

int pkm_ctrl_reset(pkm_ctrl* c, const double* x0) {
  if (!c) return PKM_ERR_ARGUMENT;
  c->error.clear();
  return guard_into(c->error, [&] { c->reset(x0); });
}

int pkm_ctrl_update(pkm_ctrl* c, double t, const double* q, const double* qd, const double* qref,
                    const double* qdref, const double* qddref, const double* xref, double* tau) {
  return pkm_ctrl_update_injected(c, t, q, qd, qref, qdref, qddref, xref, PKM_INJECT_NONE, nullptr, tau, nullptr);
}

int pkm_ctrl_update_injected(pkm_ctrl* c, double t, const double* q, const double* qd, const double* qref,
                             const double* qdref, const double* qddref, const double* xref, int point,
                             const double* w, double* tau, double* tau_inj) {
  if (!c) return PKM_ERR_ARGUMENT;
  c->error.clear();
  return guard_into(c->error, [&] {
    c->update_injected(t, q, qd, qref, qdref, qddref, xref, point, w, tau);
    if (tau_inj)
      for (int i = 0; i < c->nd; ++i) tau_inj[i] = c->inj_part[i];
  });
}

int pkm_ctrl_prime(pkm_ctrl* c, size_t n, const double* t, const double* q, const double* qd, const double* qref,
                   const double* qdref, const double* qddref, const double* xref) {
  return pkm_ctrl_prime_injected(c, n, t, q, qd, qref, qdref, qddref, xref, PKM_INJECT_NONE, nullptr);
}

int pkm_ctrl_prime_injected(pkm_ctrl* c, size_t n, const double* t, const double* q, const double* qd,
                            const double* qref, const double* qdref, const double* qddref, const double* xref,
                            int point, const double* w) {
  if (!c) return PKM_ERR_ARGUMENT;
  c->error.clear();
  return guard_into(c->error, [&] {
    if (n == 0) return;
    PKM_REQUIRE(t && q && qd && qref && qdref, PKM_ERR_ARGUMENT,
                "controller prime: t, q, qd, qref and qdref are required (qddref and xref may be NULL)");
    const size_t nd = (size_t)c->nd;
    const long saturated = c->saturated;  // the run counts its own samples only
    std::vector<double> tau(nd);
    auto row = [&](const double* a, size_t k) { return a ? a + k * nd : nullptr; };
    for (size_t k = 0; k < n; ++k)
      c->update_injected(t[k], row(q, k), row(qd, k), row(qref, k), row(qdref, k), row(qddref, k), row(xref, k),
                         point, row(w, k), tau.data());
    c->saturated = saturated;
  });
}

long pkm_ctrl_saturated(const pkm_ctrl* c) { return c ? c->saturated : 0; }

const char* pkm_ctrl_error(const pkm_ctrl* c) { return c ? c->error.c_str() : "controller is NULL"; }

// The saved state starts with a header naming the layout (version, kind, joints, LTI
// states), so that a state is loaded only into a controller of the same law and sizes.
static constexpr size_t kStateHead = 4;
static constexpr double kStateVersion = 1.0;

size_t pkm_ctrl_state_size(const pkm_ctrl* c) { return c ? kStateHead + c->state_size() : 0; }

int pkm_ctrl_state_save(const pkm_ctrl* c, double* buf) {
  if (!c || !buf) return PKM_ERR_ARGUMENT;
  buf[0] = kStateVersion;
  buf[1] = c->kind;
  buf[2] = c->nd;
  buf[3] = c->nx;
  c->save(buf + kStateHead);
  return PKM_OK;
}

int pkm_ctrl_state_load(pkm_ctrl* c, const double* buf, size_t n) {
  if (!c) return PKM_ERR_ARGUMENT;
  c->error.clear();
  return guard_into(c->error, [&] {
    PKM_REQUIRE(buf != nullptr, PKM_ERR_ARGUMENT, "controller state: buffer is NULL");
    const size_t need = kStateHead + c->state_size();
    PKM_REQUIRE(n == need, PKM_ERR_ARGUMENT,
                "controller state: " + std::to_string(n) + " values, this controller's layout has " +
                    std::to_string(need));
    PKM_REQUIRE(buf[0] == kStateVersion && buf[1] == c->kind && buf[2] == c->nd && buf[3] == c->nx, PKM_ERR_ARGUMENT,
                "controller state of another law or size (layout " + num(buf[0]) + ", kind " + num(buf[1]) + ", " +
                    num(buf[2]) + " joints, " + num(buf[3]) + " LTI states; this controller: layout " +
                    num(kStateVersion) + ", kind " + std::to_string(c->kind) + " (" + kind_name(c->kind) + "), " +
                    std::to_string(c->nd) + ", " + std::to_string(c->nx) + ")");
    // A refused state leaves the controller unchanged: load into a copy of the state first.
    std::vector<double> keep(c->state_size());
    c->save(keep.data());
    try {
      c->load(buf + kStateHead);
    } catch (...) {
      c->load(keep.data());
      throw;
    }
  });
}

}  // extern "C"
