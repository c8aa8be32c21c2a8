// Reading a robot description (docs/robots.md): fields, units, checks with file, line and
// field in every message, the parameter table, the Grubler-Kutzbach mobility count.
#include <algorithm>
#include <cmath>
#include <sstream>

#include "description/described_robot.hpp"
#include "description/joint_kind.hpp"
#include "description/schema.hpp"
#include "dynamics/drive.hpp"

namespace pkm {
namespace described {

namespace {

// bodies, joints, freedoms, idle: what the Grubler-Kutzbach count sees of one leg.
const LegType kLegTypes[] = {
    {"PUS", Structure::legs, 2, 3, 6, 0, false, "slider on a rail at the base, universal joint, rod, spherical joint", &rail_leg(), &rail_leg()},
    {"PSS", Structure::legs, 2, 3, 7, 1, false, "slider on a rail, rod between two spherical joints", &rail_leg(), &rail_leg()},
    {"P(SS)2", Structure::legs, 3, 5, 13, 2, false, "slider on a rail, parallelogram of two rods (linear Delta)", &rail_leg(), &rail_leg()},
    {"PRR", Structure::legs, 2, 3, 3, 0, true, "planar: slider on a rail, rod between two revolute joints", &rail_leg(), &rail_leg()},
    {"RUS", Structure::legs, 2, 3, 6, 0, false, "revolute arm at the base, universal joint, rod, spherical joint", &arm_leg(), &arm_leg()},
    {"RSS", Structure::legs, 2, 3, 7, 1, false, "revolute arm, rod between two spherical joints", &arm_leg(), &arm_leg()},
    {"R(SS)2", Structure::legs, 3, 5, 13, 2, false, "revolute arm, parallelogram of two rods (Delta)", &arm_leg(), &arm_leg()},
    {"RRR", Structure::legs, 2, 3, 3, 0, true, "planar: revolute arm, rod between two revolute joints", &arm_leg(), &arm_leg()},
    {"UPS", Structure::legs, 2, 3, 6, 0, false, "universal joint, actuated strut (cylinder and piston), spherical joint", &strut_leg(), &strut_leg()},
    {"SPS", Structure::legs, 2, 3, 7, 1, false, "spherical joint, actuated strut, spherical joint", &strut_leg(), &strut_leg()},
    // A passive revolute joint holds the platform point in the leg's plane: one constraint.
    {"PRS", Structure::legs, 2, 3, 5, 0, false, "slider on a rail, revolute joint, rod, spherical joint (3-PRS heads)",
     &rail_revolute_leg(), &rail_revolute_leg(), nullptr, 1},
    {"RPS", Structure::legs, 2, 3, 5, 0, false, "revolute joint at the base, actuated strut, spherical joint (3-RPS tripods)",
     &revolute_strut_leg(), &revolute_strut_leg(), nullptr, 1},
    // Single axes: the joint carries the platform (no body of its own, one joint, one freedom).
    {prismatic_axis().type(), Structure::axis, 0, 1, 1, 0, false, prismatic_axis().what(), &prismatic_axis(), nullptr, &prismatic_axis()},
    {revolute_axis().type(), Structure::axis, 0, 1, 1, 0, false, revolute_axis().what(), &revolute_axis(), nullptr, &revolute_axis()},
};

const char* kCoordNames[6] = {"x", "y", "z", "rx", "ry", "rz"};

// Whether every leg ends at the same platform point (the hint for a five-bar written with
// a platform).
template <class Legs>
bool same_platform_point(const Reader& rd, const Legs& legs) {
  std::vector<double> first;
  for (const auto& l : legs) {
    const toml::Value* v = l.t->find("platform_point");
    if (!v) return false;
    std::vector<double> p = rd.numbers(*v, "leg.platform_point", 3);
    const double c = std::cos(l.angle), s = std::sin(l.angle);
    p = {c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]};
    if (first.empty()) first = p;
    for (int k = 0; k < 3; ++k)
      if (std::abs(p[k] - first[k]) > 1e-9) return false;
  }
  return true;
}

// `continuous = true` of a [[leg]]: an R axis that turns without limit (no stroke).  Only a
// single R axis may: a leg's arm is held by its rod, a rail or strut ends.
bool continuous_joint(const Reader& rd, const toml::Table& t, const LegType* type, const std::string& where) {
  const toml::Value* v = t.find("continuous");
  if (!v) return false;
  if (v->kind != toml::Value::Bool)
    rd.fail(v->line, where + ": continuous must be true or false, got a " + v->kind_name());
  if (!v->b) return false;
  if (!type->kind->may_be_continuous())
    rd.fail(v->line, where + ": continuous: only a revolute axis (type R) turns without limit; a " +
                         std::string(type->name) + " leg's joint has a stroke");
  if (const toml::Value* st = t.find("stroke"))
    rd.fail(st->line, where + ": a continuous joint has no stroke (remove stroke, or continuous = false)");
  return true;
}

}  // namespace

const LegType* find_leg_type(const std::string& name) {
  for (const LegType& t : kLegTypes)
    if (name == t.name) return &t;
  return nullptr;
}

std::string leg_type_names() {
  std::string s;
  for (const LegType& t : kLegTypes) s += (s.empty() ? "" : ", ") + std::string(t.name);
  return s;
}

Description read_description(const std::string& text, const std::string& file) {
  return read_description(toml::parse(text, file), file);
}

namespace {

// The tables a description may have, each written the right way ([x] or [[x]]).
void check_tables(const Reader& rd, const toml::Document& doc) {
  for (const toml::Table& t : doc.tables) {
    if (t.name.empty()) {
      if (!t.keys.empty())
        rd.fail(t.keys.front().second.line, "field '" + t.keys.front().first + "' outside any [table] (start with [robot])");
      continue;
    }
    const bool known = t.name == "robot" || t.name == "gravity" || t.name == "platform" || t.name == "payload" ||
                       t.name == "leg" || t.name == "defaults" || t.name.rfind("sets.", 0) == 0;
    if (!known)
      rd.fail(t.line, "unknown table [" + t.name +
                          "] (known: [robot], [gravity], [platform], [payload], [[leg]], [defaults], [sets.NAME])");
    if (t.name == "leg" && !t.array) rd.fail(t.line, "legs are declared as [[leg]] (one per leg), not [leg]");
    if (t.name != "leg" && t.array) rd.fail(t.line, "[[" + t.name + "]] must be written [" + t.name + "]");
    if (t.name.rfind("sets.", 0) == 0) {
      const std::string set = t.name.substr(5);
      if (set.empty() || set.find_first_of(" \t") != std::string::npos || set == "default")
        rd.fail(t.line, "[" + t.name + "]: a set's name is one word, not empty and not 'default' (the file's own "
                        "values and [defaults] are the default set)");
    }
  }

}

// [robot]: name, title, source, coordinates (sorted into x y z rx ry rz order with the home
// pose), redundant constraints.
const toml::Table& read_robot(const Reader& rd, const toml::Document& doc, Description& d) {
  const auto robots = doc.named("robot");
  if (robots.empty()) rd.fail(1, "[robot] table is missing (name, coordinates, home)");
  const toml::Table& rt = *robots.front();
  rd.only(rt, {"name", "title", "source", "coordinates", "home", "redundant_constraints"}, "[robot]");
  d.name = rd.text(rt, "name", "robot", "the robot's name, what --robot takes");
  if (d.name.empty() || d.name.find_first_of(" /\\\t") != std::string::npos)
    rd.fail(rt.find("name")->line, "robot.name '" + d.name + "' must be one word without spaces or slashes");
  d.name_line = rt.find("name")->line;
  d.title = rd.text(rt, "title", "robot", "", false);
  d.source = rd.text(rt, "source", "robot", "", false);
  const toml::Value& cv = rd.need(rt, "coordinates", "robot", "the platform's degrees of freedom, e.g. [\"x\", \"y\", \"z\"]");
  if (cv.kind != toml::Value::Array || cv.items.empty() || cv.items.size() > 6)
    rd.fail(cv.line, "robot.coordinates must be an array of 1 to 6 names out of x, y, z, rx, ry, rz");
  for (const auto& it : cv.items) {
    int k = -1;
    for (int j = 0; j < 6; ++j)
      if (it.kind == toml::Value::String && it.str == kCoordNames[j]) k = j;
    if (k < 0) rd.fail(cv.line, "robot.coordinates: '" + it.str + "' is not one of x, y, z, rx, ry, rz");
    if (std::find(d.coords.begin(), d.coords.end(), k) != d.coords.end())
      rd.fail(cv.line, "robot.coordinates: '" + it.str + "' is given twice");
    d.coords.push_back(k);
  }
  const int n = (int)d.coords.size();
  if (auto v = rt.find("redundant_constraints")) {
    const double r = rd.number(*v, "robot.redundant_constraints");
    if (r < 0 || r > 36 || r != std::floor(r))
      rd.fail(v->line, "robot.redundant_constraints = " + num(r) + " must be a whole number >= 0 (docs/robots.md, Mobility)");
    d.redundant = (int)r;
  }
  const toml::Value& hv = rd.need(rt, "home", "robot", "the home pose, one value per coordinate [m, rad]");
  const std::vector<double> home_as_written = rd.numbers(hv, "robot.home", (size_t)n);
  d.home_line = hv.line;
  // The pose runs in the order x y z rx ry rz whatever order the file lists them in.
  std::vector<int> order(n);
  for (int j = 0; j < n; ++j) order[j] = j;
  std::sort(order.begin(), order.end(), [&](int a, int b) { return d.coords[a] < d.coords[b]; });
  std::vector<int> sorted;
  for (int j : order) sorted.push_back(d.coords[j]), d.home.push_back(home_as_written[j]);
  d.coords = sorted;

  return rt;
}

// [gravity], [platform], [payload] as written (the parameters come after the legs').
struct Bodies {
  double g[3] = {0, 0, -9.81};
  int g_line = 0;  // where a refused value is reported: its own line ([robot] when not written)
  const toml::Table* pt = nullptr;
  double pm = 0;
  std::vector<double> pI;
  int inertia_line = 0;
  double pay_m = 0;
  std::vector<double> pay_c = {0, 0, 0};
  int pay_m_line = 0, pay_c_line = 0;
};
Bodies read_bodies(const Reader& rd, const toml::Document& doc, const toml::Table& rt, int cv_line, Description& d) {
  Bodies b;
  int& g_line = b.g_line;
  g_line = rt.line;  // where a refused value is reported: its own line ([robot] when not written)
  if (auto gt = doc.named("gravity"); !gt.empty()) {
    rd.only(*gt[0], {"vector"}, "[gravity]");
    const toml::Value& gval = rd.need(*gt[0], "vector", "gravity", "the gravity acceleration [m/s2]");
    g_line = gval.line;
    auto gv = rd.numbers(gval, "gravity.vector", 3);
    std::copy(gv.begin(), gv.end(), b.g);
  }
  const auto pts = doc.named("platform");
  if (pts.empty()) rd.fail(rt.line, "[platform] table is missing (mass, inertia)");
  const toml::Table& pt = *pts[0];
  b.pt = &pt;
  const std::string kind = rd.text(pt, "kind", "platform", "", false);
  if (!(kind.empty() || kind == "rigid" || kind == "articulated" || kind == "point"))
    rd.fail(pt.find("kind")->line, "platform.kind '" + kind + "' is not known (known: rigid, articulated, point)");
  d.articulated = kind == "articulated";
  d.point = kind == "point";
  if (d.point)
    for (int k : d.coords)
      if (k >= 3)
        rd.fail(cv_line, std::string("legs that meet at a point (platform.kind = \"point\") move it in x, y, z only; '") +
                             kCoordNames[k] + "' is an angle");
  if (d.articulated) {
    rd.only(pt, {"kind", "mass", "inertia", "axis_angle", "ends", "centre"}, "[platform] (articulated)");
    if (d.coords != std::vector<int>{0, 1, 2, 5})
      rd.fail(cv_line, "an articulated platform moves in x, y, z and its articulation angle rz: robot.coordinates "
                       "must be [\"x\", \"y\", \"z\", \"rz\"]");
  } else {
    rd.only(pt, {"kind", "mass", "inertia"}, "[platform]");
  }
  const double pm = b.pm = rd.number(rd.need(pt, "mass", "platform", "platform mass [kg]"), "platform.mass");
  // A point (the legs' common joint) has no inertia to give: zero unless written.
  const auto pI = b.pI = d.point && !pt.find("inertia")
                      ? std::vector<double>{0, 0, 0}
                      : rd.numbers(rd.need(pt, "inertia", "platform",
                                           "principal inertias [Ixx, Iyy, Izz] about its centre of mass [kg m2]"),
                                   "platform.inertia", 3);
  b.inertia_line = pt.find("inertia") ? pt.find("inertia")->line : pt.line;
  if (pm < 0) rd.fail(pt.find("mass")->line, "platform.mass = " + num(pm) + " kg must be >= 0");
  for (double v : pI)
    if (v < 0) rd.fail(b.inertia_line, "platform.inertia has " + num(v) + " kg m2: inertias must be >= 0");
  double& pay_m = b.pay_m;
  b.pay_m_line = b.pay_c_line = pt.line;
  if (auto yt = doc.named("payload"); !yt.empty()) {
    rd.only(*yt[0], {"mass", "position"}, "[payload]");
    if (auto v = yt[0]->find("mass")) pay_m = rd.number(*v, "payload.mass"), b.pay_m_line = v->line;
    if (auto v = yt[0]->find("position")) b.pay_c = rd.numbers(*v, "payload.position", 3), b.pay_c_line = v->line;
    if (pay_m < 0) rd.fail(yt[0]->find("mass")->line, "payload.mass = " + num(pay_m) + " kg must be >= 0");
  }

  return b;
}

// [[leg]]: expanded copies, each with the line of its table.
struct LegIn {
  const toml::Table* t;
  const LegType* type;
  double angle;
  int copy;
};
std::vector<LegIn> read_legs(const Reader& rd, const toml::Document& doc, const toml::Table& rt, int cv_line,
                             const Description& d) {
  const int n = (int)d.coords.size();
  std::vector<LegIn> legs;
  for (const toml::Table* t : doc.named("leg")) {
    const std::string tn = rd.text(*t, "type", "leg", "the leg architecture (" + leg_type_names() + ")");
    const LegType* lt = find_leg_type(tn);
    if (!lt) rd.fail(t->find("type")->line, "leg type '" + tn + "' is not known (known: " + leg_type_names() + ")");
    int copies = 1;
    if (auto v = t->find("copies")) {
      const double c = rd.number(*v, "leg.copies");
      if (c < 1 || c > kMaxLegs || c != std::floor(c))
        rd.fail(v->line, "leg.copies = " + num(c) + " must be a whole number from 1 to " + std::to_string(kMaxLegs));
      copies = (int)c;
    }
    if (copies > 1 && d.articulated)
      rd.fail(t->find("copies")->line, "legs of an articulated platform are written one [[leg]] each (copies = 1): "
                                       "their attachment points do not repeat by a rotation");
    const double pi = std::acos(-1.0);
    for (int k = 0; k < copies; ++k) legs.push_back({t, lt, 2 * pi * k / copies, k});
  }
  if (legs.empty()) rd.fail(rt.line, "no [[leg]] is declared");
  // A single axis carries the platform: it is the robot's only leg, and its coordinate is
  // the joint's (a length along a rail, an angle about an axis).
  for (const auto& l : legs)
    if (l.type->axis && legs.size() > 1)
      rd.fail(l.t->find("copies") ? l.t->find("copies")->line : l.t->line,
              std::string("a single-axis leg (") + l.type->name + ") carries the platform itself: it must be the only "
              "leg (one [[leg]], copies = 1) of a robot with one coordinate");
  if (legs.size() == 1 && legs[0].type->axis && n == 1) {
    const bool angle = d.coords[0] >= 3, angular = legs[0].type->axis->angular();
    if (angle != angular)
      rd.fail(cv_line, std::string("robot.coordinates: a leg of type ") + legs[0].type->name + " moves the platform " +
                           (angular ? "by an angle: its coordinate is one of rx, ry, rz"
                                    : "along its rail: its coordinate is one of x, y, z") +
                           ", not '" + kCoordNames[d.coords[0]] + "'");
  }
  if ((int)legs.size() != n)
    rd.fail(legs.back().t->line, std::to_string(legs.size()) + " legs for " + std::to_string(n) +
                                     " coordinates: the toolkit needs one actuated leg per degree of freedom");

  return legs;
}

// Planar or spatial, the Grubler-Kutzbach count against the coordinates, the dependent
// coordinates of legs with a passive revolute joint.
void check_mobility(const Reader& rd, const std::vector<LegIn>& legs, int cv_line, Description& d) {
  const int n = (int)d.coords.size();
  // Planar or spatial.
  bool any_planar = false, all_planar = true;
  for (const auto& l : legs) any_planar |= l.type->planar, all_planar &= l.type->planar;
  if (any_planar && !all_planar) rd.fail(legs.front().t->line, "planar legs (PRR, RRR) and spatial legs are mixed");
  d.planar = all_planar;
  if (d.planar)
    for (int k : d.coords)
      if (k != 0 && k != 1 && k != 5)
        rd.fail(cv_line, std::string("a planar robot moves in x, y, rz; '") + kCoordNames[k] + "' is not planar");

  // Grubler-Kutzbach: lambda (n_bodies - n_joints - 1) + sum f - idle (+ the dependent
  // constraints the description declares).  An articulated platform is two end bars and
  // the one-freedom articulation between them.
  const int lambda = d.planar ? 3 : 6;
  int nb = 2, nj = 0, f = 0;
  if (d.articulated) nb += 1, nj += 1, f += 1;
  // Legs that meet at a point: no platform body, and the legs' joints at the point are one
  // joint fewer than the legs (k rods on one pin or ball are k - 1 joints), of the pin's or
  // ball's freedoms.
  if (d.point) nb -= 1, nj -= 1, f -= d.planar ? 1 : 3;
  for (const auto& l : legs) {
    nb += l.type->bodies, nj += l.type->joints, f += l.type->freedoms - l.type->idle;
    if (l.type->leg && &l.type->leg->motion() != &legs.front().type->leg->motion())
      rd.fail(l.t->line, "legs with different actuated joints (rail, arm, strut) are not supported in one robot");
  }
  d.structure = legs.front().type->structure;
  d.mobility = lambda * (nb - nj - 1) + f + d.redundant;
  if (d.mobility != n) {
    std::ostringstream os;
    os << "mobility mismatch: the Grubler-Kutzbach count of these legs is " << d.mobility << " = " << lambda << " x ("
       << nb << " bodies - " << nj << " joints - 1) + " << f << " joint freedoms (idle spins removed)";
    if (d.redundant) os << " + " << d.redundant << " redundant constraints";
    os << ", but " << n << " coordinates are declared";
    if (!d.point && !d.articulated && legs.size() >= 2 && same_platform_point(rd, legs))
      os << ". Every leg ends at the same platform point: legs whose rods meet at one joint (the five-bar, "
            "2-RRR) have no platform; write [platform] kind = \"point\" (docs/robots.md, Legs that meet at a point)";
    rd.fail(cv_line, os.str());
  }
  // Dependent coordinates: each PRS or RPS leg holds its platform point in a plane, fixing
  // one pose component; the components not declared are those the legs decide.
  int nc = 0;
  for (const auto& l : legs) nc += l.type->constraints;
  if (nc > 0) {
    if (d.point || d.articulated || d.planar)
      rd.fail(legs.front().t->line, "legs with a passive revolute joint (PRS, RPS) hold a rigid spatial platform");
    if (n + nc != 6) {
      std::ostringstream os;
      os << "robot.coordinates: " << nc << " legs with a passive revolute joint (PRS, RPS) fix " << nc
         << " pose components, so " << 6 - nc << " coordinates are declared (e.g. z, rx, ry for three) and the other "
         << nc << " follow from the legs; " << n << " are declared";
      rd.fail(cv_line, os.str());
    }
    for (int k = 0; k < 6; ++k)
      if (std::find(d.coords.begin(), d.coords.end(), k) == d.coords.end()) d.dependent.push_back(k);
  }

}

// The legs' parameters, leg by leg (names as the hand-written 6-PUS names its own).
void add_leg_params(const Reader& rd, const std::vector<LegIn>& legs, Description& d) {
  auto& P = d.params;
  for (int i = 0; i < (int)legs.size(); ++i) {
    const LegIn& l = legs[i];
    const toml::Table& t = *l.t;
    const std::string where = "leg " + std::to_string(i + 1) + (l.copy ? " (copy " + std::to_string(l.copy) + " of the [[leg]] on line " + std::to_string(t.line) + ")" : "");
    std::vector<std::string> known = {"type", "copies", "platform_point", "stroke", "continuous"};
    if (d.articulated) known.push_back("platform_offset");
    for (const auto& k : l.type->kind->fields()) known.push_back(k);
    rd.only(t, known, where);
    const LegSchema schema{rd, t, i, l.angle, where, P};
    auto vec = [&](const char* key, const char* what) { return schema.vec(key, what); };
    auto line_of = [&](const char* key) { return schema.line_of(key); };
    if (d.point && t.find("platform_point"))
      rd.fail(line_of("platform_point"), where + ": legs that meet at a point have no platform_point (the point is the "
                                                 "pose itself)");
    const auto p = d.point ? std::vector<double>{0, 0, 0}
                           : vec("platform_point", "the leg's attachment point in the platform frame [m]");
    const bool continuous = continuous_joint(rd, t, l.type, where);
    const auto stroke = continuous ? std::vector<double>{}
                                   : rd.numbers(rd.need(t, "stroke", where, "joint limits [min, max] [m or rad]; "
                                                "an R axis that turns without limit: continuous = true"), "leg.stroke", 2);
    if (!continuous && !(stroke[0] < stroke[1])) rd.fail(line_of("stroke"), where + ": stroke [" + num(stroke[0]) + ", " + num(stroke[1]) + "] must have min < max");
    d.continuous = d.continuous || continuous;
    d.lumped_rods.push_back(l.type->kind->read(schema, p, stroke, d.articulated));
    d.legs.push_back(l.type);
    d.leg_lines.push_back(t.line);
  }
}

// The platform's, the payload's and gravity's parameters.
void add_body_params(const Reader& rd, const Bodies& b, Description& d) {
  auto add = [&](const std::string& name, const char* unit, const std::string& desc, double v, double lo, double hi,
                 int line) { rd.add(d.params, name, unit, desc, v, lo, hi, line); };
  const toml::Table& pt = *b.pt;
  const bool art = d.articulated;
  add("platform.m", "kg", art ? "platform mass, half on each end bar (articulated platform)"
                              : "platform mass (its centre of mass is the platform frame origin)", b.pm, 0, 1e6, pt.find("mass")->line);
  add("platform.Ixx", "kg m2", art ? "inertia turning with the articulation, about the axis-frame x axis (no effect: rz only)"
                                   : "platform principal inertia about the platform x axis through its origin", b.pI[0], 0, 1e6, b.inertia_line);
  add("platform.Iyy", "kg m2", art ? "inertia turning with the articulation, about the axis-frame y axis (no effect: rz only)"
                                   : "platform principal inertia about the platform y axis through its origin", b.pI[1], 0, 1e6, b.inertia_line);
  add("platform.Izz", "kg m2", art ? "inertia about the articulation (a geared tool: ratio^2 x its inertia)"
                                   : "platform principal inertia about the platform z axis through its origin", b.pI[2], 0, 1e6, b.inertia_line);
  if (d.articulated) {
    auto field = [&](const char* key, const char* what) -> const toml::Value& { return rd.need(pt, key, "platform", what); };
    const double ang = rd.number(field("axis_angle", "direction of the end-to-end axis at rz = 0, from x [rad]"), "platform.axis_angle");
    const double ends = rd.number(field("ends", "distance of each end bar from the platform centre along the axis [m]"), "platform.ends");
    if (!(ends > 0)) rd.fail(pt.find("ends")->line, "platform.ends = " + num(ends) + " m must be > 0");
    const auto c = rd.numbers(field("centre", "platform centre from the pose point, in the axis frame (along, across, up) [m]"), "platform.centre", 3);
    add("platform.axis_angle", "rad", "direction of the articulated platform's end-to-end axis at rz = 0, from the x axis", ang, -10, 10, pt.find("axis_angle")->line);
    add("platform.ends", "m", "distance of each end bar (half the platform mass each) from the platform centre along the axis", ends, 1e-9, 1e3, pt.find("ends")->line);
    add("platform.cx", "m", "platform centre from the pose point along the axis", c[0], -1e3, 1e3, pt.find("centre")->line);
    add("platform.cy", "m", "platform centre from the pose point across the axis", c[1], -1e3, 1e3, pt.find("centre")->line);
    add("platform.cz", "m", "platform centre from the pose point, vertical", c[2], -1e3, 1e3, pt.find("centre")->line);
  }
  add("payload.m", "kg", "payload point mass rigidly fixed on the platform", b.pay_m, 0, 1e6, b.pay_m_line);
  add("payload.x", "m", std::string("x of the payload in the ") + (art ? "axis frame, from the pose point" : "platform frame"), b.pay_c[0], -1e3, 1e3, b.pay_c_line);
  add("payload.y", "m", std::string("y of the payload in the ") + (art ? "axis frame, from the pose point" : "platform frame"), b.pay_c[1], -1e3, 1e3, b.pay_c_line);
  add("payload.z", "m", std::string("z of the payload in the ") + (art ? "axis frame, from the pose point" : "platform frame"), b.pay_c[2], -1e3, 1e3, b.pay_c_line);
  add("gravity.x", "m/s2", "x of the gravity acceleration (world frame)", b.g[0], -100, 100, b.g_line);
  add("gravity.y", "m/s2", "y of the gravity acceleration (world frame)", b.g[1], -100, 100, b.g_line);
  add("gravity.z", "m/s2", "z of the gravity acceleration (world frame)", b.g[2], -100, 100, b.g_line);

}

}  // namespace

Description read_description(const toml::Document& doc, const std::string& file) {
  Reader rd{doc};
  Description d;
  d.file = file;
  check_tables(rd, doc);
  const toml::Table& rt = read_robot(rd, doc, d);
  const int cv_line = rt.find("coordinates")->line;
  const Bodies b = read_bodies(rd, doc, rt, cv_line, d);
  const std::vector<LegIn> legs = read_legs(rd, doc, rt, cv_line, d);
  check_mobility(rd, legs, cv_line, d);
  add_leg_params(rd, legs, d);
  add_body_params(rd, b, d);
  read_sets(rd, doc, d);
  return d;
}

// [defaults] and [sets.NAME]: values by parameter name (checked against the table and the
// drive layer's names once the robot exists, in load_described).  Each set keeps its own
// values (a set starts from the defaults when it is used), so the work stays linear in the
// file however many keys and sets it has.
void read_sets(const Reader& rd, const toml::Document& doc, Description& d) {
  auto overrides = [&](const toml::Table& t) {
    std::vector<Override> out;
    for (const auto& kv : t.keys) out.push_back({kv.first, rd.number(kv.second, t.name + "." + kv.first), kv.second.line});
    return out;
  };
  d.sets.emplace_back("default", std::vector<Override>{});
  if (auto dt = doc.named("defaults"); !dt.empty()) d.sets[0].second = overrides(*dt[0]);
  for (const toml::Table& t : doc.tables)
    if (t.name.rfind("sets.", 0) == 0) {
      const std::string set = t.name.substr(5);
      if (set.empty() || set.find_first_of(" \t") != std::string::npos || set == "default")
        rd.fail(t.line, "[" + t.name + "]: a set's name is one word, not empty and not 'default'");
      // Every set is compiled and checked when the robot loads: a bound on their number keeps
      // that bounded (a real robot has a handful).
      if (d.sets.size() > kMaxSets)
        rd.fail(t.line, "[" + t.name + "]: more than " + std::to_string(kMaxSets) + " parameter sets");
      d.sets.emplace_back(set, overrides(t));
    }
}

}  // namespace described
}  // namespace pkm
