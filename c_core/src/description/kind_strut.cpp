// Joint kind `strut` (UPS, SPS): an actuated strut of length q = |P - B| between a base joint
// and the platform point, a cylinder and a piston as uniform slender tubes: its schema,
// compiled form, geometry, derivatives, mass and force terms.
#include <cmath>
#include <limits>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

namespace {

class StrutMotion final : public LegMotionOf<StrutMotion> {
 public:
  const char* prefix() const override { return "strut"; }
  const char* noun() const override { return "strut"; }
  bool angular() const override { return false; }
  bool has_rod() const override { return false; }
  const char* plane_through() const override { return "base joint"; }
  int moving_point() const override { return 2; }  // the cylinder's end

  // q = |P - B|.  Points: B, P, the cylinder's end, the piston's end.
  template <class T>
  static void geometry_of(const LegModel& l, const P3<T>& P, T& q, P3<T>* out, const LegWhere& at) {
    using std::sqrt;
    const P3<T> d = P - l.base;
    out[1] = P;
    q = sqrt(dot(d, d));
    if (!(value_of(q) > 1e-9)) at.unreachable("the platform point is on the strut's base joint");
    const P3<T> nn = (T(1.0) / q) * d;
    out[0] = {T(l.base.x()), T(l.base.y()), T(l.base.z())};
    out[2] = l.base + T(l.l_cyl) * nn;  // cylinder end
    out[3] = P - T(l.l_pis) * nn;       // piston end
  }
  void geometry(const LegModel& l, const P3<double>& P, double& q, P3<double>* pts, const LegWhere& at) const override {
    geometry_of(l, P, q, pts, at);
  }
  // dq/dP = n' (n = w / q), d n / dP = (I - n n') / q.
  static void grad_of(const LegModel& l, const V3& P, LegGrad& lg, const LegWhere& at) {
    geometry_of(l, P3<double>{P.x(), P.y(), P.z()}, lg.q, lg.pos, at);
    const V3 w = lg.w = P - v3(lg.pos[0]);
    const V3 n = w / lg.q;
    lg.dq = n.transpose();
    const M3 Pn = (M3::Identity() - n * n.transpose()) / lg.q;  // d n / dP
    lg.D[0].setZero();
    lg.D[2] = l.l_cyl * Pn;
    lg.D[3] = M3::Identity() - l.l_pis * Pn;
    lg.D[1].setIdentity();
  }
  double closure_dq(const LegModel&, const LegGrad& lg) const override { return lg.q; }
  double ik_measure(const LegModel&, double) const override { return std::numeric_limits<double>::infinity(); }
  Eigen::RowVector3d dq_rate(const LegModel&, const LegGrad& lg, const V3& vP, double qd) const override {
    return ((vP - qd * lg.dq.transpose()) / lg.q).transpose();
  }
  // The general form over the body points: KE = 1/2 vP' MP vP, a point inertia at P.
  static void add_mass_of(const LegModel& l, const LegGrad& lg, TwistMass& tm) {
    M3 MP;
    MP.setZero();
    for (int k = 0; k < l.nmass; ++k) MP.noalias() += l.mass[k].m * lg.D[l.mass[k].a].transpose() * lg.D[l.mass[k].a];
    for (int k = 0; k < l.nrod; ++k) {
      const Rod& r = l.rod[k];
      const M3& A = lg.D[r.a];
      const M3& B = lg.D[r.b];
      const M3 C = A.transpose() * B;
      MP.noalias() += (r.m / 3) * (A.transpose() * A + B.transpose() * B) + (r.m / 6) * (C + C.transpose());
    }
    add_point_inertia(tm.Mt, MP, lg.rP);
  }
  // q^2 = w.w: q qdd = |vP|^2 - qd^2 + w.aP; n = w / q, ndd = (aP - qdd n - 2 qd nd) / q.
  static double qdd_of(const LegModel&, const LegGrad& lg, const V3& vP, const V3& aP) {
    const double qd = lg.dq.dot(vP);
    return (vP.squaredNorm() - qd * qd + lg.w.dot(aP)) / lg.q;
  }
  static V3 load_of(const LegModel& l, const LegGrad& lg, const V3& vP, const V3& aP, const V3& g, double& qdd) {
    const V3& w = lg.w;
    const double qd = lg.dq.dot(vP);
    const double q = lg.q;
    const V3 n = w / q, nd = (vP - qd * n) / q;
    qdd = qdd_of(l, lg, vP, aP);
    const V3 ndd = (aP - qdd * n - (2 * qd) * nd) / q;
    V3 acc[4];
    acc[0].setZero();
    acc[1] = aP;
    acc[2] = l.l_cyl * ndd;
    acc[3] = aP - l.l_pis * ndd;
    V3 f = V3::Zero();
    for (int k = 0; k < l.nmass; ++k)
      f.noalias() += lg.D[l.mass[k].a].transpose() * (l.mass[k].m * (acc[l.mass[k].a] - g));
    for (int k = 0; k < l.nrod; ++k) {
      const Rod& r = l.rod[k];
      const V3 Fa = (r.m / 3) * acc[r.a] + (r.m / 6) * acc[r.b] - (r.m / 2) * g;
      const V3 Fb = (r.m / 6) * acc[r.a] + (r.m / 3) * acc[r.b] - (r.m / 2) * g;
      f.noalias() += lg.D[r.a].transpose() * Fa + lg.D[r.b].transpose() * Fb;
    }
    if (l.I_arm != 0) f += (l.I_arm * qdd) * lg.dq.transpose();
    return f;
  }
};

class StrutLeg final : public LegKind {
 public:
  std::vector<std::string> fields() const override { return {"base_point", "cylinder_mass", "cylinder_length", "piston_mass", "piston_length"}; }

