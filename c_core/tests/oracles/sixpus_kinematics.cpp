// 6-PUS kinematics: closed-form inverse kinematics, Jacobians (Zavala-Yoe et al. 2015 eq. 5-6) and
// their time derivative, singularity measures, Newton forward kinematics and the joint
// acceleration.  Equations in docs/6pus.md.
#include <sstream>

#include "kinematics/generic_kinematics.hpp"
#include "oracles/sixpus.hpp"

namespace pkm {
namespace sixpus {

namespace {
std::string g6(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}
}  // namespace

namespace {
// One leg at a time, with the message of the first leg that fails (the slow path).
void legs_at_checked(const Model& m, const double* x, const Frame& f, Leg* legs, Strokes strokes) {
  for (int i = 0; i < NLEG; ++i) {
    Leg& l = legs[i];
    V3 d;
    leg_vectors(m, i, x, f.R, l.rP, d);
    // |d - q s|^2 = L^2:  ss q^2 - 2 b q + |d|^2 - L^2 = 0,  and s.w = b - q ss = branch sqrt(disc).
    const double b = m.s[i].dot(d);
    const double disc = b * b - m.ss[i] * (d.squaredNorm() - m.L[i] * m.L[i]);
    const double tol = m.disc_tol[i];
    if (!(disc >= tol)) {
      if (disc < -tol) {
        const double perp = std::sqrt(std::max(0.0, d.squaredNorm() - b * b / m.ss[i]));
        throw Error(PKM_ERR_UNREACHABLE, "leg " + std::to_string(i + 1) + " cannot reach the " + pose_text(x) +
                                             ": its platform point is " + g6(perp) +
                                             " m from the rail axis, more than the leg length " + g6(m.L[i]) + " m");
      }
      if (disc >= -tol)
        throw Error(PKM_ERR_SINGULAR, "leg " + std::to_string(i + 1) + " is perpendicular to its rail at the " +
                                          pose_text(x) + " (s.w = " + g6(std::sqrt(std::max(0.0, disc))) +
                                          " m): inverse-kinematic (type-1) singularity, the two roots meet");
      throw Error(PKM_ERR_ARGUMENT, "leg " + std::to_string(i + 1) + ": non-finite geometry at the " + pose_text(x));
    }
    l.c = m.branch[i] * std::sqrt(disc);
    l.q = (b - l.c) * m.inv_ss[i];
    l.w = d - l.q * m.s[i];
    if (strokes == Strokes::check && (l.q < m.qmin[i] || l.q > m.qmax[i]))
      throw Error(PKM_ERR_JOINT_LIMIT, "leg " + std::to_string(i + 1) + " stroke q = " + g6(l.q) +
                                           " m is outside its range [" + g6(m.qmin[i]) + ", " + g6(m.qmax[i]) +
                                           "] m at the " + pose_text(x));
  }
}
}  // namespace

// The forward dynamics' hot path: the legs as plain arrays, branch-free, so the compiler
// vectorises them (the square roots four at a time); the same operations in the same
// order as legs_at_checked, which any failure is handed to for its message.  The same
// per-leg arithmetic as SixPus::ik, written twice on purpose: a shared helper that also
// keeps R p_i costs the batched IK 20 % (66 -> 80 ns per pose, core_bench).
void legs_at(const Model& m, const double* x, const Frame& f, Leg* legs, Strokes strokes) {
  const auto& a = m.soa;
  const M3& R = f.R;
  double rx[NLEG], ry[NLEG], rz[NLEG], dx[NLEG], dy[NLEG], dz[NLEG], b[NLEG], disc[NLEG], c[NLEG];
  for (int i = 0; i < NLEG; ++i) {
    rx[i] = R(0, 0) * a.px[i] + R(0, 1) * a.py[i] + R(0, 2) * a.pz[i];
    ry[i] = R(1, 0) * a.px[i] + R(1, 1) * a.py[i] + R(1, 2) * a.pz[i];
    rz[i] = R(2, 0) * a.px[i] + R(2, 1) * a.py[i] + R(2, 2) * a.pz[i];
    dx[i] = (x[0] + rx[i]) - a.S0x[i];
    dy[i] = (x[1] + ry[i]) - a.S0y[i];
    dz[i] = (x[2] + rz[i]) - a.S0z[i];
    b[i] = (a.sx[i] * dx[i] + a.sy[i] * dy[i]) + a.sz[i] * dz[i];
    disc[i] = b[i] * b[i] - a.ss[i] * (((dx[i] * dx[i] + dy[i] * dy[i]) + dz[i] * dz[i]) - a.L2[i]);
  }
  int bad = 0;
  for (int i = 0; i < NLEG; ++i) {
    bad |= !(disc[i] >= m.disc_tol[i]);
    c[i] = m.branch[i] * std::sqrt(std::max(disc[i], 0.0));
  }
  if (bad) return legs_at_checked(m, x, f, legs, strokes);
  for (int i = 0; i < NLEG; ++i) {
    Leg& l = legs[i];
    l.rP = V3(rx[i], ry[i], rz[i]);
    l.c = c[i];
    l.q = (b[i] - c[i]) * m.inv_ss[i];
    l.w = V3(dx[i] - l.q * a.sx[i], dy[i] - l.q * a.sy[i], dz[i] - l.q * a.sz[i]);
    bad |= !(l.q >= m.qmin[i] && l.q <= m.qmax[i]);
  }
  if (strokes == Strokes::check && bad) legs_at_checked(m, x, f, legs, strokes);
}

// The batched hot path (target: <= 100 ns per pose): branch-free loops over the legs
// on plain arrays, which the compiler vectorises; any failure is handed to legs_at for
// its message.
void SixPus::ik(const RobotModel& rm, RobotData&, const double* x, double* q) const {
  const Model& m = model_of(rm);
  const auto& a = m.soa;
  double sx, cx, sy, cy, sz, cz;
  sin_cos_small(x[3], sx, cx);
  sin_cos_small(x[4], sy, cy);
  sin_cos_small(x[5], sz, cz);
  const double r00 = cy * cz, r01 = -cy * sz, r02 = sy;
  const double r10 = sx * sy * cz + cx * sz, r11 = -sx * sy * sz + cx * cz, r12 = -sx * cy;
  const double r20 = -cx * sy * cz + sx * sz, r21 = cx * sy * sz + sx * cz, r22 = cx * cy;
  double b[NLEG], disc[NLEG];
  for (int i = 0; i < NLEG; ++i) {
    const double dx = (x[0] + (r00 * a.px[i] + r01 * a.py[i] + r02 * a.pz[i])) - a.S0x[i];
    const double dy = (x[1] + (r10 * a.px[i] + r11 * a.py[i] + r12 * a.pz[i])) - a.S0y[i];
    const double dz = (x[2] + (r20 * a.px[i] + r21 * a.py[i] + r22 * a.pz[i])) - a.S0z[i];
    b[i] = a.sx[i] * dx + a.sy[i] * dy + a.sz[i] * dz;
    disc[i] = b[i] * b[i] - a.ss[i] * ((dx * dx + dy * dy + dz * dz) - a.L2[i]);
  }
  int bad = 0;
  for (int i = 0; i < NLEG; ++i) {
    bad |= !(disc[i] >= m.disc_tol[i]);
    q[i] = (b[i] - m.branch[i] * std::sqrt(std::max(disc[i], 0.0))) * m.inv_ss[i];
    bad |= !(q[i] >= m.qmin[i] && q[i] <= m.qmax[i]);
  }
  if (bad) {
    Frame f;
    frame_of(x, f);
    Leg legs[NLEG];
    legs_at(m, x, f, legs, Strokes::check);  // throws, naming the leg
    for (int i = 0; i < NLEG; ++i) q[i] = legs[i].q;  // a rounding-level borderline case
  }
}

void jacobian_of(const Model&, const Frame& f, const Leg* legs, M6r& J) {
  for (int i = 0; i < NLEG; ++i) {
    const Leg& l = legs[i];
    J.block<1, 3>(i, 0) = l.w.transpose() / l.c;
    J.block<1, 3>(i, 3) = (f.E.transpose() * l.rP.cross(l.w)).transpose() / l.c;
  }
}

// Jacobians are geometry: they are given outside the stroke range too (the stroke
// limits are enforced by ik, which callers use to detect them).
void SixPus::jacobians(const RobotModel& rm, RobotData&, const double* x, double* Jx, double* Jq,
                       double* J) const {
  const Model& m = model_of(rm);
  Frame f;
  frame_of(x, f);
  Leg legs[NLEG];
  legs_at(m, x, f, legs, Strokes::ignore);
  for (int i = 0; i < NLEG; ++i) {
    const Leg& l = legs[i];
    const V3 rot = f.E.transpose() * l.rP.cross(l.w);
    for (int k = 0; k < 3; ++k) {
      if (Jx) Jx[6 * i + k] = l.w[k], Jx[6 * i + 3 + k] = rot[k];
      if (J) J[6 * i + k] = l.w[k] / l.c, J[6 * i + 3 + k] = rot[k] / l.c;
    }
    if (Jq)
      for (int j = 0; j < NLEG; ++j) Jq[6 * i + j] = (i == j) ? l.c : 0.0;
  }
}

void SixPus::jacobian_dot(const RobotModel& rm, RobotData&, const double* x, const double* xd,
                          double* Jdot) const {
  const Model& m = model_of(rm);
  Frame f;
  frame_of(x, f);
  Leg legs[NLEG];
  legs_at(m, x, f, legs, Strokes::ignore);
  const V3 pd(xd[0], xd[1], xd[2]);
  const V3 ad(xd[3], xd[4], xd[5]);
  const V3 om = f.E * ad;
  const M3 Ed = Edot_of(f, xd + 3);
  for (int i = 0; i < NLEG; ++i) {
    const Leg& l = legs[i];
    LegRates r;
    leg_rates(m, i, l, pd, om, r);
    // J_i = n / c with n = (w, E^T (rP x w)); d/dt (n / c) = (n_dot c - n c_dot) / c^2.
    const V3 rPd = om.cross(l.rP);
    const V3 m_ = l.rP.cross(l.w);
    const V3 md = rPd.cross(l.w) + l.rP.cross(r.wd);
    const V3 nrot = f.E.transpose() * m_;
    const V3 nrotd = f.E.transpose() * md + Ed.transpose() * m_;
    const double cd = m.s[i].dot(r.wd);
    const double c2 = l.c * l.c;
    for (int k = 0; k < 3; ++k) {
      Jdot[6 * i + k] = (r.wd[k] * l.c - l.w[k] * cd) / c2;
      Jdot[6 * i + 3 + k] = (nrotd[k] * l.c - nrot[k] * cd) / c2;
    }
  }
}

void singularity_measures(const Model& m, const Frame& f, const Leg* legs, double* measures) {
  double t1 = 1.0;
  for (int i = 0; i < NLEG; ++i)
    t1 = std::min(t1, std::abs(legs[i].c) / (m.L[i] * std::sqrt(m.ss[i])));
  M6r J;
  jacobian_of(m, f, legs, J);
  // Rotation columns are in m/rad: scaled by the platform radius they become
  // dimensionless like the translation columns.
  J.rightCols<3>() /= m.r_char;
  Eigen::JacobiSVD<M6r> svd(J);
  const auto& sv = svd.singularValues();
  measures[0] = t1;
  measures[1] = (sv[0] > 0) ? sv[5] / sv[0] : 0.0;
}

void SixPus::singularity(const RobotModel& rm, RobotData&, const double* x, double* measures) const {
  const Model& m = model_of(rm);
  Frame f;
  frame_of(x, f);
  Leg legs[NLEG];
  legs_at(m, x, f, legs, Strokes::ignore);
  singularity_measures(m, f, legs, measures);
}

// measures[1] = s_min / s_max of the scaled J (an SVD).  With A = scaled J and its LU,
// ||A||_F ||A^-1||_F >= s_max / s_min, so 1 / (||A||_F ||A^-1||_F) is a lower bound of the
// measure (at most a factor 6 below it) at the cost of one 6x6 LU; the same LU gives
// det A = det J / r_char^3, of the sign of det J.
void SixPus::direct_singularity_guard(const RobotModel& rm, RobotData&, const double* x, double* measure_bound,
                                      double* det_j) const {
  const Model& m = model_of(rm);
  Frame f;
  frame_of(x, f);
  Leg legs[NLEG];
  legs_at(m, x, f, legs, Strokes::ignore);
  M6r A;
  jacobian_of(m, f, legs, A);
  A.rightCols<3>() /= m.r_char;
  lu_singularity_guard(A, measure_bound, det_j);
}

void SixPus::fk(const RobotModel& rm, RobotData&, const double* q, const double* x_guess,
                const pkm_fk_options& opt, double* x_out, pkm_fk_info& info) const {
  const Model& m = model_of(rm);
  for (int i = 0; i < NLEG; ++i)
    if (q[i] < m.qmin[i] || q[i] > m.qmax[i])
      throw Error(PKM_ERR_JOINT_LIMIT, "forward kinematics: leg " + std::to_string(i + 1) + " stroke q = " +
                                           g6(q[i]) + " m is outside its range [" + g6(m.qmin[i]) + ", " +
                                           g6(m.qmax[i]) + "] m");
  V6 x = Eigen::Map<const V6>(x_guess), xt, r, rt, dx;
  Frame f;
  Leg legs[NLEG];
  frame_of(x.data(), f);
  try {
    legs_at(m, x.data(), f, legs, Strokes::ignore);
  } catch (const Error& e) {
    throw Error(e.status, std::string("forward kinematics: the guess is not a valid pose: ") + e.what());
  }
  for (int i = 0; i < NLEG; ++i) r[i] = legs[i].q - q[i];
  double rn = r.cwiseAbs().maxCoeff();
  int it = 0;
  M6r J;
  for (; it < opt.max_iter && rn > opt.tol; ++it) {
    jacobian_of(m, f, legs, J);
    Eigen::PartialPivLU<M6r> lu(J);
    dx = -lu.solve(r);
    if (!dx.allFinite() || dx.cwiseAbs().maxCoeff() > 1.0) {
      // Near a direct singularity: a damped least-squares step stays bounded.
      M6r A = J.transpose() * J;
      A.diagonal().array() += std::max(opt.damping, 1e-12);
      dx = -A.ldlt().solve(J.transpose() * r);
      if (!dx.allFinite())
        throw Error(PKM_ERR_SINGULAR, "forward kinematics: singular Jacobian at iteration " + std::to_string(it) +
                                          " near the " + pose_text(x.data()));
    }
    // Halve the step while it leaves the workspace or does not reduce the residual; the
    // accepted trial's frame and legs serve the next Jacobian.
    Frame ft;
    Leg lt[NLEG];
    double rtn = 0;
    const bool accepted = backtracking_step(rn, opt.tol, [&](double step) {
      xt = x + step * dx;
      frame_of(xt.data(), ft);
      legs_at(m, xt.data(), ft, lt, Strokes::ignore);
      for (int i = 0; i < NLEG; ++i) rt[i] = lt[i].q - q[i];
      return rtn = rt.cwiseAbs().maxCoeff();
    });
    if (!accepted) break;
    x = xt, r = rt, rn = rtn, f = ft;
    for (int i = 0; i < NLEG; ++i) legs[i] = lt[i];
  }
  info.iterations = it;
  info.residual = rn;
  if (!(rn <= opt.tol)) {
    std::ostringstream os;
    os.precision(3);
    os << "forward kinematics did not converge: residual " << rn << " m after " << it << " iterations (tolerance "
       << opt.tol << " m) from the guess " << pose_text(x_guess)
       << "; the strokes may be unreachable from this guess";
    throw Error(PKM_ERR_NO_CONVERGENCE, os.str());
  }
  for (int k = 0; k < 6; ++k) x_out[k] = x[k];
}

void SixPus::joint_acceleration(const RobotModel& rm, RobotData&, const double* x, const double* xd,
                                const double* xdd, double* qdd) const {
  const Model& m = model_of(rm);
  Frame f;
  frame_of(x, f);
  Leg legs[NLEG];
  legs_at(m, x, f, legs, Strokes::ignore);
  const V3 pd(xd[0], xd[1], xd[2]);
  const V3 om = f.E * V3(xd[3], xd[4], xd[5]);
  const V3 al = f.E * V3(xdd[3], xdd[4], xdd[5]) + Edot_of(f, xd + 3) * V3(xd[3], xd[4], xd[5]);
  const V3 pdd(xdd[0], xdd[1], xdd[2]);
  for (int i = 0; i < NLEG; ++i) {
    const Leg& l = legs[i];
    LegRates r;
    leg_rates(m, i, l, pd, om, r);
    // Second derivative of |w|^2 = L^2: w.a_P - qdd (s.w) + |w_dot|^2 = 0.
    const V3 aP = pdd + al.cross(l.rP) + om.cross(om.cross(l.rP));
    qdd[i] = (l.w.dot(aP) + r.wd.squaredNorm()) / l.c;
  }
}

}  // namespace sixpus
}  // namespace pkm
