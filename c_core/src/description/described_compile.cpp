// Compiling a description-compiled robot's parameters into its model, with the checks across
// parameters (the passive joints, the home pose), and its names and parameter sets.
#include <algorithm>
#include <unordered_map>

#include "common/joint_param.hpp"
#include "description/described_platform.hpp"
#include "description/joint_kind.hpp"
#include "description/schema.hpp"

namespace pkm {
namespace described {

namespace {

const Model& model_of(const RobotModel& rm) { return static_cast<const Model&>(rm); }

// The legs' passive revolute joints at the home pose with the dependent components at 0
// (before any solve): each leg's plane must pass near its platform point (an axis along the
// leg puts the point far off it), and the planes together must fix the dependent components
// (an axis lying in the leg's plane, or axes that let the platform slide or turn within
// every plane, leave them free: an architecture singularity).  Both name the legs.
template <class Bad>
void check_passive_joints(const Model& m, const Bad& bad) {
  Platform pf;
  for (int k = 0; k < 6; ++k) pf.x6[k] = 0;
  for (int j = 0; j < m.n; ++j) pf.x6[m.coord[j]] = m.home[j];
  rotation_of(m, pf);
  std::vector<int> rows;
  for (int i = 0; i < m.n; ++i) {
    const LegModel& l = m.legs[i];
    if (!l.constrained) continue;
    rows.push_back(i);
    const V3 d = pf.p + pf.R * l.p - l.plane_o;
    const double off = std::abs(l.plane_n.dot(d));
    if (off > 0.5 * d.norm())
      bad("leg " + std::to_string(i + 1) + ": its platform point is " + g6(off) + " m off the plane its passive revolute "
          "joint turns the leg in (through its " + l.kind->plane_through() +
          ", normal to revolute_axis) at the home pose, " + g6(d.norm()) + " m from it: the revolute axis must be "
          "perpendicular to the leg, not along it or through the platform point");
  }
  VD c;
  CD C;
  constraints_of(m, pf, angle_map(pf), c, C);
  MD Cd(m.ndep, m.ndep);
  for (int k = 0; k < m.ndep; ++k) Cd.col(k) = C.col(m.dep[k]) * (m.dep[k] >= 3 ? 1.0 / m.r_char : 1.0);
  Eigen::JacobiSVD<MD> svd(Cd, Eigen::ComputeFullU);
  const auto& sv = svd.singularValues();
  const double inv_cond = sv[0] > 0 ? sv[m.ndep - 1] / sv[0] : 0.0;
  if (!(inv_cond > 1e-3)) {
    // The legs whose constraints combine to nothing: the left null vector's entries.
    std::string legs, names;
    const VD u = svd.matrixU().col(m.ndep - 1);
    for (int k = 0; k < m.ndep; ++k)
      if (std::abs(u[k]) > 0.1) legs += std::string(legs.empty() ? "" : ", ") + "leg " + std::to_string(rows[k] + 1);
    for (int k = 0; k < m.ndep; ++k) names += std::string(k ? ", " : "") + kCoordNames[m.dep[k]];
    bad("architecture singularity at the home pose: the passive revolute joints of " + legs + " do not fix the "
        "dependent coordinates (" + names + "; 1 / cond = " + g6(inv_cond) + " < 1e-3): a revolute axis lies in the "
        "plane the others leave the platform free in (e.g. axes pointing at the centre instead of tangent to it)");
  }
}


}  // namespace

DescribedRobot::DescribedRobot(Description d, int serial) : d_(std::move(d)), serial_(serial) {
  // A geometric error is a rod-length error, leg by leg (a strut has no rod: its length is
  // the joint, so the toolkit takes every length parameter instead).
  const LegKind* k = d_.legs.empty() ? nullptr : d_.legs.front()->leg;
  if (k && k->motion().has_rod())
    for (int i = 0; i < ndof(); ++i) geometry_names_.push_back("leg[" + std::to_string(i + 1) + "].L");
}

std::vector<std::string> DescribedRobot::param_sets() const {
  std::vector<std::string> out;
  for (const auto& s : d_.sets) out.push_back(s.first);
  return out;
}

namespace {
const std::vector<Override>* set_of(const Description& d, const std::string& set) {
  for (const auto& s : d.sets)
    if (s.first == set) return &s.second;
  std::string known;
  for (const auto& s : d.sets) known += (known.empty() ? "" : ", ") + s.first;
  throw Error(PKM_ERR_ARGUMENT, d.name + " has no parameter set '" + set + "' (known: " + known + ")");
}
}  // namespace

std::vector<ParamSpec> DescribedRobot::param_specs(const std::string& set) const {
  std::vector<ParamSpec> v = d_.params;
  std::unordered_map<std::string, ParamSpec*> by_name;
  for (auto& s : v) by_name.emplace(s.name, &s);
  for (const auto& o : param_overrides(set))
    if (auto it = by_name.find(o.first); it != by_name.end()) it->second->value = o.second;
  return v;
}

std::vector<std::pair<std::string, double>> DescribedRobot::param_overrides(const std::string& set) const {
  // The defaults, then the set's own values (later ones win).
  const std::vector<Override>& own = *set_of(d_, set);
  std::vector<std::pair<std::string, double>> out;
  if (&own != &d_.sets.front().second)
    for (const auto& o : d_.sets.front().second) out.emplace_back(o.name, o.value);
  for (const auto& o : own) out.emplace_back(o.name, o.value);
  return out;
}

// Model::soa from the legs; the padding legs (n..) reach: p, f, base 0, dir x, L 1.
static void fill_leg_arrays(Model& m) {
  LegArrays& a = m.soa;
  for (int i = 0; i < kMaxLegs; ++i) {
    const bool pad = i >= m.n;
    const LegModel l = pad ? LegModel() : m.legs[i];
    const V3 p = pad ? V3::Zero() : l.p, f = pad ? V3::Zero() : l.f, b = pad ? V3::Zero() : l.base;
    const V3 s = pad ? V3::UnitX() : l.dir;
    a.px[i] = p.x(), a.py[i] = p.y(), a.pz[i] = p.z(), a.fx[i] = f.x(), a.fy[i] = f.y(), a.fz[i] = f.z();
    a.bx[i] = b.x(), a.by[i] = b.y(), a.bz[i] = b.z(), a.sx[i] = s.x(), a.sy[i] = s.y(), a.sz[i] = s.z();
    a.L2[i] = pad ? 1.0 : l.L * l.L;
    a.ss[i] = pad ? 1.0 : l.ss, a.inv_ss[i] = pad ? 1.0 : l.inv_ss;
    a.branch[i] = pad ? 1.0 : l.branch, a.disc_tol[i] = pad ? 0.0 : l.disc_tol;
  }
}

std::unique_ptr<RobotModel> DescribedRobot::compile(const std::vector<ParamSpec>& specs,
                                                    const std::vector<double>& values) const {
  const ParamValues get(d_.name, specs, values);
  auto vec = [&](const char* group, int i, const char* f0) { return get.vec(group, i, f0); };
  auto bad = [&](const std::string& msg) { get.bad(msg); };
  auto m = std::make_unique<Model>();
  m->n = ndof();
  for (int j = 0; j < m->n; ++j) m->coord[j] = d_.coords[j];
  for (int k = 3; k < 6; ++k)
    m->rotates |= std::find(d_.coords.begin(), d_.coords.end(), k) != d_.coords.end();
  double rsum = 0;
  for (int i = 0; i < m->n; ++i) {
    LegModel l;
    l.type = d_.legs[i];
    l.kind = &l.type->leg->motion();
    l.type->leg->compile(get, i, d_.lumped_rods[i], l);
    if (!(l.qmin < l.qmax)) {
      const std::string j = std::string(l.kind->prefix()) + "[" + std::to_string(i + 1) + "].";
      bad("leg " + std::to_string(i + 1) + ": joint limits " + j + "qmin = " + g6(l.qmin) + " and " + j + "qmax = " +
          g6(l.qmax) + " must have min < max");
    }
    if (d_.articulated) l.f = vec("leg", i, "f");
    rsum += l.p.norm();
    m->legs.push_back(l);
  }
  m->kind = m->legs.front().kind;
  fill_leg_arrays(*m);
  m->m_platform = get("platform.m");
  m->I_platform = V3(get("platform.Ixx"), get("platform.Iyy"), get("platform.Izz"));
  // Principal moments of a real body obey the triangle inequality (those of a rigid platform
  // that turns about two axes or more: a translating or planar one's other moments have no
  // effect, an articulated one turns about its axis only, a point has none).
  const char* inames[3] = {"platform.Ixx", "platform.Iyy", "platform.Izz"};
  int turns = 0;
  for (int k = 3; k < 6; ++k)
    turns += std::find(d_.coords.begin(), d_.coords.end(), k) != d_.coords.end() ||
             std::find(d_.dependent.begin(), d_.dependent.end(), k) != d_.dependent.end();
  const bool rigid_turning = turns >= 2 && !d_.articulated && !d_.point;
  for (int k = 0; k < (rigid_turning ? 3 : 0); ++k) {
    const double a = m->I_platform[k], b = m->I_platform[(k + 1) % 3], c = m->I_platform[(k + 2) % 3];
    if (a > b + c + 1e-15)
      bad(std::string(inames[k]) + " = " + g6(a) + " kg m2 exceeds " + inames[(k + 1) % 3] + " + " +
          inames[(k + 2) % 3] + " = " + g6(b + c) + ": no rigid body has these principal moments");
  }
  m->m_payload = get("payload.m");
  m->c_payload = V3(get("payload.x"), get("payload.y"), get("payload.z"));
  m->g = V3(get("gravity.x"), get("gravity.y"), get("gravity.z"));
  m->r_char = rsum > 0 ? rsum / m->n : 1.0;
  if (d_.articulated) {
    m->articulated = true;
    m->rz0 = get("platform.axis_angle");
    const double ends = get("platform.ends");
    m->c_platform = V3(get("platform.cx"), get("platform.cy"), get("platform.cz"));
    for (int k = 0; k < 2; ++k) m->end_bars[k] = m->c_platform + V3(k ? -ends : ends, 0, 0);
    if (ends > 0) m->r_char = ends;  // the end bars' speed per articulation rate
  }
  for (int j = 0; j < m->n; ++j) m->home[j] = d_.home[j];
  m->ndep = (int)d_.dependent.size();
  for (int k = 0; k < m->ndep; ++k) m->dep[k] = d_.dependent[k];
  m->full_pose = m->n == 6 && !m->ndep;
  for (int j = 0; j < m->n; ++j) m->full_pose &= m->coord[j] == j;
  if (m->ndep) check_passive_joints(*m, bad);
  // The home pose must be reachable, within the joint limits and away from singularities.
  const std::unique_ptr<RobotData> rdp = make_data(*m);
  RobotData& rd = *rdp;
  double q[6], meas[2];
  try {
    ik(*m, rd, m->home, q);
    singularity(*m, rd, m->home, meas);
  } catch (const Error& e) {
    bad(std::string("the home pose is not valid: ") + e.what());
  }
  // A home pose this close to a singularity (measures < 1e-3; well-designed robots have
  // 0.1-1 there) is no place to start a simulation or a calibration from.
  if (!(meas[0] > 1e-3))
    bad("inverse-kinematic (serial) singularity at the home pose: a rod is (nearly) perpendicular to its joint's motion "
        "(measure " + g6(meas[0]) + " < 1e-3)");
  if (!(meas[1] > 1e-3))
    bad("architecture (direct) singularity at the home pose: the legs do not constrain the platform there "
        "(1 / cond J = " + g6(meas[1]) + " < 1e-3)");
  return m;
}

void DescribedRobot::home(const RobotModel& rm, double* x) const {
  const Model& m = model_of(rm);
  for (int j = 0; j < m.n; ++j) x[j] = m.home[j];
}

// The legs' kind (one for all; the subclasses of other structures override what uses it).
static const LegMotion* legs_kind(const Description& d) {
  return d.legs.empty() || !d.legs.front()->leg ? nullptr : &d.legs.front()->leg->motion();
}
const char* DescribedRobot::joint_prefix() const { return legs_kind(d_)->prefix(); }
const char* DescribedRobot::joint_noun() const { return legs_kind(d_)->noun(); }
bool DescribedRobot::joints_angular() const { return legs_kind(d_)->angular(); }
const char* DescribedRobot::pose_name(int i) const { return kCoordNames[d_.coords[i]]; }
const char* DescribedRobot::pose_unit(int i) const { return d_.coords[i] < 3 ? "m" : "rad"; }
std::string DescribedRobot::joint_limit_param(int i, bool upper) const {
  return joint_param(*this, i, upper ? "qmax" : "qmin");
}
const char* DescribedRobot::geometry_param(int i) const {
  return i >= 0 && i < (int)geometry_names_.size() ? geometry_names_[i].c_str() : nullptr;
}

}  // namespace described
}  // namespace pkm
