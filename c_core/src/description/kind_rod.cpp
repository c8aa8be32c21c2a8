// The rod a rail or arm leg ends in (kind_rail.cpp, kind_arm.cpp): |P - B| = L between the
// leg's moving joint B and its platform point P, its mass uniform or lumped, the inverse-
// kinematics branch; parameters leg[i].L px py pz (fx fy fz) branch m.
#include <cmath>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

bool read_rod(const LegSchema& s, const std::vector<double>& p, bool articulated) {
  const Reader& rd = s.rd;
  const toml::Table& t = s.t;
  const std::string& where = s.where;
  const int i = s.i;
  const std::string leg = "leg " + std::to_string(i + 1);
  const double L = s.scalar("rod_length", "rod length between its two joints [m]", 1e-9, 1e300, "m");
  s.add(idx("leg", i, "L"), "m", "length of " + leg + " (rod between its two joints)", L, 1e-9, 1e3, s.line_of("rod_length"));
  const std::string frame = articulated ? ", axis frame (turns with the articulation)" : ", platform frame";
  s.add(idx("leg", i, "px"), "m", "x of the platform attachment point of " + leg + frame, p[0], -1e3, 1e3, s.line_of("platform_point"));
  s.add(idx("leg", i, "py"), "m", "y of the platform attachment point of " + leg + frame, p[1], -1e3, 1e3, s.line_of("platform_point"));
  s.add(idx("leg", i, "pz"), "m", "z of the platform attachment point of " + leg + frame, p[2], -1e3, 1e3, s.line_of("platform_point"));
  if (articulated) {
    std::vector<double> f0 = {0, 0, 0};
    if (t.find("platform_offset")) f0 = rd.numbers(*t.find("platform_offset"), "leg.platform_offset", 3);
    const char* c[3] = {"x", "y", "z"};
    for (int k = 0; k < 3; ++k)
      s.add(idx("leg", i, (std::string("f") + c[k]).c_str()), "m", std::string(c[k]) + " of the fixed (non-turning) offset of the platform attachment point of " + leg, f0[k], -1e3, 1e3, s.line_of("platform_offset"));
  }
  std::string rod_model = "uniform";
  if (t.find("rod_model")) {
    rod_model = rd.text(t, "rod_model", where, "uniform or lumped");
    if (rod_model != "uniform" && rod_model != "lumped")
      rd.fail(s.line_of("rod_model"), where + ": rod_model '" + rod_model + "' is not known (known: uniform, lumped)");
  }
  double br = 1;
  if (t.find("branch")) {
    br = rd.number(*t.find("branch"), "leg.branch");
    if (br != 1 && br != -1) rd.fail(s.line_of("branch"), where + ": branch = " + num(br) + " must be +1 or -1 (which inverse-kinematics root)");
  }
  s.add(idx("leg", i, "branch"), "1", "inverse-kinematics root of " + leg + " (+1 or -1, docs/robots.md)", br, -1, 1, s.line_of("branch"));
  s.add(idx("leg", i, "m"), "kg", "mass of the rod(s) of " + leg + " (uniform slender rods)",
      s.scalar("rod_mass", "mass of the rod, or of both rods of a parallelogram [kg]", 0, 1e6, "kg"), 0, 1e6, s.line_of("rod_mass"));
  return rod_model == "lumped";
}

void compile_rod(const ParamValues& v, int i, bool lumped, LegModel& l) {
  using V3 = Eigen::Vector3d;
  const auto name = idx;
  l.L = v(name("leg", i, "L"));
  l.p = V3(v(name("leg", i, "px")), v(name("leg", i, "py")), v(name("leg", i, "pz")));
  l.branch = v(name("leg", i, "branch"));
  l.m_rod = v(name("leg", i, "m"));
  if (!(l.L > 0)) v.bad(name("leg", i, "L") + " = " + num(l.L) + " m must be > 0");
  if (l.branch != 1.0 && l.branch != -1.0) v.bad(name("leg", i, "branch") + " = " + num(l.branch) + " must be +1 or -1");
  l.disc_tol = 1e-12 * l.L * l.L;
  if (lumped) l.rod_self = 0.5, l.rod_cross = 0.0;
}

}  // namespace described
}  // namespace pkm
