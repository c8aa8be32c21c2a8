// Joint kind `strut` on a passive revolute joint at the base (RPS: the legs of 3-RPS tripods).
// The strut of length q = |P - B| turns about the base revolute of axis a through B and ends
// in a spherical joint at the platform point, so the leg holds that point in the plane through
// B normal to a,
//     a . (P - B) = 0,
// one constraint on the platform that makes a pose component dependent (docs/robots.md,
// Dependent coordinates).  Cylinder and piston are the strut kind's bodies.
#include <cmath>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

namespace {

class RevoluteStrutLeg final : public LegKind {
 public:
  std::vector<std::string> fields() const override {
    std::vector<std::string> f = strut_leg().fields();
    f.push_back("revolute_axis");
    return f;
  }

  bool read(const LegSchema& s, const std::vector<double>& p, const std::vector<double>& stroke,
            bool articulated) const override {
    const bool lumped = strut_leg().read(s, p, stroke, articulated);
    read_revolute_axis(s, "unit axis of the revolute joint at the base joint (normal to the leg's plane)");
    return lumped;
  }

  void compile(const ParamValues& v, int i, bool lumped, LegModel& l) const override {
    strut_leg().compile(v, i, lumped, l);
    compile_revolute_axis(v, i, l);
    l.plane_o = l.base;  // the plane through the base joint
  }

  const LegMotion& motion() const override { return strut_leg().motion(); }
};

}  // namespace

const LegKind& revolute_strut_leg() {
  static const RevoluteStrutLeg k;
  return k;
}

}  // namespace described
}  // namespace pkm
