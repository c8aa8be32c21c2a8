// pkm_ctrl: each law against its formula written out here (independently of the
// implementation's matrix code), PID integral/derivative/anti-windup by hand, LTI
// against an explicit recursion, state save/load, and the errors.
#include <cmath>
#include <vector>

#include "test_support.hpp"

using namespace pkm_test;

namespace {

struct CtrlPtr {
  pkm_ctrl* c = nullptr;
  ~CtrlPtr() { pkm_ctrl_destroy(c); }
};

std::vector<double> diag(int n, double v) {
  std::vector<double> m(n * n, 0.0);
  for (int i = 0; i < n; ++i) m[i * n + i] = v;
  return m;
}

pkm_ctrl_spec spec_of(int kind, const std::vector<double>& kp, const std::vector<double>& kd) {
  pkm_ctrl_spec s{};
  s.kind = kind;
  s.dt = 1e-3;
  s.kp = kp.data();
  s.kd = kd.data();
  return s;
}

// A 6-PUS PID controller after three samples of a 1 mm step on every joint: what the
// saved-state tests save, damage and replay.
struct PidAfterThreeSamples {
  ModelPtr m = make_model("6pus");
  DataPtr d = make_data(m.get());
  std::vector<double> kp = diag(6, 100), kd = diag(6, 4), ki = diag(6, 500);
  pkm_ctrl_spec s = spec_of(PKM_CTRL_PID, kp, kd);
  char err[512] = "";
  CtrlPtr c;
  double x[6], q[6], zero[6] = {0}, qr[6];

  PidAfterThreeSamples(double deriv_filter, int gravity_feedforward) {
    s.ki = ki.data();
    s.deriv_filter = deriv_filter;
    s.gravity_feedforward = gravity_feedforward;
    c.c = pkm_ctrl_create(m.get(), &s, err, sizeof err);
    EXPECT_NE(c.c, nullptr) << err;
    pkm_model_home(m.get(), x);
    EXPECT_EQ(pkm_ik(m.get(), d.get(), x, q), PKM_OK);
    for (int i = 0; i < 6; ++i) qr[i] = q[i] + 0.001;
    double tau[6];
    for (int k = 0; k < 3; ++k) EXPECT_EQ(update(c.c, k * 1e-3, tau), PKM_OK);
  }
  int update(pkm_ctrl* ctrl, double t, double* tau) {
    return pkm_ctrl_update(ctrl, t, q, zero, qr, zero, nullptr, nullptr, tau);
  }
  // The fourth sample of a fresh controller loaded with `state` equals `tau`.
  void expect_fresh_controller_replays(const std::vector<double>& state, const double* tau) {
    CtrlPtr fresh{pkm_ctrl_create(m.get(), &s, err, sizeof err)};
    ASSERT_EQ(pkm_ctrl_state_load(fresh.c, state.data(), state.size()), PKM_OK) << pkm_ctrl_error(fresh.c);
    double again[6];
    ASSERT_EQ(update(fresh.c, 3e-3, again), PKM_OK);
    for (int i = 0; i < 6; ++i) EXPECT_EQ(tau[i], again[i]);
  }
};

}  // namespace

TEST(Controller, PdIsKpErrorPlusKdRateError) {
  auto m = make_model("6pus");
  auto kp = diag(6, 300), kd = diag(6, 30);
  kp[1] = 5.0;  // an off-diagonal coupling term: row 0 gets 5 (qref1 - q1)
  auto s = spec_of(PKM_CTRL_PD, kp, kd);
  char err[512] = "";
  CtrlPtr c{pkm_ctrl_create(m.get(), &s, err, sizeof err)};
  ASSERT_NE(c.c, nullptr) << err;
  double q[6], qd[6], qr[6], qdr[6], tau[6];
  for (int i = 0; i < 6; ++i) q[i] = 0.05 + 0.001 * i, qd[i] = 0.01 * i, qr[i] = 0.06, qdr[i] = 0.0;
  ASSERT_EQ(pkm_ctrl_update(c.c, 0.0, q, qd, qr, qdr, nullptr, nullptr, tau), PKM_OK) << pkm_ctrl_error(c.c);
  for (int i = 0; i < 6; ++i) {
    double want = 300 * (qr[i] - q[i]) + 30 * (qdr[i] - qd[i]);
    if (i == 0) want += 5.0 * (qr[1] - q[1]);
    EXPECT_NEAR(tau[i], want, 1e-12) << "joint " << i + 1;
  }
}

