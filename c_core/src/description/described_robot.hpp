// A robot compiled from a description file (docs/robots.md): the description becomes a
// parameter table like a hand-written robot's, and one set of algorithms serves every
// described robot.
//
// Model.  The platform moves along a declared subset of the pose (x, y, z, rx, ry, rz),
// R = Rx(rx) Ry(ry) Rz(rz), the others held at 0 by the legs.  An articulated platform
// (Adept Quattro, H4) is two translating end bars joined so that the bar-to-bar direction
// turns with rz: its points are p + Rz(rz0 + rz) a + f, a turning with the articulation and
// f a fixed (translating) offset; kinematically rz acts on the points a as a rotation.  Every leg joins the base to
// a platform point P_i and has one actuated joint q_i of one of three kinds:
//  * rail:  a slider S = S0 + q s on a prismatic rail at the base, then a rod |P - S| = L
//           (PUS, PSS, P(SS)2, planar PRR);
//  * arm:   a revolute arm at the base, elbow B = A + r (cos q u + sin q (k x u)), then a
//           rod |P - B| = L (RUS, RSS, R(SS)2 of Delta robots, planar RRR);
//  * strut: an actuated prismatic strut of length q = |P - B| between a base point and P
//           (UPS, SPS of Gough-Stewart platforms).
// PRS and RPS legs add a passive revolute joint that holds their platform point in a plane,
// a . (P - o) = 0: the pose components not declared are then dependent (the parasitic motion
// of 3-PRS and 3-RPS heads), solved from those constraints by Newton, and every algorithm runs
// through the motion map S = d(full pose)/dx and its rate.  With [platform] kind = "point"
// the legs meet at one joint (the five-bar): no platform body, p = 0.
// Bodies: the platform (mass, principal inertias; an articulated one as half its mass at
// each end bar), a payload point, per leg a slider point mass, an arm (mass at its centre
// of mass, which may lie off the arm line, + inertia about it), rods (uniform slender, or
// lumped: half the mass at each joint; a parallelogram's rod pair is one rod of their
// total mass: its rods translate), a strut's cylinder and piston as uniform slender tubes.
//
// Algorithms.  Each leg kind (joint_kind.hpp, one file per kind) holds its geometry (the
// positions of its body points from its platform point, closed-form inverse kinematics), the
// closure's first and second derivatives in closed form, its mass and force terms; the
// algorithms here (described_robot.cpp, described_platform.cpp) are written once over them
// (the tests hold the derivatives against finite differences of the inverse kinematics).
// Dynamics by virtual power: J^T tau = sum_b J_b^T (inertia and gravity force of b), the
// bodies' inertia assembled in twist space.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "common/robot.hpp"
#include "description/toml_lite.hpp"

