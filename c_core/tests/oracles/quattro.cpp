// The hand-written Adept Quattro s650H (4-RUU), Virzi 2010, a test oracle of the robot served
// from robots/quattro.toml: parameters, inverse kinematics (ch. 1.4.1), Jacobians and their
// time derivative (ch. 2.3, 2.5), the simplified Newton-Euler model of ch. 5 written in task
// space, the GIMRE of ch. 4 and the inputs of the 22 indices.  Conventions in quattro.hpp.
#include "oracles/quattro.hpp"

#include <sstream>

#include "common/guard.hpp"

namespace pkm {
namespace quattro {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

std::string fmt(double v, int prec = 6) {
  std::ostringstream os;
  os.precision(prec);
  os << v;
  return os.str();
}

std::string arm_name(int i) { return "arm " + std::to_string(i + 1); }

}  // namespace

void Model::index_inputs(const double* x, quattro_facts::IndexInputs& in) const {
  Pose p;
  pose_kinematics(*this, x, p);
  in.JD = br * p.J;
  in.N = quattro::gimre(*this, p);
  in.M = mass_matrix(*this, p);
  const double s2 = std::sqrt(0.5);
  const Eigen::Vector4d vz(0, 0, 1, 0), vxy(s2, s2, 0, 0);
  in.hv_z = velocity_force(*this, p, vz);
  in.hv_xy = velocity_force(*this, p, vxy);
  in.grav = gravity_force(*this, p);
  in.tau_z = solve_JT(p, in.M * vz, "alfa index");
  in.tau_x = solve_JT(p, in.M * Eigen::Vector4d(-s2, -s2, 0, 0), "alfa index");
  in.tau_max = tau_arm_max();
}

Eigen::Matrix4d Model::gimre(const double* x) const {
  Pose p;
  pose_kinematics(*this, x, p);
  return quattro::gimre(*this, p);
}

void Model::points(const double* x, double* Ao, double* Bo, double* Co) const {
  Pose p;
  pose_kinematics(*this, x, p);
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < 3; ++j) {
      if (Ao) Ao[3 * i + j] = A[i][j];
      if (Bo) Bo[3 * i + j] = p.B[i][j];
      if (Co) Co[3 * i + j] = p.C[i][j];
    }
}

void Model::constants(double* out) const {
  out[0] = tau_arm_max();
  out[1] = ratio;
  out[2] = h;
  out[3] = br;
}

