// The drive layer's generic per-joint force (see joint_force.hpp).
#include "dynamics/joint_force.hpp"

#include <cmath>

#include "common/guard.hpp"
#include "common/param_lookup.hpp"
#include "common/joint_param.hpp"

namespace pkm {
namespace joint_force {

const char* const kKeys[kNKeys] = {"force_qc",   "force_k1",   "force_k2",     "force_k3",
                                   "force_v2",   "force_vpos", "force_vneg",   "force_cpos",
                                   "force_cneg", "force_sin",  "force_cos",    "force_period",
                                   "force_step", "force_step_q", "force_step_w", "force_cv",
                                   "force_inertia", "force_qv",   "force_cq1",    "force_cq2",
                                   "force_czone", "force_czone_q", "force_czone_w", "force_xj",
                                   "force_xqc",  "force_xk1",  "force_xv",     "force_cload",
                                   "force_ceff", "force_eq",   "force_eg",     "force_taut",
                                   "force_taut_q", "force_taut_w"};
namespace {
enum { QC, K1, K2, K3, V2, VPOS, VNEG, CPOS, CNEG, SIN, COS, PERIOD, STEP, STEP_Q, STEP_W, CV, INERTIA,
       QV, CQ1, CQ2, CZONE, CZONE_Q, CZONE_W, XJ, XQC, XK1, XV, CLOAD, CEFF, EQ, EG, TAUT, TAUT_Q, TAUT_W };
static_assert(INERTIA == kInertia, "kInertia names the acceleration term");
static_assert(TAUT_W + 1 == kNKeys, "one key per term");
// keys that shape a term and are no force alone
bool shape_key(int k) {
  return k == QC || k == PERIOD || k == STEP_Q || k == STEP_W || k == CV || k == INERTIA || k == CZONE_Q ||
         k == CZONE_W || k == XJ || k == XQC || k == TAUT_Q || k == TAUT_W;
}
bool effort_key(int k) { return k == CLOAD || k == CEFF || k == EQ || k == EG; }
// log(1 + e^x) without overflow: max(x, 0) + log1p(e^-|x|); its slope (the logistic) is in (0, 1)
double softplus(double x) { return std::fmax(x, 0.0) + std::log1p(std::exp(-std::fabs(x))); }
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
    add(QV, F + " s/" + Q + "2", "force per z qd (a damping that changes over the stroke)", -big);
    add(CQ1, F + "/" + Q, "Coulomb level per unit of z: force_cq1 z tanh(qd / v_c)", -big);
    add(CQ2, F + "/" + Q + "2", "Coulomb level per z^2: force_cq2 z^2 tanh(qd / v_c)", -big);
    add(CZONE, F, "Coulomb level of a friction zone: force_czone tanh(qd / v_c) (1 + tanh((q - force_czone_q) / "
                  "force_czone_w)) / 2", -big);
    add(CZONE_Q, Q, "position where the friction zone's level is half reached", -big);
    add(CZONE_W, Q, "width of the friction zone's edge (0: no zone; negative: the zone lies below force_czone_q)",
        -big);
    add(XJ, "", "the other joint (1-based index; 0: none) whose motion the cross terms force_xk1, force_xv read",
        0.0);
    add(XQC, Q, "centre of the other joint's position in the cross term force_xk1 (q_k - force_xqc)", -big);
    add(XK1, F + "/" + Q, "force per unit of the other joint's position (q_k - force_xqc): a cable carrier or hose "
                          "linking two axes", -big);
    add(XV, F + " s/" + Q, "force per unit of the other joint's rate qd_k", -big);
    add(CLOAD, "", "Coulomb level per unit of the applied effort's magnitude: force_cload |tau| tanh(qd / v_c) "
                   "(a friction that grows with the load)", -big);
    add(CEFF, "", "force per unit of the applied effort, by direction of motion: force_ceff tau tanh(qd / v_c)",
        -big);
    add(EQ, "1/" + Q, "force per unit of the applied effort and of z: force_eq z tau (an efficiency that changes "
                      "over the stroke)", -big);
    add(EG, "", "force per unit of the applied effort: force_eg tau (a torque constant or ratio off)", -big);
    add(TAUT, F + "/" + Q,
        "stiffness of a one-sided spring on the difference d = q - q_k to the other joint k = force_xj (a cable "
        "carrier or hose that pulls once taut): force_taut force_taut_w softplus((d - force_taut_q) / force_taut_w)",
        -big);
    add(TAUT_Q, Q, "the difference q - q_k past which the one-sided spring is taut (its slack)", -big);
    add(TAUT_W, Q,
        "width of the one-sided spring's smooth onset (0: no one-sided spring; negative: taut below force_taut_q)",
        -big);
  }
  return out;
}

Coefficients compile(const Robot& r, const std::vector<ParamSpec>& sp, const std::vector<double>& values) {
  Coefficients c;
  InOrderLookup table(sp, values);
  auto get = [&](const std::string& name) -> double {
    if (const double* v = table.find(name)) return *v;
    throw Error(PKM_ERR_INTERNAL, "joint force parameter " + name + " missing from the table");
  };
  for (int i = 0; i < r.ndof(); ++i)
    for (int k = 0; k < kNKeys; ++k) {
      c.v[k][i] = get(joint_param(r, i, kKeys[k]));
      // The centre, the period, the step's and the zone's position and width, the Coulomb
      // levels' velocity scale and the other joint's index and centre shape terms; alone they
      // are no force.  The inertia is the drive's joint inertia's (drive::compile), not a term of force().
      if (!shape_key(k)) c.any |= c.v[k][i] != 0;
      if (effort_key(k)) c.effort |= c.v[k][i] != 0;
    }
  for (int i = 0; i < r.ndof(); ++i) {
    const double x = c.v[XJ][i];
    if (x != std::floor(x) || x < 0 || x > r.ndof() || x == i + 1)
      throw Error(PKM_ERR_PARAMETER, joint_param(r, i, kKeys[XJ]) + " = " + num(x, 6) +
                                         " must be 0 or the 1-based index of another joint (1.." +
                                         std::to_string(r.ndof()) + ", not " + std::to_string(i + 1) + ")");
    if (x == 0 && c.v[TAUT][i] != 0 && c.v[TAUT_W][i] != 0)
      throw Error(PKM_ERR_PARAMETER, joint_param(r, i, kKeys[TAUT]) + " = " + num(c.v[TAUT][i], 6) +
                                         " is a one-sided spring to another joint: " +
                                         joint_param(r, i, kKeys[XJ]) + " must name it (1.." +
                                         std::to_string(r.ndof()) + ")");
  }
  return c;
}

void force(const Coefficients& c, int nd, double v_eps, const double* q, const double* qd, double* F) {
  const double two_pi = 6.283185307179586;
  for (int i = 0; i < nd; ++i) {
    const auto& v = c.v;
    // The smooth sign only where a Coulomb-like term reads it: else every term that would read
    // it has a zero coefficient, and its sign (that of w) gives each the same signed zero.
    const bool sign_read = v[CPOS][i] != 0 || v[CNEG][i] != 0 || v[CQ1][i] != 0 || v[CQ2][i] != 0 ||
                           (v[CZONE][i] != 0 && v[CZONE_W][i] != 0);
    const double z = q[i] - v[QC][i], w = qd[i];
    const double s = sign_read ? std::tanh(w / (v[CV][i] > 0 ? v[CV][i] : v_eps)) : std::copysign(1.0, w);
    double f = z * (v[K1][i] + z * (v[K2][i] + z * v[K3][i])) + v[V2][i] * w * std::fabs(w) +
               v[VPOS][i] * std::fmax(w, 0.0) + v[VNEG][i] * std::fmin(w, 0.0) + v[CPOS][i] * std::fmax(s, 0.0) +
               v[CNEG][i] * std::fmin(s, 0.0);
    if (v[PERIOD][i] > 0) {
      const double a = two_pi * q[i] / v[PERIOD][i];
      f += v[SIN][i] * std::sin(a) + v[COS][i] * std::cos(a);
    }
    if (v[STEP_W][i] > 0) f += v[STEP][i] * std::tanh((q[i] - v[STEP_Q][i]) / v[STEP_W][i]);
    f += v[QV][i] * z * w + (v[CQ1][i] + v[CQ2][i] * z) * z * s;
    if (v[CZONE_W][i] != 0) f += v[CZONE][i] * s * 0.5 * (1.0 + std::tanh((q[i] - v[CZONE_Q][i]) / v[CZONE_W][i]));
    const int k = static_cast<int>(v[XJ][i]) - 1;
    if (k >= 0 && k < nd) {
      f += v[XK1][i] * (q[k] - v[XQC][i]) + v[XV][i] * qd[k];
      const double w_taut = v[TAUT_W][i];
      if (w_taut != 0) f += v[TAUT][i] * w_taut * softplus((q[i] - q[k] - v[TAUT_Q][i]) / w_taut);
    }
    F[i] = f;
  }
}

void effort_gains(const Coefficients& c, int nd, double v_eps, const double* q, const double* qd, double* g,
                  double* mu) {
  const auto& v = c.v;
  for (int i = 0; i < nd; ++i) {
    const double s = std::tanh(qd[i] / (v[CV][i] > 0 ? v[CV][i] : v_eps));
    g[i] = v[CEFF][i] * s + v[EQ][i] * (q[i] - v[QC][i]) + v[EG][i];
    mu[i] = v[CLOAD][i] * s;
  }
}

void solve_effort(const Coefficients& c, int nd, double v_eps, const double* q, const double* qd, double* tau) {
  double g[kMaxJoints], mu[kMaxJoints];
  effort_gains(c, nd, v_eps, q, qd, g, mu);
  for (int i = 0; i < nd; ++i) {
    // tau (1 - g) - mu |tau| = b: with a = 1 - g > |mu| the left side rises strictly with tau,
    // and tau has the sign of b
    const double a = 1.0 - g[i];
    if (!(a - std::fabs(mu[i]) > 0))
      throw Error(PKM_ERR_ARGUMENT, "the effort terms of joint " + std::to_string(i + 1) +
                                        " (force_cload, force_ceff, force_eq, force_eg) take " + num(1.0 - a + std::fabs(mu[i]), 4) +
                                        " of the applied effort at q = " + num(q[i], 6) + ", qd = " + num(qd[i], 6) +
                                        ": the drive self-locks (must be < 1)");
    tau[i] /= a - mu[i] * (tau[i] > 0 ? 1.0 : tau[i] < 0 ? -1.0 : 0.0);
  }
}

}  // namespace joint_force
}  // namespace pkm
