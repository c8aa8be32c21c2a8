// Joint kind `rail` with a passive revolute joint at the slider (PRS: the legs of 3-PRS
// spindle heads such as the Sprint Z3).  The slider S = S0 + q s carries a revolute joint of
// axis a (perpendicular to the rail), then the rod to a spherical joint at the platform point:
// the rod turns in the plane through the rail normal to a, so besides the rod's closure
// |P - S| = L the leg holds its platform point in that plane,
//     a . (P - S0) = 0,
// one constraint on the platform that makes a pose component dependent (docs/robots.md,
// Dependent coordinates).  The slider and the rod are the rail kind's bodies.
#include <cmath>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

namespace {

class RailRevoluteLeg final : public LegKind {
 public:
  std::vector<std::string> fields() const override {
    std::vector<std::string> f = rail_leg().fields();
    f.push_back("revolute_axis");
    return f;
  }

  bool read(const LegSchema& s, const std::vector<double>& p, const std::vector<double>& stroke,
            bool articulated) const override {
    const bool lumped = rail_leg().read(s, p, stroke, articulated);
    const auto a = read_revolute_axis(s, "unit axis of the revolute joint on the slider (normal to the leg's plane)");
    const auto dir = s.unit_vec("rail_direction", "unit rail direction, q grows along it");
    if (std::abs(a[0] * dir[0] + a[1] * dir[1] + a[2] * dir[2]) > 1e-6)
      s.rd.fail(s.line_of("revolute_axis"), s.where + ": revolute_axis must be perpendicular to rail_direction (the "
                                                      "slider carries the revolute joint along the leg's plane)");
    return lumped;
  }

  void compile(const ParamValues& v, int i, bool lumped, LegModel& l) const override {
    rail_leg().compile(v, i, lumped, l);
    compile_revolute_axis(v, i, l);
    if (std::abs(l.plane_n.dot(l.dir)) > 1e-6)
      v.bad("leg " + std::to_string(i + 1) + ": its revolute axis is not perpendicular to its rail");
    l.plane_o = l.base;  // the plane through the rail
  }

  const LegMotion& motion() const override { return rail_leg().motion(); }
};

}  // namespace

const LegKind& rail_revolute_leg() {
  static const RailRevoluteLeg k;
  return k;
}

}  // namespace described
}  // namespace pkm