namespace pkm {
namespace described {

// What the robot is made of, which decides its class (loader.cpp): legs from the base to a
// platform point (rail, arm and strut kinds: DescribedRobot), a single axis carrying the
// platform itself (AxisRobot), an open chain (SerialRobot, serial_chain.hpp).
enum class Structure { legs, axis, serial };
class Kind;
class AxisKind;
class LegKind;
class LegMotion;

// A leg architecture: which actuated joint, and what the Grubler-Kutzbach count sees
// (bodies, joints, their freedoms, idle freedoms such as a rod's spin between two
// spherical joints).
struct LegType {
  const char* name;
  Structure structure;
  int bodies, joints, freedoms, idle;
  bool planar;  // a planar chain (only with planar robots)
  const char* what;
  const Kind* kind;                // its schema
  const LegKind* leg = nullptr;    // rail, arm, strut: its kind
  const AxisKind* axis = nullptr;  // a single axis: its kind
  int constraints = 0;             // passive constraints on the platform (PRS, RPS: its plane, 1)
};
const LegType* find_leg_type(const std::string& name);
std::string leg_type_names();

constexpr int kMaxLegs = 6;
constexpr size_t kMaxSets = 1000;  // [sets.NAME] tables of one description

// Mass elements of a leg over its body points (local indices; point 1 is always P).
struct PointMass {
  int a;
  double m;
};
struct Rod {  // uniform slender rod between points a and b
  int a, b;
  double m;
};

struct LegModel {
  const LegType* type = nullptr;
  const LegMotion* kind = nullptr;  // type->leg->motion(), at hand in the legs' loops
  Eigen::Vector3d p;  // platform point in the platform frame [m]
  Eigen::Vector3d f = Eigen::Vector3d::Zero();  // articulated platform: fixed offset of the point [m]
  Eigen::Vector3d base;  // rail: S0; arm: axis point A; strut: base point B [m]
  Eigen::Vector3d dir;   // rail: s; arm: axis k (unit) [1]
  Eigen::Vector3d u, w;  // arm: arm direction at q = 0 and k x u
  double L = 0, r = 0, branch = 1, ss = 1, inv_ss = 1;
  double m_rod = 0, m_body = 0, I_arm = 0, rc = 0;  // slider or arm mass, arm inertia and CoM distance
  double com_c = 1, com_s = 0;      // arm: cos, sin of the centre of mass's angle from the arm line
  double rod_self = 1.0 / 3, rod_cross = 1.0 / 6;  // rod kinetic energy (m/2)(self (|vA|^2 + |vB|^2) + 2 cross vA.vB)
  double m_cyl = 0, l_cyl = 0, m_pis = 0, l_pis = 0;
  double qmin = 0, qmax = 0;
  double disc_tol = 0;
  // PRS, RPS: a passive revolute joint holds the platform point in the plane through plane_o
  // normal to plane_n (the revolute axis): plane_n . (P - plane_o) = 0.
  bool constrained = false;
  Eigen::Vector3d plane_n = Eigen::Vector3d::Zero(), plane_o = Eigen::Vector3d::Zero();
  int npt = 0, nmass = 0, nrod = 0;  // body points: rail S, P; arm B, P, C; strut B, P, cylinder end, piston end
  PointMass mass[2];
  Rod rod[2];
};

// The legs' constant data as arrays over the legs (entry i: leg i; entries n.. are a
// harmless padding leg), for a kind's pass over every leg at once, which the compiler
// vectorises: the platform point p and offset f, the base point, the direction (rail
// s, arm axis k), L^2, |dir|^2 and its inverse, the branch and the reach tolerance.
struct LegArrays {
  double px[kMaxLegs], py[kMaxLegs], pz[kMaxLegs], fx[kMaxLegs], fy[kMaxLegs], fz[kMaxLegs];
  double bx[kMaxLegs], by[kMaxLegs], bz[kMaxLegs], sx[kMaxLegs], sy[kMaxLegs], sz[kMaxLegs];
  double L2[kMaxLegs], ss[kMaxLegs], inv_ss[kMaxLegs], branch[kMaxLegs], disc_tol[kMaxLegs];
};

struct Model final : RobotModel {
  int n = 0;
  int coord[6];    // pose index (0..5) of free coordinate j
  // Dependent pose components (PRS, RPS legs): pose index of each, solved from the legs'
  // plane constraints (as many as the legs that have one, in leg order).
  int ndep = 0;
  int dep[6];
  bool rotates = false;  // some rotation is a coordinate
  // The coordinates are the whole pose (x, y, z, rx, ry, rz) in order, none dependent: the
  // map T of the pose rates to the twist is square, and the dynamics solve in twist space.
  bool full_pose = false;
  bool articulated = false;
  double rz0 = 0;         // articulated: direction of the bar-to-bar axis at rz = 0 [rad]
  std::vector<LegModel> legs;
  LegArrays soa;                    // the legs' data as arrays
  const LegMotion* kind = nullptr;  // the legs' kind (one for all)
  double m_platform = 0;
  Eigen::Vector3d c_platform = Eigen::Vector3d::Zero();  // articulated: centre (axis frame) [m]
  Eigen::Vector3d end_bars[2];  // articulated: the end bars (half the mass each), axis frame [m]
  Eigen::Vector3d I_platform, c_payload, g;
  double m_payload = 0;
  double r_char = 1;
  double home[6];
};

// A parameter value by name, from [defaults] or [sets.NAME], with its line.
struct Override {
  std::string name;
  double value;
  int line;
};

// What a description file declares, checked, with the parameter table it defines.
struct Description {
  std::string file, name, title, source;
  std::vector<int> coords;              // pose indices of the platform's coordinates
  std::vector<const LegType*> legs;
  std::vector<int> leg_lines;
  std::vector<bool> lumped_rods;        // per leg: rod mass lumped at its joints
  bool articulated = false;             // [platform] kind = "articulated"
  bool point = false;                   // [platform] kind = "point": the legs meet at one joint
  std::vector<int> dependent;           // pose indices the legs' passive joints decide (PRS, RPS)
  int redundant = 0;                    // robot.redundant_constraints
  std::vector<ParamSpec> params;        // defaults from the file
  // "default" first ([defaults]), then each [sets.NAME] with its own values only (applied
  // after the defaults: DescribedRobot::param_overrides)
  std::vector<std::pair<std::string, std::vector<Override>>> sets;
  std::vector<double> home;
  bool continuous = false;              // a single R axis declared `continuous = true` (no limits)
  int home_line = 0;
  int name_line = 0;
  Structure structure = Structure::legs;
  bool planar = false;
  int mobility = 0;  // Grubler-Kutzbach count
};

// Reads and checks a description; throws Error(PKM_ERR_ARGUMENT, "file:line: field: what").
Description read_description(const std::string& text, const std::string& file);
Description read_description(const toml::Document& doc, const std::string& file);  // parsed already
struct Reader;
// A description's [defaults] and [sets.NAME] tables into d.sets (the first set "default").
void read_sets(const Reader& rd, const toml::Document& doc, Description& d);

class DescribedRobot : public Robot {
 public:
  DescribedRobot(Description d, int serial);
  const Description& description() const { return d_; }
  int serial() const { return serial_; }  // order of loading
  const char* name() const override { return d_.name.c_str(); }
  const char* title() const override { return d_.title.c_str(); }
  const char* source_file() const override { return d_.file.c_str(); }
  int ndof() const override { return (int)d_.coords.size(); }
  std::vector<std::string> param_sets() const override;
  std::vector<ParamSpec> param_specs(const std::string& set) const override;
  std::vector<std::pair<std::string, double>> param_overrides(const std::string& set) const override;
  std::unique_ptr<RobotModel> compile(const std::vector<ParamSpec>& specs,
                                      const std::vector<double>& values) const override;
  void home(const RobotModel&, double* x) const override;
  std::unique_ptr<RobotData> make_data(const RobotModel&) const override;
  const char* joint_prefix() const override;
  const char* joint_noun() const override;
  bool joints_angular() const override;
  const char* limb_noun() const override { return "leg"; }
  const char* pose_name(int i) const override;
  const char* pose_unit(int i) const override;
  std::string joint_limit_param(int i, bool upper) const override;
  const char* geometry_param(int i) const override;

