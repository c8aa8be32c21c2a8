// Robot-independent kinematics built on a robot's ik, jacobians and jacobian_dot:
// forward kinematics by damped Newton, and joint <-> pose velocity/acceleration maps.
#include <Eigen/Dense>
#include <cmath>
#include <sstream>

#include "common/robot.hpp"
#include "kinematics/generic_kinematics.hpp"

namespace pkm {

using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 6, 6>;
using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;

void Robot::direct_singularity_guard(const RobotModel& rm, RobotData& rd, const double* x, double* measure_bound,
                                     double* det_j) const {
  double meas[2];
  singularity(rm, rd, x, meas);
  *measure_bound = meas[1];
  Mat J(ndof(), ndof());
  jacobians(rm, rd, x, nullptr, nullptr, J.data());
  *det_j = Eigen::PartialPivLU<Mat>(J).determinant();
}

namespace {

// The damped Newton of Robot::fk on n = N coordinates (N fixed: Eigen's fixed-size products
// and factorisation are several times faster than its dynamic ones at these sizes).
template <int N>
void newton_fk(const Robot& robot, const RobotModel& rm, RobotData& rd, const double* q, const double* x_guess,
               const pkm_fk_options& opt, double* x_out, pkm_fk_info& info) {
  using MatN = Eigen::Matrix<double, N, N, Eigen::RowMajor>;
  using VecN = Eigen::Matrix<double, N, 1>;
  VecN x = Eigen::Map<const VecN>(x_guess), qk, r, dx, xt, qt;
  const Eigen::Map<const VecN> qv(q);
  MatN J;
  // The guess itself must be a pose the legs can reach.
  robot.ik(rm, rd, x.data(), qk.data());
  r = qk - qv;
  double rn = r.cwiseAbs().maxCoeff();
  int it = 0;
  for (; it < opt.max_iter && rn > opt.tol; ++it) {
    robot.jacobians(rm, rd, x.data(), nullptr, nullptr, J.data());
    MatN A = J.transpose() * J;
    A.diagonal().array() += opt.damping;
    dx = -A.ldlt().solve(J.transpose() * r);
    if (!dx.allFinite())
      throw Error(PKM_ERR_SINGULAR, "forward kinematics: singular Jacobian at iteration " + std::to_string(it));
    // Backtrack if the full step leaves the workspace or does not reduce the residual.
    double rt = 0;
    const bool accepted = backtracking_step(rn, opt.tol, [&](double step) {
      xt = x + step * dx;
      robot.ik(rm, rd, xt.data(), qt.data());
      return rt = (qt - qv).cwiseAbs().maxCoeff();
    });
    if (!accepted) break;
    x = xt;
    r = qt - qv;
    rn = rt;
  }
  info.iterations = it;
  info.residual = rn;
  if (!(rn <= opt.tol)) {
    std::ostringstream os;
    os.precision(3);
    os << "forward kinematics did not converge: residual " << rn << " after " << it
       << " iterations (tolerance " << opt.tol << "); the joints may be unreachable from this guess";
    throw Error(PKM_ERR_NO_CONVERGENCE, os.str());
  }
  for (int i = 0; i < N; ++i) x_out[i] = x[i];
}

}  // namespace

void Robot::fk(const RobotModel& rm, RobotData& rd, const double* q, const double* x_guess,
               const pkm_fk_options& opt, double* x_out, pkm_fk_info& info) const {
  switch (ndof()) {
    case 1: return newton_fk<1>(*this, rm, rd, q, x_guess, opt, x_out, info);
    case 2: return newton_fk<2>(*this, rm, rd, q, x_guess, opt, x_out, info);
    case 3: return newton_fk<3>(*this, rm, rd, q, x_guess, opt, x_out, info);
    case 4: return newton_fk<4>(*this, rm, rd, q, x_guess, opt, x_out, info);
    case 5: return newton_fk<5>(*this, rm, rd, q, x_guess, opt, x_out, info);
    case 6: return newton_fk<6>(*this, rm, rd, q, x_guess, opt, x_out, info);
  }
  throw Error(PKM_ERR_ARGUMENT, "forward kinematics: " + std::to_string(ndof()) + " coordinates (1 to 6 supported)");
}

void Robot::joint_acceleration(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                               const double* xdd, double* qdd) const {
  const int n = ndof();
  Mat J(n, n), Jd(n, n);
  jacobians(rm, rd, x, nullptr, nullptr, J.data());
  jacobian_dot(rm, rd, x, xd, Jd.data());
  Eigen::Map<Vec>(qdd, n) = J * Eigen::Map<const Vec>(xdd, n) + Jd * Eigen::Map<const Vec>(xd, n);
}

void joint_velocity(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                    double* qd) {
  const int n = r.ndof();
  double J[36];
  r.jacobians(rm, rd, x, nullptr, nullptr, J);
  for (int i = 0; i < n; ++i) {
    double s = 0;
    for (int j = 0; j < n; ++j) s += J[i * n + j] * xd[j];
    qd[i] = s;
  }
}

// Solves J y = b with a singularity check that says so instead of returning garbage.
static void solve_J(const Mat& J, const Vec& b, double* y, const char* what) {
  Eigen::FullPivLU<Mat> lu(J);
  if (!lu.isInvertible() || lu.rcond() < 1e-12)
    throw Error(PKM_ERR_SINGULAR, std::string(what) + ": the Jacobian is singular at this pose");
  Vec v = lu.solve(b);
  for (int i = 0; i < b.size(); ++i) y[i] = v[i];
}

void pose_velocity(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* qd,
                   double* xd) {
  const int n = r.ndof();
  Mat J(n, n);
  r.jacobians(rm, rd, x, nullptr, nullptr, J.data());
  solve_J(J, Eigen::Map<const Vec>(qd, n), xd, "pose velocity");
}

void pose_acceleration(const Robot& r, const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                       const double* qdd, double* xdd) {
  const int n = r.ndof();
  Mat J(n, n), Jd(n, n);
  r.jacobians(rm, rd, x, nullptr, nullptr, J.data());
  r.jacobian_dot(rm, rd, x, xd, Jd.data());
  Vec b = Eigen::Map<const Vec>(qdd, n) - Jd * Eigen::Map<const Vec>(xd, n);
  solve_J(J, b, xdd, "pose acceleration");
}

}  // namespace pkm
