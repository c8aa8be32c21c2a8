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

#include "description/described_platform.hpp"
#include "description/schema.hpp"

namespace pkm {
namespace described {

// What every kind of [[leg]] has: the fields beyond type, copies, platform_point, stroke,
// continuous (and platform_offset), and how they and the platform point p (turned with the
// copy) and the stroke become parameters, each checked at its line (a continuous joint's
// stroke is empty).  True: a rod's mass is lumped at its joints.
class Kind {
 public:
  virtual ~Kind() = default;
  virtual std::vector<std::string> fields() const = 0;
  virtual bool read(const LegSchema& s, const std::vector<double>& p, const std::vector<double>& stroke,
                    bool articulated) const = 0;
  // May be declared `continuous = true` (no stroke): an axis that turns without limit.
  virtual bool may_be_continuous() const { return false; }
};

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

class AxisKind : public Kind {
 public:
  virtual const char* type() const = 0;    // the leg type in a description ("P")
  virtual const char* what() const = 0;    // one line for the list of leg types
  virtual const char* prefix() const = 0;  // joint parameters' group, drive layer's too ("rail" -> rail[1].coulomb)
  virtual const char* noun() const = 0;    // messages: "carriage 1"
  virtual bool angular() const = 0;        // q in rad (efforts N m) or m (N)

  // Schema (Kind): the fields and their parameters, the platform point's (axis_point) with
  // them; a continuous joint has no limit parameters.
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

// A leg from the base to a platform point, with one actuated joint (rail, arm, strut): the
// joint's geometry, derivatives, mass and force terms.  One file per kind implements them
// (kind_rail.cpp, kind_arm.cpp, kind_strut.cpp); the robot's algorithms call them leg by leg.
class LegMotion {
 public:
  virtual ~LegMotion() = default;
  virtual const char* prefix() const = 0;  // joint parameters' group, drive layer's too ("rail")
  virtual const char* noun() const = 0;    // messages: "slider 1"
  virtual bool angular() const = 0;        // q in rad (efforts N m) or m (N)
  // The leg's geometric error is its rod length leg[i].L (a strut has no rod: its length is
  // the joint).
  virtual bool has_rod() const = 0;
  // What a passive revolute joint's plane passes through (messages): "rail", "base joint".
  virtual const char* plane_through() const = 0;
  // The body point drawn as the joint's moving end (chain_points).
  virtual int moving_point() const = 0;

