// Sampled joint-space controllers (pkm.h "control"): the laws of cosim.controllers in
// C++, so that a closed loop can run without leaving the core (pkm_sim_run_loop) and a
// controller FMU can carry the same law.  The model-based parts (gravity load, forward
// kinematics of the measured joints, inverse dynamics) call the core's own C API on a
// private model copy and work data, so the controller believes in exactly the physics
// the plant has, unless the caller gives it another model.
//
// This file reads a controller spec into a pkm_ctrl (controller.hpp) and holds the C API;
// the laws are in controller_law.cpp, the state in controller_state.cpp.
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "control/controller.hpp"

using namespace pkm;

namespace pkm::control {

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

Filter Filter::make(const double* b, int nb, const double* a, int na, int nd, const char* name) {
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

}  // namespace pkm::control

using namespace pkm::control;

namespace {

constexpr int kMaxStates = 64;

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


// The spec's gains, saturation and gravity options (every kind but LTI's matrices).
void read_gains(pkm_ctrl& c, const pkm_ctrl_spec& s, int nd) {
  const bool lti = s.kind == PKM_CTRL_LTI, disc = s.kind == PKM_CTRL_DISCRETE;
  c.kp = copy_matrix(s.kp, nd, nd, "kp", !lti);
  c.kd = copy_matrix(s.kd, nd, nd, "kd", !lti && !disc);
  c.ki = copy_matrix(s.ki, nd, nd, "ki", false);
  if (!lti) {
    check_gain(c.kp, "kp");
    check_gain(c.kd, "kd");
    check_gain(c.ki, "ki");
  }
  PKM_REQUIRE(std::isfinite(s.deriv_filter) && s.deriv_filter >= 0, PKM_ERR_ARGUMENT,
              "controller spec: deriv_filter = " + num(s.deriv_filter) + " s must be finite and >= 0");
  c.tf = s.deriv_filter;
  if (s.saturation) {
    c.sat.resize(nd);
    for (int i = 0; i < nd; ++i) {
      PKM_REQUIRE(std::isfinite(s.saturation[i]) && s.saturation[i] > 0, PKM_ERR_ARGUMENT,
                  "controller spec: saturation of joint " + std::to_string(i + 1) +
                      " must be a positive effort, got " + num(s.saturation[i]));
      c.sat[i] = s.saturation[i];
    }
  }
  c.gravity_ref = s.gravity_at_reference != 0;
  c.gravity_ff = s.gravity_feedforward != 0;
}

// The LTI controller's state space (A, B, C, D).
void read_lti(pkm_ctrl& c, const pkm_ctrl_spec& s, int nd) {
  PKM_REQUIRE(s.nx >= 0 && s.nx <= kMaxStates, PKM_ERR_ARGUMENT,
              "controller spec: nx = " + std::to_string(s.nx) + " must be in [0, " + std::to_string(kMaxStates) +
                  "]");
  c.nx = s.nx;
  c.A = copy_matrix(s.A, s.nx, s.nx, "A", s.nx > 0);
  c.B = copy_matrix(s.B, s.nx, nd, "B", s.nx > 0);
  c.C = copy_matrix(s.C, nd, s.nx, "C", s.nx > 0);
  c.D = copy_matrix(s.D, nd, nd, "D", false);
}

// The DISCRETE controller's law, filters, velocity source, output limits and gain, delay.
void read_discrete(pkm_ctrl& c, const pkm_ctrl_spec& s, int nd) {
  PKM_REQUIRE(s.law == PKM_LAW_CASCADE_PP || s.law == PKM_LAW_PID, PKM_ERR_ARGUMENT,
              "controller spec: law = " + std::to_string(s.law) + " is not PKM_LAW_CASCADE_PP (0) or PKM_LAW_PID (1)");
  c.law = s.law;
  c.kv = copy_matrix(s.kv, nd, nd, "kv", s.law == PKM_LAW_CASCADE_PP);
  check_gain(c.kv, "kv");
  c.pos = Filter::make(s.pos_b, s.pos_nb, s.pos_a, s.pos_na, nd, "position_filter");
  c.vel = Filter::make(s.vel_b, s.vel_nb, s.vel_a, s.vel_na, nd, "velocity_filter");
  PKM_REQUIRE(s.velocity_source == 0 || s.velocity_source == 1, PKM_ERR_ARGUMENT,
              "controller spec: velocity_source = " + std::to_string(s.velocity_source) +
                  " is not 0 (backward difference) or 1 (the reading qd)");
  c.measured_rate = s.velocity_source == 1;
  PKM_REQUIRE((s.u_min == nullptr) == (s.u_max == nullptr), PKM_ERR_ARGUMENT,
              "controller spec: u_min and u_max go together");
  if (s.u_min) {
    c.u_min = Eigen::Map<const VecX>(s.u_min, nd);
    c.u_max = Eigen::Map<const VecX>(s.u_max, nd);
    for (int i = 0; i < nd; ++i)
      PKM_REQUIRE(std::isfinite(c.u_min[i]) && std::isfinite(c.u_max[i]) && c.u_min[i] < c.u_max[i],
                  PKM_ERR_ARGUMENT,
                  "controller spec: the output limits of joint " + std::to_string(i + 1) + " [" + num(c.u_min[i]) +
                      ", " + num(c.u_max[i]) + "] must be finite with min < max");
  }
  c.gain = VecX::Ones(nd);
  if (s.output_gain)
    for (int i = 0; i < nd; ++i) {
      PKM_REQUIRE(std::isfinite(s.output_gain[i]) && s.output_gain[i] != 0, PKM_ERR_ARGUMENT,
                  "controller spec: output_gain of joint " + std::to_string(i + 1) +
                      " must be finite and non-zero, got " + num(s.output_gain[i]));
      c.gain[i] = s.output_gain[i];
    }
  PKM_REQUIRE(s.delay_samples >= 0 && s.delay_samples <= PKM_CTRL_MAX_DELAY, PKM_ERR_ARGUMENT,
              "controller spec: delay_samples = " + std::to_string(s.delay_samples) + " must be in [0, " +
                  std::to_string(PKM_CTRL_MAX_DELAY) + "]");
  c.delay = s.delay_samples;
}

}  // namespace

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
    read_gains(*c, s, nd);
    if (s.kind == PKM_CTRL_LTI) read_lti(*c, s, nd);
    if (s.kind == PKM_CTRL_DISCRETE) read_discrete(*c, s, nd);
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

}  // extern "C"
