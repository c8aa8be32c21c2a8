// The algorithms of every description-compiled robot (described_robot.hpp has the model).
#include "description/described_robot.hpp"

#include <algorithm>
#include <sstream>
#include <unordered_map>

#include "common/joint_param.hpp"
#include "description/jet.hpp"
#include "description/joint_kind.hpp"
#include "description/schema.hpp"
#include "kinematics/generic_kinematics.hpp"
#include "dynamics/drive.hpp"

namespace pkm {
namespace described {

namespace {

using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 6, 6>;
using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;
using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;

const char* kCoordNames[6] = {"x", "y", "z", "rx", "ry", "rz"};

const Model& model_of(const RobotModel& rm) { return static_cast<const Model&>(rm); }

std::string g6(double v) {
  std::ostringstream os;
  os.precision(6);
  os << v;
  return os.str();
}

std::string pose_text(const Model& m, const double* x) {
  std::ostringstream os;
  os.precision(6);
  os << "pose (";
  for (int j = 0; j < m.n; ++j) os << (j ? ", " : "") << kCoordNames[m.coord[j]];
  os << ") = (";
  for (int j = 0; j < m.n; ++j) os << (j ? ", " : "") << x[j];
  os << ")";
  return os.str();
}

enum class Check { none, limits };
using TT = Taylor2;

// A 3-vector of any scalar.
template <class T>
struct P3 {
  T x, y, z;
};
template <class T> inline P3<T> operator+(const P3<T>& a, const P3<T>& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
template <class T> inline P3<T> operator-(const P3<T>& a, const P3<T>& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
template <class T> inline P3<T> operator*(const T& s, const P3<T>& a) { return {s * a.x, s * a.y, s * a.z}; }
template <class T> inline P3<T> operator-(const P3<T>& a, const V3& b) { return {a.x - b.x(), a.y - b.y(), a.z - b.z()}; }
template <class T> inline P3<T> operator+(const V3& b, const P3<T>& a) { return {a.x + b.x(), a.y + b.y(), a.z + b.z()}; }
template <class T> inline T dot(const P3<T>& a, const P3<T>& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class T> inline T dot(const V3& a, const P3<T>& b) { return a.x() * b.x + a.y() * b.y + a.z() * b.z; }
template <class T> inline P3<T> along(const T& s, const V3& v) { return {s * v.x(), s * v.y(), s * v.z()}; }

// Leg geometry as a function of its platform point P, closed form: the joint value q and
// the leg's body points.  Only the values decide (reachability, limits); derivatives ride
// along.  Every leg's points depend on the pose through P alone, so the Jacobians are
// (d points / d P) times the platform point's Jacobian, 3 variables per leg whatever n.
template <class T>
__attribute__((always_inline)) inline void leg_geometry(const Model& m, int i, const P3<T>& P, T& q, P3<T>* out, Check check, const double* xval) {
  using std::acos;
  using std::atan2;
  using std::sqrt;
  const LegModel& l = m.legs[i];
  auto unreachable = [&](const std::string& why) {
    throw Error(PKM_ERR_UNREACHABLE, "leg " + std::to_string(i + 1) + " cannot reach " + pose_text(m, xval) + ": " + why);
  };
  const P3<T> d = P - l.base;
  out[1] = P;
  if (l.joint == Joint::rail) {
    // |d - q s|^2 = L^2 with d = P - S0: ss q^2 - 2 b q + |d|^2 - L^2 = 0.
    const T b = dot(l.dir, d);
    const T disc = b * b - l.ss * (dot(d, d) - l.L * l.L);
    if (!(value_of(disc) >= l.disc_tol))
      unreachable(value_of(disc) < -l.disc_tol ? "the rod is too short to meet the rail"
                                               : "the rod is perpendicular to its rail (inverse-kinematic singularity)");
    q = l.inv_ss * (b - l.branch * sqrt(disc));
    out[0] = l.base + along(q, l.dir);
  } else if (l.joint == Joint::arm) {
    // alpha cos q + beta sin q = K with d = P - A in the (u, w) frame of the arm.
    const T al = dot(l.u, d), be = dot(l.w, d);
    const T K = (0.5 / l.r) * (dot(d, d) + (l.r * l.r - l.L * l.L));
    const T rho = sqrt(al * al + be * be);
    const double c = value_of(K) / value_of(rho);
    if (!(std::abs(c) <= 1 - 1e-12))
      unreachable(std::abs(c) > 1 ? "the rod's sphere misses the elbow circle (|K| / rho = " + g6(std::abs(c)) + ")"
                                  : "the rod is in line with the arm (inverse-kinematic singularity)");
    q = atan2(be, al) + l.branch * acos(K / rho);
    T sq, cq;
    sin_cos(q, sq, cq);
    const P3<T> e = along(cq, l.u) + along(sq, l.w);
    out[0] = l.base + T(l.r) * e;   // elbow B
    if (l.com_s == 0) {
      out[2] = l.base + T(l.rc) * e;  // arm centre of mass
    } else {                          // off the arm line by an angle: e(q + phi)
      const P3<T> ep = along(-sq, l.u) + along(cq, l.w);
      out[2] = l.base + (T(l.rc * l.com_c) * e + T(l.rc * l.com_s) * ep);
    }
  } else {
    q = sqrt(dot(d, d));
    if (!(value_of(q) > 1e-9)) unreachable("the platform point is on the strut's base joint");
    const P3<T> nn = (T(1.0) / q) * d;
    out[0] = {T(l.base.x()), T(l.base.y()), T(l.base.z())};
    out[2] = l.base + T(l.l_cyl) * nn;  // cylinder end
    out[3] = P - T(l.l_pis) * nn;       // piston end
  }
  if (check == Check::limits) {
    const double qv = value_of(q);
    if (qv < l.qmin || qv > l.qmax)
      throw Error(PKM_ERR_JOINT_LIMIT, "leg " + std::to_string(i + 1) + " joint q = " + g6(qv) + " outside [" +
                                           g6(l.qmin) + ", " + g6(l.qmax) + "] at " + pose_text(m, xval));
  }
}

// Fixed 6 columns (zero beyond n): fixed-size products are several times faster than
// dynamic ones at these sizes; the n x n blocks are taken where a solve needs them.
using M36 = Eigen::Matrix<double, 3, 6>;
using M6 = Eigen::Matrix<double, 6, 6>;
using V6 = Eigen::Matrix<double, 6, 1>;

// Dependent coordinates (PRS, RPS legs): at most three, one per constrained leg.
using MD = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>;
using VD = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1>;

// The platform at a pose: rotation, and the maps of the coordinate rates to its
// translational and angular velocity (p_dot = Jt xd, omega = Jw xd).  With dependent
// coordinates the full pose's rates are S xd (the motion map) and Jt, Jw include them.
struct Platform {
  M3 R, E;
  V3 p;
  M36 Jt, Jw;
  double x6[6];
  double sx, cx, sy, cy;  // sines and cosines of rx, ry (E and its rate)
  M6 S;                   // dependent coordinates: d(full pose)/dx (columns j < n)
  MD Cdep_inv;            // the inverse of the constraints' Jacobian over the dependent components
};

// R = Rx Ry Rz of the full pose, and the sines and cosines E needs.
void rotation_of(const Model& m, Platform& pf) {
  double sx, cx, sy, cy, sz, cz;
  sin_cos(pf.x6[3], sx, cx);
  sin_cos(pf.x6[4], sy, cy);
  sin_cos(pf.x6[5] + m.rz0, sz, cz);
  pf.sx = sx, pf.cx = cx, pf.sy = sy, pf.cy = cy;
  pf.R << cy * cz, -(cy * sz), sy, sx * sy * cz + cx * sz, cx * cz - sx * sy * sz, -(sx * cy),
      sx * sz - cx * sy * cz, cx * sy * sz + sx * cz, cx * cy;
  pf.p = V3(pf.x6[0], pf.x6[1], pf.x6[2]);
}

// E (omega = E (rx, ry, rz)_dot) and its rate for the angle rates ax, ay.
inline M3 angle_map(const Platform& pf) {
  M3 E;
  E << 1, 0, pf.sy, 0, pf.cx, -pf.sx * pf.cy, 0, pf.sx, pf.cx * pf.cy;
  return E;
}
inline M3 angle_map_rate(const Platform& pf, double ax, double ay) {
  const double sx = pf.sx, cx = pf.cx, sy = pf.sy, cy = pf.cy;
  M3 Ed;
  Ed << 0, 0, cy * ay, 0, -sx * ax, -cx * cy * ax + sx * sy * ay, 0, cx * ax, -sx * cy * ax - cx * sy * ay;
  return Ed;
}

// The constraints of the legs with a passive revolute joint, c_k = a . (P - o), and their
// Jacobian over the full pose, row k = (a, (R p) x a)' blockdiag(I, E).
void constraints_of(const Model& m, const Platform& pf, const M3& E, VD& c, Eigen::Matrix<double, Eigen::Dynamic, 6, 0, 3, 6>& C) {
  c.resize(m.ndep);
  C.resize(m.ndep, 6);
  int k = 0;
  for (const LegModel& l : m.legs) {
    if (!l.constrained) continue;
    const V3 rP = pf.R * l.p;
    c[k] = l.plane_n.dot(pf.p + rP - l.plane_o);
    C.row(k).head<3>() = l.plane_n.transpose();
    C.row(k).tail<3>() = (rP.cross(l.plane_n)).transpose() * E;
    ++k;
  }
}

// The dependent components of the full pose by Newton from 0 (the parasitic motion is
// small; Newton converges in a few steps), to 1e-14 m of constraint.
void solve_dependent(const Model& m, Platform& pf, const double* xval) {
  VD c;
  Eigen::Matrix<double, Eigen::Dynamic, 6, 0, 3, 6> C;
  const double tol = 1e-14 * (1 + m.r_char);
  double res = 0;
  for (int it = 0; it < 40; ++it) {
    rotation_of(m, pf);
    constraints_of(m, pf, angle_map(pf), c, C);
    res = c.cwiseAbs().maxCoeff();
    if (!std::isfinite(res)) break;
    if (res <= tol) return;
    MD Cd(m.ndep, m.ndep);
    for (int k = 0; k < m.ndep; ++k) Cd.col(k) = C.col(m.dep[k]);
    Eigen::FullPivLU<MD> lu(Cd);
    if (!lu.isInvertible()) break;
    const VD dy = lu.solve(-c);
    for (int k = 0; k < m.ndep; ++k) pf.x6[m.dep[k]] += dy[k];
  }
  std::string names;
  for (int k = 0; k < m.ndep; ++k) names += std::string(k ? ", " : "") + kCoordNames[m.dep[k]];
  throw Error(PKM_ERR_NO_CONVERGENCE, "the dependent coordinates (" + names + ") did not converge at " +
                                          pose_text(m, xval) + ": the legs' passive revolute joints leave " + g6(res) +
                                          " m of constraint (no pose near the home branch holds them, or a singularity)");
}

// With rates = false only R and p (what inverse kinematics needs).
void platform_of(const Model& m, const double* x, Platform& pf, bool rates = true) {
  for (int k = 0; k < 6; ++k) pf.x6[k] = 0;
  for (int j = 0; j < m.n; ++j) pf.x6[m.coord[j]] = x[j];
  if (m.ndep) solve_dependent(m, pf, x);
  rotation_of(m, pf);
  if (!rates) return;
  pf.E = angle_map(pf);
  pf.Jt.setZero();
  pf.Jw.setZero();
  if (!m.ndep) {
    for (int j = 0; j < m.n; ++j) {
      if (m.coord[j] < 3) pf.Jt(m.coord[j], j) = 1;
      else pf.Jw.col(j) = pf.E.col(m.coord[j] - 3);
    }
    return;
  }
  // C S = 0 with S's declared rows unit rows: S_dep = -C_dep^-1 C_ind.
  VD c;
  Eigen::Matrix<double, Eigen::Dynamic, 6, 0, 3, 6> C;
  constraints_of(m, pf, pf.E, c, C);
  MD Cd(m.ndep, m.ndep);
  for (int k = 0; k < m.ndep; ++k) Cd.col(k) = C.col(m.dep[k]);
  Eigen::FullPivLU<MD> lu(Cd);
  if (!lu.isInvertible())
    throw Error(PKM_ERR_SINGULAR, "the legs' passive revolute joints do not determine the dependent coordinates at " +
                                      pose_text(m, x) + " (architecture singularity)");
  pf.Cdep_inv = lu.inverse();
  pf.S.setZero();
  for (int j = 0; j < m.n; ++j) {
    pf.S(m.coord[j], j) = 1;
    const VD sj = -pf.Cdep_inv * C.col(m.coord[j]);
    for (int k = 0; k < m.ndep; ++k) pf.S(m.dep[k], j) = sj[k];
  }
  pf.Jt = pf.S.topRows<3>();
  pf.Jw = pf.E * pf.S.bottomRows<3>();
}

// The rate of the motion map along the full pose rates r6 (om the angular velocity, Ed the
// rate of E): C S = 0, so C_dep Sdot_dep = -Cdot S, with row k of Cdot
// (0, ((om x R p) x a)' E + ((R p) x a)' Ed).  S xdd + Sdot xd is the full pose's acceleration.
M6 motion_map_rate(const Model& m, const Platform& pf, const V3& om, const M3& Ed) {
  Eigen::Matrix<double, Eigen::Dynamic, 6, 0, 3, 6> Cdot(m.ndep, 6);
  int k = 0;
  for (const LegModel& l : m.legs) {
    if (!l.constrained) continue;
    const V3 rP = pf.R * l.p;
    Cdot.row(k).head<3>().setZero();
    Cdot.row(k).tail<3>() = ((om.cross(rP)).cross(l.plane_n)).transpose() * pf.E + rP.cross(l.plane_n).transpose() * Ed;
    ++k;
  }
  const Eigen::Matrix<double, Eigen::Dynamic, 6, 0, 3, 6> CS = Cdot * pf.S;
  const Eigen::Matrix<double, Eigen::Dynamic, 6, 0, 3, 6> Sd_dep = -pf.Cdep_inv * CS;
  M6 Sd = M6::Zero();
  for (int q = 0; q < m.ndep; ++q) Sd.row(m.dep[q]) = Sd_dep.row(q);
  return Sd;
}

// Column j of T: a unit translation, or a column of E for an angle.  T' v for a twist-space
// vector v (a wrench, or a row of twist-space coefficients), without the full product.
inline V6 t_transpose(const Model& m, const Platform& pf, const V6& v) {
  V6 out = V6::Zero();
  if (m.ndep) {  // T = (Jt; Jw)
    for (int j = 0; j < m.n; ++j) out[j] = pf.Jt.col(j).dot(v.head<3>()) + pf.Jw.col(j).dot(v.tail<3>());
    return out;
  }
  for (int j = 0; j < m.n; ++j) {
    const int c = m.coord[j];
    out[j] = c < 3 ? v[c] : pf.E.col(c - 3).dot(v.tail<3>());
  }
  return out;
}
// T' Mt T for a symmetric twist-space matrix Mt.
inline M6 t_congruence(const Model& m, const Platform& pf, const M6& Mt) {
  Eigen::Matrix<double, 6, 6> MtT;  // columns j < n: Mt T e_j
  for (int j = 0; j < m.n; ++j) {
    const int c = m.coord[j];
    if (m.ndep) MtT.col(j) = Mt.leftCols<3>() * pf.Jt.col(j) + Mt.rightCols<3>() * pf.Jw.col(j);
    else MtT.col(j) = c < 3 ? V6(Mt.col(c)) : V6(Mt.rightCols<3>() * pf.E.col(c - 3));
  }
  M6 M = M6::Zero();
  for (int j = 0; j < m.n; ++j) M.col(j) = t_transpose(m, pf, MtT.col(j));
  return M;
}

// A twist-space row (f, rP x f): the power of a force f at a platform point rP is
// row . (p_dot, omega).
inline V6 twist_row(const V3& f, const V3& rP) {
  V6 r;
  r << f, rP.cross(f);
  return r;
}

// W += twist_row(f, rP), without the temporary.
inline void add_load(V6& W, const V3& f, const V3& rP) {
  W.head<3>() += f;
  W.tail<3>() += rP.cross(f);
}

inline M3 skew(const V3& v) {
  M3 S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

// Leg i's platform joint P = p + rP + f: rP = R p_i moves with the platform's rotation (an
// articulated platform's articulation), f is an articulated platform's fixed offset.
inline V3 attachment(const Model& m, const Platform& pf, int i, V3& rP) {
  rP = pf.R * m.legs[i].p;
  return pf.p + rP + m.legs[i].f;
}

// Jacobian of a point fixed on the platform at world offset rP from its origin.
inline M36 point_jacobian(const Platform& pf, const V3& rP) { return pf.Jt - skew(rP) * pf.Jw; }

// Velocity and acceleration of the platform (origin and angular) at (x, xd, xdd).
struct PlatformMotion {
  V3 v, om, a, al;
};
void platform_motion(const Model& m, const Platform& pf, const double* xd, const double* xdd, PlatformMotion& pm) {
  if (m.ndep) {
    // The full pose's rates r6 = S xd and accelerations S xdd + Sdot xd.
    V6 v = V6::Zero(), a = V6::Zero();
    for (int j = 0; j < m.n; ++j) v[j] = xd[j], a[j] = xdd ? xdd[j] : 0.0;
    const V6 r6 = pf.S * v;
    pm.v = r6.head<3>();
    pm.om = pf.E * r6.tail<3>();
    const M3 Ed = angle_map_rate(pf, r6[3], r6[4]);
    const V6 a6 = pf.S * a + motion_map_rate(m, pf, pm.om, Ed) * v;
    pm.a = a6.head<3>();
    pm.al = pf.E * a6.tail<3>() + Ed * r6.tail<3>();
    return;
  }
  V6 v = V6::Zero();
  for (int j = 0; j < m.n; ++j) v[j] = xd[j];
  pm.v = pf.Jt * v;
  pm.om = pf.Jw * v;
  pm.a.setZero();
  pm.al.setZero();
  if (xdd) {
    V6 a = V6::Zero();
    for (int j = 0; j < m.n; ++j) a[j] = xdd[j];
    pm.a = pf.Jt * a;
    pm.al = pf.Jw * a;
  }
  if (m.rotates) {
    // alpha = E a_dd + E_dot a_d (E_dot from the angle rates of the coordinates)
    double r6[6] = {0, 0, 0, 0, 0, 0};
    for (int j = 0; j < m.n; ++j) r6[m.coord[j]] = xd[j];
    pm.al += angle_map_rate(pf, r6[3], r6[4]) * V3(r6[3], r6[4], r6[5]);
  }
}

// One leg, differentiated with respect to its platform point: the first derivatives in
// closed form per joint kind (implicit differentiation of the leg's closure), which the
// tests hold against the forward-mode derivatives (jacobian_dot uses those).
struct LegGrad {
  Eigen::RowVector3d dq;  // dq / dP
  M3 D[4];                // d point / dP
  P3<double> pos[4];  // the body points
  double q;
  V3 rP;
  V3 w;   // the rod (strut) vector from its proximal joint to P
  V3 t;   // rails and arms: d S / dq (D[0] = t dq)
  V3 tb;  // rails and arms: d (slider or arm centre of mass) / dq
  V6 j;   // the leg's twist row (dq, rP x dq): qd = j . (p_dot, omega)
};

// points = false: only q and dq/dP (the Jacobian).
void leg_grad(const Model& m, int i, const Platform& pf, const double* x, LegGrad& lg, Check check,
              bool points = true) {
  const LegModel& l = m.legs[i];
  const V3 P = attachment(m, pf, i, lg.rP);
  leg_geometry(m, i, P3<double>{P.x(), P.y(), P.z()}, lg.q, lg.pos, check, x);
  const V3 w = lg.w = P - V3(lg.pos[0].x, lg.pos[0].y, lg.pos[0].z);
  if (l.joint == Joint::strut) {
    const V3 n = w / lg.q;
    lg.dq = n.transpose();
    if (points) {
      const M3 Pn = (M3::Identity() - n * n.transpose()) / lg.q;  // d n / dP
      lg.D[0].setZero();
      lg.D[2] = l.l_cyl * Pn;
      lg.D[3] = M3::Identity() - l.l_pis * Pn;
      lg.D[1].setIdentity();
    }
  } else {
    // |P - S(q)| = L: w . (dP - t dq) = 0 with t = dS/dq.
    // D[0] = t dq and the slider's or arm's centre of mass tb dq: leg_mass and leg_load use them.
    lg.t = lg.tb = l.dir;
    if (l.joint == Joint::arm) {
      double sq, cq;
      sin_cos(lg.q, sq, cq);
      const V3 e = cq * l.u + sq * l.w, ep = cq * l.w - sq * l.u;
      lg.t = l.r * ep;
      lg.tb = l.rc * (l.com_c * ep - l.com_s * e);
    }
    lg.dq = w.transpose() / w.dot(lg.t);
  }
}

// The leg's inertia seen at its platform point: KE = 1/2 vP' MP vP.  Rails and arms
// move their body points along one direction t per unit q (D = k t dq, rank one), which
// the sums use; struts take the general form.
M3 leg_mass(const LegModel& l, const LegGrad& lg) {
  M3 MP;
  if (l.joint != Joint::strut) {
    const V3& t = lg.t;
    const double ms = l.m_rod * l.rod_self, mx = l.m_rod * l.rod_cross;
    const double c = l.m_body * lg.tb.squaredNorm() + ms * t.squaredNorm() + l.I_arm;
    const V3 g = lg.dq.transpose();
    MP.noalias() = c * g * g.transpose() + mx * (g * t.transpose() + t * g.transpose());
    MP.diagonal().array() += ms;
    return MP;
  }
  MP.setZero();
  for (int k = 0; k < l.nmass; ++k) MP.noalias() += l.mass[k].m * lg.D[l.mass[k].a].transpose() * lg.D[l.mass[k].a];
  for (int k = 0; k < l.nrod; ++k) {
    const Rod& r = l.rod[k];
    const M3& A = lg.D[r.a];
    const M3& B = lg.D[r.b];
    const M3 C = A.transpose() * B;
    MP.noalias() += (r.m / 3) * (A.transpose() * A + B.transpose() * B) + (r.m / 6) * (C + C.transpose());
  }
  return MP;
}

// The leg's inertia-and-gravity load seen at its platform point (virtual power) for the
// point's velocity vP and acceleration aP.  The joint acceleration and the body points'
// accelerations in closed form per joint kind (the second derivative of the closure;
// joint_acceleration gets qdd from forward-mode Taylor coefficients, and the tests hold the
// two together).
V3 leg_load(const Model& m, const LegModel& l, const LegGrad& lg, const V3& vP, const V3& aP) {
  const V3& w = lg.w;
  const double qd = lg.dq.dot(vP);
  if (l.joint != Joint::strut) {
    // D_body = tb dq, D_S = t dq, D_P = I: the loads at S and the body act through dq.
    double qdd;
    V3 aS, aB;  // the slider or elbow, the slider or arm centre of mass
    if (l.joint == Joint::rail) {
      // w = P - S0 - q s: w.w = L^2 twice differentiated: |wd|^2 + w.(aP - qdd s) = 0.
      const V3 wd = vP - qd * l.dir;
      qdd = (w.dot(aP) + wd.squaredNorm()) / w.dot(l.dir);
      aS = aB = qdd * l.dir;
    } else {
      // B = A + r e(q), t = dB/dq = r e'(q), dt/dq = -r e(q).
      double sq, cq;
      sin_cos(lg.q, sq, cq);
      const V3 e = cq * l.u + sq * l.w;
      const V3& t = lg.t;
      const V3 wd = vP - qd * t;
      qdd = (w.dot(aP) + wd.squaredNorm() + l.r * qd * qd * w.dot(e)) / w.dot(t);
      aS = qdd * t - (l.r * qd * qd) * e;
      aB = qdd * lg.tb - (qd * qd * l.rc) * (l.com_c * e + l.com_s * (t / l.r));
    }
    const double mr = l.m_rod, ms = mr * l.rod_self, mx = mr * l.rod_cross;
    const V3 Fb = l.m_body * (aB - m.g);
    const V3 Fs = ms * aS + mx * aP - (mr / 2) * m.g;
    const V3 Fp = mx * aS + ms * aP - (mr / 2) * m.g;
    const double along = lg.tb.dot(Fb) + lg.t.dot(Fs) + l.I_arm * qdd;
    return Fp + along * lg.dq.transpose();
  }
  // q^2 = w.w: q qdd = |vP|^2 - qd^2 + w.aP; n = w / q, ndd = (aP - qdd n - 2 qd nd) / q.
  const double q = lg.q;
  const V3 n = w / q, nd = (vP - qd * n) / q;
  const double qdd = (vP.squaredNorm() - qd * qd + w.dot(aP)) / q;
  const V3 ndd = (aP - qdd * n - (2 * qd) * nd) / q;
  V3 acc[4];
  acc[0].setZero();
  acc[1] = aP;
  acc[2] = l.l_cyl * ndd;
  acc[3] = aP - l.l_pis * ndd;
  V3 f = V3::Zero();
  for (int k = 0; k < l.nmass; ++k)
    f.noalias() += lg.D[l.mass[k].a].transpose() * (l.mass[k].m * (acc[l.mass[k].a] - m.g));
  for (int k = 0; k < l.nrod; ++k) {
    const Rod& r = l.rod[k];
    const V3 Fa = (r.m / 3) * acc[r.a] + (r.m / 6) * acc[r.b] - (r.m / 2) * m.g;
    const V3 Fb = (r.m / 6) * acc[r.a] + (r.m / 3) * acc[r.b] - (r.m / 2) * m.g;
    f.noalias() += lg.D[r.a].transpose() * Fa + lg.D[r.b].transpose() * Fb;
  }
  if (l.I_arm != 0) f += (l.I_arm * qdd) * lg.dq.transpose();
  return f;
}

// Everything of a pose the dynamics need.
struct State {
  Platform pf;
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
// rows = false: J is left unset (the forward dynamics map J^T tau in twist space instead).
void state_of(const Model& m, const double* x, State& st, bool rows) {
  platform_of(m, x, st.pf);
  st.rows = false;
  for (int i = 0; i < m.n; ++i) {
    LegGrad& lg = st.lg[i];
    leg_grad(m, i, st.pf, x, lg, Check::none);
    lg.j.head<3>() = lg.dq.transpose();
    lg.j.tail<3>() = lg.rP.cross(lg.j.head<3>());
  }
  if (rows) add_rows(m, st);
}

// A pkm_data's part of a described robot: the state of the last pose it saw.  The calls at
// one pose (the drive layer asks for J, the joint velocities, the dynamics and M in turn)
// compute it once; a new pose (compared value by value) or a failed call starts afresh.
struct Data final : RobotData {
  bool valid = false;
  double x[6];
  State st;
};
const State& state_at(const Model& m, RobotData& rd, const double* x, bool rows) {
  Data& d = static_cast<Data&>(rd);  // every pkm_data of a described robot holds one (make_data)
  if (!(d.valid && std::equal(x, x + m.n, d.x))) {
    d.valid = false;
    state_of(m, x, d.st, rows);
    std::copy(x, x + m.n, d.x);
    d.valid = true;
  } else if (rows && !d.st.rows) {
    add_rows(m, d.st);
  }
  return d.st;
}

// Adds A' MP A for A = [I, -[r]x] (a point at r on the platform, twist space).
inline void add_point_inertia(M6& Mt, const M3& MP, const V3& r) {
  const M3 S = skew(r);
  const M3 MS = MP * S;
  Mt.topLeftCorner<3, 3>() += MP;
  Mt.topRightCorner<3, 3>() -= MS;
  Mt.bottomLeftCorner<3, 3>() -= MS.transpose();  // S MP = -(MP S)'
  Mt.bottomRightCorner<3, 3>().noalias() -= S * MS;
}

// The twist-space inertia Mt of every body (KE = 1/2 nu' Mt nu, nu = (p_dot, omega)).
// Point masses on the platform (its end bars, the payload, the rods' isotropic part at P)
// are summed first: mp at r adds (mp I, -mp [r]x; mp [r]x, mp (|r|^2 I - r r')).  A rail's
// or an arm's remaining inertia at P, c g g' + mx (g t' + t g') (leg_mass), is rank two in
// twist space: with j = (g, rP x g) and u = (t, rP x t) it is j v' + v j' for
// v = c/2 j + mx u.
M6 twist_mass(const Model& m, const State& st) {
  const Platform& pf = st.pf;
  double mr = m.articulated ? 0.0 : m.m_platform;
  V3 h = V3::Zero();
  M3 G = M3::Zero();  // sum mp r r'
  auto point = [&](double mp, const V3& r) {
    mr += mp;
    h += mp * r;
    G.noalias() += (mp * r) * r.transpose();
  };
  if (m.articulated)  // half the mass at each end bar
    for (const V3& e : m.end_bars) point(0.5 * m.m_platform, pf.R * e);
  if (m.m_payload != 0) point(m.m_payload, pf.R * m.c_payload);
  M6 Mt = M6::Zero(), A = M6::Zero();
  for (int i = 0; i < m.n; ++i) {
    const LegModel& l = m.legs[i];
    const LegGrad& lg = st.lg[i];
    if (l.joint == Joint::strut) {
      add_point_inertia(Mt, leg_mass(l, lg), lg.rP);
      continue;
    }
    const double ms = l.m_rod * l.rod_self, mx = l.m_rod * l.rod_cross;
    const double c = l.m_body * lg.tb.squaredNorm() + ms * lg.t.squaredNorm() + l.I_arm;
    point(ms, lg.rP);
    V6 v;  // (0.5 c) j + mx (t, rP x t)
    v.head<3>() = (0.5 * c) * lg.j.head<3>() + mx * lg.t;
    v.tail<3>() = (0.5 * c) * lg.j.tail<3>() + mx * lg.rP.cross(lg.t);
    A.noalias() += lg.j * v.transpose();
  }
  Mt += A + A.transpose();
  Mt.topLeftCorner<3, 3>().diagonal().array() += mr;
  const M3 H = skew(h);
  Mt.topRightCorner<3, 3>() -= H;
  Mt.bottomLeftCorner<3, 3>() += H;
  Mt.bottomRightCorner<3, 3>() -= G;
  Mt.bottomRightCorner<3, 3>().diagonal().array() += G.trace();
  if (m.rotates) Mt.bottomRightCorner<3, 3>() += pf.R * m.I_platform.asDiagonal() * pf.R.transpose();
  return Mt;
}

// Task-space mass matrix M = T' Mt T.
M6 mass_of(const Model& m, const State& st) { return t_congruence(m, st.pf, twist_mass(m, st)); }

// The inertia-and-gravity loads at (x, xd, xdd) as one wrench W = (force, moment) about
// the platform origin: the generalised force is Q = T' W (J^T tau = Q).
V6 load_wrench(const Model& m, const State& st, const double* xd, const double* xdd) {
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
    const M3 Iw = pf.R * m.I_platform.asDiagonal() * pf.R.transpose();
    W.tail<3>() += Iw * pm.al + pm.om.cross(Iw * pm.om);
  }
  if (m.m_payload != 0) point_load(m.m_payload, pf.R * m.c_payload);
  for (int i = 0; i < m.n; ++i) {
    const V3& rP = st.lg[i].rP;
    const V3 vP = pm.v + pm.om.cross(rP);
    const V3 aP = pm.a + pm.al.cross(rP) + pm.om.cross(pm.om.cross(rP));
    add_load(W, leg_load(m, m.legs[i], st.lg[i], vP, aP), rP);
  }
  return W;
}
V6 generalised_force(const Model& m, const State& st, const double* xd, const double* xdd) {
  return t_transpose(m, st.pf, load_wrench(m, st, xd, xdd));
}

// tau from J^T tau = Q (the n x n blocks).
template <class MatT, class VecT>
void solve_jt_n(const Model& m, const MatT& JT, const VecT& Q, const double* x, double* tau) {
  Eigen::PartialPivLU<MatT> lu(JT);
  const auto d = lu.matrixLU().diagonal().cwiseAbs();
  if (!(d.minCoeff() > 1e-13 * std::max(1.0, d.maxCoeff())))
    throw Error(PKM_ERR_SINGULAR, "direct (parallel) singularity at " + pose_text(m, x) + ": J is singular");
  const VecT t = lu.solve(Q);
  for (int i = 0; i < m.n; ++i) tau[i] = t[i];
}
void solve_jt(const Model& m, const M6& J, const V6& Q, const double* x, double* tau) {
  if (m.n == 6) solve_jt_n(m, M6(J.transpose()), Q, x, tau);
  else solve_jt_n(m, Mat(J.topLeftCorner(m.n, m.n).transpose()), Vec(Q.head(m.n)), x, tau);
}

// Cholesky factor of a symmetric positive-definite n x n matrix (n <= 6; its lower
// triangle) and solves with it: plain loops over fixed arrays, a few times faster than the
// general LLT at these sizes (the forward dynamics run at every integrator stage).
// GCC's -Wmaybe-uninitialized reads L[i][k] (k < j) as possibly unset once the loops are
// unrolled; every such entry is written at an earlier column j.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
template <int N>  // N > 0: the size, fixed (the loops unroll); N = 0: the size given to factor
struct SmallCholesky {
  int n = N;
  double L[6][6] = {}, inv[6] = {};  // inv: reciprocals of the diagonal
  int size() const { return N ? N : n; }
  bool factor(const M6& A, int size_n = N) {  // false: a pivot is not positive (A not positive definite)
    n = size_n;
    for (int j = 0; j < size(); ++j) {
      double d = A(j, j);
      for (int k = 0; k < j; ++k) d -= L[j][k] * L[j][k];
      if (!(d > 0)) return false;
      inv[j] = 1.0 / std::sqrt(d);
      for (int i = j + 1; i < size(); ++i) {
        double s = A(i, j);
        for (int k = 0; k < j; ++k) s -= L[i][k] * L[j][k];
        L[i][j] = s * inv[j];
      }
    }
    return true;
  }
  V6 solve(const V6& b) const {
    V6 y, x;
    for (int i = 0; i < size(); ++i) {
      double s = b[i];
      for (int k = 0; k < i; ++k) s -= L[i][k] * y[k];
      y[i] = s * inv[i];
    }
    for (int i = size() - 1; i >= 0; --i) {
      double s = y[i];
      for (int k = i + 1; k < size(); ++k) s -= L[k][i] * x[k];
      x[i] = s * inv[i];
    }
    return x;
  }
};
#pragma GCC diagnostic pop

// The angle rates a_dot = E^-1 w of a twist-space angular vector w (E is singular at
// ry = +-90 deg).
void angle_rates(const Model& m, const Platform& pf, const double* x, const V3& w, double* ad) {
  if (std::abs(pf.cy) < 1e-9)
    throw Error(PKM_ERR_SINGULAR, "the Euler angles are singular (ry = +-90 deg) at " + pose_text(m, x) +
                                      ": angle rates are undefined there");
  const double az = (-pf.sx * w.y() + pf.cx * w.z()) / pf.cy;
  ad[2] = az;
  ad[1] = pf.cx * w.y() + pf.sx * w.z();
  ad[0] = w.x() - pf.sy * az;
}

// The legs' passive revolute joints at the home pose with the dependent components at 0
// (before any solve): each leg's plane must pass near its platform point (an axis along the
// leg puts the point far off it), and the planes together must fix the dependent components
// (an axis lying in the leg's plane, or axes that let the platform slide or turn within
// every plane, leave them free: an architecture singularity).  Both name the legs.
template <class Bad>
void check_passive_joints(const Model& m, const Bad& bad) {
  Platform pf;
  for (int k = 0; k < 6; ++k) pf.x6[k] = 0;
  for (int j = 0; j < m.n; ++j) pf.x6[m.coord[j]] = m.home[j];
  rotation_of(m, pf);
  std::vector<int> rows;
  for (int i = 0; i < m.n; ++i) {
    const LegModel& l = m.legs[i];
    if (!l.constrained) continue;
    rows.push_back(i);
    const V3 d = pf.p + pf.R * l.p - l.plane_o;
    const double off = std::abs(l.plane_n.dot(d));
    if (off > 0.5 * d.norm())
      bad("leg " + std::to_string(i + 1) + ": its platform point is " + g6(off) + " m off the plane its passive revolute "
          "joint turns the leg in (through its " + (l.joint == Joint::rail ? "rail" : "base joint") +
          ", normal to revolute_axis) at the home pose, " + g6(d.norm()) + " m from it: the revolute axis must be "
          "perpendicular to the leg, not along it or through the platform point");
  }
  VD c;
  Eigen::Matrix<double, Eigen::Dynamic, 6, 0, 3, 6> C;
  constraints_of(m, pf, angle_map(pf), c, C);
  MD Cd(m.ndep, m.ndep);
  for (int k = 0; k < m.ndep; ++k) Cd.col(k) = C.col(m.dep[k]) * (m.dep[k] >= 3 ? 1.0 / m.r_char : 1.0);
  Eigen::JacobiSVD<MD> svd(Cd, Eigen::ComputeFullU);
  const auto& sv = svd.singularValues();
  const double inv_cond = sv[0] > 0 ? sv[m.ndep - 1] / sv[0] : 0.0;
  if (!(inv_cond > 1e-3)) {
    // The legs whose constraints combine to nothing: the left null vector's entries.
    std::string legs, names;
    const VD u = svd.matrixU().col(m.ndep - 1);
    for (int k = 0; k < m.ndep; ++k)
      if (std::abs(u[k]) > 0.1) legs += std::string(legs.empty() ? "" : ", ") + "leg " + std::to_string(rows[k] + 1);
    for (int k = 0; k < m.ndep; ++k) names += std::string(k ? ", " : "") + kCoordNames[m.dep[k]];
    bad("architecture singularity at the home pose: the passive revolute joints of " + legs + " do not fix the "
        "dependent coordinates (" + names + "; 1 / cond = " + g6(inv_cond) + " < 1e-3): a revolute axis lies in the "
        "plane the others leave the platform free in (e.g. axes pointing at the centre instead of tangent to it)");
  }
}

}  // namespace

// ------------------------------------------------------------------ the Robot

std::vector<std::string> DescribedRobot::param_sets() const {
  std::vector<std::string> out;
  for (const auto& s : d_.sets) out.push_back(s.first);
  return out;
}

namespace {
const std::vector<Override>* set_of(const Description& d, const std::string& set) {
  for (const auto& s : d.sets)
    if (s.first == set) return &s.second;
  std::string known;
  for (const auto& s : d.sets) known += (known.empty() ? "" : ", ") + s.first;
  throw Error(PKM_ERR_ARGUMENT, d.name + " has no parameter set '" + set + "' (known: " + known + ")");
}
}  // namespace

std::vector<ParamSpec> DescribedRobot::param_specs(const std::string& set) const {
  std::vector<ParamSpec> v = d_.params;
  std::unordered_map<std::string, ParamSpec*> by_name;
  for (auto& s : v) by_name.emplace(s.name, &s);
  for (const auto& o : param_overrides(set))
    if (auto it = by_name.find(o.first); it != by_name.end()) it->second->value = o.second;
  return v;
}

std::vector<std::pair<std::string, double>> DescribedRobot::param_overrides(const std::string& set) const {
  // The defaults, then the set's own values (later ones win).
  const std::vector<Override>& own = *set_of(d_, set);
  std::vector<std::pair<std::string, double>> out;
  if (&own != &d_.sets.front().second)
    for (const auto& o : d_.sets.front().second) out.emplace_back(o.name, o.value);
  for (const auto& o : own) out.emplace_back(o.name, o.value);
  return out;
}

std::unique_ptr<RobotModel> DescribedRobot::compile(const std::vector<ParamSpec>& specs,
                                                    const std::vector<double>& values) const {
  const ParamValues get(d_.name, specs, values);
  auto vec = [&](const char* group, int i, const char* f0) { return get.vec(group, i, f0); };
  auto bad = [&](const std::string& msg) { get.bad(msg); };
  auto m = std::make_unique<Model>();
  m->n = ndof();
  for (int j = 0; j < m->n; ++j) m->coord[j] = d_.coords[j];
  for (int k = 3; k < 6; ++k)
    m->rotates |= std::find(d_.coords.begin(), d_.coords.end(), k) != d_.coords.end();
  double rsum = 0;
  for (int i = 0; i < m->n; ++i) {
    LegModel l;
    l.type = d_.legs[i];
    l.joint = l.type->joint;
    l.type->leg->compile(get, i, d_.lumped_rods[i], l);
    if (!(l.qmin < l.qmax)) bad("leg " + std::to_string(i + 1) + ": joint limits must have min < max");
    if (d_.articulated) l.f = vec("leg", i, "f");
    rsum += l.p.norm();
    m->legs.push_back(l);
  }
  m->m_platform = get("platform.m");
  m->I_platform = V3(get("platform.Ixx"), get("platform.Iyy"), get("platform.Izz"));
  m->m_payload = get("payload.m");
  m->c_payload = V3(get("payload.x"), get("payload.y"), get("payload.z"));
  m->g = V3(get("gravity.x"), get("gravity.y"), get("gravity.z"));
  m->r_char = rsum > 0 ? rsum / m->n : 1.0;
  if (d_.articulated) {
    m->articulated = true;
    m->rz0 = get("platform.axis_angle");
    const double ends = get("platform.ends");
    m->c_platform = V3(get("platform.cx"), get("platform.cy"), get("platform.cz"));
    for (int k = 0; k < 2; ++k) m->end_bars[k] = m->c_platform + V3(k ? -ends : ends, 0, 0);
    if (ends > 0) m->r_char = ends;  // the end bars' speed per articulation rate
  }
  for (int j = 0; j < m->n; ++j) m->home[j] = d_.home[j];
  m->ndep = (int)d_.dependent.size();
  for (int k = 0; k < m->ndep; ++k) m->dep[k] = d_.dependent[k];
  m->full_pose = m->n == 6 && !m->ndep;
  for (int j = 0; j < m->n; ++j) m->full_pose &= m->coord[j] == j;
  if (m->ndep) check_passive_joints(*m, bad);
  // The home pose must be reachable, within the joint limits and away from singularities.
  const std::unique_ptr<RobotData> rdp = make_data(*m);
  RobotData& rd = *rdp;
  double q[6], meas[2];
  try {
    ik(*m, rd, m->home, q);
    singularity(*m, rd, m->home, meas);
  } catch (const Error& e) {
    bad(std::string("the home pose is not valid: ") + e.what());
  }
  // A home pose this close to a singularity (measures < 1e-3; well-designed robots have
  // 0.1-1 there) is no place to start a simulation or a calibration from.
  if (!(meas[0] > 1e-3))
    bad("inverse-kinematic (serial) singularity at the home pose: a rod is (nearly) perpendicular to its joint's motion "
        "(measure " + g6(meas[0]) + " < 1e-3)");
  if (!(meas[1] > 1e-3))
    bad("architecture (direct) singularity at the home pose: the legs do not constrain the platform there "
        "(1 / cond J = " + g6(meas[1]) + " < 1e-3)");
  return m;
}

std::unique_ptr<RobotData> DescribedRobot::make_data(const RobotModel&) const { return std::make_unique<Data>(); }

void DescribedRobot::home(const RobotModel& rm, double* x) const {
  const Model& m = model_of(rm);
  for (int j = 0; j < m.n; ++j) x[j] = m.home[j];
}

const char* DescribedRobot::joint_prefix() const {
  return d_.joint == Joint::rail ? "rail" : d_.joint == Joint::arm ? "arm" : "strut";
}
const char* DescribedRobot::joint_noun() const {
  return d_.joint == Joint::rail ? "slider" : d_.joint == Joint::arm ? "arm" : "strut";
}
const char* DescribedRobot::pose_name(int i) const { return kCoordNames[d_.coords[i]]; }
const char* DescribedRobot::pose_unit(int i) const { return d_.coords[i] < 3 ? "m" : "rad"; }
std::string DescribedRobot::joint_limit_param(int i, bool upper) const {
  return joint_param(*this, i, upper ? "qmax" : "qmin");
}
const char* DescribedRobot::geometry_param(int i) const {
  return i >= 0 && i < (int)geometry_names_.size() ? geometry_names_[i].c_str() : nullptr;
}

void DescribedRobot::ik(const RobotModel& rm, RobotData&, const double* x, double* q) const {
  const Model& m = model_of(rm);
  Platform pf;
  platform_of(m, x, pf, false);
  for (int i = 0; i < m.n; ++i) {
    V3 rP;
    const V3 P = attachment(m, pf, i, rP);
    P3<double> pts[4];
    leg_geometry(m, i, P3<double>{P.x(), P.y(), P.z()}, q[i], pts, Check::limits, x);
  }
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
    double jq;
    if (l.joint == Joint::rail) jq = w.dot(l.dir);
    else if (l.joint == Joint::arm) jq = l.r * w.dot(-std::sin(lg.q) * l.u + std::cos(lg.q) * l.w);
    else jq = lg.q;
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
  // hold J xdd + Jdot xd against joint_acceleration's forward-mode Taylor coefficients.)
  const Model& m = model_of(rm);
  const State& st = state_at(m, rd, x, false);
  const Platform& pf = st.pf;
  PlatformMotion pm;
  platform_motion(m, pf, xd, nullptr, pm);
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
    const V3& w = lg.w;
    const double qd = lg.dq.dot(vP);
    Eigen::RowVector3d dqd;
    if (l.joint == Joint::strut) {  // dq/dP = n' = w' / q
      dqd = ((vP - qd * lg.dq.transpose()) / lg.q).transpose();
    } else {
      // dq/dP = w' / (w . t), w = P - S(q), t = dS/dq: wd = vP - qd t, and t's rate is 0 on a
      // rail, -r qd e(q) on an arm.
      const V3& t = lg.t;
      const V3 wd = vP - qd * t;
      double c_rate = wd.dot(t);
      if (l.joint == Joint::arm) {
        double sq, cq;
        sin_cos(lg.q, sq, cq);
        c_rate -= l.r * qd * w.dot(cq * l.u + sq * l.w);
      }
      const double c = w.dot(t);
      dqd = (wd / c - (c_rate / (c * c)) * w).transpose();
    }
    const M36 JP = point_jacobian(pf, rP);
    const M36 JPd = Jtd - skew(pm.om.cross(rP)) * pf.Jw - skew(rP) * Jwd;
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
    if (l.joint == Joint::rail) t1 = std::min(t1, std::abs(Jq(i, i)) / (l.L * std::sqrt(l.ss)));
    if (l.joint == Joint::arm) t1 = std::min(t1, std::abs(Jq(i, i)) / (l.L * l.r));
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
    leg_geometry(m, i, P3<double>{P.x(), P.y(), P.z()}, q, p, Check::none, x);
    const P3<double> moving = l.joint == Joint::strut ? p[2] : p[0];  // a strut: its cylinder's end
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

void DescribedRobot::joint_acceleration(const RobotModel& rm, RobotData&, const double* x, const double* xd,
                                        const double* xdd, double* qdd) const {
  // Forward-mode Taylor coefficients of the leg closure along P(t) = P + t vP + t^2/2 aP
  // (independent of leg_load's closed forms, which the tests compare with this).
  const Model& m = model_of(rm);
  Platform pf;
  platform_of(m, x, pf);
  PlatformMotion pm;
  platform_motion(m, pf, xd, xdd, pm);
  for (int i = 0; i < m.n; ++i) {
    V3 rP;
    const V3 P = attachment(m, pf, i, rP), vP = pm.v + pm.om.cross(rP);
    const V3 aP = pm.a + pm.al.cross(rP) + pm.om.cross(pm.om.cross(rP));
    const P3<TT> Pt{TT(P.x(), vP.x(), aP.x()), TT(P.y(), vP.y(), aP.y()), TT(P.z(), vP.z(), aP.z())};
    TT q;
    P3<TT> pts[4];
    leg_geometry(m, i, Pt, q, pts, Check::none, x);
    qdd[i] = q.d2;
  }
}

void DescribedRobot::inverse_dynamics(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                      const double* xdd, double* tau) const {
  const Model& m = model_of(rm);
  const State& st = state_at(m, rd, x, !m.full_pose);
  if (!m.full_pose) {
    solve_jt(m, st.J, generalised_force(m, st, xd, xdd), x, tau);
    return;
  }
  // T square: J^T tau = T' W is Jc tau = W, Jc's columns the legs' twist rows.
  M6 Jc;
  for (int i = 0; i < 6; ++i) Jc.col(i) = st.lg[i].j;
  solve_jt_n(m, Jc, load_wrench(m, st, xd, xdd), x, tau);
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
  M6 Jc = M6::Zero();
  V6 W = -load_wrench(m, st, xd, nullptr);
  for (int i = 0; i < n; ++i) {
    Jc.col(i) = st.lg[i].j;
    W += tau[i] * Jc.col(i);
  }
  const M6 Mt = twist_mass(m, st);
  auto not_definite = [&] {
    throw Error(PKM_ERR_SINGULAR, "forward dynamics: the mass matrix is not positive definite at " + pose_text(m, x));
  };
  if (m.full_pose) {
    // T = blockdiag(I, E) is square: Mt (p_dd, E a_dd) = Jc tau - W(0).
    SmallCholesky<6> llt;
    if (!llt.factor(Mt)) not_definite();
    auto to_pose = [&](const V6& y, double* out, int stride) {
      double ad[3];
      angle_rates(m, st.pf, x, y.tail<3>(), ad);
      for (int k = 0; k < 3; ++k) out[stride * k] = y[k], out[stride * (3 + k)] = ad[k];
    };
    to_pose(llt.solve(W), xdd, 1);
    if (B)
      for (int j = 0; j < 6; ++j) to_pose(llt.solve(Jc.col(j)), B + j, 6);
    return true;
  }
  SmallCholesky<0> llt;
  if (!llt.factor(t_congruence(m, st.pf, Mt), n)) not_definite();
  const V6 a = llt.solve(t_transpose(m, st.pf, W));
  for (int i = 0; i < n; ++i) xdd[i] = a[i];
  if (B)  // B = M^-1 J^T, column j = M^-1 T' j_j
    for (int j = 0; j < n; ++j) {
      const V6 b = llt.solve(t_transpose(m, st.pf, Jc.col(j)));
      for (int i = 0; i < n; ++i) B[n * i + j] = b[i];
    }
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