  // Geometry, closed form: the joint value q and the leg's body points (point 1 is P) from
  // the platform point P.
  virtual void geometry(const LegModel& l, const P3<double>& P, double& q, P3<double>* pts,
                        const LegWhere& at) const = 0;
  // The inverse kinematics of every leg of the robot at the platform pf, each joint value
  // checked against its limits.
  virtual void ik_all(const Model& m, const Platform& pf, const double* x, double* q) const = 0;
  // Geometry and first derivatives of every leg of the robot (all of this kind) at the
  // platform pf: lg's rP, q, pos, w, dq, j and the kind's D, t, tb (arms: t, tb; struts: D).
  virtual void grad_all(const Model& m, const Platform& pf, const double* x, LegGrad* lg) const = 0;
  // -d f / d q of the closure f = (|P - S(q)|^2 - L^2) / 2 (a strut: (|P - B|^2 - q^2) / 2).
  virtual double closure_dq(const LegModel& l, const LegGrad& lg) const = 0;
  // The inverse-kinematic measure from closure_dq: the cosine between the rod and the
  // joint's motion (infinity: none, a strut).
  virtual double ik_measure(const LegModel& l, double closure_dq) const = 0;
  // The rate of dq/dP along the platform point's velocity vP (qd = dq vP).
  virtual Eigen::RowVector3d dq_rate(const LegModel& l, const LegGrad& lg, const V3& vP, double qd) const = 0;
  // Mass: each leg's inertia seen at its platform point, into the twist-space sum.
  virtual void add_mass_all(const Model& m, const LegGrad* lg, TwistMass& tm) const = 0;
  // Force: each leg's inertia-and-gravity load seen at its platform point (virtual power)
  // for the platform's motion pm, into the wrench W about the platform origin.  The joint
  // acceleration and the body points' accelerations in closed form (the second derivative
  // of the closure; the tests hold the joint accelerations against J xdd + Jdot xd and
  // second differences of the inverse kinematics).
  // qdd: the joint accelerations on the way (those of qdd_all).
  virtual void add_loads_all(const Model& m, const LegGrad* lg, const PlatformMotion& pm, V6& W,
                             double* qdd) const = 0;
  // The joint accelerations qdd of every leg for the platform's motion pm (the closure
  // differentiated twice, as in the loads).
  virtual void qdd_all(const Model& m, const LegGrad* lg, const PlatformMotion& pm, double* qdd) const = 0;
};

// The loops over a robot's legs, written once and compiled per kind K (a robot's legs share
// one kind; the reader refuses a mix), with K's per-leg terms inlined: K::geometry_of (the
// joint value and body points at P), K::grad_of (geometry
// and first derivatives at P), K::add_mass_of (the leg's inertia at P into the twist-space
// sum), K::load_of (its load at P for P's velocity vP and acceleration aP under gravity g,
// and the joint acceleration)
// and K::qdd_of (the joint acceleration there).
template <class K>
class LegMotionOf : public LegMotion {
 public:
  void ik_all(const Model& m, const Platform& pf, const double* x, double* q) const override {
    for (int i = 0; i < m.n; ++i) {
      V3 rP;
      const V3 P = attachment(m, pf, i, rP);
      P3<double> pts[4];
      const LegWhere at{m, i, x};
      K::geometry_of(m.legs[i], P3<double>{P.x(), P.y(), P.z()}, q[i], pts, at);
      if (q[i] < m.legs[i].qmin || q[i] > m.legs[i].qmax) at.joint_limit(q[i]);
    }
  }
  void grad_all(const Model& m, const Platform& pf, const double* x, LegGrad* lg) const override {
    for (int i = 0; i < m.n; ++i) {
      LegGrad& g = lg[i];
      const V3 P = attachment(m, pf, i, g.rP);
      K::grad_of(m.legs[i], P, g, LegWhere{m, i, x});
      g.j.head<3>() = g.dq.transpose();
      g.j.tail<3>() = g.rP.cross(g.j.head<3>());
    }
  }
  void add_mass_all(const Model& m, const LegGrad* lg, TwistMass& tm) const override {
    for (int i = 0; i < m.n; ++i) K::add_mass_of(m.legs[i], lg[i], tm);
  }
  void add_loads_all(const Model& m, const LegGrad* lg, const PlatformMotion& pm, V6& W,
                     double* qdd) const override {
    for (int i = 0; i < m.n; ++i) {
      const V3& rP = lg[i].rP;
      const V3 vP = pm.v + pm.om.cross(rP);
      const V3 aP = pm.a + pm.al.cross(rP) + pm.om.cross(pm.om.cross(rP));
      add_load(W, K::load_of(m.legs[i], lg[i], vP, aP, m.g, qdd[i]), rP);
    }
  }
  void qdd_all(const Model& m, const LegGrad* lg, const PlatformMotion& pm, double* qdd) const override {
    for (int i = 0; i < m.n; ++i) {
      const V3& rP = lg[i].rP;
      const V3 vP = pm.v + pm.om.cross(rP);
      const V3 aP = pm.a + pm.al.cross(rP) + pm.om.cross(pm.om.cross(rP));
      qdd[i] = K::qdd_of(m.legs[i], lg[i], vP, aP);
    }
  }
};

// The schema of such a leg (Kind) and its compiled form, and its motion.
class LegKind : public Kind {
 public:
  virtual void compile(const ParamValues& v, int i, bool lumped, LegModel& l) const = 0;
  virtual const LegMotion& motion() const = 0;
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
// Its mass and force terms: kind_rod.hpp.

// The single-axis kinds (description/kind_prismatic_axis.cpp, kind_revolute_axis.cpp).
const AxisKind& prismatic_axis();
const AxisKind& revolute_axis();
// An axis's platform point parameters leg[1].px py pz (kind_prismatic_axis.cpp).
void add_axis_point(const LegSchema& s, const std::vector<double>& p, bool angular);

}  // namespace described
}  // namespace pkm
