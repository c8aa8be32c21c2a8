// The laws of the sampled joint-space controller (controller.hpp): PD, PD + gravity,
// computed torque, PID, LTI and the DISCRETE law of a drive's own controller, then the
// output stage (an injected command, the saturation).  The model-based parts call the
// core's C API on the controller's private model copy and work data.
#include <algorithm>
#include <cmath>
#include <vector>

#include "control/controller.hpp"

using namespace pkm;
using namespace pkm::control;

void pkm_ctrl::fail_core(int s, double t, const std::string& what) {
  throw Error(s, std::string(kind_name(kind)) + " at t = " + num(t) + " s: " + what + ": " + pkm_data_error(data));
}

void pkm_ctrl::measured_pose(double t, const double* q, const double* xref, double* x) {
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

void pkm_ctrl::add_gravity(double t, const double* x, double* tau) {
  std::vector<double> g(nd);
  const int s = pkm_gravity_load(model, data, x, g.data());
  if (s != PKM_OK) fail_core(s, t, "gravity load");
  for (int i = 0; i < nd; ++i) tau[i] += g[i];
}

// One sample: the inputs checked, a signal injected at the reference or the reading
// applied, the law, the output stage.
void pkm_ctrl::update(double t, const double* q, const double* qd, const double* qref, const double* qdref,
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
  if (kind == PKM_CTRL_DISCRETE)
    discrete(q, qd, qref, qdref, u);
  else
    apply_law(t, q, qd, qddref, xref, e, ed, u);
  output(t, u, tau);
}

void pkm_ctrl::apply_law(double t, const double* q, const double* qd, const double* qddref, const double* xref,
                         const VecX& e, const VecX& ed, VecX& u) {
  const char* kn = kind_name(kind);
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
    case PKM_CTRL_COMPUTED_TORQUE:
      computed_torque(t, q, qd, qddref, xref, e, ed, u);
      break;
    case PKM_CTRL_PID:
      pid(t, q, xref, e, u);
      break;
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
    default:
      throw Error(PKM_ERR_INTERNAL, "unknown controller kind");
  }
}

void pkm_ctrl::computed_torque(double t, const double* q, const double* qd, const double* qddref,
                               const double* xref, const VecX& e, const VecX& ed, VecX& u) {
  std::vector<double> x(nd);
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
}

void pkm_ctrl::pid(double t, const double* q, const double* xref, const VecX& e, VecX& u) {
  std::vector<double> x(nd);
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
}

// The injected command (a DISCRETE controller has added it in its own units): before the
// saturation, or after it; inj_part = tau - what tau would be without it.
void pkm_ctrl::output(double t, const VecX& u0, double* tau) {
  VecX u = u0;
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
      throw Error(PKM_ERR_ARGUMENT, std::string(kind_name(kind)) + " at t = " + num(t) + " s: the effort of joint " +
                                        std::to_string(i + 1) + " is not finite (" + num(v) + ")");
    tau[i] = v;
    inj_part[i] = v - v0;
  }
  if (clipped) ++saturated;
}

void pkm_ctrl::discrete(const double* q, const double* qd, const double* qref, const double* qdref, VecX& tau) {
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

void pkm_ctrl::update_injected(double t, const double* q, const double* qd, const double* qref, const double* qdref,
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
