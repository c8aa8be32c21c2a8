// Quattro (Virzi 2010) kinematics through the C API: the closure equations of the source
// (eqs. 2.6-2.9, typed here independently of the core), Jx / Jq / J and dJ/dt against
// central finite differences, IK/FK round trip, the root choice, and errors naming the arm;
// on the robot the core serves from robots/quattro.toml and on the hand-written test oracle
// "quattro_hand" (c_core/tests/oracles/), each read by its own parameter names.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <tuple>
#include <vector>

#include "pkm/pkm.h"
#include "test_support.hpp"

namespace {

using pkm_test::kPi;

using RobotSet = std::tuple<const char*, const char*>;

struct Quattro : pkm_test::ModelFixture<::testing::TestWithParam<RobotSet>> {
  bool hand = false;
  void SetUp() override {
    open(std::get<0>(GetParam()), std::get<1>(GetParam()));
    hand = std::string(std::get<0>(GetParam())) == "quattro_hand";
  }
  bool appendix() { return std::string(std::get<1>(GetParam())) == "appendix_a"; }
  // The source's symbols (Virzi 2010 ch. 1.5) from each model's parameters: the description
  // has them per arm and leg (arm 1 lies along +x), the hand-written model lumped.
  double base_a() { return param(hand ? "base.a" : "arm[1].Ax"); }
  double base_h() { return hand ? param("base.h") : -param("arm[1].Az"); }
  double arm_b() { return hand ? std::hypot(param("arm.b_r"), param("arm.r_b")) : param("arm[1].r"); }
  double forearm_c() { return param(hand ? "forearm.c" : "leg[1].L"); }
  double platform_d() { return hand ? param("platform.d") : 2 * param("platform.ends"); }
  double offset() { return param(hand ? "platform.offset" : "platform.cx"); }
  double tool_length() { return hand ? param("tool.length") : 0.0; }
  std::string qmin_name() { return hand ? "joint.q_min" : "arm[1].qmin"; }
  double constant(int i) {
    double c[PKM_QUATTRO_NCONSTANT];
    EXPECT_EQ(pkm_quattro_constants(m, d, c), PKM_OK) << pkm_data_error(d);
    return c[i];
  }
  // Poses spread over the useful workspace (tool point, theta), all reachable.
  std::vector<std::vector<double>> poses() {
    return {{0.0, 0.0, -0.95, 0.0}, {0.12, -0.05, -1.0, 0.1}, {-0.2, 0.15, -0.9, -0.2},
            {0.05, 0.25, -1.1, 0.3}, {-0.1, -0.1, -0.80, 0.05}, {0.3, 0.0, -1.05, -0.1}};
  }
  // Source eqs. 2.6-2.9: F_i(q, x) = |C_i - B_i|^2 - c^2 with the source's coordinates
  // x0 = x + offset cos(pi/4 + th), y0 = ..., z0 = z + base + ee (ch. 1.5).  The description
  // writes each closure as half of that, (|C_i - B_i|^2 - c^2) / 2: its Jx and Jq are half the
  // source's (J = Jq^-1 Jx the same), so the closure is scaled by each model's convention.
  void source_closure(const double* q, const double* x, double* F) {
    const double a = base_a(), base = base_h(), b = arm_b(), c = forearm_c(), dd = platform_d(), off = offset(),
                 ee = tool_length();
    const double th = x[3], ps = kPi / 4 + th, r2 = std::sqrt(2.0) / 2;
    const double x0 = x[0] + off * std::cos(ps), y0 = x[1] + off * std::sin(ps), z0 = x[2] + base + ee;
    const double cp = dd / 2 * std::cos(ps), sp = dd / 2 * std::sin(ps), h = dd / 2 * r2;
    auto sq = [](double v) { return v * v; };
    F[0] = sq(x0 + cp + h - (a + b * std::cos(q[0]))) + sq(y0 + sp - h) + sq(z0 + b * std::sin(q[0])) - c * c;
    F[1] = sq(x0 + cp - h) + sq(y0 + sp + h - (a + b * std::cos(q[1]))) + sq(z0 + b * std::sin(q[1])) - c * c;
    F[2] = sq(x0 - cp - h + (a + b * std::cos(q[2]))) + sq(y0 - sp + h) + sq(z0 + b * std::sin(q[2])) - c * c;
    F[3] = sq(x0 - cp + h) + sq(y0 - sp - h + (a + b * std::cos(q[3]))) + sq(z0 + b * std::sin(q[3])) - c * c;
    for (int i = 0; i < 4; ++i) F[i] *= hand ? 1.0 : 0.5;
  }
};

TEST_P(Quattro, ParameterSetsCarryTheSourceValues) {
  EXPECT_EQ(pkm_model_ndof(m), 4);
  const bool app = appendix();
  EXPECT_DOUBLE_EQ(base_a(), app ? 0.28 : 0.275);
  EXPECT_DOUBLE_EQ(base_h(), app ? 0.20 : 0.19);
  EXPECT_DOUBLE_EQ(param("platform.m"), app ? 2.62 : 0.262);
  EXPECT_DOUBLE_EQ(param(hand ? "arm.m" : "arm[1].mass"), app ? 1.85 : 1.45);
  EXPECT_DOUBLE_EQ(offset(), app ? 0.0 : 0.075);
  EXPECT_NEAR(constant(3), 0.375, 1e-15);  // link length b_r
  EXPECT_NEAR(arm_b(), std::hypot(0.375, 0.028), 1e-15);
  EXPECT_DOUBLE_EQ(forearm_c(), 0.825);
  EXPECT_DOUBLE_EQ(constant(0), 119.5);  // arm-side torque limit: 50 x 2.39 N m
  EXPECT_NEAR(param(qmin_name()) * 180 / kPi, -51, 1e-12);
  EXPECT_NEAR(param(hand ? "joint.q_max" : "arm[1].qmax") * 180 / kPi, 123, 1e-12);
}

TEST_P(Quattro, IkSatisfiesTheSourceClosureEquations) {
  for (auto& x : poses()) {
    double q[4], F[4];
    ASSERT_EQ(pkm_ik(m, d, x.data(), q), PKM_OK) << pkm_data_error(d);
    source_closure(q, x.data(), F);
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(F[i], 0.0, 1e-12) << "arm " << i + 1;
  }
}

TEST_P(Quattro, IkTakesTheSourceRootElbowOut) {
  // Source ch. 1.4.1: of the two roots of each arm's closure, the larger x_B for arm 1
  // (smaller for arm 3; y_B for arms 2, 4), i.e. the larger cos q: the elbow out.  Both
  // roots are found here by scanning the source's closure equation over q.
  for (auto& x : poses()) {
    double q[4];
    ASSERT_EQ(pkm_ik(m, d, x.data(), q), PKM_OK);
    for (int i = 0; i < 4; ++i) {
      std::vector<double> roots;
      const int n = 20000;
      double qq[4] = {q[0], q[1], q[2], q[3]}, F0[4], F1[4];
      for (int k = 0; k < n; ++k) {
        const double a0 = -kPi + 2 * kPi * k / n, a1 = -kPi + 2 * kPi * (k + 1) / n;
        qq[i] = a0;
        source_closure(qq, x.data(), F0);
        qq[i] = a1;
        source_closure(qq, x.data(), F1);
        if (F0[i] * F1[i] <= 0) roots.push_back(0.5 * (a0 + a1));
      }
      ASSERT_EQ(roots.size(), 2u) << "arm " << i + 1;
      const double chosen = std::fabs(roots[0] - q[i]) < std::fabs(roots[1] - q[i]) ? roots[0] : roots[1];
      const double other = chosen == roots[0] ? roots[1] : roots[0];
      EXPECT_NEAR(chosen, q[i], 2 * kPi / n) << "arm " << i + 1;
      EXPECT_GT(std::cos(chosen), std::cos(other)) << "arm " << i + 1;
    }
  }
}

TEST_P(Quattro, JacobiansMatchFiniteDifferences) {
  const double h = 1e-6;
  for (auto& x : poses()) {
    double Jx[16], Jq[16], J[16], q[4];
    ASSERT_EQ(pkm_jacobians(m, d, x.data(), Jx, Jq, J), PKM_OK) << pkm_data_error(d);
    ASSERT_EQ(pkm_ik(m, d, x.data(), q), PKM_OK);
    for (int j = 0; j < 4; ++j) {
      std::vector<double> xp = x, xm = x;
      xp[j] += h;
      xm[j] -= h;
      double qp[4], qm[4], Fp[4], Fm[4];
      ASSERT_EQ(pkm_ik(m, d, xp.data(), qp), PKM_OK);
      ASSERT_EQ(pkm_ik(m, d, xm.data(), qm), PKM_OK);
      source_closure(q, xp.data(), Fp);
      source_closure(q, xm.data(), Fm);
      for (int i = 0; i < 4; ++i) {
        const double fd = (qp[i] - qm[i]) / (2 * h);
        EXPECT_NEAR(J[4 * i + j], fd, 1e-6 * std::max(1.0, std::fabs(fd))) << "J " << i << j;
        const double fdx = (Fp[i] - Fm[i]) / (2 * h);  // Jx = dF/dx (source eq. 2.2)
        EXPECT_NEAR(Jx[4 * i + j], fdx, 1e-6 * std::max(1.0, std::fabs(fdx))) << "Jx " << i << j;
      }
    }
    for (int i = 0; i < 4; ++i) {  // Jq = -dF/dq, diagonal
      double qp[4], qm[4], Fp[4], Fm[4];
      for (int k = 0; k < 4; ++k) qp[k] = qm[k] = q[k];
      qp[i] += h;
      qm[i] -= h;
      source_closure(qp, x.data(), Fp);
      source_closure(qm, x.data(), Fm);
      for (int k = 0; k < 4; ++k) {
        const double fd = -(Fp[k] - Fm[k]) / (2 * h);
        EXPECT_NEAR(Jq[4 * k + i], fd, 1e-6 * std::max(1.0, std::fabs(fd))) << "Jq " << k << i;
      }
    }
  }
}

TEST_P(Quattro, JacobianDotMatchesFiniteDifferences) {
  const double h = 1e-6;
  const double xd[4] = {0.7, -0.4, 1.1, 2.0};
  for (auto& x : poses()) {
    double Jd[16], Jp[16], Jm[16];
    ASSERT_EQ(pkm_jacobian_dot(m, d, x.data(), xd, Jd), PKM_OK) << pkm_data_error(d);
    std::vector<double> xp = x, xm = x;
    for (int j = 0; j < 4; ++j) {
      xp[j] += h * xd[j];
      xm[j] -= h * xd[j];
    }
    ASSERT_EQ(pkm_jacobians(m, d, xp.data(), nullptr, nullptr, Jp), PKM_OK);
    ASSERT_EQ(pkm_jacobians(m, d, xm.data(), nullptr, nullptr, Jm), PKM_OK);
    for (int k = 0; k < 16; ++k) {
      const double fd = (Jp[k] - Jm[k]) / (2 * h);
      EXPECT_NEAR(Jd[k], fd, 1e-6 * std::max(1.0, std::fabs(fd))) << "element " << k;
    }
  }
}

TEST_P(Quattro, AccelerationKinematicsMatchesSecondDifferences) {
  const double xd[4] = {0.5, 0.3, -0.8, 1.5}, xdd[4] = {3.0, -2.0, 5.0, -4.0}, h = 1e-4;
  for (auto& x : poses()) {
    double qdd[4], q0[4], qp[4], qm[4];
    ASSERT_EQ(pkm_joint_acceleration(m, d, x.data(), xd, xdd, qdd), PKM_OK) << pkm_data_error(d);
    std::vector<double> xp = x, xm = x;
    for (int j = 0; j < 4; ++j) {
      xp[j] += h * xd[j] + 0.5 * h * h * xdd[j];
      xm[j] += -h * xd[j] + 0.5 * h * h * xdd[j];
    }
    ASSERT_EQ(pkm_ik(m, d, x.data(), q0), PKM_OK);
    ASSERT_EQ(pkm_ik(m, d, xp.data(), qp), PKM_OK);
    ASSERT_EQ(pkm_ik(m, d, xm.data(), qm), PKM_OK);
    for (int i = 0; i < 4; ++i) {
      const double fd = (qp[i] - 2 * q0[i] + qm[i]) / (h * h);
      EXPECT_NEAR(qdd[i], fd, 1e-4 * std::max(1.0, std::fabs(fd))) << "arm " << i + 1;
    }
    // And back: the pose acceleration from the joint acceleration.
    double xdd2[4];
    ASSERT_EQ(pkm_pose_acceleration(m, d, x.data(), xd, qdd, xdd2), PKM_OK);
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(xdd2[j], xdd[j], 1e-9);
  }
}

TEST_P(Quattro, ForwardKinematicsRoundTrip) {
  for (auto& x : poses()) {
    double q[4], xg[4], xf[4];
    pkm_fk_info info{0, 0};
    ASSERT_EQ(pkm_ik(m, d, x.data(), q), PKM_OK);
    for (int j = 0; j < 4; ++j) xg[j] = x[j] + (j == 3 ? 0.05 : 0.02);
    ASSERT_EQ(pkm_fk(m, d, q, xg, nullptr, xf, &info), PKM_OK) << pkm_data_error(d);
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(xf[j], x[j], 1e-10) << "coordinate " << j;
    EXPECT_LT(info.iterations, 20);
  }
}

TEST_P(Quattro, SingularityMeasuresAreInRange) {
  for (auto& x : poses()) {
    double s[2];
    ASSERT_EQ(pkm_singularity(m, d, x.data(), s), PKM_OK);
    EXPECT_GT(s[0], 0.0);
    EXPECT_LE(s[0], 1.0);
    EXPECT_GT(s[1], 1e-3);
    EXPECT_LE(s[1], 1.0);
  }
}

TEST_P(Quattro, OutOfReachNamesTheArm) {
  double q[4];
  const double far[4] = {0.0, 0.0, -1.5, 0.0};  // below every arm's reach: arm 1 fails first
  int s = pkm_ik(m, d, far, q);
  EXPECT_EQ(s, PKM_ERR_UNREACHABLE);
  std::string msg = pkm_data_error(d);
  // the hand-written model in the source's terms (RAD < 0), the description in its own
  EXPECT_NE(msg.find(hand ? "arm 1" : "leg 1"), std::string::npos) << msg;
  EXPECT_NE(msg.find(hand ? "RAD < 0" : "the rod's sphere misses the elbow circle"), std::string::npos) << msg;
}

TEST_P(Quattro, JointRangeNamesTheArmAndAngle) {
  // Close under the base the arms must swing up past -51 deg: scanning z upwards along
  // the axis, the last reachable poses give way to a band beyond the joint range.
  double q[4];
  int found = 0;
  for (double z0 = -0.50; z0 < -0.38 && !found; z0 += 0.001) {
    const double x[4] = {0.0, 0.0, z0 - base_h(), 0.0};
    int s = pkm_ik(m, d, x, q);
    if (s == PKM_ERR_JOINT_LIMIT) {
      found = 1;
      std::string msg = pkm_data_error(d);
      // the hand-written model in degrees, the description in radians
      EXPECT_NE(msg.find(hand ? "arm 1: q = -5" : "leg 1 joint q = -0.89"), std::string::npos) << msg;
      EXPECT_NE(msg.find(hand ? "deg outside the joint range [-51, 123] deg" : "outside [-0.890118, 2.14675]"),
                std::string::npos)
          << msg;
    }
  }
  EXPECT_TRUE(found);
}

TEST_P(Quattro, BadInputIsAnErrorNotANaN) {
  const double bad[4] = {0.0, NAN, -1.0, 0.0};
  double q[4];
  EXPECT_EQ(pkm_ik(m, d, bad, q), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_data_error(d)).find("pose x[1]"), std::string::npos);
  // A batch goes on past a bad item and NaN-fills only that one.
  const double xs[12] = {0, 0, -0.95, 0, 0.9, 0, -1.0, 0, 0.05, 0.05, -1.0, 0};
  double qs[12];
  int st[3];
  EXPECT_EQ(pkm_ik_batch(m, d, 3, xs, qs, st), PKM_ERR_UNREACHABLE);
  EXPECT_EQ(st[0], PKM_OK);
  EXPECT_EQ(st[1], PKM_ERR_UNREACHABLE);
  EXPECT_EQ(st[2], PKM_OK);
  EXPECT_TRUE(std::isnan(qs[4]));
  EXPECT_TRUE(std::isfinite(qs[8]));
  EXPECT_NE(std::string(pkm_data_error(d)).find("item 1"), std::string::npos);
}