void pose_kinematics(const Model& m, const double* x, Pose& p, bool check_limits) {
  p.th = x[3];
  const double psi = kPi / 4 + p.th;
  p.cps = std::cos(psi);
  p.sps = std::sin(psi);
  p.ep = Eigen::Vector3d(p.cps, p.sps, 0);
  p.epd = Eigen::Vector3d(-p.sps, p.cps, 0);
  p.E = Eigen::Vector3d(x[0], x[1], x[2]);
  p.P = p.E + m.off * p.ep + Eigen::Vector3d(0, 0, m.ee);
  const Eigen::Vector3d ez(0, 0, 1);
  for (int i = 0; i < N; ++i) {
    p.C[i] = p.P + (0.5 * m.d) * (m.sigma[i] * p.ep + Eigen::Vector3d(m.w[i].x(), m.w[i].y(), 0));
    p.k[i] = m.off + m.sigma[i] * 0.5 * m.d;
    // In the arm's vertical plane the closure |C - B| = c reads r cos q - s sin q = K
    // (source eqs. 1.3-1.7 solved for the angle directly); RAD >= 0 <=> |K| <= R.
    const Eigen::Vector3d D = p.C[i] - m.A[i];
    const double r = D.dot(m.u[i]), s = D.z();
    const double K = (D.squaredNorm() + m.b * m.b - m.c * m.c) / (2 * m.b);
    const double R = std::hypot(r, s);
    if (!(R > 0) || std::fabs(K) > R)
      throw Error(PKM_ERR_UNREACHABLE,
                  arm_name(i) + ": pose out of reach (RAD < 0: the forearm sphere misses the elbow circle, |K|/R = " +
                      fmt(R > 0 ? std::fabs(K) / R : INFINITY, 4) + ")");
    // The source keeps the larger x_B for arm 1 (smaller for arm 3, y_B for arms 2 and 4):
    // the elbow out, which with C below the motor plane (s < 0) is the root gam - del.
    // The elbow-in root lies beyond the joint range everywhere in the workspace.
    const double gam = std::atan2(-s, r), del = std::acos(K / R);
    double q = gam - del;
    q = std::atan2(std::sin(q), std::cos(q));
    if (check_limits && (q <= m.qmin || q >= m.qmax))
      throw Error(PKM_ERR_JOINT_LIMIT, arm_name(i) + ": q = " + fmt(q / kDeg, 5) + " deg outside the joint range [" +
                                           fmt(m.qmin / kDeg, 4) + ", " + fmt(m.qmax / kDeg, 4) + "] deg");
    p.q[i] = q;
    p.cq[i] = std::cos(q);
    p.sq[i] = std::sin(q);
    p.B[i] = m.A[i] + m.b * (p.cq[i] * m.u[i] - p.sq[i] * ez);
    p.g[i] = p.C[i] - p.B[i];
    p.t[i] = m.b * (-p.sq[i] * m.u[i] - p.cq[i] * ez);
    p.Jx.block<1, 3>(i, 0) = 2 * p.g[i].transpose();
    p.Jx(i, 3) = 2 * p.k[i] * p.g[i].dot(p.epd);
    p.Jq[i] = 2 * p.g[i].dot(p.t[i]);
    if (std::fabs(p.Jq[i]) < 1e-10 * m.b * m.c)
      throw Error(PKM_ERR_SINGULAR, arm_name(i) +
                                        ": inverse-kinematic (serial) singularity, forearm in line with the upper arm");
    p.J.row(i) = p.Jx.row(i) / p.Jq[i];
  }
}

Eigen::Matrix4d jacobian_dot(const Model& m, const Pose& p, const Eigen::Vector4d& xd) {
  const Eigen::Vector4d qd = p.J * xd;
  const Eigen::Vector3d ez(0, 0, 1), epdd(-p.cps, -p.sps, 0);
  Eigen::Matrix4d Jd;
  for (int i = 0; i < N; ++i) {
    const Eigen::Vector3d Cd = xd.head<3>() + p.k[i] * xd[3] * p.epd;
    const Eigen::Vector3d gd = Cd - p.t[i] * qd[i];
    const Eigen::Vector3d td = m.b * (-p.cq[i] * m.u[i] + p.sq[i] * ez) * qd[i];
    Eigen::RowVector4d Jxd;
    Jxd.head<3>() = 2 * gd.transpose();
    Jxd[3] = 2 * p.k[i] * (gd.dot(p.epd) + p.g[i].dot(epdd) * xd[3]);
    const double Jqd = 2 * (gd.dot(p.t[i]) + p.g[i].dot(td));
    Jd.row(i) = (Jxd - p.J.row(i) * Jqd) / p.Jq[i];
  }
  return Jd;
}

namespace {
// The platform-side point masses: (mass, ell) with position E + ell e_psi + const, so
// d r / d theta = ell e_psi'.  M34 is the source's point A (tool side), M12 its point B.
struct PointMass {
  double m, ell;
};
std::array<PointMass, 3> platform_points(const Model& m) {
  return {{{m.mA, m.off - 0.5 * m.d}, {m.mB, m.off + 0.5 * m.d}, {m.mload, 0.0}}};
}
// Adds the platform's point masses (each at ell along the articulation) and the load's
// inertia through the tool ratio to a 4x4 inertia in the coordinates (x, y, z, theta).
void add_platform_inertia(const Model& m, const Pose& p, const std::array<PointMass, 3>& pts, Eigen::Matrix4d& M) {
  for (const auto& pm : pts) {
    const Eigen::Vector3d v = pm.ell * p.epd;
    M.topLeftCorner<3, 3>().diagonal().array() += pm.m;
    M.block<3, 1>(0, 3) += pm.m * v;
    M.block<1, 3>(3, 0) += pm.m * v.transpose();
    M(3, 3) += pm.m * pm.ell * pm.ell;
  }
  M(3, 3) += m.tool_ratio * m.tool_ratio * m.Jload;
}
}  // namespace

