// Joint kind `strut` (UPS, SPS): an actuated strut of length q = |P - B| between a base joint
// and the platform point, a cylinder and a piston as uniform slender tubes.  Its schema and
// compiled form; the geometry and dynamics are in described_robot.cpp.
#include <cmath>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

namespace {

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
};

}  // namespace

const LegKind& strut_leg() {
  static const StrutLeg k;
  return k;
}

}  // namespace described
}  // namespace pkm
