// Quattro index maps (Virzi 2010 ch. 3-5) through the C API: each column against its
// definition evaluated here from the core's J and M, the GIMRE against the kinetic energy
// of the links computed from finite differences of the joint points, and the batch
// conventions (NaN row + status + first failure) for poses outside the workspace; on the
// robot the core serves from robots/quattro.toml (parameters per arm and leg) and on the
// hand-written test oracle "quattro_hand" (lumped parameters): the bodies are read by each
// model's names.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <string>
#include <tuple>

#include "pkm/pkm.h"
#include "test_support.hpp"

namespace {

using Mat4 = Eigen::Matrix<double, 4, 4, Eigen::RowMajor>;

using RobotSet = std::tuple<const char*, const char*>;

struct QuattroIdx : pkm_test::ModelFixture<::testing::TestWithParam<RobotSet>> {
  bool described = false;
  void SetUp() override {
    open(std::get<0>(GetParam()), std::get<1>(GetParam()));
    described = std::string(std::get<0>(GetParam())) != "quattro_hand";
  }
  // pkm_quattro_constants: 0 the arm torque limit [N m], 3 the link length b_r [m].
  double constant(int i) {
    double c[PKM_QUATTRO_NCONSTANT];
    EXPECT_EQ(pkm_quattro_constants(m, d, c), PKM_OK) << pkm_data_error(d);
    return c[i];
  }
  // The bodies the GIMRE reads, by each model's parameter names: arm mass, its centre of
  // mass from the axis, mass of one arm's forearm rod pair, platform mass.
  double arm_mass() { return param(described ? "arm[1].mass" : "arm.m"); }
  double arm_com() { return param(described ? "arm[1].rc" : "arm.lg"); }
  double rods_mass() { return described ? param("leg[1].m") : 2 * param("forearm.m"); }
  bool centred() { return param(described ? "platform.cx" : "platform.offset") == 0; }
  int col(const char* name) {
    for (int i = 0; i < PKM_QUATTRO_NINDEX; ++i)
      if (std::string(pkm_quattro_index_name(i)) == name) return i;
    ADD_FAILURE() << "no index " << name;
    return 0;
  }
};

TEST_P(QuattroIdx, NamesAndUnits) {
  EXPECT_STREQ(pkm_quattro_index_name(0), "mu_T");
  EXPECT_STREQ(pkm_quattro_index_name(PKM_QUATTRO_NINDEX - 1), "alfa_x");
  EXPECT_STREQ(pkm_quattro_index_unit(col("alfa_z")), "m/s2");
  EXPECT_STREQ(pkm_quattro_index_name(PKM_QUATTRO_NINDEX), "");
  EXPECT_STREQ(pkm_quattro_index_name(-1), "");
}

TEST_P(QuattroIdx, ColumnsFollowTheirDefinitions) {
  const double xs[3][4] = {{0, 0, -1.0, 0}, {0.15, -0.1, -0.92, 0}, {-0.1, 0.2, -1.12, 0.2}};
  const double br = constant(3), lim = constant(0);
  EXPECT_EQ(lim, 50 * 2.39);
  for (auto& x : xs) {
    double out[PKM_QUATTRO_NINDEX];
    int st = -99;
    ASSERT_EQ(pkm_quattro_indices(m, d, 1, x, out, &st), PKM_OK) << pkm_data_error(d);
    EXPECT_EQ(st, PKM_OK);
    Mat4 J, M;
    ASSERT_EQ(pkm_jacobians(m, d, x, nullptr, nullptr, J.data()), PKM_OK);
    ASSERT_EQ(pkm_mass_matrix(m, d, x, M.data()), PKM_OK);
    Eigen::Matrix4d JD = br * J;
    Eigen::Matrix<double, 4, 3> JT = JD.leftCols<3>();
    EXPECT_NEAR(out[col("mu_T")], 1 / std::sqrt((JT.transpose() * JT).determinant()), 1e-10);
    EXPECT_NEAR(out[col("mu_z")], 1 / JD.col(2).norm(), 1e-10);
    // Eigenvalue variant on the z axis equals the sub-matrix one there (source ch. 3.5).
    if (x[0] == 0 && x[1] == 0 && centred()) {
      EXPECT_NEAR(out[col("mu_z_eig")], out[col("mu_z")], 1e-9);
      EXPECT_NEAR(out[col("mu_T_eig")], out[col("mu_T")], 1e-9);
    }
    Eigen::Matrix3d L = M.topLeftCorner<3, 3>();
    EXPECT_NEAR(out[col("kat_z")], L.row(2).norm(), 1e-10);
    EXPECT_NEAR(out[col("kat")], (L.row(0).norm() + L.row(1).norm() + L.row(2).norm()) / 3, 1e-10);
    // alfa: tau = J^-T M a, scaled to the 119.5 N m limit.
    Eigen::Vector4d az(0, 0, 1, 0), ax(-std::sqrt(0.5), -std::sqrt(0.5), 0, 0);
    Eigen::Vector4d tz = J.transpose().partialPivLu().solve(M * az);
    Eigen::Vector4d tx = J.transpose().partialPivLu().solve(M * ax);
    EXPECT_NEAR(out[col("alfa_z")], lim / tz.cwiseAbs().maxCoeff(), 1e-8);
    EXPECT_NEAR(out[col("alfa_x")], lim / tx.cwiseAbs().maxCoeff(), 1e-8);
    // Fcc: J^T (ID(x, v, 0) - ID(x, 0, 0)) at a unit vertical velocity (no friction).
    double t1[4], t0[4], zero[4] = {0, 0, 0, 0}, vz[4] = {0, 0, 1, 0};
    ASSERT_EQ(pkm_inverse_dynamics(m, d, x, vz, zero, t1), PKM_OK);
    ASSERT_EQ(pkm_inverse_dynamics(m, d, x, zero, zero, t0), PKM_OK);
    Eigen::Vector4d dt(t1[0] - t0[0], t1[1] - t0[1], t1[2] - t0[2], t1[3] - t0[3]);
    EXPECT_NEAR(out[col("Fcc_z")], (J.transpose() * dt).head<3>().norm(), 1e-8);
    Eigen::Vector4d g(t0[0], t0[1], t0[2], t0[3]);
    EXPECT_NEAR(out[col("Fgr")], (J.transpose() * g).head<3>().norm(), 1e-8);
    EXPECT_GE(out[col("kappa_T")], 1.0);
    EXPECT_GT(out[col("dTIM")], 0.0);
    EXPECT_LE(out[col("dTIM")], 1.0 + 1e-12);
  }
}

TEST_P(QuattroIdx, GimreIsTheKineticEnergyOfLinksAndPlatform) {
  // Independent bookkeeping: link 1 rotates about A_i with the source's inertia (m_b lg^2 +
  // I_G), each forearm pair is a uniform rod of mass 2 m_c between B_i and C_i, the
  // platform is m_p / 2 at each end of its axis; velocities by finite differences of the
  // points the core reports.
  const double x[4] = {0.08, -0.12, -1.02, 0.15}, v[4] = {0.6, -0.3, 0.9, 2.0}, h = 1e-6;
  Mat4 N;
  ASSERT_EQ(pkm_quattro_gimre(m, d, x, N.data()), PKM_OK) << pkm_data_error(d);
  double xp[4], xm[4];
  for (int j = 0; j < 4; ++j) xp[j] = x[j] + h * v[j], xm[j] = x[j] - h * v[j];
  double Bp[12], Bm[12], Cp[12], Cm[12], qp[4], qm[4];
  ASSERT_EQ(pkm_quattro_points(m, d, xp, nullptr, Bp, Cp), PKM_OK);
  ASSERT_EQ(pkm_quattro_points(m, d, xm, nullptr, Bm, Cm), PKM_OK);
  ASSERT_EQ(pkm_ik(m, d, xp, qp), PKM_OK);
  ASSERT_EQ(pkm_ik(m, d, xm, qm), PKM_OK);
  const double mb = arm_mass(), lg = arm_com(), br = constant(3), mc = rods_mass() / 2, mp = param("platform.m");
  const double I1 = mb * lg * lg + mb * (br * br / 3 - br * lg + lg * lg);
  double T = 0;
  for (int i = 0; i < 4; ++i) {
    const double qd = (qp[i] - qm[i]) / (2 * h);
    T += 0.5 * I1 * qd * qd;
    Eigen::Vector3d vB, vC;
    for (int k = 0; k < 3; ++k) {
      vB[k] = (Bp[3 * i + k] - Bm[3 * i + k]) / (2 * h);
      vC[k] = (Cp[3 * i + k] - Cm[3 * i + k]) / (2 * h);
    }
    T += 2 * mc / 6 * (vB.squaredNorm() + vB.dot(vC) + vC.squaredNorm());
  }
  // The platform axis ends M12 = (C1 + C2)/2 and M34 = (C3 + C4)/2.
  for (int e = 0; e < 2; ++e) {
    Eigen::Vector3d vM;
    for (int k = 0; k < 3; ++k)
      vM[k] = ((Cp[6 * e + k] + Cp[6 * e + 3 + k]) - (Cm[6 * e + k] + Cm[6 * e + 3 + k])) / (4 * h);
    T += 0.5 * (mp / 2) * vM.squaredNorm();
  }
  Eigen::Vector4d vv(v[0], v[1], v[2], v[3]);
  EXPECT_NEAR(0.5 * vv.dot(N * vv), T, 1e-7 * T);
}

TEST_P(QuattroIdx, OutsideTheWorkspaceIsANaNRowWithItsStatus) {
  const double xs[3][4] = {{0, 0, -1.0, 0}, {0.9, 0, -1.0, 0}, {0, 0, -1.5, 0}};
  double out[3][PKM_QUATTRO_NINDEX];
  int st[3];
  EXPECT_EQ(pkm_quattro_indices(m, d, 3, &xs[0][0], &out[0][0], st), PKM_ERR_UNREACHABLE);
  EXPECT_EQ(st[0], PKM_OK);
  EXPECT_EQ(st[1], PKM_ERR_UNREACHABLE);
  EXPECT_EQ(st[2], PKM_ERR_UNREACHABLE);
  for (int k = 0; k < PKM_QUATTRO_NINDEX; ++k) {
    EXPECT_TRUE(std::isfinite(out[0][k])) << pkm_quattro_index_name(k);
    EXPECT_TRUE(std::isnan(out[1][k]));
    EXPECT_TRUE(std::isnan(out[2][k]));
  }
  // the hand-written model names the arm ("item 1: arm 2: ..."), the description the leg
  EXPECT_NE(std::string(pkm_data_error(d)).find(described ? "item 1: leg" : "item 1: arm"), std::string::npos)
      << pkm_data_error(d);
}

TEST_P(QuattroIdx, RefusesAnotherRobot) {
  pkm_model* other = pkm_model_create("6pus", nullptr, err, sizeof err);
  ASSERT_NE(other, nullptr) << err;
  pkm_data* od = pkm_data_create(other);
  double x[6] = {0, 0, 0.085, 0, 0, 0}, out[PKM_QUATTRO_NINDEX];
  EXPECT_EQ(pkm_quattro_indices(other, od, 1, x, out, nullptr), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_data_error(od)).find("quattro"), std::string::npos);
  pkm_data_destroy(od);
  pkm_model_destroy(other);
}

INSTANTIATE_TEST_SUITE_P(Sets, QuattroIdx,
                         ::testing::Combine(::testing::Values("quattro_hand", "quattro"),
                                            ::testing::Values("default", "appendix_a")));

}  // namespace