Eigen::Matrix4d mass_matrix(const Model& m, const Pose& p) {
  Eigen::Matrix4d M = m.Ieq * p.J.transpose() * p.J;
  add_platform_inertia(m, p, platform_points(m), M);
  return M;
}

Eigen::Vector4d velocity_force(const Model& m, const Pose& p, const Eigen::Vector4d& xd, const Eigen::Matrix4d* Jdot) {
  const Eigen::Matrix4d Jd = Jdot ? *Jdot : jacobian_dot(m, p, xd);
  Eigen::Vector4d h = m.Ieq * p.J.transpose() * (Jd * xd);
  // d/dt (ell e_psi') = -ell e_psi thetadot; its theta component (along e_psi') is 0.
  const double w2 = xd[3] * xd[3];
  for (const auto& pm : platform_points(m)) h.head<3>() += -pm.m * pm.ell * w2 * p.ep;
  return h;
}

Eigen::Vector4d arm_gravity(const Model& m, const Pose& p) {
  Eigen::Vector4d g;
  const Eigen::Vector3d ez(0, 0, 1);
  for (int i = 0; i < N; ++i) {
    const double qr = p.q[i] - m.alp;
    const Eigen::Vector3d dG1 = m.lg * (-std::sin(qr) * m.u[i] - std::cos(qr) * ez);
    g[i] = -m.mb * m.grav.dot(dG1) - m.mc * m.grav.dot(p.t[i]);
  }
  return g;
}

Eigen::Vector4d gravity_force(const Model& m, const Pose& p) {
  Eigen::Vector4d f = p.J.transpose() * arm_gravity(m, p);
  for (const auto& pm : platform_points(m)) {
    f.head<3>() -= pm.m * m.grav;
    f[3] -= pm.m * pm.ell * m.grav.dot(p.epd);
  }
  return f;
}

double potential_energy(const Model& m, const Pose& p) {
  const Eigen::Vector3d ez(0, 0, 1);
  double V = 0;
  for (int i = 0; i < N; ++i) {
    const double qr = p.q[i] - m.alp;
    const Eigen::Vector3d G1 = m.A[i] + m.lg * (std::cos(qr) * m.u[i] - std::sin(qr) * ez);
    V -= m.mb * m.grav.dot(G1) + m.mc * m.grav.dot(p.B[i]);
  }
  const Eigen::Vector3d base = p.E + Eigen::Vector3d(0, 0, m.ee);
  for (const auto& pm : platform_points(m)) V -= pm.m * m.grav.dot(base + pm.ell * p.ep);
  return V;
}

Eigen::Vector4d solve_JT(const Pose& p, const Eigen::Vector4d& f, const char* what) {
  // J^T = Jx^T Jq^-1, so J^-T f = Jq (Jx^-T f).
  Eigen::PartialPivLU<Eigen::Matrix4d> lu(p.Jx.transpose());
  if (!(lu.rcond() > 1e-12))
    throw Error(PKM_ERR_SINGULAR, std::string(what) +
                                      ": direct (parallel) singularity, Jx is singular at this pose (rcond " +
                                      fmt(lu.rcond(), 3) + ")");
  Eigen::Vector4d z = lu.solve(f);
  return p.Jq.cwiseProduct(z);
}

Eigen::Matrix4d gimre(const Model& m, const Pose& p) {
  Eigen::Matrix4d Nm = m.I1_gimre * p.J.transpose() * p.J;
  for (int i = 0; i < N; ++i) {
    // A forearm (two rods, 2 m_c, length c) as one uniform rod between B_i and C_i:
    // T = (2 m_c / 6) (|vB|^2 + vB.vC + |vC|^2); its spin about its own axis is neglected
    // (r_c is small, source ch. 4.4.2).
    Eigen::Matrix<double, 3, 4> Bm = p.t[i] * p.J.row(i), Cm;
    Cm.leftCols<3>().setIdentity();
    Cm.col(3) = p.k[i] * p.epd;
    Nm += (2 * m.mc / 3) * (Bm.transpose() * Bm + Cm.transpose() * Cm) +
          (m.mc / 3) * (Bm.transpose() * Cm + Cm.transpose() * Bm);
  }
  add_platform_inertia(m, p, {{{0.5 * m.mp, m.off - 0.5 * m.d}, {0.5 * m.mp, m.off + 0.5 * m.d}, {m.mload, 0.0}}}, Nm);
  return Nm;
}

