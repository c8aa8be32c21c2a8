// The hand-written 6-PUS, a test oracle for the robot the core serves from robots/6pus.toml:
// parameter table, compilation of a parameter set into the constant model, registration
// under the name "6pus_hand" (test and benchmark builds only, libpkm_oracle.so).
#include <cmath>
#include <sstream>
#include <unordered_map>

#include "oracles/sixpus.hpp"

namespace pkm {
namespace sixpus {

namespace {

// Reference geometry (docs/6pus.md, Tiberi 2020 ch. 2 and Table 4.1).
constexpr double kL = 0.116;            // leg length [m]
constexpr double kRadius = 0.056;       // platform-point circle [m]
constexpr double kHomeZ = 0.085;        // home height [m]
constexpr double kHomeStroke = 0.055;   // home stroke of legs 2..6 [m]
constexpr double kQmax = 0.17;          // stroke range [0, kQmax] (docs/6pus.md)
// Platform-point angles of legs 1..6 (Tiberi 2020 eqs. 2.8-2.13 with R2 mirrored for
// legs 4-6).
constexpr double kAngleDeg[NLEG] = {30, 270, 150, -30, 90, 210};
// Rail y offsets: not proportional to the platform-point y (that would make every leg
// line meet one common line, a rank-5 Jacobian everywhere).
constexpr double kRailY[NLEG] = {0.020, -0.014, 0.057, -0.040, 0.027, -0.063};
// Legs 1, 3, 4 have their slider on the -x side of their platform point (s.w > 0),
// legs 2, 5, 6 on the +x side.
constexpr double kBranch[NLEG] = {+1, -1, +1, +1, -1, -1};

std::string idx(const char* group, int i, const char* field) {
  return std::string(group) + "[" + std::to_string(i + 1) + "]." + field;
}

std::string num(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

}  // namespace

std::string pose_text(const double* x) {
  std::ostringstream os;
  os.precision(6);
  os << "pose (x, y, z) = (" << x[0] << ", " << x[1] << ", " << x[2] << ") m, (rx, ry, rz) = (" << x[3]
     << ", " << x[4] << ", " << x[5] << ") rad";
  return os.str();
}

const Model& model_of(const RobotModel& rm) { return static_cast<const Model&>(rm); }

std::vector<ParamSpec> SixPus::param_specs(const std::string& set) const {
  if (set != "default")
    throw Error(PKM_ERR_ARGUMENT, "6pus has no parameter set '" + set + "' (known: default)");
  const double pi = std::acos(-1.0);
  std::vector<ParamSpec> v;
  v.reserve(NLEG * 15 + 11);
  for (int i = 0; i < NLEG; ++i) {
    const double a = kAngleDeg[i] * pi / 180.0;
    const double px = kRadius * std::cos(a), py = kRadius * std::sin(a);
    // Slider x at home from |P - S| = L on the chosen side, then the rail origin that
    // puts the home stroke at kHomeStroke.  Leg 1 keeps Table 4.1's S0 exactly.
    const double wy = py - kRailY[i];
    const double wx = kBranch[i] * std::sqrt(kL * kL - wy * wy - kHomeZ * kHomeZ);
    const double s0x = (i == 0) ? -0.085 : px - wx - kHomeStroke;
    const std::string leg = "leg " + std::to_string(i + 1);
    v.push_back({idx("leg", i, "L"), "m", "length of " + leg + " (slider U-joint to platform S-joint)", kL, 1e-9, 10});
    v.push_back({idx("leg", i, "px"), "m", "x of the platform attachment point of " + leg + ", platform frame", px, -10, 10});
    v.push_back({idx("leg", i, "py"), "m", "y of the platform attachment point of " + leg + ", platform frame", py, -10, 10});
    v.push_back({idx("leg", i, "pz"), "m", "z of the platform attachment point of " + leg + ", platform frame", 0.0, -10, 10});
    v.push_back({idx("leg", i, "branch"), "1",
                 "IK root of " + leg + ": +1 slider on the -s side of its platform point (s.w > 0, Tiberi 2020 eq. 2.17a), "
                 "-1 on the +s side (eq. 2.17b)",
                 kBranch[i], -1, 1});
    v.push_back({idx("leg", i, "m"), "kg", "mass of " + leg + " (uniform slender rod)", 0.025, 0, 1e6});
    v.push_back({idx("rail", i, "S0x"), "m", "x of the slider of " + leg + " at stroke q = 0", s0x, -10, 10});
    v.push_back({idx("rail", i, "S0y"), "m", "y of the slider of " + leg + " at stroke q = 0", kRailY[i], -10, 10});
    v.push_back({idx("rail", i, "S0z"), "m", "z of the slider of " + leg + " at stroke q = 0", 0.0, -10, 10});
    v.push_back({idx("rail", i, "sx"), "1", "x of the rail direction of " + leg + " (unit vector; the set checks |s| = 1 within 1e-6)", 1.0, -2, 2});
    v.push_back({idx("rail", i, "sy"), "1", "y of the rail direction of " + leg + " (unit vector; the set checks |s| = 1 within 1e-6)", 0.0, -2, 2});
    v.push_back({idx("rail", i, "sz"), "1", "z of the rail direction of " + leg + " (unit vector; the set checks |s| = 1 within 1e-6)", 0.0, -2, 2});
    v.push_back({idx("rail", i, "qmin"), "m", "lower stroke limit of " + leg, 0.0, -10, 10});
    v.push_back({idx("rail", i, "qmax"), "m", "upper stroke limit of " + leg, kQmax, -10, 10});
    v.push_back({idx("slider", i, "m"), "kg", "mass of the slider carriage of " + leg, 0.12, 0, 1e6});
  }
  v.push_back({"platform.m", "kg", "platform mass (its centre of mass is the platform frame origin)", 0.35, 0, 1e6});
  v.push_back({"platform.Ixx", "kg m2", "platform principal inertia about the platform x axis through its origin", 4.0e-4, 0, 1e6});
  v.push_back({"platform.Iyy", "kg m2", "platform principal inertia about the platform y axis through its origin", 4.0e-4, 0, 1e6});
  v.push_back({"platform.Izz", "kg m2", "platform principal inertia about the platform z axis through its origin", 7.5e-4, 0, 1e6});
  v.push_back({"payload.m", "kg", "payload point mass rigidly fixed on the platform", 0.0, 0, 1e6});
  v.push_back({"payload.x", "m", "x of the payload in the platform frame", 0.0, -10, 10});
  v.push_back({"payload.y", "m", "y of the payload in the platform frame", 0.0, -10, 10});
  v.push_back({"payload.z", "m", "z of the payload in the platform frame", 0.0, -10, 10});
  v.push_back({"gravity.x", "m/s2", "x of the gravity acceleration (world frame)", 0.0, -100, 100});
  v.push_back({"gravity.y", "m/s2", "y of the gravity acceleration (world frame)", 0.0, -100, 100});
  v.push_back({"gravity.z", "m/s2", "z of the gravity acceleration (world frame)", -9.81, -100, 100});
  return v;
}

std::unique_ptr<RobotModel> SixPus::compile(const std::vector<ParamSpec>& specs,
                                            const std::vector<double>& values) const {
  std::unordered_map<std::string, double> val;
  for (size_t k = 0; k < specs.size() && k < values.size(); ++k) val[specs[k].name] = values[k];
  auto get = [&](const std::string& name) {
    auto it = val.find(name);
    if (it == val.end()) throw Error(PKM_ERR_PARAMETER, "6pus parameter " + name + " is missing from the set");
    if (!std::isfinite(it->second))
      throw Error(PKM_ERR_PARAMETER, "6pus parameter " + name + " is not finite (" + num(it->second) + ")");
    return it->second;
  };
  auto bad = [](const std::string& msg) { throw Error(PKM_ERR_PARAMETER, msg); };

  auto m = std::make_unique<Model>();
  double rsum = 0;
  for (int i = 0; i < NLEG; ++i) {
    m->L[i] = get(idx("leg", i, "L"));
    m->p_local[i] = V3(get(idx("leg", i, "px")), get(idx("leg", i, "py")), get(idx("leg", i, "pz")));
    m->branch[i] = get(idx("leg", i, "branch"));
    m->m_leg[i] = get(idx("leg", i, "m"));
    m->S0[i] = V3(get(idx("rail", i, "S0x")), get(idx("rail", i, "S0y")), get(idx("rail", i, "S0z")));
    m->s[i] = V3(get(idx("rail", i, "sx")), get(idx("rail", i, "sy")), get(idx("rail", i, "sz")));
    m->ss[i] = m->s[i].squaredNorm();
    m->inv_ss[i] = 1.0 / m->ss[i];
    m->qmin[i] = get(idx("rail", i, "qmin"));
    m->qmax[i] = get(idx("rail", i, "qmax"));
    m->m_slider[i] = get(idx("slider", i, "m"));
    rsum += m->p_local[i].norm();

    if (!(m->L[i] > 0)) bad(idx("leg", i, "L") + " = " + num(m->L[i]) + " m must be > 0");
    // (s.w)^2 carries rounding of order 1e-16 |d|^2: a leg counts as exactly
    // perpendicular to its rail when |s.w| < 1e-6 L.
    m->disc_tol[i] = 1e-12 * m->L[i] * m->L[i];
    if (m->branch[i] != 1.0 && m->branch[i] != -1.0)
      bad(idx("leg", i, "branch") + " = " + num(m->branch[i]) +
          " must be +1 or -1 (which inverse-kinematics root, Tiberi 2020 eq. 2.17a/b)");
    const double sn = std::sqrt(m->ss[i]);
    if (std::abs(sn - 1.0) > 1e-6)
      bad("rail " + std::to_string(i + 1) + " direction (" + idx("rail", i, "sx") + ", " + idx("rail", i, "sy") +
          ", " + idx("rail", i, "sz") + ") = (" + num(m->s[i].x()) + ", " + num(m->s[i].y()) + ", " +
          num(m->s[i].z()) + ") has length " + num(sn) + "; it must be a unit vector within 1e-6");
    if (!(m->qmin[i] < m->qmax[i]))
      bad(idx("rail", i, "qmin") + " = " + num(m->qmin[i]) + " m must be below " + idx("rail", i, "qmax") + " = " +
          num(m->qmax[i]) + " m");
    if (m->m_leg[i] < 0) bad(idx("leg", i, "m") + " = " + num(m->m_leg[i]) + " kg must be >= 0");
    if (m->m_slider[i] < 0) bad(idx("slider", i, "m") + " = " + num(m->m_slider[i]) + " kg must be >= 0");
  }
  m->r_char = rsum / NLEG;
  for (int i = 0; i < NLEG; ++i) {
    auto& a = m->soa;
    a.px[i] = m->p_local[i].x(), a.py[i] = m->p_local[i].y(), a.pz[i] = m->p_local[i].z();
    a.S0x[i] = m->S0[i].x(), a.S0y[i] = m->S0[i].y(), a.S0z[i] = m->S0[i].z();
    a.sx[i] = m->s[i].x(), a.sy[i] = m->s[i].y(), a.sz[i] = m->s[i].z();
    a.ss[i] = m->ss[i];
    a.L2[i] = m->L[i] * m->L[i];
  }
  if (!(m->r_char > 0)) bad("the platform points leg[i].px/py/pz all coincide with the platform origin");

  m->m_platform = get("platform.m");
  m->I_platform = V3(get("platform.Ixx"), get("platform.Iyy"), get("platform.Izz"));
  m->m_payload = get("payload.m");
  m->c_payload = V3(get("payload.x"), get("payload.y"), get("payload.z"));
  m->g = V3(get("gravity.x"), get("gravity.y"), get("gravity.z"));
  if (!(m->m_platform > 0)) bad("platform.m = " + num(m->m_platform) + " kg must be > 0");
  const char* inames[3] = {"platform.Ixx", "platform.Iyy", "platform.Izz"};
  for (int k = 0; k < 3; ++k)
    if (!(m->I_platform[k] > 0)) bad(std::string(inames[k]) + " = " + num(m->I_platform[k]) + " kg m2 must be > 0");
  // Principal moments of a real body obey the triangle inequality.
  for (int k = 0; k < 3; ++k) {
    const double a = m->I_platform[k], b = m->I_platform[(k + 1) % 3], c = m->I_platform[(k + 2) % 3];
    if (a > b + c + 1e-15)
      bad(std::string(inames[k]) + " = " + num(a) + " kg m2 exceeds " + inames[(k + 1) % 3] + " + " +
          inames[(k + 2) % 3] + " = " + num(b + c) + ": no rigid body has these principal moments");
  }
  if (m->m_payload < 0) bad("payload.m = " + num(m->m_payload) + " kg must be >= 0");

  const double home[6] = {0, 0, kHomeZ, 0, 0, 0};
  for (int k = 0; k < 6; ++k) m->home[k] = home[k];
  Frame f;
  frame_of(home, f);
  Leg legs[NLEG];
  try {
    legs_at(*m, home, f, legs, Strokes::check);
  } catch (const Error& e) {
    bad(std::string("the home pose is not a valid configuration of this parameter set: ") + e.what() +
        " (check leg[i].L, leg[i].px/py/pz, rail[i].S0x/S0y/S0z, rail[i].s*, rail[i].qmin/qmax)");
  }
  double meas[2];
  singularity_measures(*m, f, legs, meas);
  if (meas[1] < 1e-8)
    bad("the layout is singular at the home pose (direct/type-2 singularity, 1/cond(J) = " + num(meas[1]) +
        "): e.g. rail offsets proportional to the platform-point coordinates make all legs meet one line; "
        "check rail[i].S0y/S0z and leg[i].px/py");
  return m;
}

// Each leg's rail origin S0, slider S and platform joint P at pose x (pts[6][3][3]).
static void chain_of(const Model& sm, const double* x, double* pts) {
  Frame f;
  frame_of(x, f);
  Leg legs[NLEG];
  legs_at(sm, x, f, legs, Strokes::ignore);
  for (int i = 0; i < NLEG; ++i) {
    const V3 rows[3] = {sm.S0[i], sm.S0[i] + legs[i].q * sm.s[i], V3(x[0], x[1], x[2]) + legs[i].rP};
    for (int r = 0; r < 3; ++r)
      for (int k = 0; k < 3; ++k) pts[9 * i + 3 * r + k] = rows[r][k];
  }
}

void SixPus::platform_pose(const RobotModel&, RobotData&, const double* x, double* X, double* S) const {
  for (int k = 0; k < 6; ++k) X[k] = x[k];
  if (S)
    for (int k = 0; k < 36; ++k) S[k] = k % 7 == 0 ? 1.0 : 0.0;
}

void SixPus::chain_points(const RobotModel& rm, RobotData&, const double* x, double* pts) const {
  chain_of(model_of(rm), x, pts);
}

void SixPus::home(const RobotModel& rm, double* x) const {
  const Model& m = model_of(rm);
  for (int k = 0; k < 6; ++k) x[k] = m.home[k];
}

}  // namespace sixpus

// The hand-written 6-PUS as a test oracle (robots/registry.cpp's hook for the robots of a
// test build: libpkm_oracle.so, linked into the C++ tests and benchmarks).
const Robot* oracle_6pus() {
  static sixpus::SixPus r;
  return &r;
}

}  // namespace pkm
