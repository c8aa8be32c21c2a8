// The algorithms of a single-axis robot (axis_robot.hpp), over its kind's terms.
#include "description/axis_robot.hpp"

#include <algorithm>
#include <cmath>

namespace pkm {
namespace described {

namespace {

const AxisRobotModel& model_of(const RobotModel& rm) { return static_cast<const AxisRobotModel&>(rm); }

}  // namespace

std::unique_ptr<RobotModel> AxisRobot::compile(const std::vector<ParamSpec>& specs,
                                               const std::vector<double>& values) const {
  const ParamValues v(name(), specs, values);
  auto m = std::make_unique<AxisRobotModel>();
  m->kind = kind_;
  m->a.p = v.vec("leg", 0, "p");
  m->a.continuous = description().continuous;
  kind_->compile(v, m->a);
  if (!m->a.continuous && !(m->a.qmin < m->a.qmax))
    v.bad(joint_limit_param(0, false) + " = " + num(m->a.qmin) + " must be below " + joint_limit_param(0, true) +
          " = " + num(m->a.qmax));
  m->b.m_platform = v("platform.m");
  m->b.I_platform = {v("platform.Ixx"), v("platform.Iyy"), v("platform.Izz")};
  m->b.m_payload = v("payload.m");
  m->b.c_payload = {v("payload.x"), v("payload.y"), v("payload.z")};
  m->b.g = {v("gravity.x"), v("gravity.y"), v("gravity.z")};
  m->M = kind_->inertia(m->a, m->b);
  // Nothing moves with the axis (a carriage without mass, a turntable with every mass on
  // its axis and no inertia about it): the axis would have no dynamics of its own.
  if (!(m->M > 0))
    v.bad(std::string("the ") + kind_->noun() + " carries no inertia along its motion (" + num(m->M) +
          (kind_->angular() ? " kg m2" : " kg") + "): give the platform a mass" +
          (kind_->angular() ? ", an inertia about the axis or a mass off the axis" : ""));
  m->home = description().home[0];
  if (!std::isfinite(m->home)) v.bad("the home pose is not finite");
  if (!(m->home >= m->a.qmin && m->home <= m->a.qmax))
    v.bad("the home pose is not valid: leg 1 joint q = " + num(m->home) + " outside [" + num(m->a.qmin) + ", " +
          num(m->a.qmax) + "]");
  return m;
}

void AxisRobot::home(const RobotModel& rm, double* x) const { x[0] = model_of(rm).home; }

std::string AxisRobot::joint_limit_param(int i, bool upper) const {
  return description().continuous ? std::string() : DescribedRobot::joint_limit_param(i, upper);
}

void AxisRobot::platform_pose(const RobotModel& rm, RobotData&, const double* x, double* X, double* S) const {
  // X = (o, rx, ry, rz) with R = Rx(rx) Ry(ry) Rz(rz).  An axis along a world axis (a
  // rail's R = I, a shaft along x, y or z) turns that one angle by q, unwrapped; another
  // axis gives the angles of R, their rates from w = k qd through the Euler-rate map
  // E = [ex, Rx ey, Rx Ry ez] (singular at ry = +-pi/2: refused there).
  const AxisRobotModel& m = model_of(rm);
  Eigen::Vector3d o;
  Eigen::Matrix3d R;
  kind_->place(m.a, x[0], o, R);
  // do/dq: a rail moves o along s; a shaft turns o about k (o = A - R p).
  const Eigen::Vector3d dodq = kind_->angular() ? Eigen::Vector3d(-m.a.dir.cross(R * m.a.p)) : m.a.dir;
  Eigen::Vector3d ang = Eigen::Vector3d::Zero(), dang = Eigen::Vector3d::Zero();
  if (kind_->angular()) {
    int along = -1;
    for (int c = 0; c < 3; ++c)
      if (std::abs(std::abs(m.a.dir[c]) - 1) < 1e-12) along = c;
    if (along >= 0) {
      const double sgn = m.a.dir[along] > 0 ? 1 : -1;
      ang[along] = sgn * x[0], dang[along] = sgn;
    } else {
      ang[1] = std::asin(std::clamp(R(0, 2), -1.0, 1.0));
      ang[0] = std::atan2(-R(1, 2), R(2, 2));
      ang[2] = std::atan2(-R(0, 1), R(0, 0));
      const Eigen::Matrix3d Rx = Eigen::AngleAxisd(ang[0], Eigen::Vector3d::UnitX()).toRotationMatrix();
      const Eigen::Matrix3d Ry = Eigen::AngleAxisd(ang[1], Eigen::Vector3d::UnitY()).toRotationMatrix();
      Eigen::Matrix3d E;
      E << Eigen::Vector3d::UnitX(), Rx * Eigen::Vector3d::UnitY(), Rx * Ry * Eigen::Vector3d::UnitZ();
      if (std::abs(std::cos(ang[1])) < 1e-9)
        throw Error(PKM_ERR_SINGULAR, "the platform's angles (rx, ry, rz) are singular at q = " + num(x[0]) +
                                          " (ry = +-pi/2): no rates");
      dang = E.lu().solve(m.a.dir);
    }
  }
  for (int k = 0; k < 3; ++k) X[k] = o[k], X[3 + k] = ang[k];
  if (!S) return;
  for (int k = 0; k < 3; ++k) S[k] = dodq[k], S[3 + k] = dang[k];
}

void AxisRobot::ik(const RobotModel& rm, RobotData&, const double* x, double* q) const {
  const AxisRobotModel& m = model_of(rm);
  if (!std::isfinite(x[0])) throw Error(PKM_ERR_ARGUMENT, std::string("pose ") + pose_name(0) + " is not finite");
  if (x[0] < m.a.qmin || x[0] > m.a.qmax)
    throw Error(PKM_ERR_JOINT_LIMIT, "leg 1 joint q = " + num(x[0]) + " outside [" + num(m.a.qmin) + ", " +
                                         num(m.a.qmax) + "] at pose (" + pose_name(0) + ") = (" + num(x[0]) + ")");
  q[0] = x[0];
}

void AxisRobot::fk(const RobotModel&, RobotData&, const double* q, const double*, const pkm_fk_options&,
                   double* x, pkm_fk_info& info) const {
  x[0] = q[0];
  info.iterations = 0;
  info.residual = 0;
}

void AxisRobot::jacobians(const RobotModel&, RobotData&, const double*, double* Jx, double* Jq, double* J) const {
  if (Jx) Jx[0] = 1;
  if (Jq) Jq[0] = 1;
  if (J) J[0] = 1;
}

void AxisRobot::jacobian_dot(const RobotModel&, RobotData&, const double*, const double*, double* Jdot) const {
  Jdot[0] = 0;
}

void AxisRobot::singularity(const RobotModel&, RobotData&, const double*, double* measures) const {
  measures[0] = measures[1] = 1;  // the joint is the coordinate: never singular
}

void AxisRobot::direct_singularity_guard(const RobotModel&, RobotData&, const double*, double* measure_bound,
                                         double* det_j) const {
  *measure_bound = 1;
  *det_j = 1;
}

void AxisRobot::chain_points(const RobotModel& rm, RobotData&, const double* x, double* pts) const {
  // Base (the rail's origin, the axis point), the joint's moving point, the platform origin.
  const AxisRobotModel& m = model_of(rm);
  Eigen::Vector3d o;
  Eigen::Matrix3d R;
  kind_->place(m.a, x[0], o, R);
  const Eigen::Vector3d rows[3] = {m.a.base, kind_->joint_point(m.a, x[0]), o};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) pts[3 * r + c] = rows[r][c];
}

void AxisRobot::joint_acceleration(const RobotModel&, RobotData&, const double*, const double*, const double* xdd,
                                   double* qdd) const {
  qdd[0] = xdd[0];
}

void AxisRobot::inverse_dynamics(const RobotModel& rm, RobotData&, const double* x, const double*,
                                 const double* xdd, double* tau) const {
  const AxisRobotModel& m = model_of(rm);
  tau[0] = m.M * xdd[0] - kind_->gravity(m.a, m.b, x[0]);
}

void AxisRobot::mass_matrix(const RobotModel& rm, RobotData&, const double*, double* M) const {
  M[0] = model_of(rm).M;
}

bool AxisRobot::forward_dynamics_response(const RobotModel& rm, RobotData&, const double* x, const double*,
                                          const double* tau, double* xdd, double* B) const {
  const AxisRobotModel& m = model_of(rm);
  xdd[0] = (tau[0] + kind_->gravity(m.a, m.b, x[0])) / m.M;
  if (B) B[0] = 1 / m.M;
  return true;
}

void AxisRobot::forward_dynamics(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                 const double* tau, double* xdd) const {
  forward_dynamics_response(rm, rd, x, xd, tau, xdd, nullptr);
}

void AxisRobot::energy(const RobotModel& rm, RobotData&, const double* x, const double* xd, double* kinetic,
                       double* potential) const {
  // The potential from the bodies' places (not from the kind's G): the tests' energy
  // balance then checks G against the geometry.
  const AxisRobotModel& m = model_of(rm);
  Eigen::Vector3d o;
  Eigen::Matrix3d R;
  kind_->place(m.a, x[0], o, R);
  *kinetic = 0.5 * m.M * xd[0] * xd[0];
  *potential = -m.b.g.dot(m.b.m_platform * o + m.b.m_payload * (o + R * m.b.c_payload));
}

}  // namespace described
}  // namespace pkm