// ------------------------------------------------------------------------- the robot

namespace {

struct ParamTable {
  std::vector<ParamSpec> s;
  void add(const std::string& n, const std::string& unit, double v, double lo, double hi, const std::string& desc) {
    ParamSpec p;
    p.name = n;
    p.unit = unit;
    p.description = desc;
    p.value = v;
    p.lo = lo;
    p.hi = hi;
    s.push_back(p);
  }
};

class Quattro final : public Robot {
 public:
  const char* name() const override { return "quattro_hand"; }
  const char* title() const override { return "Adept Quattro s650H 4-RUU (Virzi 2010), hand-written test oracle"; }
  int ndof() const override { return N; }
  std::vector<std::string> param_sets() const override { return {"default", "appendix_a"}; }
  std::vector<const char*> features() const override {
    return {"quattro_indices", "quattro_gimre", "quattro_points"};
  }
  const char* pose_name(int i) const override {
    static const char* n[] = {"x", "y", "z", "theta"};
    return n[i];
  }
  const char* pose_unit(int i) const override { return i < 3 ? "m" : "rad"; }
  std::string joint_limit_param(int, bool upper) const override { return upper ? "joint.q_max" : "joint.q_min"; }
  // The four lengths of the arm chain, the forearm (the longest, the one most often off
  // after a rebuild) first: the blind generator perturbs the first.
  const char* geometry_param(int i) const override {
    static const char* n[] = {"forearm.c", "base.a", "arm.b_r", "platform.d"};
    return i >= 0 && i < 4 ? n[i] : nullptr;
  }

  std::vector<ParamSpec> param_specs(const std::string& set) const override {
    const bool app = set == "appendix_a";
    if (!(set == "default" || app))
      throw Error(PKM_ERR_ARGUMENT, "quattro: unknown parameter set '" + set + "' (known: default, appendix_a)");
    ParamTable t;
    const double big = 1e3;
    t.add("base.a", "m", app ? 0.28 : 0.275, 1e-3, 10, "distance of each motor axis A_i from the base centre (source symbol a)");
    t.add("base.h", "m", app ? 0.20 : 0.19, -10, 10,
          "height of the world (Adept) origin above the motor-axis plane, tool flange drop included (source symbol base)");
    t.add("arm.b_r", "m", 0.375, 1e-3, 10, "upper arm (link 1) length (source symbol br)");
    t.add("arm.r_b", "m", 0.028, 0, 1, "upper arm radius; the forearm joint sits r_b below the arm axis (source symbol r_b)");
    t.add("arm.m", "kg", app ? 1.85 : 1.45, 0, big, "upper arm mass (source symbol m_b; 1.85 kg with the 8 screws)");
    t.add("arm.lg", "m", 0.121, 0, 10, "centre of mass of the upper arm from A_i (source symbol lg)");
    t.add("forearm.c", "m", 0.825, 1e-3, 10, "forearm rod length (source symbol c)");
    t.add("forearm.r_c", "m", 0.00675, 0, 1, "forearm rod radius (source symbol r_c; inertia about the rod axis neglected)");
    t.add("forearm.m", "kg", 0.24, 0, big, "mass of ONE forearm rod, two rods per arm (source symbol m_c)");
    t.add("platform.d", "m", 0.15, 1e-3, 10, "side of the square of the platform joints C_i (source symbol d)");
    t.add("platform.m", "kg", app ? 2.62 : 0.262, 0, big,
          "platform mass, half at each end M12 / M34 of its central axis (source symbol m_p)");
    t.add("platform.offset", "m", app ? 0.0 : 0.075, 0, 1,
          "tool point offset from the platform centre towards M34 (source symbol offset; 0 in the source's maps)");
    t.add("tool.length", "m", 0.0, -1, 1, "extra end-effector length below the flange (source symbol ee)");
    t.add("tool.ratio", "1", 4.0, 0, 100, "tool rotation per platform articulation angle (belt 1:4)");
    t.add("payload.m", "kg", 0.0, 0, big, "payload mass at the tool point (source symbol m_load)");
    t.add("payload.J", "kg.m2", 0.0, 0, big, "payload inertia about the tool axis");
    t.add("motor.J", "kg.m2", 0.811e-4, 0, 1, "rotor inertia of one motor (source symbol I_mot)");
    t.add("gear.ratio", "1", 50.0, 1e-3, 1e4, "gear reduction i: motor angle = i * arm angle");
    t.add("motor.tau_nominal", "N.m", 2.39, 0, big,
          "nominal motor torque; i * tau is the arm-side limit of the alfa indices (119.5 N m)");
    t.add("joint.q_min", "rad", -51 * kDeg, -kPi, kPi, "lower end of the arm range (source: -51 deg, upwards)");
    t.add("joint.q_max", "rad", 123 * kDeg, -kPi, kPi, "upper end of the arm range (source: +123 deg, downwards)");
    t.add("gravity.x", "m/s2", 0.0, -100, 100, "gravity acceleration, x component");
    t.add("gravity.y", "m/s2", 0.0, -100, 100, "gravity acceleration, y component");
    t.add("gravity.z", "m/s2", -9.81, -100, 100, "gravity acceleration, z component");
    return t.s;
  }

