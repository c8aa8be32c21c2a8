// Reading a serial arm's description (serial_chain.hpp; docs/robots.md, Serial arms): the
// [[joint]] tables (general joint frames as URDF writes them, or modified Denavit-Hartenberg
// parameters), the tool frame, the payload, and the parameter table they become.
#include <cmath>

#include "description/schema.hpp"
#include "description/serial_chain.hpp"

namespace pkm {
namespace described {

namespace {

// URDF's roll-pitch-yaw of a rotation matrix R = Rz(yaw) Ry(pitch) Rx(roll).
Eigen::Vector3d rpy_of(const Eigen::Matrix3d& R) {
  const double pitch = std::atan2(-R(2, 0), std::hypot(R(0, 0), R(1, 0)));
  return {std::atan2(R(2, 1), R(2, 2)), pitch, std::atan2(R(1, 0), R(0, 0))};
}

// The origin, rpy and axis of one [[joint]]: written as URDF does, or from modified
// Denavit-Hartenberg parameters dh = [a, alpha, d, theta] (Craig 1989, ch. 3):
// T = Rx(alpha) Tx(a) Rz(theta) Tz(d), the joint about (along) the new z.
void joint_frame(const Reader& rd, const toml::Table& t, const std::string& where, std::vector<double>& origin,
                 std::vector<double>& rpy, std::vector<double>& axis, int& frame_line) {
  if (const toml::Value* dh = t.find("dh")) {
    for (const char* k : {"origin", "rpy", "axis"})
      if (t.find(k))
        rd.fail(t.find(k)->line, where + ": " + k + " and dh both place the joint: give one of them");
    const auto p = rd.numbers(*dh, where + ".dh", 4);
    const double a = p[0], alpha = p[1], d = p[2], theta = p[3];
    origin = {a, -std::sin(alpha) * d, std::cos(alpha) * d};
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(alpha, Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ())).toRotationMatrix();
    const Eigen::Vector3d r = rpy_of(R);
    rpy = {r[0], r[1], r[2]};
    axis = {0, 0, 1};
    frame_line = dh->line;
    return;
  }
  origin = rd.numbers(rd.need(t, "origin", where, "the joint frame's position in the previous joint's frame [m]"),
                      where + ".origin", 3);
  frame_line = t.find("origin")->line;
  rpy = t.find("rpy") ? rd.numbers(*t.find("rpy"), where + ".rpy", 3) : std::vector<double>{0, 0, 0};
  axis = rd.numbers(rd.need(t, "axis", where, "the joint axis in the joint frame, e.g. [0, 0, 1]"), where + ".axis", 3);
  const double len = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  if (!(std::abs(len - 1) <= 1e-6))
    rd.fail(t.find("axis")->line, where + ".axis has length " + num(len) + ": it must be a unit vector");
}

// Inertia [ixx, ixy, ixz, iyy, iyz, izz] (URDF's order): a physical rigid body's (positive
// semi-definite with the triangle inequalities of its principal moments).
void check_inertia(const Reader& rd, const std::vector<double>& I, int line, const std::string& where) {
  Eigen::Matrix3d M;
  M << I[0], I[1], I[2], I[1], I[3], I[4], I[2], I[4], I[5];
  const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(M).eigenvalues();
  const double tol = 1e-12 * std::max(1.0, e.cwiseAbs().maxCoeff());
  if (e.minCoeff() < -tol || e[0] + e[1] < e[2] - tol)
    rd.fail(line, where + ".inertia [" + num(I[0]) + ", " + num(I[1]) + ", " + num(I[2]) + ", " + num(I[3]) + ", " +
                      num(I[4]) + ", " + num(I[5]) + "] kg m2 is not a rigid body's: principal moments " + num(e[0]) +
                      ", " + num(e[1]) + ", " + num(e[2]) + " must be >= 0 and each at most the sum of the others");
}

void read_joint(const Reader& rd, const toml::Table& t, int i, Description& d, ChainJointInfo& info) {
  const std::string where = "joint " + std::to_string(i + 1);
  rd.only(t, {"name", "type", "origin", "rpy", "axis", "dh", "limits", "mass", "com", "inertia"}, where);
  info.name = t.find("name") ? rd.text(t, "name", where, "") : "q" + std::to_string(i + 1);
  if (info.name.empty() || info.name.find_first_of(" \t,") != std::string::npos)
    rd.fail(t.find("name")->line, where + ".name '" + info.name + "' must be one word");
  const std::string type = rd.text(t, "type", where, "revolute, continuous or prismatic");
  if (type != "revolute" && type != "continuous" && type != "prismatic")
    rd.fail(t.find("type")->line, where + ".type '" + type + "' is not known (known: revolute, continuous, prismatic)");
  info.prismatic = type == "prismatic";
  info.limited = type != "continuous";
  std::vector<double> origin, rpy, axis;
  int fl = t.line;
  joint_frame(rd, t, where, origin, rpy, axis, fl);
  auto& P = d.params;
  auto add = [&](const char* f, const char* unit, const std::string& desc, double v, double lo, double hi, int line) {
    rd.add(P, idx("joint", i, f), unit, desc, v, lo, hi, line);
  };
  const char* xyz[3] = {"x", "y", "z"};
  const char* ang[3] = {"roll", "pitch", "yaw"};
  const char* ax[3] = {"ax", "ay", "az"};
  for (int k = 0; k < 3; ++k) add(xyz[k], "m", std::string(xyz[k]) + " of " + where + "'s frame in the previous joint's frame", origin[k], -1e3, 1e3, fl);
  for (int k = 0; k < 3; ++k) add(ang[k], "rad", std::string(ang[k]) + " of " + where + "'s frame in the previous joint's frame (R = Rz(yaw) Ry(pitch) Rx(roll))", rpy[k], -10, 10, fl);
  const int axl = t.find("axis") ? t.find("axis")->line : fl;
  for (int k = 0; k < 3; ++k) add(ax[k], "1", std::string(xyz[k]) + " of " + where + "'s axis in its frame (normalised)", axis[k], -1, 1, axl);
  if (info.limited) {
    const auto lim = rd.numbers(rd.need(t, "limits", where, "[min, max] [rad or m]"), where + ".limits", 2);
    const int ll = t.find("limits")->line;
    if (!(lim[0] < lim[1])) rd.fail(ll, where + ".limits [" + num(lim[0]) + ", " + num(lim[1]) + "] must have min < max");
    const char* u = info.prismatic ? "m" : "rad";
    add("qmin", u, where + "'s lower limit", lim[0], -1e6, 1e6, ll);
    add("qmax", u, where + "'s upper limit", lim[1], -1e6, 1e6, ll);
  } else if (t.find("limits")) {
    rd.fail(t.find("limits")->line, where + " is continuous: it has no limits (make it revolute to limit it)");
  }
  const toml::Value& mv = rd.need(t, "mass", where, "mass of the link the joint moves [kg]");
  const double m = rd.number(mv, where + ".mass");
  if (!(m >= 0)) rd.fail(mv.line, where + ".mass = " + num(m) + " kg must be >= 0");
  const auto c = t.find("com") ? rd.numbers(*t.find("com"), where + ".com", 3) : std::vector<double>{0, 0, 0};
  const int cl = t.find("com") ? t.find("com")->line : mv.line;
  const toml::Value& iv = rd.need(t, "inertia", where, "[ixx, ixy, ixz, iyy, iyz, izz] about the centre of mass [kg m2]");
  const auto I = rd.numbers(iv, where + ".inertia", 6);
  check_inertia(rd, I, iv.line, where);
  const std::string link = "link[" + std::to_string(i + 1) + "]";
  rd.add(P, link + ".m", "kg", "mass of the link " + where + " moves", m, 0, 1e6, mv.line);
  for (int k = 0; k < 3; ++k)
    rd.add(P, link + ".c" + xyz[k], "m", std::string(xyz[k]) + " of its centre of mass in " + where + "'s frame", c[k], -1e3, 1e3, cl);
  const char* In[6] = {"Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"};
  for (int k = 0; k < 6; ++k)
    rd.add(P, link + "." + In[k], "kg m2", std::string(In[k]) + " about its centre of mass, " + where + "'s frame axes",
           I[k], k == 0 || k == 3 || k == 5 ? 0 : -1e6, 1e6, iv.line);
}

// [tool], [payload], [gravity].
void read_ends(const Reader& rd, const toml::Document& doc, const toml::Table& rt, Description& d) {
  std::vector<double> o = {0, 0, 0}, r = {0, 0, 0};
  int tl = rt.line;
  if (auto tt = doc.named("tool"); !tt.empty()) {
    rd.only(*tt[0], {"origin", "rpy"}, "[tool]");
    tl = tt[0]->line;
    if (auto v = tt[0]->find("origin")) o = rd.numbers(*v, "tool.origin", 3);
    if (auto v = tt[0]->find("rpy")) r = rd.numbers(*v, "tool.rpy", 3);
  }
  const char* xyz[3] = {"x", "y", "z"};
  const char* ang[3] = {"roll", "pitch", "yaw"};
  for (int k = 0; k < 3; ++k) rd.add(d.params, std::string("tool.") + xyz[k], "m", std::string(xyz[k]) + " of the tool frame in the last joint's frame", o[k], -1e3, 1e3, tl);
  for (int k = 0; k < 3; ++k) rd.add(d.params, std::string("tool.") + ang[k], "rad", std::string(ang[k]) + " of the tool frame in the last joint's frame", r[k], -10, 10, tl);
  double pm = 0;
  std::vector<double> pc = {0, 0, 0};
  int pl = rt.line;
  if (auto yt = doc.named("payload"); !yt.empty()) {
    rd.only(*yt[0], {"mass", "position"}, "[payload]");
    pl = yt[0]->line;
    if (auto v = yt[0]->find("mass")) pm = rd.number(*v, "payload.mass");
    if (auto v = yt[0]->find("position")) pc = rd.numbers(*v, "payload.position", 3);
  }
  rd.add(d.params, "payload.m", "kg", "payload point mass in the tool frame", pm, 0, 1e6, pl);
  for (int k = 0; k < 3; ++k) rd.add(d.params, std::string("payload.") + xyz[k], "m", std::string(xyz[k]) + " of the payload in the tool frame", pc[k], -1e3, 1e3, pl);
  double g[3] = {0, 0, -9.81};
  int gl = rt.line;
  if (auto gt = doc.named("gravity"); !gt.empty()) {
    rd.only(*gt[0], {"vector"}, "[gravity]");
    const toml::Value& gv = rd.need(*gt[0], "vector", "gravity", "the gravity acceleration [m/s2]");
    gl = gv.line;
    const auto v = rd.numbers(gv, "gravity.vector", 3);
    std::copy(v.begin(), v.end(), g);
  }
  for (int k = 0; k < 3; ++k) rd.add(d.params, std::string("gravity.") + xyz[k], "m/s2", std::string(xyz[k]) + " of the gravity acceleration (world frame)", g[k], -100, 100, gl);
}

}  // namespace

bool is_serial_description(const toml::Document& doc) {
  for (const toml::Table* t : doc.named("robot"))
    if (const toml::Value* k = t->find("kind"))
      if (k->kind == toml::Value::String && k->str == "serial") return true;
  return false;
}

Description read_serial_description(const toml::Document& doc, const std::string& file,
                                    std::vector<ChainJointInfo>& joints) {
  Reader rd{doc};
  Description d;
  d.file = file;
  for (const toml::Table& t : doc.tables) {
    if (t.name.empty()) {
      if (!t.keys.empty()) rd.fail(t.keys.front().second.line, "field '" + t.keys.front().first + "' outside any [table]");
      continue;
    }
    const bool known = t.name == "robot" || t.name == "gravity" || t.name == "tool" || t.name == "payload" ||
                       t.name == "joint" || t.name == "defaults" || t.name.rfind("sets.", 0) == 0;
    if (!known)
      rd.fail(t.line, "unknown table [" + t.name + "] in a serial arm (known: [robot], [gravity], [[joint]], [tool], "
                      "[payload], [defaults], [sets.NAME])");
    if (t.name == "joint" && !t.array) rd.fail(t.line, "joints are declared as [[joint]] (one per joint), not [joint]");
    if (t.name != "joint" && t.array) rd.fail(t.line, "[[" + t.name + "]] must be written [" + t.name + "]");
  }
  const toml::Table& rt = *doc.named("robot").front();
  rd.only(rt, {"name", "kind", "title", "source", "home"}, "[robot]");
  d.name = rd.text(rt, "name", "robot", "the robot's name, what --robot takes");
  d.name_line = rt.find("name")->line;
  if (d.name.empty() || d.name.find_first_of(" /\\\t") != std::string::npos)
    rd.fail(d.name_line, "robot.name '" + d.name + "' must be one word without spaces or slashes");
  d.title = rd.text(rt, "title", "robot", "", false);
  d.source = rd.text(rt, "source", "robot", "", false);
  const auto jt = doc.named("joint");
  if (jt.empty()) rd.fail(rt.line, "a serial arm declares its joints as [[joint]] tables, base to tool; none is given");
  if ((int)jt.size() > kMaxChainJoints)
    rd.fail(jt[kMaxChainJoints]->line, std::to_string(jt.size()) + " joints: a serial arm has at most " +
                                           std::to_string(kMaxChainJoints) + " (the drive layer's joints)");
  joints.assign(jt.size(), {});
  for (size_t i = 0; i < jt.size(); ++i) {
    read_joint(rd, *jt[i], (int)i, d, joints[i]);
    for (size_t k = 0; k < i; ++k)
      if (joints[k].name == joints[i].name) rd.fail(jt[i]->line, "joint " + std::to_string(i + 1) + ".name '" + joints[i].name + "' is also joint " + std::to_string(k + 1) + "'s");
    if (joints[i].prismatic != joints[0].prismatic)
      rd.fail(jt[i]->line, "joint " + std::to_string(i + 1) + " is " + (joints[i].prismatic ? "prismatic" : "revolute") +
                               " and joint 1 is not: a serial arm's joints are all revolute or all prismatic (the "
                               "drive layer has one unit for its joints)");
  }
  const toml::Value& hv = rd.need(rt, "home", "robot", "the home pose, one value per joint [rad or m]");
  d.home = rd.numbers(hv, "robot.home", jt.size());
  d.home_line = hv.line;
  for (size_t i = 0; i < jt.size(); ++i) d.coords.push_back((int)i);
  d.structure = Structure::serial;
  d.mobility = (int)jt.size();
  read_ends(rd, doc, rt, d);
  read_sets(rd, doc, d);  // [defaults] and [sets.NAME] as in any description
  return d;
}

}  // namespace described
}  // namespace pkm
