// Joint kind `P`: a prismatic axis whose carriage is the platform (a linear drive: carriage
// on a ball screw or a belt, a linear motor).  The platform point p sits on the rail at
// S = S0 + q s: the platform frame is at o = S0 + q s - p, not turning, so every body
// moves by s per unit q and
//   tau = (m_platform + m_payload) qdd - (m_platform + m_payload) g.s
// (an inclined rail carries the weight's component along it; a horizontal one none).
#include <cmath>

#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

namespace {

class PrismaticAxis final : public AxisKind {
 public:
  const char* type() const override { return "P"; }
  const char* what() const override { return "prismatic axis: the carriage is the platform, q along the rail"; }
  const char* prefix() const override { return "rail"; }
  const char* noun() const override { return "carriage"; }
  bool angular() const override { return false; }

  std::vector<std::string> fields() const override { return {"rail_origin", "rail_direction"}; }

  bool read(const LegSchema& s, const std::vector<double>& p, const std::vector<double>& stroke,
            bool /*articulated: an axis carries a rigid platform*/) const override {
    add_axis_point(s, p, angular());
    const auto S0 = s.vec("rail_origin", "where the platform point is at q = 0 [m]");
    const auto dir = s.unit_vec("rail_direction", "unit rail direction, q grows along it");
    const std::string leg = "leg " + std::to_string(s.i + 1);
    const char* c[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k)
      s.add(idx("rail", s.i, (std::string("S0") + c[k]).c_str()), "m",
            std::string(c[k]) + " of the platform point of " + leg + " at stroke q = 0", S0[k], -1e3, 1e3,
            s.line_of("rail_origin"));
    for (int k = 0; k < 3; ++k)
      s.add(idx("rail", s.i, (std::string("s") + c[k]).c_str()), "1",
            std::string(c[k]) + " of the rail direction of " + leg + " (unit vector)", dir[k], -1, 1,
            s.line_of("rail_direction"));
    s.add(idx("rail", s.i, "qmin"), "m", "lower stroke limit of " + leg, stroke[0], -1e3, 1e3, s.line_of("stroke"));
    s.add(idx("rail", s.i, "qmax"), "m", "upper stroke limit of " + leg, stroke[1], -1e3, 1e3, s.line_of("stroke"));
    return false;
  }

  void compile(const ParamValues& v, AxisModel& a) const override {
    a.base = v.vec("rail", 0, "S0");
    a.dir = v.vec("rail", 0, "s");
    if (std::abs(a.dir.norm() - 1) > 1e-6)
      v.bad("rail[1].s = (" + num(a.dir.x()) + ", " + num(a.dir.y()) + ", " + num(a.dir.z()) +
            ") is not a unit vector");
    a.dir.normalize();
    a.qmin = v("rail[1].qmin"), a.qmax = v("rail[1].qmax");
  }

  void place(const AxisModel& a, double q, Eigen::Vector3d& o, Eigen::Matrix3d& R) const override {
    o = a.base + q * a.dir - a.p;
    R.setIdentity();
  }
  Eigen::Vector3d joint_point(const AxisModel& a, double q) const override { return a.base + q * a.dir; }
  double inertia(const AxisModel&, const AxisBodies& b) const override { return b.m_platform + b.m_payload; }
  double gravity(const AxisModel& a, const AxisBodies& b, double) const override {
    return (b.m_platform + b.m_payload) * b.g.dot(a.dir);
  }
};

}  // namespace

void add_axis_point(const LegSchema& s, const std::vector<double>& p, bool angular) {
  const std::string leg = "leg " + std::to_string(s.i + 1);
  const char* c[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k)
    s.add(idx("leg", s.i, (std::string("p") + c[k]).c_str()), "m",
          std::string(c[k]) + " of the platform point on the " + (angular ? "axis" : "rail") + " of " + leg +
              ", platform frame",
          p[k], -1e3, 1e3, s.line_of("platform_point"));
}

const AxisKind& prismatic_axis() {
  static const PrismaticAxis k;
  return k;
}

}  // namespace described
}  // namespace pkm