  std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>& specs, const std::vector<double>& v) const override {
    auto get = [&](const std::string& n) {
      for (size_t i = 0; i < specs.size(); ++i)
        if (specs[i].name == n) return v[i];
      throw Error(PKM_ERR_INTERNAL, "quattro: parameter " + n + " missing from the table");
    };
    auto m = std::make_unique<Model>();
    m->a = get("base.a");
    m->h = get("base.h");
    m->br = get("arm.b_r");
    m->rb = get("arm.r_b");
    m->b = std::hypot(m->br, m->rb);
    m->alp = std::atan2(m->rb, m->br);
    m->c = get("forearm.c");
    m->rc = get("forearm.r_c");
    m->d = get("platform.d");
    m->off = get("platform.offset");
    m->ee = get("tool.length");
    m->mb = get("arm.m");
    m->lg = get("arm.lg");
    m->mc = get("forearm.m");
    m->mp = get("platform.m");
    m->mload = get("payload.m");
    m->Jload = get("payload.J");
    m->tool_ratio = get("tool.ratio");
    m->Jm = get("motor.J");
    m->ratio = get("gear.ratio");
    m->tau_motor = get("motor.tau_nominal");
    m->qmin = get("joint.q_min");
    m->qmax = get("joint.q_max");
    m->grav = Eigen::Vector3d(get("gravity.x"), get("gravity.y"), get("gravity.z"));
    if (!(m->qmin < m->qmax))
      throw Error(PKM_ERR_PARAMETER, "joint.q_min = " + fmt(m->qmin) + " rad must be below joint.q_max = " +
                                         fmt(m->qmax) + " rad");
    if (m->lg > m->br)
      throw Error(PKM_ERR_PARAMETER, "arm.lg = " + fmt(m->lg) + " m lies beyond the arm length arm.b_r = " + fmt(m->br) + " m");
    // Source ch. 5.3.1 / 5.2: rotor through the gear, link 1 as a rod about its end, the
    // elbow half of both forearm rods; the platform ends carry half the platform and the
    // other halves of the rods (2 m_c each end = 4 arms x m_c / 2).
    m->Ieq = m->ratio * m->ratio * m->Jm + m->mb * m->br * m->br / 3 + m->mc * m->b * m->b;
    m->I1_gimre = m->mb * m->lg * m->lg + m->mb * (m->br * m->br / 3 - m->br * m->lg + m->lg * m->lg);
    m->mA = 0.5 * m->mp + 2 * m->mc;
    m->mB = 0.5 * m->mp + 2 * m->mc;
    const double s2 = std::sqrt(0.5);
    for (int i = 0; i < N; ++i) {
      const double phi = i * kPi / 2;
      m->u[i] = Eigen::Vector3d(std::cos(phi), std::sin(phi), 0);
      if (std::fabs(m->u[i].x()) < 1e-15) m->u[i].x() = 0;
      if (std::fabs(m->u[i].y()) < 1e-15) m->u[i].y() = 0;
      m->A[i] = m->a * m->u[i] - Eigen::Vector3d(0, 0, m->h);
      m->sigma[i] = i < 2 ? 1.0 : -1.0;
    }
    m->w[0] = Eigen::Vector2d(s2, -s2);
    m->w[1] = Eigen::Vector2d(-s2, s2);
    m->w[2] = Eigen::Vector2d(-s2, s2);
    m->w[3] = Eigen::Vector2d(s2, -s2);
    // The home pose must be reachable and regular, or nothing else can work.
    double xh[4];
    home(*m, xh);
    Pose p;
    try {
      pose_kinematics(*m, xh, p);
      solve_JT(p, Eigen::Vector4d::Ones(), "home pose");
    } catch (const Error& e) {
      throw Error(PKM_ERR_PARAMETER, std::string("quattro: the home pose (0, 0, ") + fmt(xh[2]) +
                                         " m, 0) is not a regular reachable pose with these parameters: " + e.what());
    }
    return m;
  }

