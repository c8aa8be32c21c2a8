// Joint kind `R`: a revolute axis that carries the platform (a turntable, a pendulum, a
// rotary stage).  The platform point p lies on the axis, which passes through the world
// point A along the unit k; the platform turns about it by q (right-hand rule):
// R = Rot(k, q), o = A - R p.  A body at platform point c moves on a circle about the
// axis, so
//   M = k.I k + m_platform |k x p|^2 + m_payload |k x (c - p)|^2     (constant)
//   G(q) = g . (k x R r),  r = m_platform (0 - p) + m_payload (c - p)
// (a pendulum of mass m at distance l below a horizontal axis: tau = M qdd + m |g| l sin q).
#include <cmath>

#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

namespace {

class RevoluteAxis final : public AxisKind {
 public:
  const char* type() const override { return "R"; }
  const char* what() const override { return "revolute axis: the platform turns on it (turntable, pendulum), q the angle"; }
  const char* prefix() const override { return "axis"; }
  const char* noun() const override { return "axis"; }
  bool angular() const override { return true; }
  bool may_be_continuous() const override { return true; }

  std::vector<std::string> fields() const override { return {"axis_point", "axis"}; }

  bool read(const LegSchema& s, const std::vector<double>& p, const std::vector<double>& stroke,
            bool /*articulated: an axis carries a rigid platform*/) const override {
    add_axis_point(s, p, angular());
    const auto A = s.vec("axis_point", "a point of the axis, world frame [m]");
    const auto k = s.unit_vec("axis", "unit axis; q turns the platform about it by the right-hand rule");
    const std::string leg = "leg " + std::to_string(s.i + 1);
    const char* c[3] = {"x", "y", "z"};
    for (int j = 0; j < 3; ++j)
      s.add(idx("axis", s.i, (std::string("A") + c[j]).c_str()), "m", std::string(c[j]) + " of the axis point of " + leg,
            A[j], -1e3, 1e3, s.line_of("axis_point"));
    for (int j = 0; j < 3; ++j)
      s.add(idx("axis", s.i, (std::string("k") + c[j]).c_str()), "1",
            std::string(c[j]) + " of the axis direction of " + leg + " (unit vector)", k[j], -1, 1, s.line_of("axis"));
    if (stroke.empty()) return false;  // continuous: no limits
    s.add(idx("axis", s.i, "qmin"), "rad", "lower joint limit of " + leg, stroke[0], -100, 100, s.line_of("stroke"));
    s.add(idx("axis", s.i, "qmax"), "rad", "upper joint limit of " + leg, stroke[1], -100, 100, s.line_of("stroke"));
    return false;
  }

  void compile(const ParamValues& v, AxisModel& a) const override {
    a.base = v.vec("axis", 0, "A");
    a.dir = v.vec("axis", 0, "k");
    if (std::abs(a.dir.norm() - 1) > 1e-6)
      v.bad("axis[1].k = (" + num(a.dir.x()) + ", " + num(a.dir.y()) + ", " + num(a.dir.z()) +
            ") is not a unit vector");
    a.dir.normalize();
    if (a.continuous)
      a.qmin = -INFINITY, a.qmax = INFINITY;
    else
      a.qmin = v("axis[1].qmin"), a.qmax = v("axis[1].qmax");
  }

  void place(const AxisModel& a, double q, Eigen::Vector3d& o, Eigen::Matrix3d& R) const override {
    R = Eigen::AngleAxisd(q, a.dir).toRotationMatrix();
    o = a.base - R * a.p;
  }
  Eigen::Vector3d joint_point(const AxisModel& a, double) const override { return a.base; }
  double inertia(const AxisModel& a, const AxisBodies& b) const override {
    const Eigen::Vector3d& k = a.dir;
    return k.dot(b.I_platform.cwiseProduct(k)) + b.m_platform * k.cross(a.p).squaredNorm() +
           b.m_payload * k.cross(b.c_payload - a.p).squaredNorm();
  }
  double gravity(const AxisModel& a, const AxisBodies& b, double q) const override {
    const Eigen::Vector3d r = -b.m_platform * a.p + b.m_payload * (b.c_payload - a.p);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(q, a.dir).toRotationMatrix();
    return b.g.dot(a.dir.cross(R * r));
  }
};

}  // namespace

const AxisKind& revolute_axis() {
  static const RevoluteAxis k;
  return k;
}

}  // namespace described
}  // namespace pkm