TEST(Controller, PdGravityAddsTheCoreGravityLoadAtTheMeasuredPose) {
  auto m = make_model("6pus");
  auto d = make_data(m.get());
  auto kp = diag(6, 300), kd = diag(6, 30);
  auto s = spec_of(PKM_CTRL_PD_GRAVITY, kp, kd);
  char err[512] = "";
  CtrlPtr c{pkm_ctrl_create(m.get(), &s, err, sizeof err)};
  ASSERT_NE(c.c, nullptr) << err;
  double x[6], q[6], zero[6] = {0}, g[6], tau[6];
  pkm_model_home(m.get(), x);
  x[0] += 0.004;
  x[5] += 0.02;
  ASSERT_EQ(pkm_ik(m.get(), d.get(), x, q), PKM_OK);
  ASSERT_EQ(pkm_gravity_load(m.get(), d.get(), x, g), PKM_OK);
  ASSERT_EQ(pkm_ctrl_update(c.c, 0.0, q, zero, q, zero, nullptr, nullptr, tau), PKM_OK) << pkm_ctrl_error(c.c);
  for (int i = 0; i < 6; ++i) EXPECT_NEAR(tau[i], g[i], 1e-9 * (1 + std::fabs(g[i])));
}

TEST(Controller, ComputedTorqueReproducesTheReferenceAccelerationOnTheTrueModel) {
  // With zero tracking error the command is the inverse dynamics of the reference motion:
  // the forward dynamics of the command gives back qddref.
  auto m = make_model("quattro");
  auto d = make_data(m.get());
  auto kp = diag(4, 400), kd = diag(4, 40);
  auto s = spec_of(PKM_CTRL_COMPUTED_TORQUE, kp, kd);
  char err[512] = "";
  CtrlPtr c{pkm_ctrl_create(m.get(), &s, err, sizeof err)};
  ASSERT_NE(c.c, nullptr) << err;
  double x[4], xd[4] = {0.1, -0.05, 0.2, 0.3}, q[4], qd[4], qdd[4] = {1.0, -2.0, 0.5, 0.3}, tau[4], xdd[4], qdd2[4];
  pkm_model_home(m.get(), x);
  ASSERT_EQ(pkm_ik(m.get(), d.get(), x, q), PKM_OK);
  ASSERT_EQ(pkm_joint_velocity(m.get(), d.get(), x, xd, qd), PKM_OK);
  ASSERT_EQ(pkm_ctrl_update(c.c, 0.0, q, qd, q, qd, qdd, x, tau), PKM_OK) << pkm_ctrl_error(c.c);
  ASSERT_EQ(pkm_forward_dynamics(m.get(), d.get(), x, xd, tau, xdd), PKM_OK);
  ASSERT_EQ(pkm_joint_acceleration(m.get(), d.get(), x, xd, xdd, qdd2), PKM_OK);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(qdd2[i], qdd[i], 1e-7);
}

TEST(Controller, PidIntegratesFiltersTheDerivativeAndStopsWindingUpAtSaturation) {
  auto m = make_model("6pus");
  auto kp = diag(6, 100), kd = diag(6, 4), ki = diag(6, 1000);
  auto s = spec_of(PKM_CTRL_PID, kp, kd);
  s.ki = ki.data();
  s.deriv_filter = 0.002;
  const double sat[6] = {50, 50, 50, 50, 50, 0.5};  // joint 6 saturates
  s.saturation = sat;
  char err[512] = "";
  CtrlPtr c{pkm_ctrl_create(m.get(), &s, err, sizeof err)};
  ASSERT_NE(c.c, nullptr) << err;
  const double dt = s.dt, tf = s.deriv_filter;
  double I[6] = {0}, D[6] = {0}, e_prev[6] = {0};
  double q[6], zero[6] = {0}, qr[6], tau[6];
  long clipped = 0, frozen = 0;
  for (int k = 0; k < 20; ++k) {
    bool any = false;
    for (int i = 0; i < 6; ++i) qr[i] = 0.06, q[i] = 0.05 + 0.0004 * k * (i + 1) / 6.0;
    ASSERT_EQ(pkm_ctrl_update(c.c, k * dt, q, zero, qr, zero, nullptr, nullptr, tau), PKM_OK);
    for (int i = 0; i < 6; ++i) {
      const double e = qr[i] - q[i];
      D[i] = k == 0 ? 0.0 : (tf * D[i] + (e - e_prev[i])) / (tf + dt);
      double trial = I[i] + dt * e;
      double u = 100 * e + 1000 * trial + 4 * D[i];
      if ((u > sat[i] && e > 0) || (u < -sat[i] && e < 0)) {
        ++frozen;
        trial = I[i];
        u = 100 * e + 1000 * trial + 4 * D[i];
      }
      I[i] = trial;
      e_prev[i] = e;
      any = any || std::fabs(u) > sat[i];
      EXPECT_NEAR(tau[i], std::fmax(-sat[i], std::fmin(u, sat[i])), 1e-12) << "sample " << k << " joint " << i + 1;
    }
    clipped += any ? 1 : 0;
  }
  EXPECT_EQ(pkm_ctrl_saturated(c.c), clipped);
  EXPECT_GE(frozen, 1);  // the case is exercised: joint 6 spent a sample with its integral frozen
  EXPECT_LT(clipped, 20);  // and left the limit again
}

