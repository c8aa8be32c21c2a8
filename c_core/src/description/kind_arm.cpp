// Joint kind `arm` (RUS, RSS, R(SS)2, RRR): a revolute arm at the base, elbow
// B = A + r (cos q u + sin q (k x u)), its mass at its centre of mass plus an inertia, then the
// rod to the platform point (kind_rod.cpp): its schema, compiled form, geometry, derivatives,
// mass and force terms.
#include <cmath>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"
#include "description/kind_rod.hpp"

namespace pkm {
namespace described {

namespace {

class ArmMotion final : public LegMotionOf<ArmMotion> {
 public:
  const char* prefix() const override { return "arm"; }
  const char* noun() const override { return "arm"; }
  bool angular() const override { return true; }
  bool has_rod() const override { return true; }
  const char* plane_through() const override { return "base joint"; }
  int moving_point() const override { return 0; }  // the elbow

  // alpha cos q + beta sin q = K with d = P - A in the (u, w) frame of the arm.  Points: the
  // elbow B, P, the arm's centre of mass.
  template <class T>
  static void geometry_of(const LegModel& l, const P3<T>& P, T& q, P3<T>* out, const LegWhere& at) {
    using std::acos;
    using std::atan2;
    using std::sqrt;
    const P3<T> d = P - l.base;
    out[1] = P;
    const T al = dot(l.u, d), be = dot(l.w, d);
    const T K = (0.5 / l.r) * (dot(d, d) + (l.r * l.r - l.L * l.L));
    const T rho = sqrt(al * al + be * be);
    const double c = value_of(K) / value_of(rho);
    if (!(std::abs(c) <= 1 - 1e-12))
      at.unreachable(std::abs(c) > 1 ? "the rod's sphere misses the elbow circle (|K| / rho = " + g6(std::abs(c)) + ")"
                                     : "the rod is in line with the arm (inverse-kinematic singularity)");
    q = atan2(be, al) + l.branch * acos(K / rho);
    T sq, cq;
    sin_cos(q, sq, cq);
    const P3<T> e = along(cq, l.u) + along(sq, l.w);
    out[0] = l.base + T(l.r) * e;   // elbow B
    if (l.com_s == 0) {
      out[2] = l.base + T(l.rc) * e;  // arm centre of mass
    } else {                          // off the arm line by an angle: e(q + phi)
      const P3<T> ep = along(-sq, l.u) + along(cq, l.w);
      out[2] = l.base + (T(l.rc * l.com_c) * e + T(l.rc * l.com_s) * ep);
    }
  }
  void geometry(const LegModel& l, const P3<double>& P, double& q, P3<double>* pts, const LegWhere& at) const override {
    geometry_of(l, P, q, pts, at);
  }
  // |P - B(q)| = L: w . (dP - t dq) = 0 with t = dB/dq = r e'(q); the centre of mass moves
  // along tb = rc (com_c e' - com_s e).
  static void grad_of(const LegModel& l, const V3& P, LegGrad& lg, const LegWhere& at) {
    geometry_of(l, P3<double>{P.x(), P.y(), P.z()}, lg.q, lg.pos, at);
    const V3 w = lg.w = P - v3(lg.pos[0]);
    double sq, cq;
    sin_cos(lg.q, sq, cq);
    const V3 e = cq * l.u + sq * l.w, ep = cq * l.w - sq * l.u;
    lg.t = l.r * ep;
    lg.tb = l.rc * (l.com_c * ep - l.com_s * e);
    lg.wt = w.dot(lg.t);
    lg.dq = w.transpose() / lg.wt;
  }
  double closure_dq(const LegModel& l, const LegGrad& lg) const override {
    return l.r * lg.w.dot(-std::sin(lg.q) * l.u + std::cos(lg.q) * l.w);
  }
  double ik_measure(const LegModel& l, double jq) const override { return std::abs(jq) / (l.L * l.r); }
  // t's rate is -r qd e(q).
  Eigen::RowVector3d dq_rate(const LegModel& l, const LegGrad& lg, const V3& vP, double qd) const override {
    double sq, cq;
    sin_cos(lg.q, sq, cq);
    return rod_dq_rate(lg, lg.t, vP, qd, l.r * qd * lg.w.dot(cq * l.u + sq * l.w));
  }
  static void add_mass_of(const LegModel& l, const LegGrad& lg, TwistMass& tm) { add_rod_leg_mass(l, lg, tm); }
  // B = A + r e(q), t = dB/dq = r e'(q), dt/dq = -r e(q).
  // The joint's rate and acceleration, and e(q).
  struct Accel {
    double qd, qdd;
    V3 e;
  };
  static Accel accel(const LegModel& l, const LegGrad& lg, const V3& vP, const V3& aP) {
    Accel a;
    const V3& w = lg.w;
    const double qd = a.qd = lg.dq.dot(vP);
    double sq, cq;
    sin_cos(lg.q, sq, cq);
    const V3 e = a.e = cq * l.u + sq * l.w;
    const V3& t = lg.t;
    const V3 wd = vP - qd * t;
    a.qdd = (w.dot(aP) + wd.squaredNorm() + l.r * qd * qd * w.dot(e)) / lg.wt;
    return a;
  }
  static double qdd_of(const LegModel& l, const LegGrad& lg, const V3& vP, const V3& aP) {
    return accel(l, lg, vP, aP).qdd;
  }
  static V3 load_of(const LegModel& l, const LegGrad& lg, const V3& vP, const V3& aP, const V3& g, double& qdd) {
    const Accel a = accel(l, lg, vP, aP);
    const double qd = a.qd;
    qdd = a.qdd;
    const V3& e = a.e;
    const V3& t = lg.t;
    const V3 aS = qdd * t - (l.r * qd * qd) * e;
    const V3 aB = qdd * lg.tb - (qd * qd * l.rc) * (l.com_c * e + l.com_s * (t / l.r));
    return rod_leg_load(l, lg, aP, aS, aB, qdd, g);
  }
};

class ArmLeg final : public LegKind {
 public:
  std::vector<std::string> fields() const override { return {"rod_length", "rod_mass", "rod_model", "branch", "axis_point", "axis", "arm_direction", "arm_length", "arm_mass", "arm_com", "arm_com_angle", "arm_inertia"}; }