TEST_P(Quattro, InvalidParametersAreRejectedWithTheirNames) {
  int i = pkm_param_index(m, qmin_name().c_str());
  ASSERT_GE(i, 0);
  ASSERT_EQ(pkm_param_set(m, i, 2.5, err, sizeof err), PKM_OK);
  EXPECT_EQ(pkm_model_validate(m, err, sizeof err), PKM_ERR_PARAMETER);
  EXPECT_NE(std::string(err).find(qmin_name()), std::string::npos) << err;
  double q[4], x[4] = {0, 0, -0.95, 0};
  EXPECT_EQ(pkm_ik(m, d, x, q), PKM_ERR_PARAMETER);  // an unvalidated model refuses to compute
  ASSERT_EQ(pkm_param_set(m, i, -0.5, err, sizeof err), PKM_OK);
  // A forearm too short to reach the home pose.
  for (int k = 1; k <= (hand ? 1 : 4); ++k) {
    const std::string c = hand ? "forearm.c" : "leg[" + std::to_string(k) + "].L";
    ASSERT_EQ(pkm_param_set(m, pkm_param_index(m, c.c_str()), 0.2, err, sizeof err), PKM_OK);
  }
  EXPECT_EQ(pkm_model_validate(m, err, sizeof err), PKM_ERR_PARAMETER);
  EXPECT_NE(std::string(err).find("home pose"), std::string::npos) << err;
  const std::string mass = hand ? "arm.m" : "arm[1].mass";
  EXPECT_EQ(pkm_param_set(m, pkm_param_index(m, mass.c_str()), -1.0, err, sizeof err), PKM_ERR_PARAMETER);
  EXPECT_NE(std::string(err).find(mass), std::string::npos) << err;
  char e2[256];
  pkm_model* bad = pkm_model_create(std::get<0>(GetParam()), "no_such_set", e2, sizeof e2);
  EXPECT_EQ(bad, nullptr);
  EXPECT_NE(std::string(e2).find("appendix_a"), std::string::npos) << e2;
}

INSTANTIATE_TEST_SUITE_P(Sets, Quattro,
                         ::testing::Combine(::testing::Values("quattro", "quattro_hand"),
                                            ::testing::Values("default", "appendix_a")));

}  // namespace
