// The drive layer (see drive.hpp): friction, joint force, rotor inertia, saturation and sensor model
// added to a robot's rigid-body mechanics.
#include "dynamics/drive.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <vector>

#include "common/guard.hpp"
#include "common/param_lookup.hpp"
#include "common/joint_param.hpp"
#include "kinematics/generic_kinematics.hpp"

namespace pkm {
namespace drive {

namespace {
// Per-joint parameter names, in the order of the loop in specs() and compile().
const char* kKeys[] = {"coulomb",    "viscous",    "stribeck",  "stribeck_v", "rotor_inertia",       "effort_max",
                       "encoder_offset", "backlash", "compliance", "dead_zone", "coulomb_v", "transmission_damping", "offset"};
constexpr int kNKeys = sizeof(kKeys) / sizeof(kKeys[0]);

double* field(Params& p, int k) {
  switch (k) {
    case 0: return p.coulomb;
    case 1: return p.viscous;
    case 2: return p.stribeck;
    case 3: return p.stribeck_v;
    case 4: return p.rotor;
    case 5: return p.effort_max;
    case 6: return p.encoder_offset;
    case 7: return p.backlash;
    case 8: return p.compliance;
    case 9: return p.dead_zone;
    case 10: return p.coulomb_v;
    case 11: return p.transmission_damping;
    default: return p.offset;
  }
}

}  // namespace

std::vector<ParamSpec> specs(const Robot& r) {
  const bool ang = r.joints_angular();
  const std::string F = ang ? "N m" : "N", V = ang ? "rad/s" : "m/s", Q = ang ? "rad" : "m";
  const std::string noun = r.joint_noun();
  std::vector<ParamSpec> out;
  for (int i = 0; i < r.ndof(); ++i) {
    const std::string who = noun + " " + std::to_string(i + 1);
    out.push_back({joint_param(r, i, "coulomb"), F, "Coulomb friction of actuated " + who, 0.0, 0.0, 1e6});
    out.push_back({joint_param(r, i, "viscous"), F + " s/" + Q, "viscous friction coefficient of actuated " + who,
                   0.0, 0.0, 1e6});
    out.push_back({joint_param(r, i, "stribeck"), F,
                   "Stribeck friction: static friction in excess of Coulomb at rest, " + who, 0.0, 0.0, 1e6});
    out.push_back({joint_param(r, i, "stribeck_v"), V, "Stribeck velocity (decay scale of the Stribeck term), " + who,
                   ang ? 0.05 : 0.005, 1e-9, 1e3});
    out.push_back({joint_param(r, i, "rotor_inertia"), ang ? "kg m2" : "kg",
                   "reflected actuator (rotor) inertia at the joint, " + who, 0.0, 0.0, 1e6});
    out.push_back({joint_param(r, i, "effort_max"), F, "actuator saturation |tau| <= effort_max (0: none), " + who,
                   0.0, 0.0, 1e9});
    out.push_back({joint_param(r, i, "encoder_offset"), Q, "encoder offset: measured minus true joint position, " + who,
                   0.0, -1.0, 1.0});
    out.push_back({joint_param(r, i, "backlash"), Q,
                   "backlash: total transmission gap; the encoder reads +-gap/2 by the sign of the transmitted effort, " +
                       who,
                   0.0, 0.0, 0.1});
    out.push_back({joint_param(r, i, "compliance"), Q + "/" + F,
                   "transmission compliance (1/stiffness): encoder deflection per unit effort, " + who, 0.0, 0.0, 1.0});
    out.push_back({joint_param(r, i, "dead_zone"), F,
                   "drive dead zone: commands within +-dead_zone deliver nothing, larger ones lose dead_zone, " + who,
                   0.0, 0.0, 1e6});
    out.push_back({joint_param(r, i, "coulomb_v"), V,
                   "velocity scale of the Coulomb friction, tanh(v / coulomb_v): friction that fades below it "
                   "(0: drive.v_eps, a numerical regularisation), " + who,
                   0.0, 0.0, 1e3});
    out.push_back({joint_param(r, i, "transmission_damping"), F + " s/" + Q,
                   "damping of the two-body transmission in contact (drive.two_body = 1), " + who, 0.0, 0.0, 1e9});
    out.push_back({joint_param(r, i, "offset"), F,
                   "constant effort offset: the drive supplies inverse dynamics + friction + offset (a force "
                   "pulling the joint the negative way, a cable carrier, an unbalanced mass, a measured bias), " +
                       who,
                   0.0, -1e6, 1e6});
  }
  out.push_back({"drive.v_eps", V, "velocity scale of the smooth sign used by friction", ang ? 1e-3 : 1e-4, 1e-9, 1.0});
  out.push_back({"drive.f_eps", F,
                 "effort scale of the smooth sign that picks the backlash contact side (the transmitted effort's)",
                 ang ? 0.05 : 0.01, 1e-9, 1e3});
  out.push_back({"drive.two_body", "1",
                 "1: a joint with a backlash or a compliance is a drive body (its rotor inertia and friction) and the "
                 "carriage joined by a dead-band spring, integrated by pkm_sim; 0: both are reading models",
                 0.0, 0.0, 1.0});
  out.push_back({"actuator.delay", "s", "time delay between commanded and applied actuator effort", 0.0, 0.0, 1.0});
  out.push_back({"sensor.delay", "s", "time delay of the joint readings", 0.0, 0.0, 1.0});
  for (auto& s : joint_force::specs(r)) out.push_back(std::move(s));
  return out;
}

std::shared_ptr<const Params> compile(const Robot& r, const std::vector<ParamSpec>& sp,
                                      const std::vector<double>& values) {
  auto p = std::make_shared<Params>();
  p->nd = r.ndof();
  InOrderLookup table(sp, values);
  auto get = [&](const std::string& name) -> double {
    if (const double* v = table.find(name)) return *v;
    throw Error(PKM_ERR_INTERNAL, "drive parameter " + name + " missing from the table");
  };
  for (int i = 0; i < p->nd; ++i)
    for (int k = 0; k < kNKeys; ++k) field(*p, k)[i] = get(joint_param(r, i, kKeys[k]));
  p->v_eps = get("drive.v_eps");
  p->f_eps = get("drive.f_eps");
  p->actuator_delay = get("actuator.delay");
  p->sensor_delay = get("sensor.delay");
  const double tb = get("drive.two_body");
  if (tb != 0 && tb != 1)
    throw Error(PKM_ERR_PARAMETER, "drive.two_body = " + std::to_string(tb) + " must be 0 or 1");
  p->two_body = tb == 1;
  for (int i = 0; i < p->nd; ++i) {
    if (!p->two_body_joint(i)) continue;
    // A drive body needs an inertia, and a gap's faces a stiffness: else the two-body
    // model has no dynamics of its own.
    if (!(p->rotor[i] > 0))
      throw Error(PKM_ERR_PARAMETER, "drive.two_body = 1: " + joint_param(r, i, "rotor_inertia") +
                                         " must be > 0 (the drive body's inertia) where a backlash or a compliance is set");
    if (!(p->compliance[i] > 0))
      throw Error(PKM_ERR_PARAMETER, "drive.two_body = 1: " + joint_param(r, i, "compliance") +
                                         " must be > 0 (1 / the stiffness of the transmission, or of a gap's contact "
                                         "faces) where a backlash is set");
  }
  p->force = joint_force::compile(r, sp, values);
  p->platform = platform_force::compile(r, sp, values);
  for (int i = 0; i < p->nd; ++i) {
    p->any_friction |= p->coulomb[i] != 0 || p->viscous[i] != 0 || p->stribeck[i] != 0 || p->offset[i] != 0;
    p->inertia[i] = p->rotor[i] + p->force.v[joint_force::kInertia][i];
    // A negative added inertia may correct a rotor's; a joint with a negative inertia is no body.
    if (!(p->inertia[i] >= 0))
      throw Error(PKM_ERR_PARAMETER, joint_param(r, i, "rotor_inertia") + " + " +
                                         joint_param(r, i, joint_force::kKeys[joint_force::kInertia]) + " = " +
                                         num(p->inertia[i], 6) + " must be >= 0 (the joint inertia the drive adds)");
    p->any_inertia |= p->inertia[i] != 0;
  }
  return p;
}

namespace {
// The friction keys friction_slot knows: their fields feed nothing but friction() and any_friction.
constexpr int kFrictionKeys[] = {0, 1, 2, 12};  // coulomb, viscous, stribeck, offset
}  // namespace

int friction_slot(const Robot& r, const std::string& name) {
  for (int k : kFrictionKeys)
    for (int i = 0; i < r.ndof(); ++i)
      if (joint_param(r, i, kKeys[k]) == name) return k * kMaxJoints + i;
  return -1;
}

void set_friction(Params& p, int slot, double v) {
  field(p, slot / kMaxJoints)[slot % kMaxJoints] = v;
  p.any_friction = false;
  for (int i = 0; i < p.nd; ++i)
    p.any_friction |= p.coulomb[i] != 0 || p.viscous[i] != 0 || p.stribeck[i] != 0 || p.offset[i] != 0;
}

double smooth_sign(double v, double eps) { return std::tanh(v / eps); }

void friction(const Params& p, const double* qd, double* f) {
  for (int i = 0; i < p.nd; ++i) {
    const double v = qd[i];
    // A term whose coefficient is zero is not evaluated: its value is the signed zero the
    // product gives (the smooth sign has the sign of v, the exponential is >= 0), so the sum
    // is the same bit for bit; a NaN rate still makes it NaN through the viscous term.
    const double zero = std::copysign(1.0, v);
    double coulomb = p.coulomb[i] * zero, stribeck = p.stribeck[i] * zero;
    if (p.coulomb[i] != 0) coulomb = p.coulomb[i] * smooth_sign(v, p.coulomb_v[i] > 0 ? p.coulomb_v[i] : p.v_eps);
    if (p.stribeck[i] != 0) {
      const double r = v / p.stribeck_v[i];
      stribeck = p.stribeck[i] * std::exp(-r * r) * smooth_sign(v, p.v_eps);
    }
    f[i] = coulomb + stribeck + p.viscous[i] * v + p.offset[i];
  }
}

std::shared_ptr<const Params> carriage_side(const Params& p) {
  auto c = std::make_shared<Params>(p);
  c->any_friction = c->any_inertia = false;
  for (int i = 0; i < p.nd; ++i) {
    if (p.two_body_joint(i)) {
      c->coulomb[i] = c->viscous[i] = c->stribeck[i] = c->rotor[i] = c->offset[i] = 0.0;
      c->inertia[i] = p.force.v[joint_force::kInertia][i];
    }
    c->any_friction |= c->coulomb[i] != 0 || c->viscous[i] != 0 || c->stribeck[i] != 0 || c->offset[i] != 0;
    c->any_inertia |= c->inertia[i] != 0;
  }
  return c;
}

double transmitted_effort(const Params& p, int i, double delta, double delta_dot) {
  const double half = 0.5 * p.backlash[i], k = 1.0 / p.compliance[i];
  if (delta > half) return k * (delta - half) + p.transmission_damping[i] * delta_dot;
  if (delta < -half) return k * (delta + half) + p.transmission_damping[i] * delta_dot;
  return 0.0;
}

}  // namespace drive

using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 6, 6>;
using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;

namespace {
// out += sign * the generic joint force (joint_force.hpp) at the joint motion q, qd.
void add_joint_force_at(const drive::Params& dp, int n, const double* q, const double* qd, double sign, double* out) {
  double F[6];
  joint_force::force(dp.force, n, dp.v_eps, q, qd, F);
  for (int i = 0; i < n; ++i) out[i] += sign * F[i];
}

// out -= the generic joint force at the pose x, xd with the applied effort tau (its effort
// terms read it); nothing when none is set.
void subtract_joint_force(const pkm_model* m, const drive::Params& dp, pkm_data* d, const double* x,
                          const double* xd, const double* tau, double* out) {
  if (!dp.force.any) return;
  double q[6], qd[6];
  m->robot->ik(*m->compiled, *d->rd, x, q);
  joint_velocity(*m->robot, *m->compiled, *d->rd, x, xd, qd);
  add_joint_force_at(dp, d->ndof, q, qd, -1.0, out);
  if (!dp.force.effort) return;
  double g[6], mu[6];
  joint_force::effort_gains(dp.force, d->ndof, dp.v_eps, q, qd, g, mu);
  for (int i = 0; i < d->ndof; ++i) out[i] -= g[i] * tau[i] + mu[i] * std::fabs(tau[i]);
}
}  // namespace

void mechanism_inverse_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                                const double* xdd, double* tau) {
  m->robot->inverse_dynamics(*m->compiled, *d->rd, x, xd, xdd, tau);
  platform_force::add(m, d, m->drive->platform, x, xd, 1.0, tau);
}

