// The working types of the description-compiled robots' algorithms (described_robot.cpp,
// described_platform.cpp, described_compile.cpp and the leg kinds' motion in kind_*.cpp):
// small vectors, the platform at a pose, one leg's derivatives, the twist-space inertia being
// summed, and where a leg is (for its messages).
#pragma once

#include <Eigen/Dense>
#include <string>

#include "description/described_robot.hpp"
#include "description/jet.hpp"

namespace pkm {
namespace described {

using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 6, 6>;
using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;
using V3 = Eigen::Vector3d;
using M3 = Eigen::Matrix3d;
// Fixed 6 columns (zero beyond n): fixed-size products are several times faster than
// dynamic ones at these sizes; the n x n blocks are taken where a solve needs them.
using M36 = Eigen::Matrix<double, 3, 6>;
using M6 = Eigen::Matrix<double, 6, 6>;
using V6 = Eigen::Matrix<double, 6, 1>;
// Dependent coordinates (PRS, RPS legs): at most three, one per constrained leg.
using MD = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 3, 3>;
using VD = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 3, 1>;
using CD = Eigen::Matrix<double, Eigen::Dynamic, 6, 0, 3, 6>;
using TT = Taylor2;

extern const char* const kCoordNames[6];
std::string g6(double v);                             // 6 significant digits
std::string pose_text(const Model& m, const double* x);  // "pose (x, y) = (0.1, 0.2)"

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
inline V3 v3(const P3<double>& p) { return V3(p.x, p.y, p.z); }

// Leg i of a robot at pose x: a leg kind's geometry throws through it when the leg cannot
// reach its platform point ("leg 2 cannot reach pose (...) = (...): why") or its joint value
// q is outside its limits.
struct LegWhere {
  const Model& m;
  int i;
  const double* x;
  [[noreturn]] void unreachable(const std::string& why) const;
  [[noreturn]] void joint_limit(double q) const;
};

// One leg, differentiated with respect to its platform point: the first derivatives in
// closed form per joint kind (implicit differentiation of the leg's closure), which the
// tests hold against the forward-mode derivatives.
struct LegGrad {
  Eigen::RowVector3d dq;  // dq / dP
  M3 D[4];                // d point / dP
  P3<double> pos[4];      // the body points
  double q;
  V3 rP;
  V3 w;   // the rod (strut) vector from its proximal joint to P
  V3 t;   // arms: d S / dq (D[0] = t dq); a rail's is its direction (LegModel::dir), not set here
  V3 tb;  // arms: d (arm centre of mass) / dq; a rail's slider moves along its direction
  double wt;  // rails and arms: w . t (dq = w' / wt)
  V6 j;   // the leg's twist row (dq, rP x dq): qd = j . (p_dot, omega)
};

inline M3 skew(const V3& v) {
  M3 S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
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

// The twist-space inertia Mt of every body (KE = 1/2 nu' Mt nu, nu = (p_dot, omega)) being
// summed.  Point masses on the platform are summed first into one mass mr, first moment h
// and G = sum mp r r'; a leg kind adds its rank-two terms to A (Mt gets A + A' at the end)
// or its general terms to Mt.
struct TwistMass {
  double mr = 0;
  V3 h = V3::Zero();
  M3 G = M3::Zero();
  M6& Mt;  // the sum (the caller's matrix)
  M6 A = M6::Zero();
  explicit TwistMass(M6& out) : Mt(out) { Mt.setZero(); }
  void point(double mp, const V3& r) {
    mr += mp;
    h += mp * r;
    G.noalias() += (mp * r) * r.transpose();
  }
};

}  // namespace described
}  // namespace pkm