  bool read(const LegSchema& s, const std::vector<double>& p, const std::vector<double>& stroke,
            bool /*articulated: a strut has no turning offset*/) const override {
    const Reader& rd = s.rd;
    const std::string& where = s.where;
    const int i = s.i;
    const std::string leg = "leg " + std::to_string(i + 1);

      const auto B = s.vec("base_point", "the strut's base joint [m]");
    const char* c[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) s.add(idx("leg", i, (std::string("b") + c[k]).c_str()), "m", std::string(c[k]) + " of the base joint of " + leg, B[k], -1e3, 1e3, s.line_of("base_point"));
    for (int k = 0; k < 3; ++k) s.add(idx("leg", i, (std::string("p") + c[k]).c_str()), "m", std::string(c[k]) + " of the platform attachment point of " + leg + ", platform frame", p[k], -1e3, 1e3, s.line_of("platform_point"));
    if (!(stroke[0] > 0)) rd.fail(s.line_of("stroke"), where + ": a strut's stroke is its length between the joints; min = " + num(stroke[0]) + " m must be > 0");
    s.add(idx("strut", i, "qmin"), "m", "shortest length of the strut of " + leg, stroke[0], 1e-9, 1e3, s.line_of("stroke"));
    s.add(idx("strut", i, "qmax"), "m", "longest length of the strut of " + leg, stroke[1], 1e-9, 1e3, s.line_of("stroke"));
    s.add(idx("cylinder", i, "m"), "kg", "cylinder mass of " + leg + " (uniform tube from the base joint)", s.scalar("cylinder_mass", "cylinder mass [kg]", 0, 1e6, "kg"), 0, 1e6, s.line_of("cylinder_mass"));
    s.add(idx("cylinder", i, "l"), "m", "cylinder length of " + leg, s.scalar("cylinder_length", "cylinder length [m]", 1e-9, 1e300, "m"), 1e-9, 1e3, s.line_of("cylinder_length"));
    s.add(idx("piston", i, "m"), "kg", "piston mass of " + leg + " (uniform rod ending at the platform joint)", s.scalar("piston_mass", "piston mass [kg]", 0, 1e6, "kg"), 0, 1e6, s.line_of("piston_mass"));
    s.add(idx("piston", i, "l"), "m", "piston length of " + leg, s.scalar("piston_length", "piston length [m]", 1e-9, 1e300, "m"), 1e-9, 1e3, s.line_of("piston_length"));
    return false;
  }

  void compile(const ParamValues& v, int i, bool /*lumped: a strut has no rod*/, LegModel& l) const override {
    const auto name = idx;

    l.base = v.vec("leg", i, "b");
    l.p = v.vec("leg", i, "p");
    l.qmin = v(name("strut", i, "qmin")), l.qmax = v(name("strut", i, "qmax"));
    l.m_cyl = v(name("cylinder", i, "m")), l.l_cyl = v(name("cylinder", i, "l"));
    l.m_pis = v(name("piston", i, "m")), l.l_pis = v(name("piston", i, "l"));
    l.npt = 4, l.nrod = 2;
    l.rod[0] = {0, 2, l.m_cyl};
    l.rod[1] = {3, 1, l.m_pis};
  }

  const LegMotion& motion() const override {
    static const StrutMotion k;
    return k;
  }
};

}  // namespace

const LegKind& strut_leg() {
  static const StrutLeg k;
  return k;
}

}  // namespace described
}  // namespace pkm