void total_inverse_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* xdd,
                            double* tau) {
  mechanism_inverse_dynamics(m, d, x, xd, xdd, tau);
  add_drive_inverse_dynamics(m, d, x, xd, xdd, tau);
}

void add_drive_inverse_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                                const double* xdd, double* tau) {
  const RobotModel& rm = *m->compiled;
  const drive::Params& dp = *m->drive;
  const int n = d->ndof;
  double q[6] = {}, qd[6] = {}, qdd[6] = {};
  if (dp.force.any) m->robot->ik(rm, *d->rd, x, q);
  if (dp.force.any || dp.any_friction) joint_velocity(*m->robot, rm, *d->rd, x, xd, qd);
  if (dp.any_inertia) m->robot->joint_acceleration(rm, *d->rd, x, xd, xdd, qdd);
  add_drive_efforts(dp, n, q, qd, qdd, tau);
}

void add_drive_efforts(const drive::Params& dp, int n, const double* q, const double* qd, const double* qdd,
                       double* tau) {
  if (dp.force.any) add_joint_force_at(dp, n, q, qd, 1.0, tau);
  if (dp.any_friction) {
    double f[6];
    drive::friction(dp, qd, f);
    for (int i = 0; i < n; ++i) tau[i] += f[i];
  }
  if (dp.any_inertia)
    for (int i = 0; i < n; ++i) tau[i] += dp.inertia[i] * qdd[i];
  // the terms of the applied effort last: tau = b + g tau + mu |tau| solved for tau
  if (dp.force.effort) joint_force::solve_effort(dp.force, n, dp.v_eps, q, qd, tau);
}

