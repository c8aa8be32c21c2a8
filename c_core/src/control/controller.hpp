// The sampled joint-space controller of pkm.h "control" (struct pkm_ctrl): its spec read
// into matrices, its state, and the laws.  controller.cpp creates it from a spec and holds
// the C API, controller_law.cpp computes an update, controller_state.cpp resets, saves and
// loads its state.
#pragma once

#include <Eigen/Dense>

#include <string>
#include <vector>

#include "common/guard.hpp"

namespace pkm::control {

using MatX = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using VecX = Eigen::VectorXd;

// The law's name in messages ("pd", "pid", ...).
const char* kind_name(int kind);

// A discrete filter y_k = (sum_i b_i x_{k-i} - sum_{i>=1} a_i y_{k-i}) / a_0, one per
// joint, its past inputs and outputs kept newest first.
struct Filter {
  std::vector<double> b, a;  // empty: the identity
  int nd = 0;
  std::vector<double> xin, yout;  // [nd * (nb - 1)], [nd * (na - 1)]

  // The filter of b (nb taps) over a (na taps) for nd joints; none (the identity) when
  // both are empty.  name: the spec's field, for the messages.
  static Filter make(const double* b, int nb, const double* a, int na, int nd, const char* name);
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

}  // namespace pkm::control

struct pkm_ctrl {
  using MatX = pkm::control::MatX;
  using VecX = pkm::control::VecX;
  using Filter = pkm::control::Filter;

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

  // Throws the core's error s of a model-based part (what) with the controller's name and t.
  [[noreturn]] void fail_core(int s, double t, const std::string& what);
  // Pose of the measured joints by forward kinematics from the last pose (or the
  // reference pose, or home), as cosim.controllers.PDGravity.pose.
  void measured_pose(double t, const double* q, const double* xref, double* x);
  // tau += the gravity load at pose x.
  void add_gravity(double t, const double* x, double* tau);

  // controller_law.cpp: one sample of the law, tau [nd] from the readings and the reference.
  void update(double t, const double* q, const double* qd, const double* qref, const double* qdref,
              const double* qddref, const double* xref, double* tau);
  // update() with a signal injected at point (pkm_inject_point), w [nd] (NULL: none).
  void update_injected(double t, const double* q, const double* qd, const double* qref, const double* qdref,
                       const double* qddref, const double* xref, int point, const double* w, double* tau);
  // The law before the output stage: u [nd] (pre_part: the injected command it holds).
  void apply_law(double t, const double* q, const double* qd, const double* qddref, const double* xref, const VecX& e,
           const VecX& ed, VecX& u);
  void computed_torque(double t, const double* q, const double* qd, const double* qddref, const double* xref,
                       const VecX& e, const VecX& ed, VecX& u);
  void pid(double t, const double* q, const double* xref, const VecX& e, VecX& u);
  // The DISCRETE law: filters, cascade P-P or PID, the output clamp and gain, the delay.
  void discrete(const double* q, const double* qd, const double* qref, const double* qdref, VecX& tau);
  // The injected command, the saturation and the finite check: tau from u.
  void output(double t, const VecX& u, double* tau);

  // controller_state.cpp: the state, its size and layout.
  void reset(const double* x0);
  // Layout: integral[nd], deriv[nd], e_prev[nd], x_guess[nd], xc[nx], have_prev,
  // have_guess, saturated; for DISCRETE then its block: the layout (kDiscreteTag, nd,
  // position filter's past inputs and outputs per joint, the velocity filter's, delay),
  // started, qf_prev[nd], the filters' histories, the delay queue[delay nd].
  static constexpr double kDiscreteTag = 5001.0;
  std::vector<double> discrete_layout() const;
  size_t discrete_size() const;
  size_t state_size() const;
  void save(double* b) const;
  void load(const double* b);
};
