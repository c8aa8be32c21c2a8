// Joint kind `rail` (PUS, PSS, P(SS)2, PRR): a slider S = S0 + q s on a prismatic rail at the
// base (its mass a point at S), then the rod to the platform point (kind_rod.cpp): its schema,
// compiled form, geometry, derivatives, mass and force terms.
#include <algorithm>
#include <cmath>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"
#include "description/kind_rod.hpp"

namespace pkm {
namespace described {

namespace {

class RailMotion final : public LegMotionOf<RailMotion> {
 public:
  const char* prefix() const override { return "rail"; }
  const char* noun() const override { return "slider"; }
  bool angular() const override { return false; }
  bool has_rod() const override { return true; }
  const char* plane_through() const override { return "rail"; }
  int moving_point() const override { return 0; }  // the slider

  // |d - q s|^2 = L^2 with d = P - S0: ss q^2 - 2 b q + |d|^2 - L^2 = 0.  Points: S, P.
  template <class T>
  static void geometry_of(const LegModel& l, const P3<T>& P, T& q, P3<T>* out, const LegWhere& at) {
    using std::sqrt;
    const P3<T> d = P - l.base;
    out[1] = P;
    const T b = dot(l.dir, d);
    const T disc = b * b - l.ss * (dot(d, d) - l.L * l.L);
    if (!(value_of(disc) >= l.disc_tol))
      at.unreachable(value_of(disc) < -l.disc_tol ? "the rod is too short to meet the rail"
                                                  : "the rod is perpendicular to its rail (inverse-kinematic singularity)");
    q = l.inv_ss * (b - l.branch * sqrt(disc));
    out[0] = l.base + along(q, l.dir);
  }
  void geometry(const LegModel& l, const P3<double>& P, double& q, P3<double>* pts, const LegWhere& at) const override {
    geometry_of(l, P, q, pts, at);
  }
  // |P - S(q)| = L: w . (dP - s dq) = 0.
  static void grad_of(const LegModel& l, const V3& P, LegGrad& lg, const LegWhere& at) {
    geometry_of(l, P3<double>{P.x(), P.y(), P.z()}, lg.q, lg.pos, at);
    const V3 w = lg.w = P - v3(lg.pos[0]);
    lg.wt = w.dot(l.dir);
    lg.dq = w.transpose() / lg.wt;
  }
  // Every leg at once over the model's arrays (the loops vectorise; the same operations as
  // grad_of); a leg that does not reach is handed to the leg-by-leg pass for its message.
  void grad_all(const Model& m, const Platform& pf, const double* x, LegGrad* lg) const override {
    const LegArrays& a = m.soa;
    const M3& R = pf.R;
    constexpr int K = kMaxLegs;
    double rx[K], ry[K], rz[K], Px[K], Py[K], Pz[K], dx[K], dy[K], dz[K], b[K], disc[K], q[K];
    for (int i = 0; i < K; ++i) {
      rx[i] = R(0, 0) * a.px[i] + R(0, 1) * a.py[i] + R(0, 2) * a.pz[i];
      ry[i] = R(1, 0) * a.px[i] + R(1, 1) * a.py[i] + R(1, 2) * a.pz[i];
      rz[i] = R(2, 0) * a.px[i] + R(2, 1) * a.py[i] + R(2, 2) * a.pz[i];
      Px[i] = pf.p.x() + rx[i] + a.fx[i], Py[i] = pf.p.y() + ry[i] + a.fy[i], Pz[i] = pf.p.z() + rz[i] + a.fz[i];
      dx[i] = Px[i] - a.bx[i], dy[i] = Py[i] - a.by[i], dz[i] = Pz[i] - a.bz[i];
      b[i] = a.sx[i] * dx[i] + a.sy[i] * dy[i] + a.sz[i] * dz[i];
      disc[i] = b[i] * b[i] - a.ss[i] * (dx[i] * dx[i] + dy[i] * dy[i] + dz[i] * dz[i] - a.L2[i]);
    }
    int bad = 0;
    for (int i = 0; i < m.n; ++i) bad |= !(disc[i] >= a.disc_tol[i]);
    if (bad) return LegMotionOf<RailMotion>::grad_all(m, pf, x, lg);
    double wt[K];  // w . s = b - q ss = branch sqrt(disc)
    for (int i = 0; i < K; ++i) wt[i] = a.branch[i] * std::sqrt(std::max(disc[i], 0.0));
    for (int i = 0; i < K; ++i) q[i] = a.inv_ss[i] * (b[i] - wt[i]);
    for (int i = 0; i < m.n; ++i) {
      // Every value first, then the stores (which might alias the model for the compiler).
      const V3 rP(rx[i], ry[i], rz[i]);
      const V3 P(Px[i], Py[i], Pz[i]);
      const V3 S(a.bx[i] + q[i] * a.sx[i], a.by[i] + q[i] * a.sy[i], a.bz[i] + q[i] * a.sz[i]);
      const V3 w = P - S, dq = w / wt[i];
      LegGrad& g = lg[i];
      g.rP = rP;
      g.q = q[i];
      g.pos[1] = P3<double>{P.x(), P.y(), P.z()};
      g.pos[0] = P3<double>{S.x(), S.y(), S.z()};
      g.w = w;
      g.wt = wt[i];
      g.dq = dq.transpose();
      g.j.head<3>() = dq;
      g.j.tail<3>() = rP.cross(dq);
    }
  }
  double closure_dq(const LegModel& l, const LegGrad& lg) const override { return lg.w.dot(l.dir); }
  double ik_measure(const LegModel& l, double jq) const override { return std::abs(jq) / (l.L * std::sqrt(l.ss)); }
  Eigen::RowVector3d dq_rate(const LegModel& l, const LegGrad& lg, const V3& vP, double qd) const override {
    return rod_dq_rate(lg, l.dir, vP, qd, 0.0);  // s does not turn
  }
  // The slider and S move along s (tb = t = s): the inertia along q is (m_body + ms) |s|^2.
  static void add_mass_of(const LegModel& l, const LegGrad& lg, TwistMass& tm) {
    add_rod_leg_mass(l, lg, tm, (l.m_body + l.m_rod * l.rod_self) * l.ss, l.dir);
  }
  // w = P - S0 - q s: w.w = L^2 twice differentiated: |wd|^2 + w.(aP - qdd s) = 0.
  static double qdd_of(const LegModel& l, const LegGrad& lg, const V3& vP, const V3& aP) {
    const V3& w = lg.w;
    const double qd = lg.dq.dot(vP);
    const V3 wd = vP - qd * l.dir;
    return (w.dot(aP) + wd.squaredNorm()) / lg.wt;
  }
  // rod_leg_load with the slider and S at a_S = qdd s (tb = t = s): the load along the rail
  // qdd (m_body + ms) |s|^2 + mx s.aP - (m_body + m_rod / 2) s.g acts through dq.
  static V3 load_of(const LegModel& l, const LegGrad& lg, const V3& vP, const V3& aP, const V3& g, double& qdd) {
    const double a = qdd_of(l, lg, vP, aP);
    const double mr = l.m_rod, ms = mr * l.rod_self, mx = mr * l.rod_cross;
    const V3 Fp = (mx * a) * l.dir + ms * aP - (mr / 2) * g;
    const double along = a * (l.m_body + ms) * l.ss + mx * l.dir.dot(aP) - (l.m_body + mr / 2) * l.dir.dot(g);
    qdd = a;  // last: the compiler reloads what a store through qdd might change
    return Fp + along * lg.dq.transpose();
  }
};

class RailLeg final : public LegKind {
 public:
  std::vector<std::string> fields() const override { return {"rod_length", "rod_mass", "rod_model", "branch", "rail_origin", "rail_direction", "slider_mass"}; }