  void home(const RobotModel& rm, double* x) const override {
    const Model& m = static_cast<const Model&>(rm);
    // Tool point centred over the robot axis, at the source's best cycle height band.
    x[0] = 0;
    x[1] = 0;
    x[2] = -0.76 - m.h - m.ee;  // z0 = z + base + ee = -0.76 m (z = -0.95 m by default)
    x[3] = 0;
  }

  // The travelling plate's full pose: (x, y, z) its tool point, theta its rotation about z (rz);
  // rx, ry held at 0.
  void platform_pose(const RobotModel&, RobotData&, const double* x, double* X, double* S) const override {
    const double full[6] = {x[0], x[1], x[2], 0.0, 0.0, x[3]};
    for (int k = 0; k < 6; ++k) X[k] = full[k];
    if (!S) return;
    for (int k = 0; k < 6 * N; ++k) S[k] = 0.0;
    S[0 * N + 0] = S[1 * N + 1] = S[2 * N + 2] = S[5 * N + 3] = 1.0;
  }
  bool has_platform() const override { return true; }

  void ik(const RobotModel& rm, RobotData&, const double* x, double* q) const override {
    Pose p;
    pose_kinematics(static_cast<const Model&>(rm), x, p);
    for (int i = 0; i < N; ++i) q[i] = p.q[i];
  }

