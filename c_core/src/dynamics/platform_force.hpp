// A force on the platform (or end effector), not on a joint: what the discrepancy engine's
// platform-force search fits (cosim/discrepancy/platform_force.py) when a load acts on the
// moving platform itself (a cable or umbilical to a fixed anchor, an air flow, a weight).
// World frame, on the platform by the environment, with P = p + R r the platform point r
// (platform frame of the full pose X = (p, rx, ry, rz), R = Rx(rx) Ry(ry) Rz(rz), pkm_platform_pose),
// v = dp/dt the velocity of the pose's reference point and w the platform's angular velocity:
//
//   f = (wrench.fx, wrench.fy, wrench.fz)                                 (constant force at p)
//     + (cable.tension + cable.stiffness (L - cable.rest_length)) u       (a cable or spring from P
//         to the anchor A = cable.anchor_*, L = |A - P|, u = (A - P) / L; stiffness 0: constant tension)
//     - platform_drag.linear v                                            (drag on the platform's velocity)
//   m = (wrench.mx, wrench.my, wrench.mz) + (R r) x f_cable - platform_drag.angular w   (about p)
//
// Mapped to the joints through the robot's own Jacobian: the wrench's generalised force on the
// pose coordinates is Q = S' [f; E' m] (S = dX/dx the motion map, w = E (rx, ry, rz)_dot), and
// the drive spends F = -J^-T Q (qd = J xd) to hold it: F adds to the inverse dynamics (the
// mechanism's part: pkm_mechanism_inverse_dynamics_batch includes it, like gravity) and is
// subtracted from the applied effort in the forward dynamics.  Every parameter defaults to 0
// (no force); the robots with a platform (Robot::has_platform) declare them.
#pragma once

#include <vector>

#include "common/handles.hpp"

namespace pkm {
namespace platform_force {

struct Params {
  double force[3] = {}, moment[3] = {};  // constant wrench [N], [N m] (world, moment about p)
  double anchor[3] = {}, point[3] = {};  // cable anchor [m, world], attachment point [m, platform frame]
  double tension = 0, stiffness = 0, rest_length = 0;  // [N], [N/m], [m]
  double drag_linear = 0, drag_angular = 0;            // [N s/m], [N m s/rad]
  bool any = false;                                    // a term is set (the force is not zero)
};

// Parameter specs of a robot with a platform; none for the others.
std::vector<ParamSpec> specs(const Robot& r);
// Reads the parameters (by name) from a model's table; all zero if the robot has no platform.
Params compile(const Robot& r, const std::vector<ParamSpec>& specs, const std::vector<double>& values);
// The wrench on the platform w[6] = (f, m) [N, N m], world frame, moment about p, at the pose x and
// rate xd (xd may be nullptr: at rest).
void wrench(const pkm_model* m, pkm_data* d, const Params& p, const double* x, const double* xd, double* w);
// out[nd] += sign * F, F = -J^-T Q the efforts the drive spends on the wrench; nothing when none is set.
void add(const pkm_model* m, pkm_data* d, const Params& p, const double* x, const double* xd, double sign,
         double* out);

}  // namespace platform_force
}  // namespace pkm
