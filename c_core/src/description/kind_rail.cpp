// Joint kind `rail` (PUS, PSS, P(SS)2, PRR): a slider S = S0 + q s on a prismatic rail at the
// base (its mass a point at S), then the rod to the platform point (kind_rod.cpp).  Its
// schema and compiled form; the geometry and dynamics are in described_robot.cpp.
#include <cmath>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

namespace {

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
    if (std::abs(std::sqrt(l.ss) - 1) > 1e-6) v.bad("rail " + std::to_string(i + 1) + " direction is not a unit vector");
    l.qmin = v(name("rail", i, "qmin")), l.qmax = v(name("rail", i, "qmax"));
    l.m_body = v(name("slider", i, "m"));
    l.npt = 2, l.nmass = 1, l.nrod = 1;
    l.mass[0] = {0, l.m_body};
    l.rod[0] = {0, 1, l.m_rod};
  }
};

}  // namespace

const LegKind& rail_leg() {
  static const RailLeg k;
  return k;
}

}  // namespace described
}  // namespace pkm
