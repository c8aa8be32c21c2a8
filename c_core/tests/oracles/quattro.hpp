// The hand-written Adept Quattro s650H (4-RUU), Virzi 2010, a test oracle for the robot the
// core serves from robots/quattro.toml, registered as "quattro_hand" (test and benchmark
// builds only, libpkm_oracle.so): the constant model and the per-pose kinematics of the robot
// (quattro.cpp), which also gives the Quattro facts itself (quattro_facts::OwnFacts).
//
// Frames and coordinates (docs/quattro.md has the figures):
//  * World frame: the source's model frame (arm 1 in the x-z plane along +x, arm 2 along +y,
//    z up) with the origin `base.h` above the plane of the motor axes, so A_i = a u_i - h e_z.
//    The source's `base` (190 mm = 105 mm Adept origin above the motor plane + 85 mm tool
//    flange below the platform) folds the tool drop into that offset (ch. 1.5).
//  * Pose x = (x, y, z, theta): the tool point E in that frame [m] and the articulation
//    angle theta of the platform (source symbol theta_0) [rad].  Platform centre P = E + offset
//    e_psi + ee e_z with psi = pi/4 + theta, e_psi = (cos psi, sin psi, 0).
//  * q_i: the source's arm angle (A_i -> B_i against the horizontal, positive downwards)
//    at the gearbox output [rad]; tau_i: torque at the gearbox output [N m] (arm side).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <cmath>

#include "common/robot.hpp"
#include "robots/quattro_facts.hpp"

namespace pkm {
namespace quattro {

constexpr int N = 4;

struct Model final : RobotModel, quattro_facts::OwnFacts {
  // geometry [m]
  double a, h, br, rb, b, alp, c, rc, d, off, ee;
  // masses [kg] and inertias [kg m^2]
  double mb, lg, mc, mp, mload, Jload, tool_ratio, Jm, ratio, tau_motor;
  double Ieq;        // equivalent arm inertia at A_i (source ch. 5.3.1)
  double I1_gimre;   // link-1 inertia about A_i used by the GIMRE (source ch. 4.4.2)
  double mA, mB;     // platform point masses at M34 (tool side) and M12 (source ch. 5.2)
  double qmin, qmax;
  Eigen::Vector3d grav;
  std::array<Eigen::Vector3d, N> u;       // horizontal direction of arm i
  std::array<Eigen::Vector3d, N> A;       // motor axis point A_i
  std::array<double, N> sigma;            // +1 arms 1, 2 on M12; -1 arms 3, 4 on M34
  std::array<Eigen::Vector2d, N> w;       // fixed part of C_i - P (times 2/d)
  double tau_arm_max() const { return ratio * tau_motor; }
  // The facts of the C functions pkm_quattro_* from this model (quattro.cpp).
  void index_inputs(const double* x, quattro_facts::IndexInputs& in) const override;
  Eigen::Matrix4d gimre(const double* x) const override;
  void points(const double* x, double* A, double* B, double* C) const override;
  void constants(double* out) const override;
};

// Everything about one pose that kinematics, dynamics and indices need.
struct Pose {
  double th, cps, sps;                 // theta, cos/sin(pi/4 + theta)
  Eigen::Vector3d P, E, ep, epd;       // centre, tool, e_psi, d e_psi / d psi
  std::array<double, N> q, cq, sq;
  std::array<Eigen::Vector3d, N> B, C, g, t;  // elbow, platform joint, g = C - B, t = dB/dq
  std::array<double, N> k;             // dC_i/dtheta = k_i * epd
  Eigen::Matrix4d Jx, J;               // Jx xd = Jq qd, qd = J xd
  Eigen::Vector4d Jq;                  // diagonal of Jq
};

// Pose kinematics: IK with the source's root (branch) and RAD test, joint range check,
// Jx, Jq, J.  Throws Error(PKM_ERR_UNREACHABLE / JOINT_LIMIT / SINGULAR) naming the arm.
void pose_kinematics(const Model& m, const double* x, Pose& p, bool check_limits = true);

// dJ/dt at (pose, xd).
Eigen::Matrix4d jacobian_dot(const Model& m, const Pose& p, const Eigen::Vector4d& xd);

// Simplified dynamic model of source ch. 5 (rigid platform points, forearm mass split).
Eigen::Matrix4d mass_matrix(const Model& m, const Pose& p);
// Task-space velocity force h_v(x, xd) (Coriolis/centrifugal): J^T (M-part) such that
// J^T tau = M xdd + h_v + grad V (friction is the drive layer's).
Eigen::Vector4d velocity_force(const Model& m, const Pose& p, const Eigen::Vector4d& xd,
                               const Eigen::Matrix4d* Jdot = nullptr);
// dV/dq of the arm-side bodies (link 1 and the forearm mass at the elbow) [N m].
Eigen::Vector4d arm_gravity(const Model& m, const Pose& p);
// Task-space gradient of the potential energy of everything (arm side mapped by J^T).
Eigen::Vector4d gravity_force(const Model& m, const Pose& p);
double potential_energy(const Model& m, const Pose& p);
// y = J^-T f; throws PKM_ERR_SINGULAR at a direct (parallel) singularity.
Eigen::Vector4d solve_JT(const Pose& p, const Eigen::Vector4d& f, const char* what);
// Generalized inertia matrix reduced to the end effector (source ch. 4), no motor rotors.
Eigen::Matrix4d gimre(const Model& m, const Pose& p);

}  // namespace quattro
}  // namespace pkm
