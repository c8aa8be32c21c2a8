// 6-PUS dynamics by virtual power (Kane's form of Newton-Euler) over every body:
// the platform, the payload, six slender legs and six slider carriages.
//
// Each body's velocity is linear in the twist nu = (p_dot, omega) = T xd, so the
// generalised inertia-and-gravity force is Q = T^T W with W = sum_b J_b^T F_b (F_b the
// body's m a - m g and I alpha + omega x I omega).  The actuators act along the rails;
// their virtual power tau.qd = tau . (Jq^-1 Jxw nu) balances Q.  Rail friction and
// rotor inertia are added around these functions by the drive layer (dynamics/drive.hpp).
// Reactions of the rails, of the U and S joints are workless and drop out: they are in
// the model implicitly (Zavala-Yoe et al. 2015 sec. 5 explains why dropping them fails).
//
// A uniform slender rod between S and P with linear velocity field has kinetic energy
// m/6 (|vS|^2 + vS.vP + |vP|^2): it acts as m/3 at each end plus a cross term m/6, i.e.
// end forces F_S = m/3 a_S + m/6 a_P - m/2 g and F_P = m/6 a_S + m/3 a_P - m/2 g.
// (Spin about its own axis carries no inertia for a slender rod.)
//
// Equations and symbols: docs/6pus.md.
#include <sstream>

#include "oracles/sixpus.hpp"

