// The drive layer: what lies between a robot's rigid-body mechanics and its
// controller, common to every robot.  Per actuated joint: friction (Coulomb,
// viscous, Stribeck), reflected rotor inertia, effort saturation; per sensor: encoder
// offset, backlash at reversal, transmission compliance; and actuator/sensor delays
// (applied by the integrator, which keeps the history).
//
// Backlash and compliance have two models.  By default (drive.two_body = 0) they are the
// readings' quasi-static model: the drive-side encoder reads q + gap/2 by the side the
// carried effort pushes + compliance x that effort, the mechanism moving as one body.
// With drive.two_body = 1 a joint that has a gap or a compliance is two bodies: the drive
// (its rotor inertia, its friction, the command) and the carriage (the robot's joint),
// joined by a spring of stiffness 1 / compliance with a dead band of the gap and damping
// <j>[i].transmission_damping; the contact side is wherever the transmitted force puts
// it, and the encoder reads the drive body.  The integrator (pkm_sim) carries the drive
// bodies' positions and rates as states of its own.
//
// Rigid-body robots implement only their mechanics; every entry point of the C API
// and the integrator go through the total_* functions here, so a drive effect is
// modelled once for all robots and all its users (core, FMU, Python).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/handles.hpp"
#include "dynamics/joint_force.hpp"
#include "dynamics/platform_force.hpp"

namespace pkm {
namespace drive {

constexpr int kMaxJoints = 6;

struct Params {
  int nd = 0;
  double coulomb[kMaxJoints] = {};      // [N | N m]
  double viscous[kMaxJoints] = {};      // [N s/m | N m s/rad]
  double stribeck[kMaxJoints] = {};     // static friction in excess of Coulomb at rest [N | N m]
  double stribeck_v[kMaxJoints] = {};   // Stribeck velocity [m/s | rad/s]
  double rotor[kMaxJoints] = {};        // reflected actuator inertia [kg | kg m2]
  double effort_max[kMaxJoints] = {};   // saturation |tau| <= effort_max; 0 = none [N | N m]
  double encoder_offset[kMaxJoints] = {};  // q_measured - q [m | rad]
  double backlash[kMaxJoints] = {};     // total gap; measured q leads by +-gap/2 [m | rad]
  double compliance[kMaxJoints] = {};   // transmission deflection per effort [m/N | rad/(N m)]
  double dead_zone[kMaxJoints] = {};    // drive dead band: |u| <= u0 gives 0, else u - u0 sgn(u) [N | N m]
  double coulomb_v[kMaxJoints] = {};    // velocity scale of this joint's Coulomb sign; 0: v_eps [m/s | rad/s]
  double transmission_damping[kMaxJoints] = {};  // two-body transmission damping in contact [N s/m | N m s/rad]
  double offset[kMaxJoints] = {};       // constant effort the drive supplies besides ID and friction [N | N m]
  double v_eps = 1e-4;                  // velocity scale of the friction's smooth sign [m/s | rad/s]
  double f_eps = 0.01;                  // effort scale of the backlash side's smooth sign [N | N m]
  double actuator_delay = 0;            // [s]
  double sensor_delay = 0;              // [s]
  bool two_body = false;                // drive.two_body: gaps and compliances as two bodies (above)
  // The joint inertia the drive adds to the mechanism's [kg | kg m2]: the rotor's and the joint
  // force's force_inertia (an added inertia, joint_force.hpp), one term inertia qdd in the inverse
  // dynamics, the mass matrix, the energy and the forward dynamics.  On a two-body joint the
  // rotor is the drive body's (rotor[i]) and the carriage side keeps the force_inertia.
  double inertia[kMaxJoints] = {};
  bool any_friction = false, any_inertia = false;
  joint_force::Coefficients force;      // the generic per-joint force (joint_force.hpp); force.any: a q or qd term is set
  platform_force::Params platform;      // the force on the platform (platform_force.hpp): the mechanism's inverse
                                        // dynamics add it; the forward dynamics subtract it from the applied effort
  // Joint i is two bodies: drive.two_body and a gap or a compliance on it.
  bool two_body_joint(int i) const { return two_body && (backlash[i] > 0 || compliance[i] > 0); }
};

// Friction of joint i at velocity v:
//   coulomb tanh(v / vc) + stribeck exp(-(v / stribeck_v)^2) tanh(v / v_eps) + viscous v + offset,
// vc = coulomb_v if set, else v_eps.  v_eps is a numerical regularisation (far below any
// speed of interest); a coulomb_v of millimetres per second is physics: friction that fades
// at low speed, as in drives with lubricated contacts or soft-friction simulators.  The
// offset is a constant effort whatever the velocity (a force the drive works against: a
// cable carrier, an unbalanced mass on a vertical axis, a bias of the effort measurement):
// it is carried with the friction so every path that spends friction spends it too (the
// inverse and forward dynamics, the carried effort of the sensor model, a two-body drive).
// Parameter specs appended to every robot's table: "<prefix>[i].coulomb" ..., with the
// prefix and units of the robot's actuated joints.
std::vector<ParamSpec> specs(const Robot& r);
// Reads the drive parameters (by name) from a model's parameter vector.
std::shared_ptr<const Params> compile(const Robot& r, const std::vector<ParamSpec>& specs,
                                      const std::vector<double>& values);

// A per-joint friction parameter's place in Params ("<j>[i].coulomb", ".viscous", ".stribeck",
// ".offset"; -1 for any other name), and the parameters with the value at that place changed
// (what compile gives for the changed value, without reading the table again: the time
// courses of integration/ode.cpp set a trend at every stage).
int friction_slot(const Robot& r, const std::string& name);
void set_friction(Params& p, int slot, double v);

// Smooth sign, tanh(v / eps): friction (and the backlash side, over an effort scale) switch over a scale eps so
// the dynamics stay Lipschitz for the integrator; sign(0) = 0, so a robot at rest
// feels no friction force.
double smooth_sign(double v, double eps);
// Joint friction efforts f[nd] at joint velocities qd[nd] (opposing the motion when
// subtracted from the actuator effort).
void friction(const Params& p, const double* qd, double* f);
// The carriage side of a two-body drive layer: the same parameters with the friction
// and rotor inertia of every two-body joint removed (they act on its drive body; its joint
// force and added inertia stay on the carriage).
std::shared_ptr<const Params> carriage_side(const Params& p);
// Effort a two-body joint's transmission carries at the drive-to-carriage deflection
// delta = theta - q and its rate: k dz(delta) + c delta_dot in contact, 0 inside the gap
// (k = 1 / compliance, dz the dead band of half-width backlash / 2).
double transmitted_effort(const Params& p, int i, double delta, double delta_dot);

}  // namespace drive

// The mechanism's efforts alone: the robot's inverse dynamics and the force on its platform
// (platform_force.hpp), a load like gravity that no drive-layer parameter changes.
void mechanism_inverse_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                                const double* xdd, double* tau);
// Total dynamics = robot mechanics + drive (friction, joint force, rotor and added inertia).  m must be
// validated; d prepared.  Throw Error like the robot functions.
void total_inverse_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                            const double* xdd, double* tau);
// tau += the drive layer's part of total_inverse_dynamics (generic joint force and offset,
// friction, rotor inertia), in the order total_inverse_dynamics adds them: the robot's
// inverse dynamics followed by this is total_inverse_dynamics bit for bit.
void add_drive_inverse_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                                const double* xdd, double* tau);
// The same from the joint motion at that pose: q = ik(x), qd = joint velocity, qdd = joint
// acceleration (q unused without a joint force, qdd without a rotor or added inertia).
void add_drive_efforts(const drive::Params& dp, int n, const double* q, const double* qd, const double* qdd,
                       double* tau);
