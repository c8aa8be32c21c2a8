// Actuated-joint kinds as traits: one file per kind (description/kind_*.cpp) holds what a
// description of that kind means: the [[leg]] fields it takes and their checks (its
// schema), the parameters they become, and its geometry, derivatives, mass and force
// terms.  The rest of the reader and the robot's algorithms are written once over this
// interface.
//
// The kinds here are single-axis joints: the actuated joint carries the platform
// itself (a carriage on a rail, a turntable or pendulum on a shaft), so the robot has
// one coordinate and it is the joint coordinate q.  The platform frame moves rigidly with
// q; the bodies are the platform (mass at its frame origin, principal inertias about its
// axes) and the payload point.
#pragma once

#include <Eigen/Dense>
#include <string>
#include <vector>

#include "description/schema.hpp"

namespace pkm {
namespace described {

// An axis's constant data, from the parameters.
struct AxisModel {
  Eigen::Vector3d base;  // P: S0, the rail point the platform point sits on at q = 0; R: A, a point of the axis [m]
  Eigen::Vector3d dir;   // P: s, unit rail direction; R: k, unit axis (q by the right-hand rule) [1]
  Eigen::Vector3d p;     // the platform point on the rail / on the axis, platform frame [m]
  double qmin = 0, qmax = 0;  // -inf, inf on a continuous joint
  bool continuous = false;    // R: `continuous = true`, no limits (q the unwrapped angle)
};

// What the axis carries, in the platform frame.
struct AxisBodies {
  double m_platform = 0;            // at the platform frame origin [kg]
  Eigen::Vector3d I_platform;       // principal inertias about the platform axes [kg m2]
  double m_payload = 0;             // [kg]
  Eigen::Vector3d c_payload;        // [m]
  Eigen::Vector3d g;                // gravity, world frame [m/s2]
};

class AxisKind {
 public:
  virtual ~AxisKind() = default;
  virtual const char* type() const = 0;    // the leg type in a description ("P")
  virtual const char* what() const = 0;    // one line for the list of leg types
  virtual const char* prefix() const = 0;  // joint parameters' group, drive layer's too ("rail" -> rail[1].coulomb)
  virtual const char* noun() const = 0;    // messages: "carriage 1"
  virtual bool angular() const = 0;        // q in rad (efforts N m) or m (N)
  // May be declared `continuous = true` (no stroke): an axis that turns without limit.
  virtual bool may_be_continuous() const { return false; }

  // Schema: the [[leg]] fields beyond type, copies, platform_point and stroke, and how
  // they (and the stroke) become parameters, each checked at its line.  A continuous
  // joint's stroke is empty: no limit parameters.
  virtual std::vector<std::string> fields() const = 0;
  virtual void read(const LegSchema& s, const std::vector<double>& stroke) const = 0;
  // The parameters into the model, with the checks across parameters (a.continuous is set
  // before: its limits are then -inf, inf).
  virtual void compile(const ParamValues& v, AxisModel& a) const = 0;

  // Geometry: the platform frame at q (world point of platform point c: o + R c) and the
  // joint's moving point (the carriage's rail point, a point of the shaft) for drawings.
  virtual void place(const AxisModel& a, double q, Eigen::Vector3d& o, Eigen::Matrix3d& R) const = 0;
  virtual Eigen::Vector3d joint_point(const AxisModel& a, double q) const = 0;
  // Mass and force terms of the equation of motion  tau = M qdd + c qd^2 - G(q):
  // M the inertia along the axis (constant for both kinds here), c qd^2 the velocity
  // terms (zero: a body moving rigidly along or about a fixed axis), G the generalised
  // gravity force G = -dV/dq.
  virtual double inertia(const AxisModel& a, const AxisBodies& b) const = 0;
  virtual double gravity(const AxisModel& a, const AxisBodies& b, double q) const = 0;
};

// A leg from the base to a platform point, with one actuated joint of the kind (rail, arm,
// strut): its [[leg]] fields and their parameters (the schema) and its compiled form; the
// kinds' geometry and dynamics are still in described_robot.cpp.
struct LegModel;
class LegKind {
 public:
  virtual ~LegKind() = default;
  // The fields beyond type, copies, platform_point, stroke (and platform_offset).
  virtual std::vector<std::string> fields() const = 0;
  // Fields to parameters (p the platform point, turned with the copy); true: the rod's mass
  // is lumped at its joints.
  virtual bool read(const LegSchema& s, const std::vector<double>& p, const std::vector<double>& stroke,
                    bool articulated) const = 0;
  virtual void compile(const ParamValues& v, int i, bool lumped, LegModel& l) const = 0;
};
const LegKind& rail_leg();   // kind_rail.cpp
const LegKind& arm_leg();    // kind_arm.cpp
const LegKind& strut_leg();  // kind_strut.cpp
// The same with a passive revolute joint that holds the platform point in the leg's plane.
const LegKind& rail_revolute_leg();    // kind_rail_revolute.cpp (PRS)
const LegKind& revolute_strut_leg();   // kind_revolute_strut.cpp (RPS)
// Their revolute axis (kind_passive_revolute.cpp): leg[i].ax ay az; compiled into the leg's
// plane normal (the kind sets the plane's point).
std::vector<double> read_revolute_axis(const LegSchema& s, const char* what);
void compile_revolute_axis(const ParamValues& v, int i, LegModel& l);
// The rod a rail or an arm ends in (kind_rod.cpp): leg[i].L px py pz (fx fy fz) branch m.
bool read_rod(const LegSchema& s, const std::vector<double>& p, bool articulated);
void compile_rod(const ParamValues& v, int i, bool lumped, LegModel& l);

// The single-axis kinds (description/kind_prismatic_axis.cpp, kind_revolute_axis.cpp).
const AxisKind& prismatic_axis();
const AxisKind& revolute_axis();

}  // namespace described
}  // namespace pkm