  bool read(const LegSchema& s, const std::vector<double>& p, const std::vector<double>& stroke,
            bool articulated) const override {
    const bool lumped = read_rod(s, p, articulated);
    const Reader& rd = s.rd;
    const toml::Table& t = s.t;
    const int i = s.i;
    const std::string leg = "leg " + std::to_string(i + 1);

    const auto A = s.vec("axis_point", "a point of the motor axis [m]");
    const auto k_ = s.unit_vec("axis", "unit motor axis; q turns the arm about it by the right-hand rule");
    const auto u = s.unit_vec("arm_direction", "unit arm direction at q = 0, perpendicular to the axis");
    if (std::abs(k_[0] * u[0] + k_[1] * u[1] + k_[2] * u[2]) > 1e-6) rd.fail(s.line_of("arm_direction"), s.where + ": arm_direction must be perpendicular to the axis");
    const char* c[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) s.add(idx("arm", i, (std::string("A") + c[k]).c_str()), "m", std::string(c[k]) + " of the motor axis point of " + leg, A[k], -1e3, 1e3, s.line_of("axis_point"));
    for (int k = 0; k < 3; ++k) s.add(idx("arm", i, (std::string("k") + c[k]).c_str()), "1", std::string(c[k]) + " of the motor axis of " + leg + " (unit vector)", k_[k], -2, 2, s.line_of("axis"));
    for (int k = 0; k < 3; ++k) s.add(idx("arm", i, (std::string("u") + c[k]).c_str()), "1", std::string(c[k]) + " of the arm direction of " + leg + " at q = 0 (unit, perpendicular to the axis)", u[k], -2, 2, s.line_of("arm_direction"));
    s.add(idx("arm", i, "r"), "m", "arm length of " + leg + " (motor axis to elbow joint)",
        s.scalar("arm_length", "motor axis to elbow [m]", 1e-9, 1e300, "m"), 1e-9, 1e3, s.line_of("arm_length"));
    s.add(idx("arm", i, "mass"), "kg", "arm mass of " + leg, s.scalar("arm_mass", "arm mass [kg]", 0, 1e6, "kg"), 0, 1e6, s.line_of("arm_mass"));
    s.add(idx("arm", i, "rc"), "m", "distance from the motor axis to the arm's centre of mass along the arm, " + leg,
        s.scalar("arm_com", "axis to the arm's centre of mass [m]", -1e3, 1e3, "m"), -1e3, 1e3, s.line_of("arm_com"));
    s.add(idx("arm", i, "I"), "kg m2", "arm inertia about its centre of mass, about an axis parallel to the motor axis, " + leg,
        s.scalar("arm_inertia", "arm inertia about its centre of mass [kg m2]", 0, 1e6, "kg m2"), 0, 1e6, s.line_of("arm_inertia"));
    double phi = 0;
    if (t.find("arm_com_angle")) phi = rd.number(*t.find("arm_com_angle"), "leg.arm_com_angle");
    s.add(idx("arm", i, "com_angle"), "rad", "angle of the arm's centre of mass from the line axis-to-elbow, positive as q, " + leg,
        phi, -4, 4, s.line_of("arm_com_angle"));
    s.add(idx("arm", i, "qmin"), "rad", "lower joint limit of " + leg, stroke[0], -100, 100, s.line_of("stroke"));
    s.add(idx("arm", i, "qmax"), "rad", "upper joint limit of " + leg, stroke[1], -100, 100, s.line_of("stroke"));
    return lumped;
  }

  void compile(const ParamValues& v, int i, bool lumped, LegModel& l) const override {
    compile_rod(v, i, lumped, l);
    const auto name = idx;

    l.base = v.vec("arm", i, "A");
    l.dir = v.vec("arm", i, "k");
    l.u = v.vec("arm", i, "u");
    if (std::abs(l.dir.norm() - 1) > 1e-6 || std::abs(l.u.norm() - 1) > 1e-6 || std::abs(l.dir.dot(l.u)) > 1e-6)
      v.bad("arm " + std::to_string(i + 1) + ": axis and arm direction must be perpendicular unit vectors");
    // Used as exact unit vectors (a file's rounded directions, within 1e-6 of unit and
    // perpendicular, would otherwise make the arm r |u| long and the closure inexact).
    l.dir.normalize();
    l.u = (l.u - l.u.dot(l.dir) * l.dir).normalized();
    l.w = l.dir.cross(l.u);
    l.r = v(name("arm", i, "r"));
    l.m_body = v(name("arm", i, "mass"));
    l.rc = v(name("arm", i, "rc"));
    l.I_arm = v(name("arm", i, "I"));
    const double phi = v(name("arm", i, "com_angle"));
    l.com_c = std::cos(phi), l.com_s = std::sin(phi);
    l.qmin = v(name("arm", i, "qmin")), l.qmax = v(name("arm", i, "qmax"));
    l.npt = 3, l.nmass = 1, l.nrod = 1;
    l.mass[0] = {2, l.m_body};
    l.rod[0] = {0, 1, l.m_rod};
  }

  const LegMotion& motion() const override {
    static const ArmMotion k;
    return k;
  }
};

}  // namespace

const LegKind& arm_leg() {
  static const ArmLeg k;
  return k;
}

}  // namespace described
}  // namespace pkm