namespace {

// The largest magnitude of n values, for messages that say which input is too large.
double max_abs(const double* v, int n) {
  double a = 0;
  for (int i = 0; i < n; ++i) a = std::fmax(a, std::fabs(v[i]));
  return a;
}

// Finite inputs can still overflow inside the dynamics (an effort of 1e308 N): the result
// is then refused naming the inputs' sizes, never passed on as an infinity or a NaN.
void require_finite_result(const double* out, int n, const char* what, const double* xd, const double* tau,
                           int nd) {
  for (int i = 0; i < n; ++i)
    if (!std::isfinite(out[i]))
      throw Error(PKM_ERR_ARGUMENT, std::string(what) + " is not finite for finite inputs: an input is too large "
                                                         "(largest |xd| = " + num(max_abs(xd, nd), 3) +
                                        (tau ? ", largest |tau| = " + num(max_abs(tau, nd), 3) : std::string()) +
                                        ")");
}

void forward_dynamics_of(const pkm_model* m, const drive::Params& dp, pkm_data* d, const double* x, const double* xd,
                         const double* tau, double* xdd);

}  // namespace

namespace {
// Runs a forward-dynamics call f(); a robot may find an overflowing load singular: then
// the message says which input is too large instead.
template <class F>
void with_overflow_message(pkm_data* d, const double* xd, const double* tau, F&& f) {
  try {
    f();
  } catch (const Error& e) {
    const int n = d->ndof;
    if (e.status == PKM_ERR_SINGULAR && (max_abs(tau, n) > 1e150 || max_abs(xd, n) > 1e75))
      require_finite_result(std::vector<double>(n, NAN).data(), 1, "the acceleration", xd, tau, n);
    throw;
  }
}

// The effort that drives the mechanism: the command less joint friction.
void net_effort(const pkm_model* m, const drive::Params& dp, pkm_data* d, const double* x, const double* xd,
                const double* tau, double* net) {
  const int n = d->ndof;
  for (int i = 0; i < n; ++i) net[i] = tau[i];
  platform_force::add(m, d, dp.platform, x, xd, -1.0, net);
  subtract_joint_force(m, dp, d, x, xd, tau, net);
  if (!dp.any_friction) return;
  double qd[6] = {0, 0, 0, 0, 0, 0}, f[6];
  joint_velocity(*m->robot, *m->compiled, *d->rd, x, xd, qd);
  drive::friction(dp, qd, f);
  for (int i = 0; i < n; ++i) net[i] -= f[i];
}
}  // namespace