TEST(Controller, LtiIsTheStateSpaceRecursionOnTheError) {
  auto m = make_model("quattro");
  const int nd = 4, nx = 2;
  const std::vector<double> A = {0.9, 0.1, 0.0, 0.8};
  std::vector<double> B(nx * nd, 0.0), C(nd * nx, 0.0), Dm = diag(nd, 2.0);
  B[0 * nd + 0] = 1.0, B[1 * nd + 2] = 0.5;
  C[1 * nx + 0] = 3.0, C[3 * nx + 1] = -1.0;
  pkm_ctrl_spec s{};
  s.kind = PKM_CTRL_LTI;
  s.dt = 1e-3;
  s.nx = nx;
  s.A = A.data(), s.B = B.data(), s.C = C.data(), s.D = Dm.data();
  char err[512] = "";
  CtrlPtr c{pkm_ctrl_create(m.get(), &s, err, sizeof err)};
  ASSERT_NE(c.c, nullptr) << err;
  double xc[2] = {0, 0}, q[4] = {0}, zero[4] = {0}, qr[4], tau[4];
  for (int k = 0; k < 5; ++k) {
    for (int i = 0; i < nd; ++i) qr[i] = 0.1 * (i + 1) + 0.01 * k;
    ASSERT_EQ(pkm_ctrl_update(c.c, k * 1e-3, q, zero, qr, zero, nullptr, nullptr, tau), PKM_OK);
    const double* e = qr;
    const double want[4] = {2 * e[0], 3 * xc[0] + 2 * e[1], 2 * e[2], -xc[1] + 2 * e[3]};
    for (int i = 0; i < nd; ++i) EXPECT_NEAR(tau[i], want[i], 1e-12) << "sample " << k << " joint " << i + 1;
    const double x0 = 0.9 * xc[0] + 0.1 * xc[1] + e[0], x1 = 0.8 * xc[1] + 0.5 * e[2];
    xc[0] = x0, xc[1] = x1;
  }
}

TEST(Controller, SavedStateReplaysTheSameOutputs) {
  PidAfterThreeSamples p(0.01, 1);
  ASSERT_NE(p.c.c, nullptr);
  std::vector<double> st(pkm_ctrl_state_size(p.c.c));
  ASSERT_EQ(pkm_ctrl_state_save(p.c.c, st.data()), PKM_OK);
  double tau[6];
  ASSERT_EQ(p.update(p.c.c, 3e-3, tau), PKM_OK);
  p.expect_fresh_controller_replays(st, tau);
}