  void ik(const RobotModel&, RobotData&, const double* x, double* q) const override;
  void jacobians(const RobotModel&, RobotData&, const double* x, double* Jx, double* Jq,
                 double* J) const override;
  void jacobian_dot(const RobotModel&, RobotData&, const double* x, const double* xd,
                    double* Jdot) const override;
  void singularity(const RobotModel&, RobotData&, const double* x, double* measures) const override;
  void direct_singularity_guard(const RobotModel&, RobotData&, const double* x, double* measure_bound,
                                double* det_j) const override;
  void chain_points(const RobotModel&, RobotData&, const double* x, double* pts) const override;
  void platform_pose(const RobotModel&, RobotData&, const double* x, double* X, double* S) const override;
  bool has_platform() const override { return true; }
  void joint_acceleration(const RobotModel&, RobotData&, const double* x, const double* xd,
                          const double* xdd, double* qdd) const override;
  void inverse_dynamics(const RobotModel&, RobotData&, const double* x, const double* xd,
                        const double* xdd, double* tau) const override;
  void mass_matrix(const RobotModel&, RobotData&, const double* x, double* M) const override;
  void forward_dynamics(const RobotModel&, RobotData&, const double* x, const double* xd,
                        const double* tau, double* xdd) const override;
  bool forward_dynamics_response(const RobotModel&, RobotData&, const double* x, const double* xd,
                                 const double* tau, double* xdd, double* B) const override;
  void energy(const RobotModel&, RobotData&, const double* x, const double* xd, double* kinetic,
              double* potential) const override;

 private:
  Description d_;
  int serial_;
  std::vector<std::string> geometry_names_;
};

// The robot a name or path stands for: a path to a description file (contains '/' or
// ends in ".toml"), or the name of a description in the search path (PKM_ROBOT_PATH,
// then the project's robots/ folder).  nullptr if it is neither; throws Error naming the
// file and line if the description is bad.  Robots stay alive for the process; a file
// whose text changed gives a new robot.
const Robot* load_described(const std::string& name_or_path);
// Compiles a description from its text (file names it in messages).
const Robot* register_description(const std::string& text, const std::string& file);
// Names of the descriptions in the search path, sorted.
std::vector<std::string> bundled_descriptions();

}  // namespace described
}  // namespace pkm