void total_forward_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* tau,
                            double* xdd) {
  total_forward_dynamics(m, *m->drive, d, x, xd, tau, xdd);
}

void total_forward_dynamics(const pkm_model* m, const drive::Params& dp, pkm_data* d, const double* x,
                            const double* xd, const double* tau, double* xdd) {
  with_overflow_message(d, xd, tau, [&] { forward_dynamics_of(m, dp, d, x, xd, tau, xdd); });
  require_finite_result(xdd, d->ndof, "the acceleration", xd, tau, d->ndof);
}

bool total_forward_dynamics_response(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                                     const double* tau, double* xdd, double* B) {
  // A joint inertia (rotor, added) changes the mass matrix the robot factorises: no cheap response then.
  if (m->drive->any_inertia) return false;
  // Effort terms of the joint force (force_cload, ...) make the net effort nonlinear in tau: none either.
  if (m->drive->force.effort) return false;
  bool ok = false;
  with_overflow_message(d, xd, tau, [&] {
    double net[6];
    net_effort(m, *m->drive, d, x, xd, tau, net);
    ok = m->robot->forward_dynamics_response(*m->compiled, *d->rd, x, xd, net, xdd, B);
  });
  if (!ok) return false;
  require_finite_result(xdd, d->ndof, "the acceleration", xd, tau, d->ndof);
  require_finite_result(B, d->ndof * d->ndof, "the acceleration's response to the efforts", xd, tau, d->ndof);
  return true;
}