// A saved state is checked against the law's own layout before anything is loaded, and a
// refused one leaves the controller as it was.
TEST(Controller, DamagedSavedStatesAreRefused) {
  PidAfterThreeSamples p(0.0, 0);
  ASSERT_NE(p.c.c, nullptr);
  auto& c = p.c;
  std::vector<double> good(pkm_ctrl_state_size(c.c));
  ASSERT_EQ(pkm_ctrl_state_save(c.c, good.data()), PKM_OK);
  const auto refused = [&](std::vector<double> bad, size_t n, const char* words) {
    EXPECT_EQ(pkm_ctrl_state_load(c.c, bad.data(), n), PKM_ERR_ARGUMENT);
    EXPECT_NE(std::string(pkm_ctrl_error(c.c)).find(words), std::string::npos) << pkm_ctrl_error(c.c);
  };
  refused(good, good.size() - 1, "this controller's layout has");
  std::vector<double> bad = good;
  bad[1] = PKM_CTRL_PD;  // a state of another law with the same sizes
  refused(bad, bad.size(), "another law or size");
  bad = good;
  bad[4] = NAN;
  refused(bad, bad.size(), "not finite");
  bad = good;
  bad[bad.size() - 3] = 2.0;  // have_prev is a flag
  refused(bad, bad.size(), "flag");
  bad = good;
  bad[bad.size() - 1] = 1e300;  // the saturation count
  refused(bad, bad.size(), "not a count");
  // Nothing of the refused states was kept: the next sample is the one the good state gives.
  double tau[6];
  ASSERT_EQ(p.update(c.c, 3e-3, tau), PKM_OK);
  p.expect_fresh_controller_replays(good, tau);
}

TEST(Controller, BadSpecsAndReadingsAreNamed) {
  auto m = make_model("6pus");
  auto kp = diag(6, 300), kd = diag(6, 30);
  char err[512] = "";
  auto s = spec_of(PKM_CTRL_PD, kp, kd);
  s.dt = 0;
  EXPECT_EQ(pkm_ctrl_create(m.get(), &s, err, sizeof err), nullptr);
  EXPECT_NE(std::string(err).find("dt"), std::string::npos) << err;
  s.dt = 1e-3;
  kp[7] = NAN;
  EXPECT_EQ(pkm_ctrl_create(m.get(), &s, err, sizeof err), nullptr);
  EXPECT_NE(std::string(err).find("kp[1,1]"), std::string::npos) << err;
  kp[7] = -1;
  EXPECT_EQ(pkm_ctrl_create(m.get(), &s, err, sizeof err), nullptr);
  EXPECT_NE(std::string(err).find("kp of joint 2 is negative"), std::string::npos) << err;
  kp[7] = 300;
  s.kind = 9;
  EXPECT_EQ(pkm_ctrl_create(m.get(), &s, err, sizeof err), nullptr);
  EXPECT_NE(std::string(err).find("kind = 9"), std::string::npos) << err;
  s.kind = PKM_CTRL_PD_GRAVITY;
  CtrlPtr c{pkm_ctrl_create(m.get(), &s, err, sizeof err)};
  ASSERT_NE(c.c, nullptr) << err;
  double q[6] = {0.05, 0.05, 0.05, 0.05, 0.05, 0.05}, zero[6] = {0}, tau[6];
  q[3] = INFINITY;
  EXPECT_EQ(pkm_ctrl_update(c.c, 0.25, q, zero, zero, zero, nullptr, nullptr, tau), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_ctrl_error(c.c)).find("q of joint 4"), std::string::npos) << pkm_ctrl_error(c.c);
  EXPECT_NE(std::string(pkm_ctrl_error(c.c)).find("t = 0.25 s"), std::string::npos) << pkm_ctrl_error(c.c);
  for (double& v : q) v = 5.0;  // strokes of 5 m: no pose has them
  const int st = pkm_ctrl_update(c.c, 0.5, q, zero, zero, zero, nullptr, nullptr, tau);
  EXPECT_NE(st, PKM_OK);
  EXPECT_NE(std::string(pkm_ctrl_error(c.c)).find("forward kinematics of the measured joints"), std::string::npos)
      << pkm_ctrl_error(c.c);
}

