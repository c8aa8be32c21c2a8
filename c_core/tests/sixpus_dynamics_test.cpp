// 6-PUS dynamics through the C API: forward(inverse) round trips, the mass matrix
// against the kinetic energy and the inverse dynamics, power balance along a
// trajectory (an independent check of the inverse dynamics through the energy), the
// gravity load by virtual work, holding still, friction and payload.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "pkm/pkm.h"
#include "test_support.hpp"

namespace {

using pkm_test::central_difference;
using pkm_test::rad;

using Mat6 = Eigen::Matrix<double, 6, 6, Eigen::RowMajor>;
using Vec6 = Eigen::Matrix<double, 6, 1>;

struct Dyn : pkm_test::ModelFixture<> {
  void SetUp() override {
    rng.seed(777);
    open("6pus");
  }
  // A payload off the platform centre (the offset makes its rotation matter).
  void payload() {
    set("payload.m", 0.2);
    set("payload.x", 0.01);
    set("payload.y", -0.02);
    set("payload.z", 0.03);
    validate();
  }
  Vec6 pose() {
    for (;;) {
      Vec6 x, q;
      x << uni(-0.04, 0.04), uni(-0.04, 0.04), uni(0.03, 0.1), rad(uni(-5, 5)), rad(uni(-5, 5)), rad(uni(-5, 5));
      if (pkm_ik(m, d, x.data(), q.data()) == PKM_OK) return x;
    }
  }
  Vec6 vel() {
    Vec6 v;
    v << uni(-0.3, 0.3), uni(-0.3, 0.3), uni(-0.3, 0.3), uni(-2, 2), uni(-2, 2), uni(-2, 2);
    return v;
  }
  Vec6 acc() {
    Vec6 a;
    a << uni(-5, 5), uni(-5, 5), uni(-5, 5), uni(-50, 50), uni(-50, 50), uni(-50, 50);
    return a;
  }
  Vec6 ID(const Vec6& x, const Vec6& xd, const Vec6& xdd) {
    Vec6 tau;
    EXPECT_EQ(pkm_inverse_dynamics(m, d, x.data(), xd.data(), xdd.data(), tau.data()), PKM_OK) << pkm_data_error(d);
    return tau;
  }
  Vec6 FD(const Vec6& x, const Vec6& xd, const Vec6& tau) {
    Vec6 xdd;
    EXPECT_EQ(pkm_forward_dynamics(m, d, x.data(), xd.data(), tau.data(), xdd.data()), PKM_OK) << pkm_data_error(d);
    return xdd;
  }
  Mat6 M(const Vec6& x) {
    Mat6 mm;
    EXPECT_EQ(pkm_mass_matrix(m, d, x.data(), mm.data()), PKM_OK) << pkm_data_error(d);
    return mm;
  }
  Mat6 J(const Vec6& x) {
    Mat6 j;
    EXPECT_EQ(pkm_jacobians(m, d, x.data(), nullptr, nullptr, j.data()), PKM_OK) << pkm_data_error(d);
    return j;
  }
  double KE(const Vec6& x, const Vec6& xd) {
    double k = NAN, p = NAN;
    EXPECT_EQ(pkm_energy(m, d, x.data(), xd.data(), &k, &p), PKM_OK);
    return k;
  }
  double PE(const Vec6& x) {
    double k = NAN, p = NAN;
    Vec6 z = Vec6::Zero();
    EXPECT_EQ(pkm_energy(m, d, x.data(), z.data(), &k, &p), PKM_OK);
    return p;
  }
};

double rel(const Vec6& a, const Vec6& b) { return (a - b).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff(); }

TEST_F(Dyn, ForwardOfInverseReturnsTheAcceleration) {
  // With gravity, payload, and rail friction away from qd = 0 (the drive layer's).
  payload();
  for (int i = 1; i <= 6; ++i) {
    set("rail[" + std::to_string(i) + "].coulomb", 1.5 + 0.1 * i);
    set("rail[" + std::to_string(i) + "].viscous", 4.0);
  }
  validate();
  double worst = 0;
  for (int t = 0; t < 1000; ++t) {
    Vec6 x = pose(), xd = vel(), xdd = acc();
    Vec6 tau = ID(x, xd, xdd);
    ASSERT_TRUE(tau.allFinite());
    worst = std::max(worst, rel(FD(x, xd, tau), xdd));
  }
  EXPECT_LT(worst, 1e-9);
}

TEST_F(Dyn, BatchedCallsAgreeWithSingleOnes) {
  payload();
  const int n = 200;
  Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor> X(n, 6), XD(n, 6), XDD(n, 6), T(n, 6), A(n, 6);
  for (int k = 0; k < n; ++k) X.row(k) = pose(), XD.row(k) = vel(), XDD.row(k) = acc();
  ASSERT_EQ(pkm_inverse_dynamics_batch(m, d, n, X.data(), XD.data(), XDD.data(), T.data(), nullptr), PKM_OK);
  ASSERT_EQ(pkm_forward_dynamics_batch(m, d, n, X.data(), XD.data(), T.data(), A.data(), nullptr), PKM_OK);
  for (int k = 0; k < n; ++k) {
    EXPECT_EQ(Vec6(T.row(k)), ID(X.row(k), XD.row(k), XDD.row(k)));
    EXPECT_LT(rel(A.row(k), XDD.row(k)), 1e-9);
  }
}

TEST_F(Dyn, MassMatrixIsSymmetricPositiveDefiniteAndGivesTheKineticEnergy) {
  payload();
  for (int t = 0; t < 200; ++t) {
    Vec6 x = pose(), xd = vel();
    Mat6 mm = M(x);
    EXPECT_LT((mm - mm.transpose()).cwiseAbs().maxCoeff(), 1e-15 * mm.cwiseAbs().maxCoeff());
    Eigen::SelfAdjointEigenSolver<Mat6> es(mm);
    EXPECT_GT(es.eigenvalues().minCoeff(), 0.0);
    // energy() sums the bodies' kinetic energies from their own velocities.
    const double k = KE(x, xd), kq = 0.5 * xd.dot(mm * xd);
    EXPECT_NEAR(k, kq, 1e-12 * kq);
  }
}

TEST_F(Dyn, MassMatrixColumnsAreTheInverseDynamicsOfUnitAccelerations) {
  // Without gravity, at rest: J^T ID(x, 0, e_k) = M e_k.
  payload();
  set("gravity.z", 0.0);
  validate();
  for (int t = 0; t < 50; ++t) {
    Vec6 x = pose();
    Mat6 mm = M(x), fromID;
    for (int k = 0; k < 6; ++k) fromID.col(k) = J(x).transpose() * ID(x, Vec6::Zero(), Vec6::Unit(k));
    EXPECT_LT((fromID - mm).cwiseAbs().maxCoeff(), 1e-12 * mm.cwiseAbs().maxCoeff());
  }
}

TEST_F(Dyn, PowerBalanceAlongATrajectory) {
  // d(KE + PE)/dt = tau . qd with no friction: the energy (body velocities, heights)
  // checks the inverse dynamics independently.  x(t) = x + xd t + xdd t^2 / 2.
  payload();
  double worst = 0;
  for (int t = 0; t < 200; ++t) {
    Vec6 x = pose(), xd = vel(), xdd = acc();
    Vec6 tau = ID(x, xd, xdd);
    Vec6 qd;
    ASSERT_EQ(pkm_joint_velocity(m, d, x.data(), xd.data(), qd.data()), PKM_OK);
    const double h = 1e-6;
    auto E = [&](double s) {
      Vec6 xs = x + s * xd + 0.5 * s * s * xdd, xds = xd + s * xdd;
      return KE(xs, xds) + PE(xs);
    };
    // Richardson extrapolation of central differences: error O(h^4).
    const double d1 = central_difference(E, h), d2 = central_difference(E, 2 * h);
    const double dEdt = (4 * d1 - d2) / 3;
    const double power = tau.dot(qd);
    // Scale: the largest single term of the power.
    const double scale = (tau.cwiseProduct(qd)).cwiseAbs().maxCoeff();
    double meas[2];
    ASSERT_EQ(pkm_singularity(m, d, x.data(), meas), PKM_OK);
    EXPECT_NEAR(dEdt, power, 1e-6 * scale) << "state " << t << ", type-1 measure " << meas[0];
    worst = std::max(worst, std::abs(dEdt - power) / scale);
  }
  std::printf("power balance: worst |dE/dt - tau.qd| / max|tau_i qd_i| = %.2e\n", worst);
}

TEST_F(Dyn, GravityLoadIsTheVirtualWorkOfThePotential) {
  // Holding efforts g at x: tau . dq = dPE for every virtual displacement, i.e.
  // J^T g = dPE/dx (central differences of the potential energy).
  payload();
  for (int t = 0; t < 100; ++t) {
    Vec6 x = pose(), g, dPE;
    ASSERT_EQ(pkm_gravity_load(m, d, x.data(), g.data()), PKM_OK);
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) dPE[k] = central_difference([&](double s) { return PE(x + s * Vec6::Unit(k)); }, h);
    EXPECT_LT(rel(J(x).transpose() * g, dPE), 1e-6);
  }
}