namespace {

void forward_dynamics_of(const pkm_model* m, const drive::Params& dp, pkm_data* d, const double* x, const double* xd,
                         const double* tau, double* xdd) {
  const RobotModel& rm = *m->compiled;
  if (!dp.any_friction && !dp.any_inertia && !dp.force.any && !dp.platform.any) {
    m->robot->forward_dynamics(rm, *d->rd, x, xd, tau, xdd);
    return;
  }
  const int n = d->ndof;
  // Friction and the velocity part of the joint inertia force are efforts the actuator
  // spends before the mechanism sees any: the mechanism is driven by the net effort.
  Vec net(n);
  net_effort(m, dp, d, x, xd, tau, net.data());
  if (!dp.any_inertia) {
    m->robot->forward_dynamics(rm, *d->rd, x, xd, net.data(), xdd);
    return;
  }
  // Joint inertia (rotor and added) Jr qdd with qdd = J xdd + Jdot xd: the mechanism sees
  // net - Jr (J xdd + Jdot xd), so (M + J' Jr J) xdd = M xdd0 with
  // xdd0 = FD_robot(net - Jr Jdot xd).
  double J[36], Jd[36];
  m->robot->jacobians(rm, *d->rd, x, nullptr, nullptr, J);
  Eigen::Map<const Mat> Jm(J, n, n);
  m->robot->jacobian_dot(rm, *d->rd, x, xd, Jd);
  Vec jdxd = Eigen::Map<const Mat>(Jd, n, n) * Eigen::Map<const Vec>(xd, n);
  for (int i = 0; i < n; ++i) net[i] -= dp.inertia[i] * jdxd[i];
  Vec xdd0(n);
  m->robot->forward_dynamics(rm, *d->rd, x, xd, net.data(), xdd0.data());
  Mat M(n, n);
  m->robot->mass_matrix(rm, *d->rd, x, M.data());
  Mat Mt = M;
  for (int i = 0; i < n; ++i)
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) Mt(a, b) += Jm(i, a) * dp.inertia[i] * Jm(i, b);
  Eigen::LLT<Mat> llt(Mt);
  if (llt.info() != Eigen::Success)
    throw Error(PKM_ERR_SINGULAR, "forward dynamics: the mass matrix is not positive definite at this pose");
  Eigen::Map<Vec>(xdd, n) = llt.solve(M * xdd0);
}

}  // namespace

void total_mass_matrix(const pkm_model* m, pkm_data* d, const double* x, double* M) {
  const RobotModel& rm = *m->compiled;
  const drive::Params& dp = *m->drive;
  m->robot->mass_matrix(rm, *d->rd, x, M);
  if (!dp.any_inertia) return;
  const int n = d->ndof;
  double J[36];
  m->robot->jacobians(rm, *d->rd, x, nullptr, nullptr, J);
  for (int i = 0; i < n; ++i)
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) M[a * n + b] += J[i * n + a] * dp.inertia[i] * J[i * n + b];
}