  bool read(const LegSchema& s, const std::vector<double>& p, const std::vector<double>& stroke,
            bool articulated) const override {
    const bool lumped = read_rod(s, p, articulated);
    const int i = s.i;
    const std::string leg = "leg " + std::to_string(i + 1);

    const auto S0 = s.vec("rail_origin", "slider position at q = 0 [m]");
    const auto dir = s.unit_vec("rail_direction", "unit rail direction, q grows along it");
    const char* c[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k) s.add(idx("rail", i, (std::string("S0") + c[k]).c_str()), "m", std::string(c[k]) + " of the slider of " + leg + " at stroke q = 0", S0[k], -1e3, 1e3, s.line_of("rail_origin"));
    for (int k = 0; k < 3; ++k) s.add(idx("rail", i, (std::string("s") + c[k]).c_str()), "1", std::string(c[k]) + " of the rail direction of " + leg + " (unit vector)", dir[k], -2, 2, s.line_of("rail_direction"));
    s.add(idx("rail", i, "qmin"), "m", "lower stroke limit of " + leg, stroke[0], -1e3, 1e3, s.line_of("stroke"));
    s.add(idx("rail", i, "qmax"), "m", "upper stroke limit of " + leg, stroke[1], -1e3, 1e3, s.line_of("stroke"));
    s.add(idx("slider", i, "m"), "kg", "mass of the slider carriage of " + leg,
        s.scalar("slider_mass", "slider carriage mass [kg]", 0, 1e6, "kg"), 0, 1e6, s.line_of("slider_mass"));
    return lumped;
  }

  void compile(const ParamValues& v, int i, bool lumped, LegModel& l) const override {
    compile_rod(v, i, lumped, l);
    const auto name = idx;

    l.base = v.vec("rail", i, "S0");
    l.dir = v.vec("rail", i, "s");
    l.ss = l.dir.squaredNorm();
    l.inv_ss = 1.0 / l.ss;
    if (std::abs(std::sqrt(l.ss) - 1) > 1e-6)
      v.bad("rail " + std::to_string(i + 1) + " direction (" + name("rail", i, "sx") + ", " + name("rail", i, "sy") + ", " +
            name("rail", i, "sz") + ") has length " + std::to_string(std::sqrt(l.ss)) + ": it must be a unit vector within 1e-6");
    l.qmin = v(name("rail", i, "qmin")), l.qmax = v(name("rail", i, "qmax"));
    l.m_body = v(name("slider", i, "m"));
    l.npt = 2, l.nmass = 1, l.nrod = 1;
    l.mass[0] = {0, l.m_body};
    l.rod[0] = {0, 1, l.m_rod};
  }

  const LegMotion& motion() const override {
    static const RailMotion k;
    return k;
  }
};

}  // namespace

const LegKind& rail_leg() {
  static const RailLeg k;
  return k;
}

}  // namespace described
}  // namespace pkm
