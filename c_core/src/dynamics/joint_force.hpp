// A generic per-joint force of the drive layer: the term the discrepancy engine's discovery
// step fits when no effect of its library explains a residual (cosim/discrepancy/discovery.py).
// Per actuated joint i, with z = q - force_qc and s = tanh(qd / v_c), v_c = force_cv if it is
// positive (a friction that fades below that speed), else drive.v_eps (a sharp Coulomb friction):
//
//   F = force_k1 z + force_k2 z^2 + force_k3 z^3                     (springs)
//     + force_v2 qd |qd|                                              (quadratic drag)
//     + force_vpos max(qd, 0) + force_vneg min(qd, 0)                 (viscous by direction)
//     + force_cpos max(s, 0) + force_cneg min(s, 0)                   (Coulomb by direction)
//     + force_sin sin(2 pi q / P) + force_cos cos(2 pi q / P)         (ripple; P = force_period > 0)
//     + force_step tanh((q - force_step_q) / force_step_w)            (a smooth step; force_step_w > 0)
//     + force_inertia qdd                                             (an added inertia)
//     + force_qv z qd                                                 (position x rate)
//     + (force_cq1 z + force_cq2 z^2) s                               (a Coulomb level over the stroke)
//     + force_czone s (1 + tanh((q - force_czone_q) / force_czone_w)) / 2   (a friction zone; width != 0)
//     + force_xk1 (q_k - force_xqc) + force_xv qd_k                   (another joint's motion, k = force_xj)
//     + force_taut w softplus((q - q_k - force_taut_q) / w)           (one-sided spring; w = force_taut_w != 0)
//     + force_cload |tau| s + force_ceff tau s + (force_eq z + force_eg) tau   (the drive's applied effort tau)
//
// The last line depends on the effort the drive applies (a friction that grows with the
// load, a transmission whose efficiency changes with the position): the forward dynamics
// subtract it from the given tau; the inverse dynamics solve tau = b + g tau + mu |tau| per
// joint (b the effort without these terms, g = force_ceff s + force_eq z + force_eg, mu = force_cload s):
// tau = b / (1 - g - mu sign(b)), unique while 1 - g - |mu| > 0 (else the drive self-locks:
// an error naming the joint).  force_xj is the 1-based index of the other joint (0: none).
//
// The one-sided spring is a cable carrier or hose joining two carriages that pulls only once
// taut: softplus(x) = log(1 + e^x), so for w > 0 it is about force_taut (d - force_taut_q) once
// the difference d = q - q_k is a few w past its slack force_taut_q, 0 well below it, and smooth
// between (its slope force_taut / (1 + e^-x) is bounded: the dynamics stay Lipschitz).  A
// negative w makes it taut below force_taut_q.  Joint i's force_taut is its slope dF_i/dq_i once
// taut; the reaction on the other joint k is k's own term with force_xj = i, the same
// force_taut, and force_taut_q and force_taut_w negated (force on k = -force on i).  A one-sided
// spring set without another joint (force_xj = 0) is an error.
//
// F is an effort the drive spends on the joint, like friction: it adds to the inverse
// dynamics and is subtracted from the applied effort in the forward dynamics.  Its
// acceleration term is an inertia the drive carries on the joint (a coupling, a pulley, a
// belt, a mass riding on the carriage): it is not evaluated here but added to the drive's
// joint inertia with the rotor inertia (drive.hpp, Params::inertia), so it is part of the
// mass matrix, the energy and the implicit forward dynamics like the rotor's.  Every
// coefficient defaults to 0 (no force).  Its constant term is the drive's own
// "<j>[i].offset" (drive.hpp): one parameter, so that a constant force has one column and
// one name whether the effect library or the discovery step finds it.
#pragma once

#include <string>
#include <vector>

#include "common/handles.hpp"

namespace pkm {
namespace joint_force {

constexpr int kMaxJoints = 6;
// Per-joint parameter keys, "<prefix>[i].<key>", in the order of Coefficients::field.
constexpr int kNKeys = 34;
// Index of "force_inertia" in kKeys (the acceleration term, not evaluated by force()).
constexpr int kInertia = 16;
extern const char* const kKeys[kNKeys];

struct Coefficients {
  // [key][joint], in the order of kKeys
  double v[kNKeys][kMaxJoints] = {};
  bool any = false;     // a coefficient of a term is set (force() or the effort terms are not zero)
  bool effort = false;  // a coefficient of an effort term is set (force_cload, force_ceff, force_eq, force_eg)
};

// Parameter specs of the robot's joints (units of its joints and efforts).
std::vector<ParamSpec> specs(const Robot& r);
// Reads the coefficients (by name) from a model's parameter table.
Coefficients compile(const Robot& r, const std::vector<ParamSpec>& specs, const std::vector<double>& values);
// F[nd] at joint positions q[nd] and rates qd[nd], the acceleration term left out (the drive's
// joint inertia carries it); v_eps the drive's velocity scale (of the Coulomb levels where force_cv is 0).
void force(const Coefficients& c, int nd, double v_eps, const double* q, const double* qd, double* F);
// The effort terms at q, qd: g[nd] and mu[nd] of F_effort = g tau + mu |tau| (see above).
void effort_gains(const Coefficients& c, int nd, double v_eps, const double* q, const double* qd, double* g,
                  double* mu);
// tau[nd] (holding b, the effort without the effort terms) replaced by the solution of
// tau = b + g tau + mu |tau|; an Error naming joint_names' joint where the drive self-locks.
void solve_effort(const Coefficients& c, int nd, double v_eps, const double* q, const double* qd, double* tau);

}  // namespace joint_force
}  // namespace pkm