void total_energy(const pkm_model* m, pkm_data* d, const double* x, const double* xd, double* kinetic,
                  double* potential) {
  const RobotModel& rm = *m->compiled;
  const drive::Params& dp = *m->drive;
  m->robot->energy(rm, *d->rd, x, xd, kinetic, potential);
  const double both[2] = {*kinetic, *potential};
  require_finite_result(both, 2, "the energy", xd, nullptr, d->ndof);
  if (!dp.any_inertia) return;
  const int n = d->ndof;
  double J[36];
  m->robot->jacobians(rm, *d->rd, x, nullptr, nullptr, J);
  for (int i = 0; i < n; ++i) {
    double qd = 0;
    for (int j = 0; j < n; ++j) qd += J[i * n + j] * xd[j];
    *kinetic += 0.5 * dp.inertia[i] * qd * qd;
  }
  require_finite_result(kinetic, 1, "the kinetic energy", xd, nullptr, n);
}

void actuator_effort(const drive::Params& p, const double* tau_cmd, double* tau_applied) {
  for (int i = 0; i < p.nd; ++i) {
    // The amplifier's dead band first (a command of magnitude u delivers u - u0 beyond
    // it, nothing within it), then the saturation of what it delivers.
    const double u0 = p.dead_zone[i], u = tau_cmd[i];
    const double v = u0 > 0 ? std::copysign(std::fmax(std::fabs(u) - u0, 0.0), u) : u;
    const double lim = p.effort_max[i];
    tau_applied[i] = lim > 0 ? std::fmax(-lim, std::fmin(lim, v)) : v;
  }
}

void sensor_readings(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* tau,
                     const double* theta, const double* theta_d, double* q_meas, double* qd_meas) {
  const drive::Params& dp = *m->drive;
  const int n = d->ndof;
  measure_joints(m, d, x, xd, tau, q_meas);
  if (qd_meas) joint_velocity(*m->robot, *m->compiled, *d->rd, x, xd, qd_meas);
  for (int i = 0; i < n; ++i) {
    if (!dp.two_body_joint(i)) continue;
    if (theta) q_meas[i] = theta[i] + dp.encoder_offset[i];
    if (theta_d && qd_meas) qd_meas[i] = theta_d[i];
  }
}

void measure_joints(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* tau,
                    double* q_meas) {
  const RobotModel& rm = *m->compiled;
  const drive::Params& dp = *m->drive;
  const int n = d->ndof;
  bool flexible = false;
  for (int i = 0; i < n; ++i) flexible |= dp.backlash[i] != 0 || dp.compliance[i] != 0;
  // The effort the transmission carries: the applied one less what the drive side spends on
  // its own friction, joint force and joint inertia (computed only when a gap or an elasticity reads it).
  double carried[6];
  for (int i = 0; i < n; ++i) carried[i] = tau[i];
  if (flexible) subtract_joint_force(m, dp, d, x, xd, tau, carried);
  if (flexible) platform_force::add(m, d, dp.platform, x, xd, -1.0, carried);
  if (flexible && (dp.any_friction || dp.any_inertia)) {
    double J[36], qd[6], f[6], xdd[6], qdd[6];
    m->robot->jacobians(rm, *d->rd, x, nullptr, nullptr, J);
    for (int i = 0; i < n; ++i) {
      qd[i] = 0;
      for (int j = 0; j < n; ++j) qd[i] += J[i * n + j] * xd[j];
    }
    if (dp.any_friction) {
      drive::friction(dp, qd, f);
      for (int i = 0; i < n; ++i) carried[i] -= f[i];
    }
    if (dp.any_inertia) {
      total_forward_dynamics(m, d, x, xd, tau, xdd);
      m->robot->joint_acceleration(rm, *d->rd, x, xd, xdd, qdd);
      for (int i = 0; i < n; ++i) carried[i] -= dp.inertia[i] * qdd[i];
    }
  }
  m->robot->ik(rm, *d->rd, x, q_meas);
  for (int i = 0; i < n; ++i) {
    // The encoder sits on the drive side of the transmission: the carriage leans on the
    // side of the gap the carried effort pushes it to (under a gravity preload that is
    // not the side of the velocity), and the transmission deflects by compliance * effort.
    q_meas[i] += dp.encoder_offset[i] + 0.5 * dp.backlash[i] * drive::smooth_sign(carried[i], dp.f_eps) +
                 dp.compliance[i] * carried[i];
  }
}

}  // namespace pkm
