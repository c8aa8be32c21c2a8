// The algorithms of a serial arm (serial_chain.hpp): forward kinematics of the joint
// frames and the tool, recursive Newton-Euler, composite-rigid-body, forward dynamics.
#include "description/serial_chain.hpp"

#include <cmath>

#include "description/schema.hpp"

namespace pkm {
namespace described {

namespace {

using V6 = Eigen::Matrix<double, 6, 1>;
using M6 = Eigen::Matrix<double, 6, 6>;
using MatN = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, kMaxChainJoints, kMaxChainJoints>;
using VecN = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxChainJoints, 1>;

const ChainModel& model_of(const RobotModel& rm) { return static_cast<const ChainModel&>(rm); }

Eigen::Matrix3d skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

Eigen::Matrix3d rpy_matrix(double r, double p, double y) {
  return (Eigen::AngleAxisd(y, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(p, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(r, Eigen::Vector3d::UnitX())).toRotationMatrix();
}

// Spatial motion cross product v x m, v = [w; v0] (Featherstone 2008, eq. 2.31).
V6 crm(const V6& v, const V6& m) {
  V6 out;
  out.head<3>() = v.head<3>().cross(m.head<3>());
  out.tail<3>() = v.tail<3>().cross(m.head<3>()) + v.head<3>().cross(m.tail<3>());
  return out;
}

// Spatial force cross product v x* f (Featherstone 2008, eq. 2.32).
V6 crf(const V6& v, const V6& f) {
  V6 out;
  out.head<3>() = v.head<3>().cross(f.head<3>()) + v.tail<3>().cross(f.tail<3>());
  out.tail<3>() = v.head<3>().cross(f.tail<3>());
  return out;
}

// A body's spatial inertia about the world origin: mass m at world point c, rotational
// inertia Ic about c in world axes (Featherstone 2008, eq. 2.63).
M6 spatial_inertia(double m, const Eigen::Vector3d& c, const Eigen::Matrix3d& Ic) {
  const Eigen::Matrix3d C = skew(c);
  M6 I;
  I.topLeftCorner<3, 3>() = Ic + m * C * C.transpose();
  I.topRightCorner<3, 3>() = m * C;
  I.bottomLeftCorner<3, 3>() = m * C.transpose();
  I.bottomRightCorner<3, 3>() = m * Eigen::Matrix3d::Identity();
  return I;
}

// The chain at q, world frame: joint frames after their motion, motion subspaces and the
// links' spatial inertias (the payload in the last).
struct Placed {
  int n = 0;
  Eigen::Matrix3d R[kMaxChainJoints];
  Eigen::Vector3d p[kMaxChainJoints];
  V6 S[kMaxChainJoints];
  M6 I[kMaxChainJoints];
  Eigen::Vector3d com[kMaxChainJoints];  // the links' centres of mass [m]
  Eigen::Vector3d payload;               // [m]
  Eigen::Matrix3d R_tool;
  Eigen::Vector3d p_tool;
};

void place(const ChainModel& m, const double* q, Placed& k, bool inertias) {
  k.n = m.n;
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  for (int i = 0; i < m.n; ++i) {
    const ChainJoint& j = m.j[i];
    p += R * j.p0;
    R = R * j.R0;
    const Eigen::Vector3d a = R * j.axis;
    if (j.prismatic) {
      p += a * q[i];
      k.S[i] << Eigen::Vector3d::Zero(), a;
    } else {
      R = R * Eigen::AngleAxisd(q[i], j.axis).toRotationMatrix();
      k.S[i] << a, p.cross(a);
    }
    k.R[i] = R;
    k.p[i] = p;
    k.com[i] = p + R * j.c;
    if (inertias) k.I[i] = spatial_inertia(j.m, k.com[i], R * j.Ic * R.transpose());
  }
  k.R_tool = R * m.R_tool;
  k.p_tool = p + R * m.p_tool;
  k.payload = k.p_tool + k.R_tool * m.c_payload;
  if (inertias && m.m_payload > 0) k.I[m.n - 1] += spatial_inertia(m.m_payload, k.payload, Eigen::Matrix3d::Zero());
}

// Recursive Newton-Euler (Featherstone 2008, table 5.1): tau = M qdd + h, gravity as a base
// acceleration -g.
void rnea(const ChainModel& m, const Placed& k, const double* qd, const double* qdd, double* tau) {
  V6 v = V6::Zero(), a;
  a << Eigen::Vector3d::Zero(), -m.g;
  V6 f[kMaxChainJoints];
  for (int i = 0; i < m.n; ++i) {
    v += k.S[i] * qd[i];
    a += k.S[i] * qdd[i] + crm(v, k.S[i]) * qd[i];
    f[i] = k.I[i] * a + crf(v, k.I[i] * v);
  }
  for (int i = m.n - 1; i >= 0; --i) {
    tau[i] = k.S[i].dot(f[i]);
    if (i > 0) f[i - 1] += f[i];
  }
}

// Composite-rigid-body (Featherstone 2008, table 6.2), world frame: M_ji = S_j' Ic_i S_i, j <= i.
void crba(const ChainModel& m, const Placed& k, MatN& M) {
  M.setZero(m.n, m.n);
  M6 Ic = M6::Zero();
  for (int i = m.n - 1; i >= 0; --i) {
    Ic += k.I[i];
    const V6 F = Ic * k.S[i];
    for (int j = 0; j <= i; ++j) M(i, j) = M(j, i) = k.S[j].dot(F);
  }
}

// Roll-pitch-yaw of the pose convention R = Rx(rx) Ry(ry) Rz(rz).
Eigen::Vector3d xyz_angles(const Eigen::Matrix3d& R) {
  const double ry = std::asin(std::max(-1.0, std::min(1.0, R(0, 2))));
  return {std::atan2(-R(1, 2), R(2, 2)), ry, std::atan2(-R(0, 1), R(0, 0))};
}

}  // namespace

SerialRobot::SerialRobot(Description d, std::vector<ChainJointInfo> joints, int serial)
    : DescribedRobot(std::move(d), serial), joints_(std::move(joints)) {}

std::string SerialRobot::joint_limit_param(int i, bool upper) const {
  if (i < 0 || i >= ndof() || !joints_[i].limited) return "";
  return idx("joint", i, upper ? "qmax" : "qmin");
}

std::unique_ptr<RobotModel> SerialRobot::compile(const std::vector<ParamSpec>& specs,
                                                 const std::vector<double>& values) const {
  const ParamValues v(name(), specs, values);
  auto m = std::make_unique<ChainModel>();
  m->n = ndof();
  for (int i = 0; i < m->n; ++i) {
    ChainJoint& j = m->j[i];
    const std::string J = "joint[" + std::to_string(i + 1) + "].", L = "link[" + std::to_string(i + 1) + "].";
    j.prismatic = joints_[i].prismatic;
    j.limited = joints_[i].limited;
    j.p0 = v.vec("joint", i, "");
    j.R0 = rpy_matrix(v(J + "roll"), v(J + "pitch"), v(J + "yaw"));
    j.axis = {v(J + "ax"), v(J + "ay"), v(J + "az")};
    if (!(j.axis.norm() > 1e-9))
      v.bad("joint " + std::to_string(i + 1) + "'s axis (" + J + "ax, ay, az) is zero: it needs a direction");
    j.axis.normalize();
    if (j.limited) {
      j.qmin = v(J + "qmin"), j.qmax = v(J + "qmax");
      if (!(j.qmin < j.qmax)) v.bad(J + "qmin = " + num(j.qmin) + " must be below " + J + "qmax = " + num(j.qmax));
    }
    j.m = v(L + "m");
    j.c = {v(L + "cx"), v(L + "cy"), v(L + "cz")};
    j.Ic << v(L + "Ixx"), v(L + "Ixy"), v(L + "Ixz"), v(L + "Ixy"), v(L + "Iyy"), v(L + "Iyz"), v(L + "Ixz"),
        v(L + "Iyz"), v(L + "Izz");
    const Eigen::Vector3d e = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(j.Ic).eigenvalues();
    const double tol = 1e-12 * std::max(1.0, e.cwiseAbs().maxCoeff());
    if (e.minCoeff() < -tol || e[0] + e[1] < e[2] - tol)
      v.bad(L + "Ixx ... Izz are not a rigid body's inertia: principal moments " + num(e[0]) + ", " + num(e[1]) + ", " +
            num(e[2]) + " kg m2 must be >= 0 and each at most the sum of the others");
    m->home[i] = description().home[i];
  }
  m->p_tool = {v("tool.x"), v("tool.y"), v("tool.z")};
  m->R_tool = rpy_matrix(v("tool.roll"), v("tool.pitch"), v("tool.yaw"));
  m->m_payload = v("payload.m");
  m->c_payload = {v("payload.x"), v("payload.y"), v("payload.z")};
  m->g = {v("gravity.x"), v("gravity.y"), v("gravity.z")};
  // The home pose within the limits, and a mass matrix there the forward dynamics can
  // solve with (each joint moves some inertia, its rotor's counted).
  RobotData rd;
  double q[kMaxChainJoints];
  try {
    ik(*m, rd, m->home, q);
  } catch (const Error& e) {
    v.bad(std::string("the home pose is not valid: ") + e.what());
  }
  MatN M;
  Placed k;
  place(*m, m->home, k, true);
  crba(*m, k, M);
  for (int i = 0; i < m->n; ++i) {
    const auto it = v.val.find(idx("joint", i, "rotor_inertia"));
    if (it != v.val.end()) M(i, i) += it->second;
  }
  Eigen::LLT<MatN> llt(M);
  if (llt.info() != Eigen::Success || !(llt.matrixL().toDenseMatrix().diagonal().minCoeff() > 1e-12 * M.diagonal().maxCoeff())) {
    int worst = 0;
    for (int i = 1; i < m->n; ++i)
      if (M(i, i) < M(worst, worst)) worst = i;
    v.bad("the mass matrix at the home pose is singular: joint " + std::to_string(worst + 1) + " moves " + num(M(worst, worst)) +
          (joints_[worst].prismatic ? " kg" : " kg m2") + " along its motion (give its link or the links beyond it a "
          "mass, an inertia about its axis, or the joint a rotor_inertia)");
  }
  return m;
}

void SerialRobot::home(const RobotModel& rm, double* x) const {
  const ChainModel& m = model_of(rm);
  for (int i = 0; i < m.n; ++i) x[i] = m.home[i];
}

void SerialRobot::ik(const RobotModel& rm, RobotData&, const double* x, double* q) const {
  const ChainModel& m = model_of(rm);
  for (int i = 0; i < m.n; ++i) {
    if (!std::isfinite(x[i])) throw Error(PKM_ERR_ARGUMENT, std::string("pose ") + pose_name(i) + " is not finite");
    const ChainJoint& j = m.j[i];
    if (j.limited && (x[i] < j.qmin || x[i] > j.qmax))
      throw Error(PKM_ERR_JOINT_LIMIT, "joint " + std::to_string(i + 1) + " (" + pose_name(i) + ") q = " + num(x[i]) +
                                           " outside [" + num(j.qmin) + ", " + num(j.qmax) + "]");
  }
  for (int i = 0; i < m.n; ++i) q[i] = x[i];
}

void SerialRobot::fk(const RobotModel& rm, RobotData&, const double* q, const double*, const pkm_fk_options&,
                     double* x, pkm_fk_info& info) const {
  for (int i = 0; i < model_of(rm).n; ++i) x[i] = q[i];
  info.iterations = 0;
  info.residual = 0;
}

void SerialRobot::jacobians(const RobotModel& rm, RobotData&, const double*, double* Jx, double* Jq,
                            double* J) const {
  const int n = model_of(rm).n;
  for (double* out : {Jx, Jq, J})
    if (out)
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) out[a * n + b] = a == b;
}

void SerialRobot::jacobian_dot(const RobotModel& rm, RobotData&, const double*, const double*, double* Jdot) const {
  const int n = model_of(rm).n;
  for (int a = 0; a < n * n; ++a) Jdot[a] = 0;
}

void SerialRobot::singularity(const RobotModel&, RobotData&, const double*, double* measures) const {
  measures[0] = measures[1] = 1;  // the joints are the coordinates: J = 1 everywhere
}

void SerialRobot::direct_singularity_guard(const RobotModel&, RobotData&, const double*, double* measure_bound,
                                           double* det_j) const {
  *measure_bound = 1;
  *det_j = 1;
}

void SerialRobot::chain_points(const RobotModel& rm, RobotData&, const double* x, double* pts) const {
  // Per joint: its frame's origin, the next joint's (the tool's for the last), the tool's.
  const ChainModel& m = model_of(rm);
  Placed k;
  place(m, x, k, false);
  for (int i = 0; i < m.n; ++i) {
    const Eigen::Vector3d rows[3] = {k.p[i], i + 1 < m.n ? k.p[i + 1] : k.p_tool, k.p_tool};
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) pts[9 * i + 3 * r + c] = rows[r][c];
  }
}

void SerialRobot::platform_pose(const RobotModel& rm, RobotData&, const double* x, double* X, double* S) const {
  // The tool frame: position and R = Rx(rx) Ry(ry) Rz(rz); S = d(X)/dq, its angular rows the
  // angle rates E^-1 w of the geometric Jacobian's w (E: angle rates -> angular velocity).
  const ChainModel& m = model_of(rm);
  Placed k;
  place(m, x, k, false);
  const Eigen::Vector3d ang = xyz_angles(k.R_tool);
  for (int c = 0; c < 3; ++c) X[c] = k.p_tool[c], X[3 + c] = ang[c];
  if (!S) return;
  const int n = m.n;
  Eigen::Matrix3d E;
  const Eigen::Matrix3d Rx = Eigen::AngleAxisd(ang[0], Eigen::Vector3d::UnitX()).toRotationMatrix();
  E.col(0) = Eigen::Vector3d::UnitX();
  E.col(1) = Rx.col(1);
  E.col(2) = Rx * Eigen::AngleAxisd(ang[1], Eigen::Vector3d::UnitY()).toRotationMatrix().col(2);
  const Eigen::PartialPivLU<Eigen::Matrix3d> lu(E);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d w = k.S[i].head<3>();
    const Eigen::Vector3d v = k.S[i].tail<3>() + w.cross(k.p_tool);  // the tool point's velocity per unit rate
    const Eigen::Vector3d r = lu.solve(w);
    for (int c = 0; c < 3; ++c) S[c * n + i] = v[c], S[(3 + c) * n + i] = r[c];
  }
}

void SerialRobot::joint_acceleration(const RobotModel& rm, RobotData&, const double*, const double*,
                                     const double* xdd, double* qdd) const {
  for (int i = 0; i < model_of(rm).n; ++i) qdd[i] = xdd[i];
}

void SerialRobot::inverse_dynamics(const RobotModel& rm, RobotData&, const double* x, const double* xd,
                                   const double* xdd, double* tau) const {
  const ChainModel& m = model_of(rm);
  Placed k;
  place(m, x, k, true);
  rnea(m, k, xd, xdd, tau);
}

void SerialRobot::mass_matrix(const RobotModel& rm, RobotData&, const double* x, double* M) const {
  const ChainModel& m = model_of(rm);
  Placed k;
  place(m, x, k, true);
  MatN Mm;
  crba(m, k, Mm);
  Eigen::Map<MatN>(M, m.n, m.n) = Mm;
}

bool SerialRobot::forward_dynamics_response(const RobotModel& rm, RobotData&, const double* x, const double* xd,
                                            const double* tau, double* xdd, double* B) const {
  const ChainModel& m = model_of(rm);
  const int n = m.n;
  Placed k;
  place(m, x, k, true);
  MatN M;
  crba(m, k, M);
  VecN h(n), zero = VecN::Zero(n);
  rnea(m, k, xd, zero.data(), h.data());
  const Eigen::LLT<MatN> llt(M);
  if (llt.info() != Eigen::Success)
    throw Error(PKM_ERR_SINGULAR, "forward dynamics: the mass matrix is not positive definite at this pose");
  Eigen::Map<VecN>(xdd, n) = llt.solve(Eigen::Map<const VecN>(tau, n) - h);
  if (B) Eigen::Map<MatN>(B, n, n) = llt.solve(MatN::Identity(n, n));
  return true;
}

void SerialRobot::forward_dynamics(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                   const double* tau, double* xdd) const {
  forward_dynamics_response(rm, rd, x, xd, tau, xdd, nullptr);
}

void SerialRobot::energy(const RobotModel& rm, RobotData&, const double* x, const double* xd, double* kinetic,
                         double* potential) const {
  const ChainModel& m = model_of(rm);
  Placed k;
  place(m, x, k, true);
  V6 v = V6::Zero();
  double T = 0, U = 0;
  for (int i = 0; i < m.n; ++i) {
    v += k.S[i] * xd[i];
    T += 0.5 * v.dot(k.I[i] * v);  // the payload is in the last link's inertia
    U -= m.j[i].m * m.g.dot(k.com[i]);
  }
  U -= m.m_payload * m.g.dot(k.payload);
  *kinetic = T;
  *potential = U;
}

}  // namespace described
}  // namespace pkm