TEST_F(Dyn, HeldByTheGravityLoadTheRobotStaysStill) {
  payload();
  for (int t = 0; t < 100; ++t) {
    Vec6 x = pose(), g;
    ASSERT_EQ(pkm_gravity_load(m, d, x.data(), g.data()), PKM_OK);
    EXPECT_EQ(g, ID(x, Vec6::Zero(), Vec6::Zero()));
    Vec6 a = FD(x, Vec6::Zero(), g);
    EXPECT_LT(a.cwiseAbs().maxCoeff(), 1e-9 * 9.81);
    // Without the holding force it falls: the vertical acceleration is downwards.
    Vec6 a0 = FD(x, Vec6::Zero(), Vec6::Zero());
    EXPECT_LT(a0[2], -1.0);
  }
}

TEST_F(Dyn, GravityLoadOfThePlatformAloneBalancesItsWeight) {
  // Massless legs and sliders: the actuators hold the platform's weight m g through the
  // legs and the rails.  The vertical force the mechanism puts on the platform is
  // sum_i (w_i / (s_i . w_i)) tau_i  (J^T tau, translational part) = m g.
  for (int i = 1; i <= 6; ++i) {
    set("leg[" + std::to_string(i) + "].m", 0.0);
    set("slider[" + std::to_string(i) + "].m", 0.0);
  }
  validate();
  for (int t = 0; t < 20; ++t) {
    Vec6 x = pose(), g;
    ASSERT_EQ(pkm_gravity_load(m, d, x.data(), g.data()), PKM_OK);
    Vec6 Q = J(x).transpose() * g;
    EXPECT_NEAR(Q[0], 0.0, 1e-12);
    EXPECT_NEAR(Q[1], 0.0, 1e-12);
    EXPECT_NEAR(Q[2], 0.35 * 9.81, 1e-12);
    // The platform centre is its CoM: gravity has no moment about it.
    EXPECT_NEAR(Q.tail<3>().cwiseAbs().maxCoeff(), 0.0, 1e-12);
  }
}