namespace pkm {
namespace sixpus {

namespace {

inline M3 skew(const V3& v) {
  M3 S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

// Kinematics of a state (x, xd) and, for a given pose acceleration, the accelerations.
struct State {
  Frame f;
  Leg legs[NLEG];
  LegRates r[NLEG];
  V3 pd, om, Ed_ad;  // p_dot, omega, Edot a_dot
  M3 Iw;             // platform inertia in the world frame
  V3 rc;             // R c_payload
};

void state_of(const Model& m, const double* x, const double* xd, State& st) {
  frame_of(x, st.f);
  legs_at(m, x, st.f, st.legs, Strokes::ignore);
  st.pd = V3(xd[0], xd[1], xd[2]);
  const V3 ad(xd[3], xd[4], xd[5]);
  st.om = st.f.E * ad;
  st.Ed_ad = Edot_of(st.f, xd + 3) * ad;
  for (int i = 0; i < NLEG; ++i) leg_rates(m, i, st.legs[i], st.pd, st.om, st.r[i]);
  st.Iw = st.f.R * m.I_platform.asDiagonal() * st.f.R.transpose();
  st.rc = st.f.R * m.c_payload;
}

// Inertia-and-gravity load of the bodies for the twist acceleration (pdd, alpha):
// Wp = wrench about p of the platform-attached loads, fs[i] = rail component of the
// load at slider i.  Generalised force in twist space: Wp + sum_i jt_i fs[i].
void loads(const Model& m, const State& st, const V3& pdd, const V3& al, V6& Wp, double* fs) {
  const V3& g = m.g;
  const V3& om = st.om;
  Wp.head<3>() = m.m_platform * (pdd - g);
  Wp.tail<3>() = st.Iw * al + om.cross(st.Iw * om);
  if (m.m_payload != 0) {
    const V3 ac = pdd + al.cross(st.rc) + om.cross(om.cross(st.rc));
    const V3 F = m.m_payload * (ac - g);
    Wp.head<3>() += F;
    Wp.tail<3>() += st.rc.cross(F);
  }
  for (int i = 0; i < NLEG; ++i) {
    const Leg& l = st.legs[i];
    const V3 aP = pdd + al.cross(l.rP) + om.cross(om.cross(l.rP));
    const double qdd = (l.w.dot(aP) + st.r[i].wd.squaredNorm()) / l.c;
    const V3 aS = qdd * m.s[i];
    const double ml = m.m_leg[i], ms = m.m_slider[i];
    const V3 FP = (ml / 3) * aP + (ml / 6) * aS - (ml / 2) * g;
    const V3 FS = (ml / 3 + ms) * aS + (ml / 6) * aP - (ml / 2 + ms) * g;
    Wp.head<3>() += FP;
    Wp.tail<3>() += l.rP.cross(FP);
    fs[i] = m.s[i].dot(FS);
  }
}

// Twist-space Jacobian rows of every leg as columns: Jc.col(i) = twist_row(leg i).
void twist_rows(const State& st, M6& Jc) {
  for (int i = 0; i < NLEG; ++i) Jc.col(i) = twist_row(st.legs[i]);
}

// Twist-space mass matrix: KE = 0.5 nu' Mt nu; Jc from twist_rows.
void twist_mass(const Model& m, const State& st, const M6& Jc, M6& Mt) {
  // Platform-attached mass: the platform, the payload and one third of each leg at P.
  double mr = m.m_platform + m.m_payload;
  V3 h = m.m_payload * st.rc;
  // Point masses mp at r: sum mp (|r|^2 I - r r') = trace(G) I - G with G = sum mp r r'.
  M3 G = m.m_payload * (st.rc * st.rc.transpose());
  for (int i = 0; i < NLEG; ++i) {
    const double mp = m.m_leg[i] / 3;
    const V3& r = st.legs[i].rP;
    mr += mp;
    h += mp * r;
    G.noalias() += (mp * r) * r.transpose();
  }
  M3 Irot = st.Iw - G;
  Irot.diagonal().array() += G.trace();
  Mt.setZero();
  Mt.topLeftCorner<3, 3>().diagonal().setConstant(mr);
  const M3 H = skew(h);
  Mt.topRightCorner<3, 3>() = -H;
  Mt.bottomLeftCorner<3, 3>() = H;
  Mt.bottomRightCorner<3, 3>() = Irot;
  // Slider (translating with the rail) and the rest of each leg, with qd_i = j.nu and
  // s.v_P = u.nu:  c1 j j' + c2 (j u' + u j') = j v' + v j'  for v = c1/2 j + c2 u.
  M6 Vc;
  for (int i = 0; i < NLEG; ++i) {
    const Leg& l = st.legs[i];
    V6 u;
    u.head<3>() = m.s[i];
    u.tail<3>() = l.rP.cross(m.s[i]);
    const double c1 = (m.m_slider[i] + m.m_leg[i] / 3) * m.ss[i];
    const double c2 = m.m_leg[i] / 6;
    Vc.col(i) = (0.5 * c1) * Jc.col(i) + c2 * u;
  }
  M6 A;
  A.noalias() = Jc * Vc.transpose();
  Mt += A + A.transpose();
}

// Cholesky factor of a symmetric positive-definite 6x6 matrix (its lower triangle) and
// solves with it.  Fixed loops the compiler unrolls: a few times faster than the general
// LLT at this size, and the forward dynamics call it at every Runge-Kutta stage.
struct Cholesky6 {
  double L[NLEG][NLEG], inv[NLEG];  // inv: reciprocals of the diagonal
  bool factor(const M6& A) {        // false: a pivot is not positive (A not positive definite)
    for (int j = 0; j < 6; ++j) {
      double d = A(j, j);
      for (int k = 0; k < j; ++k) d -= L[j][k] * L[j][k];
      if (!(d > 0)) return false;
      inv[j] = 1.0 / std::sqrt(d);
      for (int i = j + 1; i < 6; ++i) {
        double s = A(i, j);
        for (int k = 0; k < j; ++k) s -= L[i][k] * L[j][k];
        L[i][j] = s * inv[j];
      }
    }
    return true;
  }
  void solve(const V6& b, V6& x) const {
    double y[6];
    for (int i = 0; i < 6; ++i) {
      double s = b[i];
      for (int k = 0; k < i; ++k) s -= L[i][k] * y[k];
      y[i] = s * inv[i];
    }
    for (int i = 5; i >= 0; --i) {
      double s = y[i];
      for (int k = i + 1; k < 6; ++k) s -= L[k][i] * x[k];
      x[i] = s * inv[i];
    }
  }
  // X = A^-1 R for six right-hand sides at once (X[row][column]): the columns are
  // independent, so the loops over them vectorise.
  void solve_columns(const M6& R, double X[NLEG][NLEG]) const {
    for (int i = 0; i < 6; ++i) {
      for (int c = 0; c < 6; ++c) X[i][c] = R(i, c);
      for (int k = 0; k < i; ++k)
        for (int c = 0; c < 6; ++c) X[i][c] -= L[i][k] * X[k][c];
      for (int c = 0; c < 6; ++c) X[i][c] *= inv[i];
    }
    for (int i = 5; i >= 0; --i) {
      for (int k = i + 1; k < 6; ++k)
        for (int c = 0; c < 6; ++c) X[i][c] -= L[k][i] * X[k][c];
      for (int c = 0; c < 6; ++c) X[i][c] *= inv[i];
    }
  }
};

// Euler-angle rates from the angular velocity: a_dot = E^-1 omega.
void rates_from_omega(const Frame& f, const double* x, const V3& w, double* ad) {
  if (std::abs(f.cy) < 1e-9)
    throw Error(PKM_ERR_SINGULAR, "the Euler angles are singular (ry = +-90 deg) at the " + pose_text(x) +
                                      ": angle rates are undefined there");
  const double az = (-f.sx * w.y() + f.cx * w.z()) / f.cy;
  ad[2] = az;
  ad[1] = f.cx * w.y() + f.sx * w.z();
  ad[0] = w.x() - f.sy * az;
}

}  // namespace

void SixPus::inverse_dynamics(const RobotModel& rm, RobotData&, const double* x, const double* xd,
                              const double* xdd, double* tau) const {
  const Model& m = model_of(rm);
  State st;
  state_of(m, x, xd, st);
  const V3 pdd(xdd[0], xdd[1], xdd[2]);
  const V3 al = st.f.E * V3(xdd[3], xdd[4], xdd[5]) + st.Ed_ad;
  V6 W;
  double fs[NLEG];
  loads(m, st, pdd, al, W, fs);
  // Jxw^T Jq^-1 (tau - fs) = W, Jxw rows (w_i, rP_i x w_i).
  M6 JxwT;
  for (int i = 0; i < NLEG; ++i) {
    JxwT.col(i).head<3>() = st.legs[i].w;
    JxwT.col(i).tail<3>() = st.legs[i].rP.cross(st.legs[i].w);
  }
  Eigen::PartialPivLU<M6> lu(JxwT);
  const auto d = lu.matrixLU().diagonal().cwiseAbs();
  if (!(d.minCoeff() > 1e-13 * d.maxCoeff()))
    throw Error(PKM_ERR_SINGULAR, "inverse dynamics: direct (type-2) singularity at the " + pose_text(x) +
                                      ": the legs cannot balance every platform load");
  const V6 y = lu.solve(W);
  for (int i = 0; i < NLEG; ++i) tau[i] = st.legs[i].c * y[i] + fs[i];
}

void SixPus::mass_matrix(const RobotModel& rm, RobotData&, const double* x, double* M) const {
  const Model& m = model_of(rm);
  const double zero[6] = {0, 0, 0, 0, 0, 0};
  State st;
  state_of(m, x, zero, st);
  M6 Jc, Mt;
  twist_rows(st, Jc);
  twist_mass(m, st, Jc, Mt);
  // Task space (Euler-angle rates): M = T^T Mt T, T = blockdiag(I, E).
  M6 T = M6::Identity();
  T.bottomRightCorner<3, 3>() = st.f.E;
  Eigen::Map<M6r> Mout(M);
  Mout = T.transpose() * Mt * T;
}

namespace {
// Forward dynamics; with B != nullptr also B = d xdd / d tau = [I 0; 0 E^-1] Mt^-1 Jc.
void forward_dynamics_of(const Model& m, const double* x, const double* xd, const double* tau, double* xdd,
                         double* B) {
  State st;
  state_of(m, x, xd, st);
  // Velocity-dependent and gravity load at zero pose acceleration (alpha = Edot a_dot).
  V6 W;
  double fs[NLEG];
  loads(m, st, V3::Zero(), st.Ed_ad, W, fs);
  M6 Jc, Mt;
  twist_rows(st, Jc);
  V6 net;
  for (int i = 0; i < NLEG; ++i) net[i] = tau[i] - fs[i];
  W.noalias() -= Jc * net;
  twist_mass(m, st, Jc, Mt);
  Cholesky6 chol;
  if (!chol.factor(Mt))
    throw Error(PKM_ERR_SINGULAR, "forward dynamics: the mass matrix is not positive definite at the " +
                                      pose_text(x));
  // Mt (T xdd) = -W.
  V6 y;
  chol.solve(-W, y);
  if (!y.allFinite())
    throw Error(PKM_ERR_SINGULAR, "forward dynamics: singular mass matrix at the " + pose_text(x));
  xdd[0] = y[0], xdd[1] = y[1], xdd[2] = y[2];
  rates_from_omega(st.f, x, V3(y[3], y[4], y[5]), xdd + 3);
  if (!B) return;
  double X[NLEG][NLEG];
  chol.solve_columns(Jc, X);
  for (int j = 0; j < NLEG; ++j) {
    double ad[3];
    rates_from_omega(st.f, x, V3(X[3][j], X[4][j], X[5][j]), ad);
    for (int k = 0; k < 3; ++k) B[6 * k + j] = X[k][j], B[6 * (3 + k) + j] = ad[k];
  }
}
}  // namespace

void SixPus::forward_dynamics(const RobotModel& rm, RobotData&, const double* x, const double* xd,
                              const double* tau, double* xdd) const {
  forward_dynamics_of(model_of(rm), x, xd, tau, xdd, nullptr);
}

bool SixPus::forward_dynamics_response(const RobotModel& rm, RobotData&, const double* x, const double* xd,
                                       const double* tau, double* xdd, double* B) const {
  forward_dynamics_of(model_of(rm), x, xd, tau, xdd, B);
  return true;
}

void SixPus::energy(const RobotModel& rm, RobotData&, const double* x, const double* xd, double* kinetic,
                    double* potential) const {
  const Model& m = model_of(rm);
  State st;
  state_of(m, x, xd, st);
  const V3 p(x[0], x[1], x[2]);
  const V3& g = m.g;
  // Body by body from the body velocities (independent of the mass-matrix assembly).
  double T = 0.5 * m.m_platform * st.pd.squaredNorm() + 0.5 * st.om.dot(st.Iw * st.om);
  double U = -m.m_platform * g.dot(p);
  const V3 vc = st.pd + st.om.cross(st.rc);
  T += 0.5 * m.m_payload * vc.squaredNorm();
  U -= m.m_payload * g.dot(p + st.rc);
  for (int i = 0; i < NLEG; ++i) {
    const V3& vP = st.r[i].Pd;
    const V3 vS = st.r[i].qd * m.s[i];
    const V3 P = p + st.legs[i].rP;
    const V3 S = P - st.legs[i].w;
    T += m.m_leg[i] / 6 * (vS.squaredNorm() + vS.dot(vP) + vP.squaredNorm());
    T += 0.5 * m.m_slider[i] * vS.squaredNorm();
    U -= m.m_leg[i] * g.dot(0.5 * (S + P)) + m.m_slider[i] * g.dot(S);
  }
  *kinetic = T;
  *potential = U;
}

}  // namespace sixpus
}  // namespace pkm
