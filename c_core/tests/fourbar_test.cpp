// The four-bar of Vitali 2020 through the C API: the source's tables, dX/dl against central
// finite differences, and errors that name the crank angle.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "pkm/pkm.h"
#include "test_support.hpp"

namespace {

using pkm_test::rad;

struct Fourbar : pkm_test::ModelFixture<> {
  void SetUp() override { open("fourbar"); }
  void set_lengths_mm(const double* l) {
    const char* names[4] = {"link[1].l", "link[2].l", "link[3].l", "link[4].l"};
    for (int j = 0; j < 4; ++j) set(names[j], l[j] * 1e-3);
    validate();
  }
  double X_mm(double theta_deg, double* dX = nullptr) {
    double X = NAN;
    EXPECT_EQ(pkm_fourbar_output(m, d, rad(theta_deg), &X, dX), PKM_OK) << pkm_data_error(d);
    return X * 1e3;
  }
};

// Vitali 2020 ch. 1.1 and appendix, typed from the thesis.  theta = 30..60 deg step 5.
const double kXp[7] = {815.2891, 803.5676, 783.9942, 757.9735, 726.5904, 690.7086, 651.0450};
const double kXpr[7] = {815.6833, 803.9667, 784.3931, 758.3677, 726.9759, 691.0819, 651.4034};
// phi in radians to 4 decimals (appendix "phi" rows; 30 deg from 37.9585 deg of ch. 1.1).
const double kPhiRad[7] = {0.6625, 0.5877, 0.5257, 0.4737, 0.4296, 0.3919, 0.3594};
// Vitali 2020 ch. 4 matrix A (columns dX/dl1..dX/dl4, mm/mm).
const double kA[7][4] = {{1.2343, 0.8090, -0.5164, -0.1379}, {1.1503, 0.7409, -0.4270, -0.1166},
                         {1.0599, 0.6870, -0.3574, -0.0943}, {0.9670, 0.6445, -0.3031, -0.0735},
                         {0.8731, 0.6107, -0.2603, -0.0552}, {0.7787, 0.5836, -0.2264, -0.0393},
                         {0.6839, 0.5616, -0.1992, -0.0257}};

TEST_F(Fourbar, ParameterTableHasTheSourceLengths) {
  ASSERT_EQ(pkm_model_ndof(m), 1);
  // the robot's own table comes first (the drive layer appends joint[1].* etc.)
  ASSERT_GE(pkm_model_nparam(m), 4);
  const double l[4] = {0.600, 0.750, 0.790, 0.900};
  const char* names[4] = {"link[1].l", "link[2].l", "link[3].l", "link[4].l"};
  for (int j = 0; j < 4; ++j) {
    int i = pkm_param_index(m, names[j]);
    ASSERT_EQ(i, j) << names[j];
    EXPECT_DOUBLE_EQ(pkm_param_get(m, i), l[j]);
    EXPECT_STREQ(pkm_param_unit(m, i), "m");
  }
}

TEST_F(Fourbar, ReproducesSourceOutputTableNominal) {
  for (int k = 0; k < 7; ++k) EXPECT_NEAR(X_mm(30 + 5 * k), kXp[k], 0.5e-4) << "theta = " << 30 + 5 * k;
}

TEST_F(Fourbar, ReproducesSourceOutputTableOfTheRealLinkage) {
  const double lr[4] = {600.30, 750.50, 790.55, 900.70};
  set_lengths_mm(lr);
  for (int k = 0; k < 7; ++k) EXPECT_NEAR(X_mm(30 + 5 * k), kXpr[k], 0.5e-4) << "theta = " << 30 + 5 * k;
}

// The coupler angle is not an output; recover it from X = l1 cos(theta) + l2/2 cos(phi)
// (phi > 0 on this branch) and compare with the source's 4-decimal radians.
TEST_F(Fourbar, CouplerAngleOfTheSourceBranch) {
  for (int k = 0; k < 7; ++k) {
    const double th = rad(30 + 5 * k);
    const double X = X_mm(30 + 5 * k);
    const double phi = std::acos((X - 600.0 * std::cos(th)) / 375.0);
    EXPECT_NEAR(phi, kPhiRad[k], 0.5e-4) << "theta = " << 30 + 5 * k;
  }
}

TEST_F(Fourbar, ReproducesSourceJacobianA) {
  for (int k = 0; k < 7; ++k) {
    double dX[4];
    X_mm(30 + 5 * k, dX);
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(dX[j], kA[k][j], 0.5e-4) << "theta = " << 30 + 5 * k << ", l" << j + 1;
  }
}

TEST_F(Fourbar, JacobianMatchesCentralDifferences) {
  const char* names[4] = {"link[1].l", "link[2].l", "link[3].l", "link[4].l"};
  const double h = 1e-6;  // m
  for (double th_deg : {-40.0, 0.0, 12.5, 30.0, 47.0, 60.0, 95.0}) {
    double dX[4], X;
    ASSERT_EQ(pkm_fourbar_output(m, d, rad(th_deg), &X, dX), PKM_OK) << pkm_data_error(d);
    for (int j = 0; j < 4; ++j) {
      const int i = pkm_param_index(m, names[j]);
      const double l0 = pkm_param_get(m, i);
      double Xp, Xm;
      ASSERT_EQ(pkm_param_set(m, i, l0 + h, err, sizeof err), PKM_OK);
      ASSERT_EQ(pkm_model_validate(m, err, sizeof err), PKM_OK) << err;
      ASSERT_EQ(pkm_fourbar_output(m, d, rad(th_deg), &Xp, nullptr), PKM_OK);
      ASSERT_EQ(pkm_param_set(m, i, l0 - h, err, sizeof err), PKM_OK);
      ASSERT_EQ(pkm_model_validate(m, err, sizeof err), PKM_OK) << err;
      ASSERT_EQ(pkm_fourbar_output(m, d, rad(th_deg), &Xm, nullptr), PKM_OK);
      ASSERT_EQ(pkm_param_set(m, i, l0, err, sizeof err), PKM_OK);
      ASSERT_EQ(pkm_model_validate(m, err, sizeof err), PKM_OK) << err;
      EXPECT_NEAR(dX[j], (Xp - Xm) / (2 * h), 1e-7) << "theta = " << th_deg << " deg, l" << j + 1;
    }
  }
}

TEST_F(Fourbar, UnassemblableAngleIsAnErrorNamingTheta) {
  // At theta = 180 deg the crank tip is 1.5 m from D, farther than l2 + l3 = 1.25 m.
  const double l[4] = {600, 750, 500, 900};
  set_lengths_mm(l);
  double X = 123.0;
  int s = pkm_fourbar_output(m, d, rad(180.0), &X, nullptr);
  EXPECT_EQ(s, PKM_ERR_UNREACHABLE);
  const std::string msg = pkm_data_error(d);
  EXPECT_NE(msg.find("theta"), std::string::npos) << msg;
  EXPECT_NE(msg.find("180"), std::string::npos) << msg;
  EXPECT_EQ(X, 123.0) << "a failing call must not write a result";
  double q;
  const double x = rad(180.0);
  EXPECT_EQ(pkm_ik(m, d, &x, &q), PKM_ERR_UNREACHABLE);
  EXPECT_NE(std::string(pkm_data_error(d)).find("theta"), std::string::npos);
}

TEST_F(Fourbar, BadInputsAreErrors) {
  double X;
  EXPECT_EQ(pkm_fourbar_output(m, d, NAN, &X, nullptr), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_data_error(d)).find("theta"), std::string::npos);
  EXPECT_EQ(pkm_fourbar_output(m, d, 0.5, nullptr, nullptr), PKM_ERR_ARGUMENT);
  EXPECT_EQ(pkm_fourbar_output(nullptr, d, 0.5, &X, nullptr), PKM_ERR_ARGUMENT);
  EXPECT_EQ(pkm_fourbar_output(m, nullptr, 0.5, &X, nullptr), PKM_ERR_ARGUMENT);
  // A link longer than the other three together can never close.
  EXPECT_EQ(pkm_param_set(m, pkm_param_index(m, "link[4].l"), 3.0, err, sizeof err), PKM_OK);
  EXPECT_EQ(pkm_model_validate(m, err, sizeof err), PKM_ERR_PARAMETER);
  EXPECT_NE(std::string(err).find("link[4].l"), std::string::npos) << err;
  EXPECT_EQ(pkm_param_set(m, pkm_param_index(m, "link[1].l"), -1.0, err, sizeof err), PKM_ERR_PARAMETER);
}

