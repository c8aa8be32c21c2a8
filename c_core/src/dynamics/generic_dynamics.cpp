// Robot-independent forward dynamics from the mass matrix and the inverse dynamics.
//
// Virtual power gives J^T tau = M(x) xdd + h(x, xd), with h = J^T ID(x, xd, 0), so
// xdd = M^-1 (J^T tau - h).  A robot may override it with a faster specialised form.
#include <Eigen/Dense>

#include "common/robot.hpp"

namespace pkm {

using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 6, 6>;
using Vec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;

void Robot::forward_dynamics(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                             const double* tau, double* xdd) const {
  generic_forward_dynamics(rm, rd, x, xd, tau, xdd, nullptr);
}

void Robot::generic_forward_dynamics(const RobotModel& rm, RobotData& rd, const double* x, const double* xd,
                                     const double* tau, double* xdd, double* B) const {
  const int n = ndof();
  Mat J(n, n), M(n, n);
  Vec zero = Vec::Zero(n), h0(n);
  jacobians(rm, rd, x, nullptr, nullptr, J.data());
  mass_matrix(rm, rd, x, M.data());
  inverse_dynamics(rm, rd, x, xd, zero.data(), h0.data());
  Vec rhs = J.transpose() * (Eigen::Map<const Vec>(tau, n) - h0);
  Eigen::LLT<Mat> llt(M);
  if (llt.info() != Eigen::Success)
    throw Error(PKM_ERR_SINGULAR, "forward dynamics: the mass matrix is not positive definite at this pose");
  Eigen::Map<Vec>(xdd, n) = llt.solve(rhs);
  if (B) Eigen::Map<Mat>(B, n, n) = llt.solve(Mat(J.transpose()));  // d xdd / d tau = M^-1 J^T
}

}  // namespace pkm
