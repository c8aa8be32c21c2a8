// What the Adept Quattro offers beyond the common algorithms (pkm.h: the 22 indices of Virzi
// 2010 ch. 3-5, the GIMRE of ch. 4, the joint points), on the robot the core serves from its
// description (robots/quattro.toml, description/described_robot.hpp).  Any described robot of
// four revolute arms with rods on an articulated platform (coordinates x y z rz) is a Quattro
// in this sense, recognised by its legs' kind traits (angular, has_rod).
//
// The index formulas are written once (quattro_indices.cpp) over IndexInputs, which the
// described model fills here.
#pragma once

#include <Eigen/Dense>

#include "common/handles.hpp"
#include "common/robot.hpp"

namespace pkm {
namespace quattro_facts {

constexpr int kArms = 4;

// The arm-side torque limit of the alfa indices [N m]: the s650H's nominal motor torque
// 2.39 N m through its 50:1 gear (Virzi 2010 ch. 5.6).  A description carries no drive
// rating, so the facts module holds the source's figure.
constexpr double kGearRatio = 50, kArmTorqueNominal = kGearRatio * 2.39;

// What the 22 indices read at one pose (quattro_indices.cpp computes them from it).
struct IndexInputs {
  Eigen::Matrix4d JD;             // qd = J xd with row i times arm i's link length [m/s per task rate]
  Eigen::Matrix4d N;              // GIMRE (source ch. 4) [kg, kg m, kg m2]
  Eigen::Matrix4d M;              // task-space mass matrix, rotors included
  Eigen::Vector4d hv_z, hv_xy;    // task velocity force at xd = e_z and (e_x + e_y) / sqrt 2, unit speeds
  Eigen::Vector4d grav;           // task-space gradient of the potential energy
  Eigen::Vector4d tau_z, tau_x;   // arm torques J^-T M a for a = e_z and -(e_x + e_y) / sqrt 2 [N m]
  double tau_max = 0;             // arm-side torque limit [N m]
};

// The 22 indices of IndexInputs into out[PKM_QUATTRO_NINDEX] (quattro_indices.cpp).
void indices(const IndexInputs& in, double* out);

// A model that gives these facts itself: the hand-written Quattro kept as a test oracle
// (c_core/tests/oracles/quattro.hpp, robot "quattro_hand" of libpkm_oracle.so only), so that
// the C functions compare the two models.  No robot of the shipped library implements it.
struct OwnFacts {
  virtual ~OwnFacts() = default;
  virtual void index_inputs(const double* x, IndexInputs& in) const = 0;
  virtual Eigen::Matrix4d gimre(const double* x) const = 0;
  virtual void points(const double* x, double* A, double* B, double* C) const = 0;
  virtual void constants(double* out) const = 0;
};

// The robot is a described Quattro: four arm-and-rod legs on an articulated platform.
bool is_described_quattro(const Robot& r);
// The described Quattro's index inputs, GIMRE (row-major 4x4) and joint points (A, B, C:
// each [4,3], any may be nullptr) at pose x; (m, d) prepared, x checked finite.  Throws
// Error naming the arm at an unreachable pose or a singularity.
void index_inputs(const pkm_model* m, pkm_data* d, const double* x, IndexInputs& in);
Eigen::Matrix4d gimre(const pkm_model* m, pkm_data* d, const double* x);
void points(const pkm_model* m, pkm_data* d, const double* x, double* A, double* B, double* C);
// pkm_quattro_constants of the described Quattro (m prepared).
void constants(const pkm_model* m, pkm_data* d, double* out);

}  // namespace quattro_facts
}  // namespace pkm
