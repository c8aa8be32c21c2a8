// The passive revolute joint of the PRS and RPS legs (kind_rail_revolute.cpp,
// kind_revolute_strut.cpp): its axis a, normal to the plane the leg turns in, read as the
// parameters leg[i].ax ay az and compiled into the leg's plane constraint a . (P - o) = 0.
#include <cmath>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

// The passive revolute joint of a PRS or RPS leg: parameters leg[i].ax ay az.
std::vector<double> read_revolute_axis(const LegSchema& s, const char* what) {
  const auto a = s.unit_vec("revolute_axis", what);
  const char* c[3] = {"x", "y", "z"};
  for (int k = 0; k < 3; ++k)
    s.add(idx("leg", s.i, (std::string("a") + c[k]).c_str()), "1",
          std::string(c[k]) + " of the passive revolute axis of leg " + std::to_string(s.i + 1) +
              " (unit vector, normal to the leg's plane)",
          a[k], -2, 2, s.line_of("revolute_axis"));
  return a;
}

void compile_revolute_axis(const ParamValues& v, int i, LegModel& l) {
  const Eigen::Vector3d a = v.vec("leg", i, "a");
  if (std::abs(a.norm() - 1) > 1e-6) v.bad("leg " + std::to_string(i + 1) + ": its revolute axis is not a unit vector");
  l.plane_n = a.normalized();
  l.constrained = true;
}

}  // namespace described
}  // namespace pkm