// The compiled loop is the same sequence as stepping the sim and the controller by hand
// (what an FMU-based master does): the same numbers, bit for bit.
TEST(ClosedLoop, EqualsTheLoopSteppedByHandAndKeepsTheRowsBeforeAFailure) {
  auto m = make_model("6pus");
  auto d = make_data(m.get());
  auto kp = diag(6, 300), kd = diag(6, 30);
  auto s = spec_of(PKM_CTRL_PD_GRAVITY, kp, kd);
  char err[512] = "";
  const int nd = 6;
  const size_t n = 200;
  double home[6];
  pkm_model_home(m.get(), home);
  std::vector<double> qref(n * nd), qdref(n * nd, 0.0), xref(n * nd);
  for (size_t k = 0; k < n; ++k) {
    double x[6];
    for (int i = 0; i < nd; ++i) x[i] = home[i];
    x[2] += 0.01 * std::min(1.0, k / 50.0);
    ASSERT_EQ(pkm_ik(m.get(), d.get(), x, &qref[k * nd]), PKM_OK);
    for (int i = 0; i < nd; ++i) xref[k * nd + i] = x[i];
  }
  pkm_loop_reference ref{n, 0.0, 1e-3, nullptr, qref.data(), qdref.data(), nullptr, xref.data(), nullptr};
  std::vector<double> q(n * nd), x(n * nd), tau(n * nd);
  pkm_loop_record rec{};
  rec.q = q.data(), rec.x = x.data(), rec.tau_cmd = tau.data();
  pkm_sim* sim = pkm_sim_create(m.get(), nullptr, err, sizeof err);
  CtrlPtr c{pkm_ctrl_create(m.get(), &s, err, sizeof err)};
  ASSERT_NE(sim, nullptr);
  ASSERT_EQ(pkm_ctrl_reset(c.c, home), PKM_OK);
  size_t done = 0;
  ASSERT_EQ(pkm_closed_loop(sim, c.c, &ref, nullptr, nullptr, 0, &rec, &done), PKM_OK) << pkm_sim_error(sim);
  EXPECT_EQ(done, n);

  pkm_sim* hand = pkm_sim_create(m.get(), nullptr, err, sizeof err);
  CtrlPtr c2{pkm_ctrl_create(m.get(), &s, err, sizeof err)};
  ASSERT_EQ(pkm_ctrl_reset(c2.c, home), PKM_OK);
  for (size_t k = 0; k < n; ++k) {
    double t, xs[6], xds[6], qs[6], qds[6], u[6];
    pkm_sim_get_state(hand, &t, xs, xds);
    ASSERT_EQ(pkm_ik(m.get(), d.get(), xs, qs), PKM_OK);
    ASSERT_EQ(pkm_joint_velocity(m.get(), d.get(), xs, xds, qds), PKM_OK);
    ASSERT_EQ(pkm_ctrl_update(c2.c, k * 1e-3, qs, qds, &qref[k * nd], &qdref[k * nd], nullptr, &xref[k * nd], u),
              PKM_OK);
    for (int i = 0; i < nd; ++i) {
      ASSERT_EQ(q[k * nd + i], qs[i]) << "sample " << k;
      ASSERT_EQ(x[k * nd + i], xs[i]) << "sample " << k;
      ASSERT_EQ(tau[k * nd + i], u[i]) << "sample " << k;
    }
    pkm_sim_set_input(hand, u);
    ASSERT_EQ(pkm_sim_advance(hand, k * 1e-3 + 1e-3), PKM_OK);
  }
  // The platform follows the 10 mm lift (kp = 300 N/m: still 1-2 mm short after 0.2 s).
  EXPECT_GT(x[(n - 1) * nd + 2], home[2] + 0.008);

  // A reference beyond the stroke limit: the loop stops at the limit, names the leg and
  // the time, and keeps the rows before the failing sample.
  // A PD far too weak to hold the platform: it falls until the sim stops it (through the
  // rail plane to a direct singularity, with this geometry).
  auto weak_kp = diag(6, 1.0), weak_kd = diag(6, 0.1);
  auto weak = spec_of(PKM_CTRL_PD, weak_kp, weak_kd);
  CtrlPtr c3{pkm_ctrl_create(m.get(), &weak, err, sizeof err)};
  ASSERT_EQ(pkm_sim_reset(sim, 0.0, home, std::vector<double>(6, 0.0).data()), PKM_OK);
  const int st = pkm_closed_loop(sim, c3.c, &ref, nullptr, nullptr, 0, &rec, &done);
  EXPECT_EQ(st, PKM_ERR_SINGULAR) << pkm_sim_error(sim);
  const std::string msg = pkm_sim_error(sim);
  EXPECT_NE(msg.find("closed loop stopped at sample " + std::to_string(done)), std::string::npos) << msg;
  EXPECT_NE(msg.find("direct (type 2) singularity"), std::string::npos) << msg;
  EXPECT_GT(done, 0u);
  EXPECT_LT(done, n);
  pkm_sim_destroy(sim);
  pkm_sim_destroy(hand);
}