void total_forward_dynamics(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                            const double* tau, double* xdd);
// The same with the drive parameters dp instead of the model's (pkm_sim: the carriage side).
void total_forward_dynamics(const pkm_model* m, const drive::Params& dp, pkm_data* d, const double* x,
                            const double* xd, const double* tau, double* xdd);
// The same with B = d xdd / d tau (row-major nd x nd) when the robot offers it cheaply
// and the drive adds no joint inertia; false otherwise (outputs untouched).
bool total_forward_dynamics_response(const pkm_model* m, pkm_data* d, const double* x, const double* xd,
                                     const double* tau, double* xdd, double* B);
void total_mass_matrix(const pkm_model* m, pkm_data* d, const double* x, double* M);
void total_energy(const pkm_model* m, pkm_data* d, const double* x, const double* xd, double* kinetic,
                  double* potential);
// Effort that reaches the mechanism for a commanded effort (saturation).
void actuator_effort(const drive::Params& p, const double* tau_cmd, double* tau_applied);
// Joint readings of the sensors at state (x, xd) with the applied effort tau:
// q + encoder offset + backlash/2 * smooth_sign(c) + compliance * c (encoder on the drive side), c the
// effort the transmission carries: tau less the drive's friction and rotor inertia force.
void measure_joints(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* tau,
                    double* q_meas);
// Readings and rates of the sensors: measure_joints's readings and the joint rates, and on a
// two-body joint, when its drive body (theta, theta_d) is given, that body's position plus
// the encoder offset and its rate (the encoder sits on the drive body).
void sensor_readings(const pkm_model* m, pkm_data* d, const double* x, const double* xd, const double* tau,
                     const double* theta, const double* theta_d, double* q_meas, double* qd_meas);

}  // namespace pkm
