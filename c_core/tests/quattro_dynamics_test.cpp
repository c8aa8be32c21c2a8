// Quattro (Virzi 2010 ch. 5) dynamics through the C API, on the robot the core serves from
// robots/quattro.toml, checked against independent facts:
// the gravity load is the gradient of the potential energy, the velocity terms are those
// of Lagrange's equations for the mass matrix (finite differences of M), forward dynamics
// inverts inverse dynamics, and a free motion conserves T + V.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "pkm/pkm.h"
#include "test_support.hpp"

namespace {

struct QuattroDyn : pkm_test::ModelFixture<::testing::TestWithParam<const char*>> {
  void SetUp() override {
    create_model("quattro", GetParam());
    if (!m) return;
    // A payload makes the platform-side terms and the tool-spin inertia matter (a payload
    // inertia of 2e-3 kg m2 about the tool axis, turned 4 times per articulation radian, is
    // 16 x 2e-3 kg m2 about the articulation).
    set("payload.m", 0.5);
    set("platform.Izz", 16 * 2e-3);
    validate();
    create_data();
  }
  std::vector<std::vector<double>> poses() {
    return {{0.0, 0.0, -0.95, 0.0}, {0.12, -0.05, -1.0, 0.1}, {-0.2, 0.15, -0.9, -0.2}, {0.05, 0.25, -1.1, 0.3}};
  }
  double V(const double* x) {
    double T, Vv, z[4] = {0, 0, 0, 0};
    EXPECT_EQ(pkm_energy(m, d, x, z, &T, &Vv), PKM_OK) << pkm_data_error(d);
    return Vv;
  }
  void M(const double* x, double* out) { ASSERT_EQ(pkm_mass_matrix(m, d, x, out), PKM_OK) << pkm_data_error(d); }
  void J(const double* x, double* out) {
    ASSERT_EQ(pkm_jacobians(m, d, x, nullptr, nullptr, out), PKM_OK) << pkm_data_error(d);
  }
};

TEST_P(QuattroDyn, GravityLoadIsTheGradientOfThePotential) {
  const double h = 1e-6;
  for (auto& x : poses()) {
    double g[4], Jm[16];
    ASSERT_EQ(pkm_gravity_load(m, d, x.data(), g), PKM_OK) << pkm_data_error(d);
    J(x.data(), Jm);
    for (int j = 0; j < 4; ++j) {  // J^T g = dV/dx (virtual work)
      std::vector<double> xp = x, xm = x;
      xp[j] += h;
      xm[j] -= h;
      const double fd = (V(xp.data()) - V(xm.data())) / (2 * h);
      double JTg = 0;
      for (int i = 0; i < 4; ++i) JTg += Jm[4 * i + j] * g[i];
      EXPECT_NEAR(JTg, fd, 1e-6 * std::max(1.0, std::fabs(fd))) << "coordinate " << j;
    }
  }
}

TEST_P(QuattroDyn, HoldingTorqueLiftsTheArms) {
  // Virzi 2010 writes the gravity terms with the sign of the load (+g m_b lg cos q_r);
  // the effort that holds the robot is the opposite: upwards, i.e. negative q.
  double g[4];
  const double x[4] = {0, 0, -0.95, 0};
  ASSERT_EQ(pkm_gravity_load(m, d, x, g), PKM_OK);
  for (int i = 0; i < 4; ++i) EXPECT_LT(g[i], 0.0) << "arm " << i + 1;
}

TEST_P(QuattroDyn, InverseDynamicsFollowsLagrangeForTheMassMatrix) {
  // J^T (ID(x, xd, xdd) - ID(x, 0, 0)) = M xdd + Mdot xd - 1/2 d(xd' M xd)/dx.
  const double xd[4] = {0.8, -0.5, 1.2, 3.0}, xdd[4] = {4.0, 2.0, -6.0, 10.0}, h = 1e-6;
  const double zero[4] = {0, 0, 0, 0};
  for (auto& x : poses()) {
    double t1[4], t0[4], Mm[16], Jm[16];
    ASSERT_EQ(pkm_inverse_dynamics(m, d, x.data(), xd, xdd, t1), PKM_OK) << pkm_data_error(d);
    ASSERT_EQ(pkm_inverse_dynamics(m, d, x.data(), zero, zero, t0), PKM_OK);
    M(x.data(), Mm);
    J(x.data(), Jm);
    double Mdot[16], dT[4];
    {
      std::vector<double> xp = x, xm = x;
      for (int j = 0; j < 4; ++j) {
        xp[j] += h * xd[j];
        xm[j] -= h * xd[j];
      }
      double Mp[16], Mq[16];
      M(xp.data(), Mp);
      M(xm.data(), Mq);
      for (int k = 0; k < 16; ++k) Mdot[k] = (Mp[k] - Mq[k]) / (2 * h);
    }
    for (int j = 0; j < 4; ++j) {
      std::vector<double> xp = x, xm = x;
      xp[j] += h;
      xm[j] -= h;
      double Mp[16], Mq[16];
      M(xp.data(), Mp);
      M(xm.data(), Mq);
      double qp = 0, qm = 0;
      for (int a = 0; a < 4; ++a)
        for (int b = 0; b < 4; ++b) {
          qp += xd[a] * Mp[4 * a + b] * xd[b];
          qm += xd[a] * Mq[4 * a + b] * xd[b];
        }
      dT[j] = 0.5 * (qp - qm) / (2 * h);
    }
    for (int j = 0; j < 4; ++j) {
      double lhs = 0, rhs = -dT[j];
      for (int i = 0; i < 4; ++i) {
        lhs += Jm[4 * i + j] * (t1[i] - t0[i]);
        rhs += Mm[4 * j + i] * xdd[i] + Mdot[4 * j + i] * xd[i];
      }
      EXPECT_NEAR(lhs, rhs, 1e-6 * std::max(1.0, std::fabs(rhs))) << "coordinate " << j;
    }
  }
}

TEST_P(QuattroDyn, MassMatrixIsSymmetricPositiveAndCarriesTheRotors) {
  for (auto& x : poses()) {
    double Mm[16];
    M(x.data(), Mm);
    for (int a = 0; a < 4; ++a)
      for (int b = 0; b < 4; ++b) EXPECT_NEAR(Mm[4 * a + b], Mm[4 * b + a], 1e-12);
    // Leading principal minors > 0 (Sylvester).
    double m11 = Mm[0], m22 = Mm[0] * Mm[5] - Mm[1] * Mm[4];
    EXPECT_GT(m11, 0);
    EXPECT_GT(m22, 0);
  }
  // Doubling the reflected rotor inertia J_r = ratio^2 J_m of every arm (the drive layer's
  // arm[i].rotor_inertia) adds J_r J^T J.
  const double x[4] = {0.05, -0.1, -1.0, 0.1};
  double M1[16], M2[16], Jm[16];
  M(x, M1);
  J(x, Jm);
  const double Jrot = param("arm[1].rotor_inertia");
  for (int i = 1; i <= 4; ++i) {
    EXPECT_EQ(param("arm[" + std::to_string(i) + "].rotor_inertia"), Jrot);
    set("arm[" + std::to_string(i) + "].rotor_inertia", 2 * Jrot);
  }
  validate();
  pkm_data_destroy(d);
  d = pkm_data_create(m);
  M(x, M2);
  for (int a = 0; a < 4; ++a)
    for (int b = 0; b < 4; ++b) {
      double JtJ = 0;
      for (int i = 0; i < 4; ++i) JtJ += Jm[4 * i + a] * Jm[4 * i + b];
      EXPECT_NEAR(M2[4 * a + b] - M1[4 * a + b], Jrot * JtJ, 1e-9 * (1 + std::fabs(M1[4 * a + b])));
    }
}

TEST_P(QuattroDyn, ForwardDynamicsInvertsInverseDynamics) {
  const double xd[4] = {0.3, 0.6, -0.9, 1.0}, xdd[4] = {-5.0, 8.0, 3.0, -20.0};
  for (auto& x : poses()) {
    double tau[4], back[4];
    ASSERT_EQ(pkm_inverse_dynamics(m, d, x.data(), xd, xdd, tau), PKM_OK) << pkm_data_error(d);
    ASSERT_EQ(pkm_forward_dynamics(m, d, x.data(), xd, tau, back), PKM_OK) << pkm_data_error(d);
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(back[j], xdd[j], 1e-8 * std::max(1.0, std::fabs(xdd[j])));
  }
}

TEST_P(QuattroDyn, FreeMotionConservesEnergy) {
  // No input, no friction: T + V is constant.  RK4 on the core's forward dynamics.
  std::vector<double> x = {0.02, -0.03, -0.97, 0.05}, v = {0.4, -0.3, 0.5, 1.0};
  auto E = [&](const std::vector<double>& xx, const std::vector<double>& vv) {
    double T, Vv;
    EXPECT_EQ(pkm_energy(m, d, xx.data(), vv.data(), &T, &Vv), PKM_OK);
    return T + Vv;
  };
  auto f = [&](const std::vector<double>& xx, const std::vector<double>& vv, std::vector<double>& a) {
    const double tau[4] = {0, 0, 0, 0};
    a.assign(4, 0);
    ASSERT_EQ(pkm_forward_dynamics(m, d, xx.data(), vv.data(), tau, a.data()), PKM_OK) << pkm_data_error(d);
  };
  const double E0 = E(x, v), dt = 2e-4;
  double Tscale = 0;
  {
    double T, Vv;
    pkm_energy(m, d, x.data(), v.data(), &T, &Vv);
    Tscale = T;
  }
  for (int s = 0; s < 500; ++s) {
    std::vector<double> a1, a2, a3, a4, xt(4), vt(4);
    f(x, v, a1);
    for (int j = 0; j < 4; ++j) xt[j] = x[j] + 0.5 * dt * v[j], vt[j] = v[j] + 0.5 * dt * a1[j];
    std::vector<double> v2 = vt;
    f(xt, vt, a2);
    for (int j = 0; j < 4; ++j) xt[j] = x[j] + 0.5 * dt * v2[j], vt[j] = v[j] + 0.5 * dt * a2[j];
    std::vector<double> v3 = vt;
    f(xt, vt, a3);
    for (int j = 0; j < 4; ++j) xt[j] = x[j] + dt * v3[j], vt[j] = v[j] + dt * a3[j];
    std::vector<double> v4 = vt;
    f(xt, vt, a4);
    for (int j = 0; j < 4; ++j) {
      x[j] += dt / 6 * (v[j] + 2 * v2[j] + 2 * v3[j] + v4[j]);
      v[j] += dt / 6 * (a1[j] + 2 * a2[j] + 2 * a3[j] + a4[j]);
    }
  }
  EXPECT_NEAR(E(x, v), E0, 1e-8 * std::max(1.0, Tscale));
}

// The explicit integrator carries its last stage across a change of the input as
// f(y, 0) + B tau (B = M^-1 J^T from the generic forward dynamics): a 1 kHz loop with a
// new effort every millisecond gives the trajectory of CVODE BDF at rtol 1e-12, which
// calls the forward dynamics at every stage, with 6 calls per step instead of 7.  The stage
// is carried when the drive layer adds no inertia (integration_test.cpp checks 7 calls with
// one): the served Quattro's motor rotors are the drive layer's arm[i].rotor_inertia, set to
// 0 here.
TEST_P(QuattroDyn, CarriedFirstStageMatchesFreshForwardDynamics) {
  for (int i = 1; i <= 4; ++i) set("arm[" + std::to_string(i) + "].rotor_inertia", 0.0);
  validate();
  pkm_data_destroy(d);
  d = pkm_data_create(m);
  double x0[4], g[4];
  ASSERT_EQ(pkm_model_home(m, x0), PKM_OK);
  ASSERT_EQ(pkm_gravity_load(m, d, x0, g), PKM_OK) << pkm_data_error(d);
  auto run = [&](int method, double rtol, pkm_sim_stats* stats) {
    pkm_sim_options o;
    pkm_sim_default_options(&o);
    o.method = method;
    o.rtol = rtol;
    o.atol = rtol * 1e-2;
    char err[512] = "";
    pkm_sim* s = pkm_sim_create(m, &o, err, sizeof err);
    EXPECT_NE(s, nullptr) << err;
    std::vector<double> out;
    for (int k = 0; k < 200 && s; ++k) {
      double tau[4], t, x[4], xd[4];
      for (int i = 0; i < 4; ++i) tau[i] = g[i] * (1.0 + 0.05 * std::sin(0.07 * k + i));
      EXPECT_EQ(pkm_sim_set_input(s, tau), PKM_OK);
      EXPECT_EQ(pkm_sim_advance(s, (k + 1) * 1e-3), PKM_OK) << pkm_sim_error(s);
      pkm_sim_get_state(s, &t, x, xd);
      out.insert(out.end(), x, x + 4);
    }
    if (s) pkm_sim_get_stats(s, stats);
    pkm_sim_destroy(s);
    return out;
  };
  pkm_sim_stats erk{}, bdf{};
  const std::vector<double> a = run(PKM_ERK, 1e-10, &erk), b = run(PKM_BDF, 1e-12, &bdf);
  ASSERT_EQ(a.size(), b.size());
  double err = 0;
  for (size_t k = 0; k < a.size(); ++k) err = std::fmax(err, std::fabs(a[k] - b[k]));
  EXPECT_LT(err, 1e-9);
  EXPECT_LT((double)erk.rhs_evals / erk.steps, 6.05) << erk.rhs_evals << " calls in " << erk.steps << " steps";
}

INSTANTIATE_TEST_SUITE_P(Sets, QuattroDyn, ::testing::Values("default", "appendix_a"));

}  // namespace