TEST_F(Fourbar, WrongRobotIsRejected) {
  pkm_model* other = pkm_model_create("6pus", nullptr, err, sizeof err);
  if (!other) GTEST_SKIP() << "no 6pus in this build: " << err;
  pkm_data* od = pkm_data_create(other);
  double X;
  EXPECT_EQ(pkm_fourbar_output(other, od, 0.5, &X, nullptr), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_data_error(od)).find("fourbar"), std::string::npos);
  pkm_data_destroy(od);
  pkm_model_destroy(other);
}

TEST_F(Fourbar, KinematicsIsTheIdentityOnTheCrankAngle) {
  double x[1], q[1], xf[1];
  ASSERT_EQ(pkm_model_home(m, x), PKM_OK);
  EXPECT_NEAR(x[0], rad(30.0), 1e-15);
  ASSERT_EQ(pkm_ik(m, d, x, q), PKM_OK);
  EXPECT_EQ(q[0], x[0]);
  ASSERT_EQ(pkm_fk(m, d, q, x, nullptr, xf, nullptr), PKM_OK) << pkm_data_error(d);
  EXPECT_EQ(xf[0], x[0]);
  double meas[2];
  ASSERT_EQ(pkm_singularity(m, d, x, meas), PKM_OK);
  EXPECT_GT(meas[1], 0.1);
  EXPECT_LE(meas[1], 1.0);
}

// Dead point: coupler and rocker are collinear when the crank tip B is l3 - l2 from D.
// With l = (1, 1, 2, 2) m, at theta = 0 B = (1, 0) is exactly 1 m = l3 - l2 from D = (2, 0).
TEST_F(Fourbar, DeadPointIsASingularityError) {
  const double l[4] = {1000, 1000, 2000, 2000};
  set_lengths_mm(l);
  double X, dX[4], meas[2];
  const double x = 0.0;
  int s = pkm_fourbar_output(m, d, 0.0, &X, dX);
  EXPECT_EQ(s, PKM_ERR_SINGULAR) << pkm_data_error(d);
  EXPECT_NE(std::string(pkm_data_error(d)).find("theta"), std::string::npos);
  ASSERT_EQ(pkm_singularity(m, d, &x, meas), PKM_OK);
  EXPECT_LT(meas[1], 1e-6);
}

}  // namespace