TEST_F(Dyn, FrictionAddsAgainstTheMotion) {
  Vec6 x = pose(), xd = vel(), xdd = acc(), qd;
  ASSERT_EQ(pkm_joint_velocity(m, d, x.data(), xd.data(), qd.data()), PKM_OK);
  Vec6 tau0 = ID(x, xd, xdd);
  for (int i = 1; i <= 6; ++i) set("rail[" + std::to_string(i) + "].viscous", 3.0);
  validate();
  Vec6 tau1 = ID(x, xd, xdd);
  // Viscous friction: the actuator supplies 3 qd more, along the motion.
  EXPECT_LT(rel(tau1 - tau0, 3.0 * qd), 1e-12);
}

TEST_F(Dyn, AConstantOffsetIsAnEffortTheDriveSuppliesWhateverTheMotion) {
  // rail[i].offset: the drive supplies inverse dynamics + friction + offset; holding still
  // needs it too, and the forward dynamics spends it before the mechanism sees the rest.
  Vec6 x = pose(), xd = vel(), xdd = acc(), g0, g1, off;
  off << 0.5, -0.25, 0.0, 1.5, -2.0, 0.125;
  Vec6 tau0 = ID(x, xd, xdd), zero0 = ID(x, Vec6::Zero(), Vec6::Zero());
  ASSERT_EQ(pkm_gravity_load(m, d, x.data(), g0.data()), PKM_OK);
  Vec6 fd0 = FD(x, xd, tau0 - off);
  for (int i = 1; i <= 6; ++i) set("rail[" + std::to_string(i) + "].offset", off[i - 1]);
  validate();
  EXPECT_LT((ID(x, xd, xdd) - tau0 - off).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((ID(x, Vec6::Zero(), Vec6::Zero()) - zero0 - off).cwiseAbs().maxCoeff(), 1e-12);
  ASSERT_EQ(pkm_gravity_load(m, d, x.data(), g1.data()), PKM_OK);
  EXPECT_LT((g1 - g0 - off).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(FD(x, Vec6::Zero(), g1).cwiseAbs().maxCoeff(), 1e-9 * 9.81);
  // the command tau0 with the offset moves it as tau0 - offset without
  EXPECT_LT(rel(FD(x, xd, tau0), fd0), 1e-12);
  EXPECT_LT(rel(FD(x, xd, tau0 + off), xdd), 1e-9);
  // the friction call reports it (the part of the effort not reaching the mechanism)
  Vec6 f, qd = Vec6::Zero();
  ASSERT_EQ(pkm_joint_friction(m, d, qd.data(), f.data()), PKM_OK);
  EXPECT_EQ(f, off);
}

TEST_F(Dyn, PayloadWeighsWhereItIs) {
  // A payload at rest adds exactly its weight to the generalised gravity force, with
  // the moment of its offset: J^T (g_with - g_without) = (0, 0, m g, dPE/dangles).
  Vec6 x = pose(), g0, g1;
  ASSERT_EQ(pkm_gravity_load(m, d, x.data(), g0.data()), PKM_OK);
  payload();
  ASSERT_EQ(pkm_gravity_load(m, d, x.data(), g1.data()), PKM_OK);
  Vec6 Q = J(x).transpose() * (g1 - g0);
  EXPECT_NEAR(Q[0], 0.0, 1e-12);
  EXPECT_NEAR(Q[1], 0.0, 1e-12);
  EXPECT_NEAR(Q[2], 0.2 * 9.81, 1e-12);
  EXPECT_GT(Q.tail<3>().cwiseAbs().maxCoeff(), 1e-4);  // the offset gives a moment
}

TEST_F(Dyn, ErrorsAreReportedNotNaN) {
  Vec6 x = pose(), xd = vel(), tau = Vec6::Zero(), out = Vec6::Constant(7);
  xd[3] = NAN;
  EXPECT_EQ(pkm_forward_dynamics(m, d, x.data(), xd.data(), tau.data(), out.data()), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_data_error(d)).find("xd"), std::string::npos);
  x[2] = 0.3;  // unreachable
  xd = vel();
  EXPECT_EQ(pkm_inverse_dynamics(m, d, x.data(), xd.data(), tau.data(), out.data()), PKM_ERR_UNREACHABLE);
  EXPECT_EQ(pkm_forward_dynamics(m, d, x.data(), xd.data(), tau.data(), out.data()), PKM_ERR_UNREACHABLE);
  EXPECT_NE(std::string(pkm_data_error(d)).find("leg"), std::string::npos);
  Mat6 mm;
  EXPECT_EQ(pkm_mass_matrix(m, d, x.data(), mm.data()), PKM_ERR_UNREACHABLE);
  double k, p;
  EXPECT_EQ(pkm_energy(m, d, x.data(), xd.data(), &k, &p), PKM_ERR_UNREACHABLE);
}

}  // namespace