  void jacobians(const RobotModel& rm, RobotData&, const double* x, double* Jx, double* Jq, double* J) const override {
    Pose p;
    pose_kinematics(static_cast<const Model&>(rm), x, p);
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < N; ++j) {
        if (Jx) Jx[i * N + j] = p.Jx(i, j);
        if (Jq) Jq[i * N + j] = i == j ? p.Jq[i] : 0.0;
        if (J) J[i * N + j] = p.J(i, j);
      }
  }

  void jacobian_dot(const RobotModel& rm, RobotData&, const double* x, const double* xd, double* Jdot) const override {
    const Model& m = static_cast<const Model&>(rm);
    Pose p;
    pose_kinematics(m, x, p);
    const Eigen::Matrix4d Jd = quattro::jacobian_dot(m, p, Eigen::Map<const Eigen::Vector4d>(xd));
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < N; ++j) Jdot[i * N + j] = Jd(i, j);
  }

  // Each arm's motor axis point A, elbow B and platform joint C (drawing; no range check).
  void chain_points(const RobotModel& rm, RobotData&, const double* x, double* pts) const override {
    const Model& m = static_cast<const Model&>(rm);
    Pose p;
    pose_kinematics(m, x, p, false);
    for (int i = 0; i < N; ++i) {
      const Eigen::Vector3d* rows[3] = {&m.A[i], &p.B[i], &p.C[i]};
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) pts[9 * i + 3 * r + k] = (*rows[r])[k];
    }
  }

  void singularity(const RobotModel& rm, RobotData&, const double* x, double* measures) const override {
    const Model& m = static_cast<const Model&>(rm);
    Pose p;
    pose_kinematics(m, x, p);
    double s1 = 1;
    for (int i = 0; i < N; ++i)
      s1 = std::min(s1, std::fabs(p.g[i].dot(p.t[i])) / (p.g[i].norm() * p.t[i].norm()));
    // Tangential arm speed per end-effector speed: columns in m/s, rotation as the speed of
    // the platform joints (d/2) theta-dot.
    Eigen::Matrix4d Js = m.br * p.J;
    Js.col(3) /= 0.5 * m.d;
    Eigen::JacobiSVD<Eigen::Matrix4d> svd(Js);
    const auto& sv = svd.singularValues();
    measures[0] = s1;
    measures[1] = sv[0] > 0 ? sv[3] / sv[0] : 0.0;
  }

  void inverse_dynamics(const RobotModel& rm, RobotData&, const double* x, const double* xd, const double* xdd,
                        double* tau) const override {
    const Model& m = static_cast<const Model&>(rm);
    Pose p;
    pose_kinematics(m, x, p);
    Eigen::Map<const Eigen::Vector4d> v(xd), a(xdd);
    const Eigen::Matrix4d Jd = quattro::jacobian_dot(m, p, v);
    const Eigen::Vector4d qdd = p.J * a + Jd * v;
    // Joint friction (the source's f_s, f_v) is the drive layer's joint[i].coulomb/.viscous,
    // added by the C API (dynamics/drive.hpp).  Arm side directly in joint space; the platform side as a task-space force mapped by
    // J^-T (virtual power), so a near-singular J only touches what passes through it.
    Eigen::Vector4d fp = Eigen::Vector4d::Zero();
    const double w2 = v[3] * v[3];
    for (const auto& pm : platform_points(m)) {
      const Eigen::Vector3d acc = a.head<3>() + pm.ell * (a[3] * p.epd - w2 * p.ep) - m.grav;
      fp.head<3>() += pm.m * acc;
      fp[3] += pm.m * pm.ell * p.epd.dot(acc);
    }
    fp[3] += m.tool_ratio * m.tool_ratio * m.Jload * a[3];
    Eigen::Map<Eigen::Vector4d> out(tau);
    out = m.Ieq * qdd + arm_gravity(m, p) + solve_JT(p, fp, "inverse dynamics");
  }

  // The generic forward dynamics, with its effort response for the integrator.
  bool forward_dynamics_response(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                 const double* tau, double* xdd, double* B) const override {
    generic_forward_dynamics(rm, rd, x, xd, tau, xdd, B);
    return true;
  }

  void mass_matrix(const RobotModel& rm, RobotData&, const double* x, double* M) const override {
    const Model& m = static_cast<const Model&>(rm);
    Pose p;
    pose_kinematics(m, x, p);
    const Eigen::Matrix4d Mm = quattro::mass_matrix(m, p);
    for (int i = 0; i < N; ++i)
      for (int j = 0; j < N; ++j) M[i * N + j] = Mm(i, j);
  }

  void energy(const RobotModel& rm, RobotData&, const double* x, const double* xd, double* kin,
              double* pot) const override {
    const Model& m = static_cast<const Model&>(rm);
    Pose p;
    pose_kinematics(m, x, p);
    Eigen::Map<const Eigen::Vector4d> v(xd);
    *kin = 0.5 * v.dot(quattro::mass_matrix(m, p) * v);
    *pot = potential_energy(m, p);
  }
};

}  // namespace
}  // namespace quattro

const Robot* oracle_quattro() {
  static quattro::Quattro r;
  return &r;
}

}  // namespace pkm
