// The platform of a description-compiled robot at a pose (described_platform.cpp): its
// rotation, the maps of the coordinate rates to its twist, dependent coordinates (PRS, RPS
// legs), its velocity and acceleration, and the products with the map T of the pose rates to
// the twist that the dynamics use.
#pragma once

#include "description/described_state.hpp"

namespace pkm {
namespace described {

// The platform at a pose: rotation, and with dependent coordinates the maps of the
// coordinate rates to its translational and angular velocity (p_dot = Jt xd, omega = Jw xd;
// the full pose's rates are S xd, the motion map); coordinate_maps gives Jt, Jw for any robot.
struct Platform {
  M3 R, E;
  V3 p;
  M36 Jt, Jw;  // dependent coordinates only
  double x6[6];
  double sx, cx, sy, cy;  // sines and cosines of rx, ry (E and its rate)
  M6 S;                   // dependent coordinates: d(full pose)/dx (columns j < n)
  MD Cdep_inv;            // the inverse of the constraints' Jacobian over the dependent components
};

// R = Rx Ry Rz of the full pose, and the sines and cosines E needs.
inline void rotation_of(const Model& m, Platform& pf) {
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
void constraints_of(const Model& m, const Platform& pf, const M3& E, VD& c, CD& C);

// The dependent components of the full pose by Newton from 0 (the parasitic motion is
// small), to 1e-14 m of constraint; the motion map S and Jt, Jw from them.
void solve_dependent(const Model& m, Platform& pf, const double* xval);
void dependent_rates(const Model& m, const double* x, Platform& pf);

// The platform at pose x; with rates = false only R and p (what inverse kinematics needs).
inline void platform_of(const Model& m, const double* x, Platform& pf, bool rates = true) {
  for (int k = 0; k < 6; ++k) pf.x6[k] = 0;
  for (int j = 0; j < m.n; ++j) pf.x6[m.coord[j]] = x[j];
  if (m.ndep) solve_dependent(m, pf, x);
  rotation_of(m, pf);
  if (!rates) return;
  pf.E = angle_map(pf);
  if (m.ndep) dependent_rates(m, x, pf);
}

// Jt, Jw of the platform pf (p_dot = Jt xd, omega = Jw xd): unit translations and columns of
// E for coordinates that are pose components, the motion map's with dependent coordinates.
inline void coordinate_maps(const Model& m, const Platform& pf, M36& Jt, M36& Jw) {
  if (m.ndep) {
    Jt = pf.Jt, Jw = pf.Jw;
    return;
  }
  Jt.setZero();
  Jw.setZero();
  for (int j = 0; j < m.n; ++j) {
    if (m.coord[j] < 3) Jt(m.coord[j], j) = 1;
    else Jw.col(j) = pf.E.col(m.coord[j] - 3);
  }
}


// The rate of the motion map along the full pose rates (om the angular velocity, Ed the rate
// of E).
M6 motion_map_rate(const Model& m, const Platform& pf, const V3& om, const M3& Ed);

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

// Leg i's platform joint P = p + rP + f: rP = R p_i moves with the platform's rotation (an
// articulated platform's articulation), f is an articulated platform's fixed offset.
inline V3 attachment(const Model& m, const Platform& pf, int i, V3& rP) {
  rP = pf.R * m.legs[i].p;
  return pf.p + rP + m.legs[i].f;
}


// Velocity and acceleration of the platform (origin and angular) at (x, xd, xdd).
struct PlatformMotion {
  V3 v, om, a, al;
};
void platform_motion(const Model& m, const Platform& pf, const double* xd, const double* xdd, PlatformMotion& pm);

// The angle rates a_dot = E^-1 w of a twist-space angular vector w (E is singular at
// ry = +-90 deg).
void angle_rates(const Model& m, const Platform& pf, const double* x, const V3& w, double* ad);

}  // namespace described
}  // namespace pkm
