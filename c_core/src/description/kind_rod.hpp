// The mass and force terms of a leg that ends in a rod (kind_rail.cpp, kind_arm.cpp): the
// rail's or arm's body moving along tb and the joint S along t per unit q (lg.t, lg.tb), the
// rod between S and the platform point P (kind_rod.cpp has its schema).
#pragma once

#include "description/joint_kind.hpp"

namespace pkm {
namespace described {

// The leg's inertia at P, a rank-two twist-space term (and a point mass at P).
// c: the leg's inertia along q, m_body |tb|^2 + ms |t|^2 + I_arm (a kind may know it cheaper);
// t: S per unit q (lg.t; a rail's is its direction, which its LegGrad leaves out).
[[gnu::always_inline]] inline void add_rod_leg_mass(const LegModel& l, const LegGrad& lg, TwistMass& tm, double c,
                                                    const V3& t) {
  // At P: c g g' + mx (g t' + t g') + ms I (g = dq', the body along tb, S along t per unit
  // q).  The isotropic ms I is a point mass at P; the rest is rank two in twist space: with
  // j = (g, rP x g) and u = (t, rP x t) it is j v' + v j' for v = c/2 j + mx u.
  const double ms = l.m_rod * l.rod_self, mx = l.m_rod * l.rod_cross;
  const V3 r = lg.rP;  // a copy: tm's sums might alias lg for the compiler (no reloads)
  tm.point(ms, r);
  V6 v;  // (0.5 c) j + mx (t, rP x t)
  v.head<3>() = (0.5 * c) * lg.j.head<3>() + mx * t;
  v.tail<3>() = (0.5 * c) * lg.j.tail<3>() + mx * r.cross(t);
  tm.A.noalias() += lg.j * v.transpose();
}

// The load at P for the accelerations aS of S, aB of the body, qdd of the joint.
inline V3 rod_leg_load(const LegModel& l, const LegGrad& lg, const V3& aP, const V3& aS, const V3& aB, double qdd,
                       const V3& g) {
  // D_body = tb dq, D_S = t dq, D_P = I: the loads at S and the body act through dq.
  const double mr = l.m_rod, ms = mr * l.rod_self, mx = mr * l.rod_cross;
  const V3 Fb = l.m_body * (aB - g);
  const V3 Fs = ms * aS + mx * aP - (mr / 2) * g;
  const V3 Fp = mx * aS + ms * aP - (mr / 2) * g;
  const double along = lg.tb.dot(Fb) + lg.t.dot(Fs) + l.I_arm * qdd;
  return Fp + along * lg.dq.transpose();
}

inline void add_rod_leg_mass(const LegModel& l, const LegGrad& lg, TwistMass& tm) {
  const double ms = l.m_rod * l.rod_self;
  add_rod_leg_mass(l, lg, tm, l.m_body * lg.tb.squaredNorm() + ms * lg.t.squaredNorm() + l.I_arm, lg.t);
}

// dq/dP = w' / (w . t) for w = P - S(q), t = dS/dq: its rate, with t_term = w . (t's rate) (0
// on a rail).
inline Eigen::RowVector3d rod_dq_rate(const LegGrad& lg, const V3& t, const V3& vP, double qd, double t_term) {
  // dq/dP = w' / (w . t), w = P - S(q): wd = vP - qd t.
  const V3& w = lg.w;
  const V3 wd = vP - qd * t;
  double c_rate = wd.dot(t);
  c_rate -= t_term;
  const double c = lg.wt;
  return (wd / c - (c_rate / (c * c)) * w).transpose();
}

}  // namespace described
}  // namespace pkm
