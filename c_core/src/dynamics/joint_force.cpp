// The drive layer's generic per-joint force (see joint_force.hpp).
#include "dynamics/joint_force.hpp"

#include <cmath>

#include "common/guard.hpp"
#include "common/joint_param.hpp"

namespace pkm {
namespace joint_force {

const char* const kKeys[kNKeys] = {"force_qc",   "force_k1",   "force_k2",     "force_k3",
                                   "force_v2",   "force_vpos", "force_vneg",   "force_cpos",
                                   "force_cneg", "force_sin",  "force_cos",    "force_period",
                                   "force_step", "force_step_q", "force_step_w", "force_cv",
                                   "force_inertia"};
namespace {
enum { QC, K1, K2, K3, V2, VPOS, VNEG, CPOS, CNEG, SIN, COS, PERIOD, STEP, STEP_Q, STEP_W, CV, INERTIA };
static_assert(INERTIA == kInertia, "kInertia names the last key");
}  // namespace

std::vector<ParamSpec> specs(const Robot& r) {
  const bool ang = r.joints_angular();
  const std::string F = ang ? "N m" : "N", Q = ang ? "rad" : "m", V = ang ? "rad/s" : "m/s";
  const double big = 1e12;
  std::vector<ParamSpec> out;
  for (int i = 0; i < r.ndof(); ++i) {
    const std::string who = std::string(", generic joint force of ") + r.joint_noun() + " " + std::to_string(i + 1);
    auto add = [&](int k, const std::string& unit, const std::string& what, double lo) {
      out.push_back({joint_param(r, i, kKeys[k]), unit, what + who, 0.0, lo, big});
    };
    add(QC, Q, "centre z = q - force_qc of the position polynomial", -big);
    add(K1, F + "/" + Q, "stiffness: force per unit of z", -big);
    add(K2, F + "/" + Q + "2", "force per z^2", -big);
    add(K3, F + "/" + Q + "3", "force per z^3", -big);
    add(V2, F + " s2/" + Q + "2", "quadratic drag: force per qd |qd|", -big);
    add(VPOS, F + " s/" + Q, "viscous coefficient moving in the positive direction", -big);
    add(VNEG, F + " s/" + Q, "viscous coefficient moving in the negative direction", -big);
    add(CPOS, F, "Coulomb level moving in the positive direction", -big);
    add(CNEG, F, "Coulomb level moving in the negative direction", -big);
    add(SIN, F, "amplitude of sin(2 pi q / force_period)", -big);
    add(COS, F, "amplitude of cos(2 pi q / force_period)", -big);
    add(PERIOD, Q, "period of the ripple in position (0: no ripple)", 0.0);
    add(STEP, F, "height of the smooth step tanh((q - force_step_q) / force_step_w)", -big);
    add(STEP_Q, Q, "position of the smooth step", -big);
    add(STEP_W, Q, "width of the smooth step (0: no step)", 0.0);
    add(CV, V,
        "velocity scale of the Coulomb levels force_cpos / force_cneg, tanh(qd / force_cv): a friction that fades "
        "below it (0: drive.v_eps)",
        0.0);
    add(INERTIA, ang ? "kg m2" : "kg",
        "added inertia the drive carries on the joint (a coupling, pulley, belt, a mass riding on it): force per "
        "unit of joint acceleration, added to the rotor inertia",
        -big);
  }
  return out;
}

Coefficients compile(const Robot& r, const std::vector<ParamSpec>& sp, const std::vector<double>& values) {
  Coefficients c;
  auto get = [&](const std::string& name) -> double {
    for (size_t i = 0; i < sp.size(); ++i)
      if (sp[i].name == name) return values[i];
    throw Error(PKM_ERR_INTERNAL, "joint force parameter " + name + " missing from the table");
  };
  for (int i = 0; i < r.ndof(); ++i)
    for (int k = 0; k < kNKeys; ++k) {
      c.v[k][i] = get(joint_param(r, i, kKeys[k]));
      // The centre, the period, the step's position and width and the Coulomb levels' velocity scale
      // shape terms; alone they are no force.  The inertia is the drive's joint inertia's
      // (drive::compile), not a term of force().
      if (k != QC && k != PERIOD && k != STEP_Q && k != STEP_W && k != CV && k != INERTIA) c.any |= c.v[k][i] != 0;
    }
  return c;
}

void force(const Coefficients& c, int nd, double v_eps, const double* q, const double* qd, double* F) {
  const double two_pi = 6.283185307179586;
  for (int i = 0; i < nd; ++i) {
    const auto& v = c.v;
    const double z = q[i] - v[QC][i], w = qd[i], s = std::tanh(w / (v[CV][i] > 0 ? v[CV][i] : v_eps));
    double f = z * (v[K1][i] + z * (v[K2][i] + z * v[K3][i])) + v[V2][i] * w * std::fabs(w) +
               v[VPOS][i] * std::fmax(w, 0.0) + v[VNEG][i] * std::fmin(w, 0.0) + v[CPOS][i] * std::fmax(s, 0.0) +
               v[CNEG][i] * std::fmin(s, 0.0);
    if (v[PERIOD][i] > 0) {
      const double a = two_pi * q[i] / v[PERIOD][i];
      f += v[SIN][i] * std::sin(a) + v[COS][i] * std::cos(a);
    }
    if (v[STEP_W][i] > 0) f += v[STEP][i] * std::tanh((q[i] - v[STEP_Q][i]) / v[STEP_W][i]);
    F[i] = f;
  }
}

}  // namespace joint_force
}  // namespace pkm
