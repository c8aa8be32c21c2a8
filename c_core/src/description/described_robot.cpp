// The algorithms of every description-compiled robot (described_robot.hpp has the model):
// the state of a pose, the dynamics by virtual power, and the Robot's functions, written once
// over the leg kinds' terms (joint_kind.hpp, kind_*.cpp) and the platform
// (described_platform.hpp).
#include "description/described_robot.hpp"

#include <algorithm>

#include "description/described_platform.hpp"
#include "description/joint_kind.hpp"
#include "description/small_solve.hpp"
#include "kinematics/generic_kinematics.hpp"

namespace pkm {
namespace described {

namespace {

const Model& model_of(const RobotModel& rm) { return static_cast<const Model&>(rm); }

// Everything of a pose the dynamics need.
struct State {
  Platform pf;
  M3 Iw;  // the platform's inertia in the world frame (if it rotates)
  LegGrad lg[kMaxLegs];
  M6 J;              // dq/dx (zero beyond n), if rows
  bool rows = false;
};
// J's rows from the legs' twist rows.
void add_rows(const Model& m, State& st) {
  st.J.setZero();
  for (int i = 0; i < m.n; ++i) st.J.row(i) = t_transpose(m, st.pf, st.lg[i].j).transpose();
  st.rows = true;
}
// R diag(I) R' (I principal inertias), entry by entry over its upper triangle.
M3 world_inertia(const M3& R, const V3& I) {
  const V3 a = R.col(0) * I[0], b = R.col(1) * I[1], c = R.col(2) * I[2];  // R diag(I)
  auto at = [&](int r, int k) { return a[r] * R(k, 0) + b[r] * R(k, 1) + c[r] * R(k, 2); };
  M3 Iw;
  Iw(0, 0) = at(0, 0), Iw(1, 1) = at(1, 1), Iw(2, 2) = at(2, 2);
  Iw(0, 1) = Iw(1, 0) = at(0, 1);
  Iw(0, 2) = Iw(2, 0) = at(0, 2);
  Iw(1, 2) = Iw(2, 1) = at(1, 2);
  return Iw;
}
// rows = false: J is left unset (the forward dynamics map J^T tau in twist space instead).
void state_of(const Model& m, const double* x, State& st, bool rows) {
  platform_of(m, x, st.pf);
  if (m.rotates) st.Iw = world_inertia(st.pf.R, m.I_platform);
  st.rows = false;
  m.kind->grad_all(m, st.pf, x, st.lg);
  if (rows) add_rows(m, st);
}

// A pkm_data's part of a described robot: the state of the last pose it saw.  The calls at
// one pose (the drive layer asks for J, the joint velocities, the dynamics and M in turn)
// compute it once; a new pose (compared value by value) or a failed call starts afresh.
// The inverse dynamics keep the joint accelerations of their loads at (xd, xdd), which the
// drive layer asks for next (a joint's rotor inertia).
struct Data final : RobotData {
  bool valid = false;
  double x[6];
  State st;
  bool accel = false;  // qdd holds the joint accelerations at (x, xd, xdd)
  double xd[6], xdd[6], qdd[6];
};
Data& data_of(RobotData& rd) { return static_cast<Data&>(rd); }  // every pkm_data of a described robot holds one (make_data)
// out = in, n values (a fixed loop for n = 6: no library call on the hot path).
void copy_n(const double* in, int n, double* out) {
  if (n == 6)
    for (int k = 0; k < 6; ++k) out[k] = in[k];
  else
    std::copy(in, in + n, out);
}
bool equal_n(const double* a, int n, const double* b) {
  bool same = true;
  for (int k = 0; k < n; ++k) same &= a[k] == b[k];
  return same;
}
const State& state_at(const Model& m, RobotData& rd, const double* x, bool rows) {
  Data& d = data_of(rd);
  if (!(d.valid && equal_n(x, m.n, d.x))) {
    d.valid = d.accel = false;
    state_of(m, x, d.st, rows);
    copy_n(x, m.n, d.x);
    d.valid = true;
  } else if (rows && !d.st.rows) {
    add_rows(m, d.st);
  }
  return d.st;
}


// The twist-space inertia Mt of every body (KE = 1/2 nu' Mt nu, nu = (p_dot, omega)):
// point masses on the platform (its end bars, the payload) summed into one mass, first
// moment and inertia (mp at r adds (mp I, -mp [r]x; mp [r]x, mp (|r|^2 I - r r'))), and each
// leg's inertia at its platform point from its kind (LegMotion::add_mass_all).
void twist_mass(const Model& m, const State& st, M6& Mt) {
  const Platform& pf = st.pf;
  TwistMass tm(Mt);
  tm.mr = m.articulated ? 0.0 : m.m_platform;
  if (m.articulated)  // half the mass at each end bar
    for (const V3& e : m.end_bars) tm.point(0.5 * m.m_platform, pf.R * e);
  if (m.m_payload != 0) tm.point(m.m_payload, pf.R * m.c_payload);
  m.kind->add_mass_all(m, st.lg, tm);
  Mt += tm.A + tm.A.transpose();
  Mt.topLeftCorner<3, 3>().diagonal().array() += tm.mr;
  const M3 H = skew(tm.h);
  Mt.topRightCorner<3, 3>() -= H;
  Mt.bottomLeftCorner<3, 3>() += H;
  Mt.bottomRightCorner<3, 3>() -= tm.G;
  Mt.bottomRightCorner<3, 3>().diagonal().array() += tm.G.trace();
  if (m.rotates) Mt.bottomRightCorner<3, 3>() += st.Iw;
}

// Task-space mass matrix M = T' Mt T.
M6 mass_of(const Model& m, const State& st) {
  M6 Mt;
  twist_mass(m, st, Mt);
  return t_congruence(m, st.pf, Mt);
}

// The inertia-and-gravity loads at (x, xd, xdd) as one wrench W = (force, moment) about
// the platform origin: the generalised force is Q = T' W (J^T tau = Q).
// qdd: the joint accelerations of the legs on the way.
V6 load_wrench(const Model& m, const State& st, const double* xd, const double* xdd, double* qdd) {
  const Platform& pf = st.pf;
  PlatformMotion pm;
  platform_motion(m, pf, xd, xdd, pm);
  V6 W;
  W.setZero();
  auto point_load = [&](double mass, const V3& rc) {
    const V3 ac = pm.a + pm.al.cross(rc) + pm.om.cross(pm.om.cross(rc));
    add_load(W, mass * (ac - m.g), rc);
  };
  if (!m.articulated) W.head<3>() = m.m_platform * (pm.a - m.g);
  else
    for (const V3& e : m.end_bars) point_load(0.5 * m.m_platform, pf.R * e);
  if (m.rotates) {
    const M3& Iw = st.Iw;
    W.tail<3>() += Iw * pm.al + pm.om.cross(Iw * pm.om);
  }
  if (m.m_payload != 0) point_load(m.m_payload, pf.R * m.c_payload);
  m.kind->add_loads_all(m, st.lg, pm, W, qdd);
  return W;
}

// tau from J^T tau = Q: column i of J^T is the twist-space row of leg i, mapped by T' unless
// the coordinates are the whole pose (T square: then Jc tau = W, the wrench itself).
template <int N>
void solve_jt(const Model& m, const State& st, const V6& W, const double* x, double* tau) {
  double a[N][N], b[N], t[N];
  const V6 Q = m.full_pose ? W : t_transpose(m, st.pf, W);
  for (int i = 0; i < N; ++i) {
    const V6 col = m.full_pose ? st.lg[i].j : t_transpose(m, st.pf, st.lg[i].j);
    for (int r = 0; r < N; ++r) a[r][i] = col[r];
    b[i] = Q[i];
  }
  if (!small_lu_solve<N>(a, b, t))
    throw Error(PKM_ERR_SINGULAR, "direct (parallel) singularity at " + pose_text(m, x) + ": J is singular");
  for (int i = 0; i < N; ++i) tau[i] = t[i];
}

// The forward dynamics' solve T' Mt T xdd = T' (Jc tau - W(0)) =: T' W and its response
// B = M^-1 J^T (column j = M^-1 T' j_j, j_j leg j's twist row); false when the mass matrix is not positive definite.
// The coordinates the whole pose: T = blockdiag(I, E) is square, Mt (p_dd, E a_dd) = W.
bool full_pose_response(const Model& m, const State& st, const M6& Mt, const V6& W, const double* x, double* xdd,
                        double* B) {
  SmallCholesky<6> llt;
  if (!llt.factor(Mt)) return false;
  auto to_pose = [&](const V6& y, double* out, int stride) {
    double ad[3];
    angle_rates(m, st.pf, x, y.tail<3>(), ad);
    for (int k = 0; k < 3; ++k) out[stride * k] = y[k], out[stride * (3 + k)] = ad[k];
  };
  to_pose(llt.solve(W), xdd, 1);
  if (B)
    for (int j = 0; j < 6; ++j) to_pose(llt.solve(st.lg[j].j), B + j, 6);
  return true;
}
template <int N>
bool pose_rate_response(const Model& m, const State& st, const M6& Mt, const V6& W, double* xdd, double* B) {
  SmallCholesky<N> llt;
  if (!llt.factor(t_congruence(m, st.pf, Mt))) return false;
  const V6 a = llt.solve(t_transpose(m, st.pf, W));
  for (int i = 0; i < N; ++i) xdd[i] = a[i];
  if (B)
    for (int j = 0; j < N; ++j) {
      const V6 b = llt.solve(t_transpose(m, st.pf, st.lg[j].j));
      for (int i = 0; i < N; ++i) B[N * i + j] = b[i];
    }
  return true;
}

}  // namespace

std::unique_ptr<RobotData> DescribedRobot::make_data(const RobotModel&) const { return std::make_unique<Data>(); }

void DescribedRobot::ik(const RobotModel& rm, RobotData&, const double* x, double* q) const {
  const Model& m = model_of(rm);
  Platform pf;
  platform_of(m, x, pf, false);
  m.kind->ik_all(m, pf, x, q);
}

void DescribedRobot::jacobians(const RobotModel& rm, RobotData& rd, const double* x, double* Jx, double* Jq,
                               double* J) const {
  const Model& m = model_of(rm);
  const State& st = state_at(m, rd, x, true);
  const int n = m.n;
  if (J)
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) J[n * i + j] = st.J(i, j);
  if (!Jx && !Jq) return;
  for (int i = 0; i < n; ++i) {
    // Constraint f_i = (|P - S(q)|^2 - L^2) / 2 (a strut: (|P - B|^2 - q^2) / 2):
    // Jx = df/dx at fixed q, Jq = -df/dq, so that Jx xd = Jq qd.
    const LegModel& l = m.legs[i];
    const LegGrad& lg = st.lg[i];
    const V3& w = lg.w;
    const double jq = l.kind->closure_dq(l, lg);
    const V6 jx = t_transpose(m, st.pf, twist_row(w, lg.rP));
    for (int j = 0; j < n; ++j) {
      if (Jx) Jx[n * i + j] = jx[j];
      if (Jq) Jq[n * i + j] = (i == j) ? jq : 0.0;
    }
  }
}

void DescribedRobot::jacobian_dot(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                  double* Jdot) const {
  // J_i = dq_i/dP JP_i, so Jdot_i = (d/dt dq_i/dP) JP_i + dq_i/dP JPdot_i; the first in closed
  // form per joint kind along P(t) = P + t vP, the second from JP = Jt - [rP]x Jw.  (The tests
  // hold J xdd + Jdot xd against joint_acceleration's closed form of the closure's second
  // derivative and second differences of the inverse kinematics.)
  const Model& m = model_of(rm);
  const State& st = state_at(m, rd, x, false);
  const Platform& pf = st.pf;
  PlatformMotion pm;
  platform_motion(m, pf, xd, nullptr, pm);
  M36 Jt, Jw;
  coordinate_maps(m, pf, Jt, Jw);
  M36 Jwd = M36::Zero();  // d/dt of Jw: the columns of E_dot
  M36 Jtd = M36::Zero();  // d/dt of Jt: dependent coordinates only
  if (m.ndep) {
    // Jt = S_t, Jw = E S_r: Jtd = Sdot_t, Jwd = Ed S_r + E Sdot_r.
    V6 v = V6::Zero();
    for (int j = 0; j < m.n; ++j) v[j] = xd[j];
    const V6 r6 = pf.S * v;
    const M3 Ed = angle_map_rate(pf, r6[3], r6[4]);
    const M6 Sd = motion_map_rate(m, pf, pm.om, Ed);
    Jtd = Sd.topRows<3>();
    Jwd = Ed * pf.S.bottomRows<3>() + pf.E * Sd.bottomRows<3>();
  } else if (m.rotates) {
    double r6[6] = {0, 0, 0, 0, 0, 0};
    for (int j = 0; j < m.n; ++j) r6[m.coord[j]] = xd[j];
    const M3 Ed = angle_map_rate(pf, r6[3], r6[4]);
    for (int j = 0; j < m.n; ++j)
      if (m.coord[j] >= 3) Jwd.col(j) = Ed.col(m.coord[j] - 3);
  }
  for (int i = 0; i < m.n; ++i) {
    const LegModel& l = m.legs[i];
    const LegGrad& lg = st.lg[i];
    const V3& rP = lg.rP;
    const V3 vP = pm.v + pm.om.cross(rP);
    const Eigen::RowVector3d dqd = l.kind->dq_rate(l, lg, vP, lg.dq.dot(vP));
    const M36 JP = Jt - skew(rP) * Jw;  // the Jacobian of the point at rP on the platform
    const M36 JPd = Jtd - skew(pm.om.cross(rP)) * Jw - skew(rP) * Jwd;
    const Eigen::Matrix<double, 1, 6> row = dqd * JP + lg.dq * JPd;
    for (int j = 0; j < m.n; ++j) Jdot[m.n * i + j] = row[j];
  }
}

void DescribedRobot::singularity(const RobotModel& rm, RobotData& rd, const double* x, double* measures) const {
  const Model& m = model_of(rm);
  const int n = m.n;
  Mat Jx(n, n), Jq(n, n), J(n, n);
  jacobians(rm, rd, x, Jx.data(), Jq.data(), J.data());
  // Inverse-kinematic: the cosine between the rod and its joint's motion, worst leg.
  double t1 = 1.0;
  for (int i = 0; i < n; ++i) {
    const LegModel& l = m.legs[i];
    t1 = std::min(t1, l.kind->ik_measure(l, Jq(i, i)));
  }
  // Direct: 1 / cond of J with the rotation columns scaled by the platform radius.
  for (int j = 0; j < n; ++j)
    if (m.coord[j] >= 3) J.col(j) /= m.r_char;
  Eigen::JacobiSVD<Mat> svd(J);
  const auto& sv = svd.singularValues();
  measures[0] = t1;
  measures[1] = (sv[0] > 0) ? sv[n - 1] / sv[0] : 0.0;
}

void DescribedRobot::platform_pose(const RobotModel& rm, RobotData&, const double* x, double* X, double* S) const {
  const Model& m = model_of(rm);
  Platform pf;
  platform_of(m, x, pf, S != nullptr);
  for (int k = 0; k < 6; ++k) X[k] = pf.x6[k];
  if (!S) return;
  for (int r = 0; r < 6; ++r)
    for (int j = 0; j < m.n; ++j) S[m.n * r + j] = m.ndep ? pf.S(r, j) : (m.coord[j] == r ? 1.0 : 0.0);
}

void DescribedRobot::chain_points(const RobotModel& rm, RobotData&, const double* x, double* pts) const {
  const Model& m = model_of(rm);
  Platform pf;
  platform_of(m, x, pf, false);
  for (int i = 0; i < m.n; ++i) {
    const LegModel& l = m.legs[i];
    V3 rP;
    const V3 P = attachment(m, pf, i, rP);
    P3<double> p[4];
    double q;
    l.kind->geometry(l, P3<double>{P.x(), P.y(), P.z()}, q, p, LegWhere{m, i, x});
    const P3<double> moving = p[l.kind->moving_point()];
    const P3<double> rows[3] = {{l.base.x(), l.base.y(), l.base.z()}, moving, p[1]};
    for (int r = 0; r < 3; ++r) {
      pts[9 * i + 3 * r + 0] = rows[r].x;
      pts[9 * i + 3 * r + 1] = rows[r].y;
      pts[9 * i + 3 * r + 2] = rows[r].z;
    }
  }
}

void DescribedRobot::direct_singularity_guard(const RobotModel& rm, RobotData& rd, const double* x,
                                              double* measure_bound, double* det_j) const {
  // The J of state_of (no points), scaled as in singularity(), one LU.
  const Model& m = model_of(rm);
  const State& st = state_at(m, rd, x, true);
  M6 A = st.J;
  for (int j = 0; j < m.n; ++j)
    if (m.coord[j] >= 3) A.col(j) /= m.r_char;
  if (m.n == 6) lu_singularity_guard(A, measure_bound, det_j);
  else lu_singularity_guard(Mat(A.topLeftCorner(m.n, m.n)), measure_bound, det_j);
}

void DescribedRobot::joint_acceleration(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                        const double* xdd, double* qdd) const {
  // The leg closures differentiated twice, in closed form per kind at the kept state (the
  // tests hold them against J xdd + Jdot xd and second differences of the inverse kinematics).
  const Model& m = model_of(rm);
  const State& st = state_at(m, rd, x, false);
  const Data& d = data_of(rd);
  if (d.accel && equal_n(xd, m.n, d.xd) && equal_n(xdd, m.n, d.xdd)) {
    copy_n(d.qdd, m.n, qdd);  // the inverse dynamics' at this motion
    return;
  }
  PlatformMotion pm;
  platform_motion(m, st.pf, xd, xdd, pm);
  m.kind->qdd_all(m, st.lg, pm, qdd);
}

void DescribedRobot::inverse_dynamics(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                      const double* xdd, double* tau) const {
  const Model& m = model_of(rm);
  const State& st = state_at(m, rd, x, false);
  Data& d = data_of(rd);
  d.accel = false;
  const V6 W = load_wrench(m, st, xd, xdd, d.qdd);
  with_size(m.n, [&](auto N) { solve_jt<N()>(m, st, W, x, tau); });
  copy_n(xd, m.n, d.xd);
  copy_n(xdd, m.n, d.xdd);
  d.accel = true;
}

void DescribedRobot::mass_matrix(const RobotModel& rm, RobotData& rd, const double* x, double* M) const {
  const Model& m = model_of(rm);
  const State& st = state_at(m, rd, x, false);
  Eigen::Map<Mat>(M, m.n, m.n) = mass_of(m, st).topLeftCorner(m.n, m.n);
}

bool DescribedRobot::forward_dynamics_response(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                               const double* tau, double* xdd, double* B) const {
  // J^T tau = T' Jc tau, Jc's columns the legs' twist rows j_i = (dq_i, rP_i x dq_i), and the
  // loads W(xdd) = W(0) + Mt (T xdd) (W(0) holds the T_dot xd part): T' Mt T xdd = T' (Jc tau - W(0)).
  const Model& m = model_of(rm);
  const int n = m.n;
  const State& st = state_at(m, rd, x, false);
  double qdd[6];
  V6 W = -load_wrench(m, st, xd, nullptr, qdd);
  for (int i = 0; i < n; ++i) W += tau[i] * st.lg[i].j;
  M6 Mt;
  twist_mass(m, st, Mt);
  const bool ok = m.full_pose ? full_pose_response(m, st, Mt, W, x, xdd, B)
                              : with_size(n, [&](auto N) { return pose_rate_response<N()>(m, st, Mt, W, xdd, B); });
  if (!ok)
    throw Error(PKM_ERR_SINGULAR, "forward dynamics: the mass matrix is not positive definite at " + pose_text(m, x));
  return true;
}

void DescribedRobot::forward_dynamics(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                      const double* tau, double* xdd) const {
  forward_dynamics_response(rm, rd, x, xd, tau, xdd, nullptr);
}

void DescribedRobot::energy(const RobotModel& rm, RobotData& rd, const double* x, const double* xd, double* kinetic,
                            double* potential) const {
  const Model& m = model_of(rm);
  const State& st = state_at(m, rd, x, false);
  V6 v = V6::Zero();
  for (int j = 0; j < m.n; ++j) v[j] = xd[j];
  *kinetic = 0.5 * v.dot(mass_of(m, st) * v);
  auto height = [&](const P3<double>& p) { return -m.g.dot(V3(p.x, p.y, p.z)); };
  // The platform's centre of mass: its origin, or an articulated platform's centre (the ends' mean).
  double V = -m.g.dot(st.pf.p + st.pf.R * m.c_platform) * m.m_platform;
  const V3 c = st.pf.p + st.pf.R * m.c_payload;
  V += m.m_payload * height(P3<double>{c.x(), c.y(), c.z()});
  for (int i = 0; i < m.n; ++i) {
    const LegModel& l = m.legs[i];
    const LegGrad& lg = st.lg[i];
    for (int k = 0; k < l.nmass; ++k) V += l.mass[k].m * height(lg.pos[l.mass[k].a]);
    for (int k = 0; k < l.nrod; ++k) V += 0.5 * l.rod[k].m * (height(lg.pos[l.rod[k].a]) + height(lg.pos[l.rod[k].b]));
  }
  *potential = V;
}

}  // namespace described
}  // namespace pkm
