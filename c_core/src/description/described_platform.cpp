// The platform of a description-compiled robot at a pose (described_platform.hpp).
#include "description/described_platform.hpp"

#include <sstream>

namespace pkm {
namespace described {

const char* const kCoordNames[6] = {"x", "y", "z", "rx", "ry", "rz"};

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

void LegWhere::unreachable(const std::string& why) const {
  throw Error(PKM_ERR_UNREACHABLE, "leg " + std::to_string(i + 1) + " cannot reach " + pose_text(m, x) + ": " + why);
}

void LegWhere::joint_limit(double q) const {
  const LegModel& l = m.legs[i];
  throw Error(PKM_ERR_JOINT_LIMIT, "leg " + std::to_string(i + 1) + " joint q = " + g6(q) + " outside [" +
                                       g6(l.qmin) + ", " + g6(l.qmax) + "] at " + pose_text(m, x));
}

void constraints_of(const Model& m, const Platform& pf, const M3& E, VD& c, CD& C) {
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

void dependent_rates(const Model& m, const double* x, Platform& pf) {
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
  // The coordinates are pose components: T xd is xd's translations and E times its angle rates.
  double r6[6] = {0, 0, 0, 0, 0, 0}, a6[6] = {0, 0, 0, 0, 0, 0};
  for (int j = 0; j < m.n; ++j) r6[m.coord[j]] = xd[j];
  if (xdd)
    for (int j = 0; j < m.n; ++j) a6[m.coord[j]] = xdd[j];
  const V3 ad(r6[3], r6[4], r6[5]);
  pm.v = V3(r6[0], r6[1], r6[2]);
  pm.a = V3(a6[0], a6[1], a6[2]);
  if (!m.rotates) {
    pm.om.setZero();
    pm.al.setZero();
    return;
  }
  // alpha = E a_dd + E_dot a_d (E_dot from the angle rates of the coordinates)
  pm.om = pf.E * ad;
  pm.al = pf.E * V3(a6[3], a6[4], a6[5]) + angle_map_rate(pf, r6[3], r6[4]) * ad;
}

void angle_rates(const Model& m, const Platform& pf, const double* x, const V3& w, double* ad) {
  if (std::abs(pf.cy) < 1e-9)
    throw Error(PKM_ERR_SINGULAR, "the Euler angles are singular (ry = +-90 deg) at " + pose_text(m, x) +
                                      ": angle rates are undefined there");
  const double az = (-pf.sx * w.y() + pf.cx * w.z()) / pf.cy;
  ad[2] = az;
  ad[1] = pf.cx * w.y() + pf.sx * w.z();
  ad[0] = w.x() - pf.sy * az;
}

}  // namespace described
}  // namespace pkm
