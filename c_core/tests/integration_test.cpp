// The CVODE simulator (pkm_sim_*) through the C API: option and argument checks,
// bit-for-bit rollback, independent simulators in one process, and with the 6-PUS the
// physics the integration must keep (energy without gravity, friction or input; a fall
// under gravity that stops at a stroke limit naming the leg and the time; BDF = Adams;
// the drive layer's saturation and actuator delay).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "pkm/pkm.h"
#include "test_support.hpp"

namespace {

using pkm_test::DataPtr;
using pkm_test::make_data;
using pkm_test::ModelPtr;
using SimPtr = std::unique_ptr<pkm_sim, decltype(&pkm_sim_destroy)>;

constexpr int N = 6;

struct State {
  double t = NAN;
  double x[N], xd[N];
};

// Every simulator test here runs the 6-PUS.
ModelPtr make_model(const pkm_test::Params& params = {}) { return pkm_test::make_model("6pus", nullptr, params); }

pkm_sim_options defaults() {
  pkm_sim_options o;
  pkm_sim_default_options(&o);
  return o;
}

SimPtr make_sim(const pkm_model* m, const pkm_sim_options& o) {
  char err[1024] = "";
  SimPtr s(pkm_sim_create(m, &o, err, sizeof err), &pkm_sim_destroy);
  EXPECT_NE(s, nullptr) << err;
  return s;
}

State state_of(const pkm_sim* s) {
  State st;
  EXPECT_EQ(pkm_sim_get_state(s, &st.t, st.x, st.xd), PKM_OK);
  return st;
}

bool same_bits(const State& a, const State& b) {
  return std::memcmp(&a.t, &b.t, sizeof(double)) == 0 && std::memcmp(a.x, b.x, sizeof a.x) == 0 &&
         std::memcmp(a.xd, b.xd, sizeof a.xd) == 0;
}

double max_diff(const State& a, const State& b) {
  double d = 0;
  for (int i = 0; i < N; ++i) d = std::fmax(d, std::fmax(std::fabs(a.x[i] - b.x[i]), std::fabs(a.xd[i] - b.xd[i])));
  return d;
}

void home_of(const pkm_model* m, double* x) { ASSERT_EQ(pkm_model_home(m, x), PKM_OK); }

// The time a stop message gives ("... at t = 0.1234 s ...").
double time_in(const std::string& msg) {
  std::smatch mt;
  if (!std::regex_search(msg, mt, std::regex("at t = ([-+0-9.eE]+) s"))) return NAN;
  return std::stod(mt[1]);
}

// A motion with some of everything: held efforts near the gravity load plus a push.
void some_input(const pkm_model* m, const double* x, double* tau) {
  DataPtr d = make_data(m);
  ASSERT_EQ(pkm_gravity_load(m, d.get(), x, tau), PKM_OK) << pkm_data_error(d.get());
  const double push[N] = {0.3, -0.2, 0.1, 0.25, -0.15, 0.05};
  for (int i = 0; i < N; ++i) tau[i] += push[i];
}

// ------------------------------------------------------------------ options

TEST(SimOptions, DefaultsAreTheDocumentedOnes) {
  pkm_sim_options o = defaults();
  EXPECT_EQ(o.method, PKM_ERK);
  EXPECT_EQ(o.rtol, 1e-8);
  EXPECT_EQ(o.atol, 1e-10);
  EXPECT_EQ(o.max_step, 0.0);
  EXPECT_EQ(o.max_steps, 100000);
  EXPECT_EQ(o.sing_min, 1e-4);
}

TEST(SimCreate, RejectsBadOptionsNamingTheOption) {
  ModelPtr m = make_model();
  struct Case {
    const char* what;
    void (*spoil)(pkm_sim_options&);
  } cases[] = {
      {"method", [](pkm_sim_options& o) { o.method = 7; }},
      {"rtol", [](pkm_sim_options& o) { o.rtol = 0; }},
      {"rtol", [](pkm_sim_options& o) { o.rtol = NAN; }},
      {"atol", [](pkm_sim_options& o) { o.atol = -1e-10; }},
      {"atol", [](pkm_sim_options& o) { o.atol = INFINITY; }},
      {"max_step", [](pkm_sim_options& o) { o.max_step = -1; }},
      {"max_steps", [](pkm_sim_options& o) { o.max_steps = 0; }},
      {"max_steps", [](pkm_sim_options& o) { o.max_steps = PKM_SIM_MAX_STEPS_LIMIT + 1; }},
      {"max_steps", [](pkm_sim_options& o) { o.max_steps = 2147483647; }},
      {"sing_min", [](pkm_sim_options& o) { o.sing_min = 1.5; }},
      {"sing_min", [](pkm_sim_options& o) { o.sing_min = -1e-3; }},
  };
  for (const Case& c : cases) {
    pkm_sim_options o = defaults();
    c.spoil(o);
    char err[512] = "";
    pkm_sim* s = pkm_sim_create(m.get(), &o, err, sizeof err);
    EXPECT_EQ(s, nullptr) << c.what;
    pkm_sim_destroy(s);
    EXPECT_NE(std::string(err).find(c.what), std::string::npos) << "message: " << err;
  }
}

TEST(SimCreate, RejectsNullAndUnvalidatedModels) {
  char err[512] = "";
  pkm_sim_options o = defaults();
  EXPECT_EQ(pkm_sim_create(nullptr, &o, err, sizeof err), nullptr);
  EXPECT_NE(std::string(err).find("model is NULL"), std::string::npos) << err;

  ModelPtr m = make_model();
  const int i = pkm_param_index(m.get(), "platform.m");
  ASSERT_GE(i, 0);
  ASSERT_EQ(pkm_param_set(m.get(), i, 0.4, err, sizeof err), PKM_OK) << err;
  err[0] = 0;
  EXPECT_EQ(pkm_sim_create(m.get(), &o, err, sizeof err), nullptr);
  EXPECT_NE(std::string(err).find("pkm_model_validate"), std::string::npos) << err;
}

TEST(SimCreate, NullOptionsMeanDefaultsAndTheStartIsHomeAtRest) {
  ModelPtr m = make_model();
  char err[512] = "";
  SimPtr s(pkm_sim_create(m.get(), nullptr, err, sizeof err), &pkm_sim_destroy);
  ASSERT_NE(s, nullptr) << err;
  double home[N];
  home_of(m.get(), home);
  State st = state_of(s.get());
  EXPECT_EQ(st.t, 0.0);
  for (int i = 0; i < N; ++i) {
    EXPECT_EQ(st.x[i], home[i]);
    EXPECT_EQ(st.xd[i], 0.0);
  }
  pkm_sim_stats stats;
  ASSERT_EQ(pkm_sim_get_stats(s.get(), &stats), PKM_OK);
  EXPECT_EQ(stats.steps, 0);
  EXPECT_EQ(pkm_sim_get_stats(s.get(), nullptr), PKM_ERR_ARGUMENT);
  EXPECT_EQ(pkm_sim_get_state(nullptr, nullptr, nullptr, nullptr), PKM_ERR_ARGUMENT);
  EXPECT_EQ(pkm_sim_advance(nullptr, 1.0), PKM_ERR_ARGUMENT);
}

// ---------------------------------------------------------------- arguments

TEST(SimArgs, NonFiniteInputsAreArgumentErrorsAndChangeNothing) {
  ModelPtr m = make_model();
  SimPtr s = make_sim(m.get(), defaults());
  double x[N], xd[N] = {0, 0, 0, 0, 0, 0};
  home_of(m.get(), x);
  ASSERT_EQ(pkm_sim_reset(s.get(), 0.25, x, xd), PKM_OK) << pkm_sim_error(s.get());
  const State before = state_of(s.get());

  double bad[N];
  std::memcpy(bad, x, sizeof bad);
  bad[2] = NAN;
  EXPECT_EQ(pkm_sim_reset(s.get(), 0.0, bad, xd), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_sim_error(s.get())).find("x[2]"), std::string::npos) << pkm_sim_error(s.get());
  double badv[N] = {0, 0, 0, 0, INFINITY, 0};
  EXPECT_EQ(pkm_sim_reset(s.get(), 0.0, x, badv), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_sim_error(s.get())).find("xd[4]"), std::string::npos) << pkm_sim_error(s.get());
  EXPECT_EQ(pkm_sim_reset(s.get(), NAN, x, xd), PKM_ERR_ARGUMENT);
  EXPECT_EQ(pkm_sim_reset(s.get(), 0.0, nullptr, xd), PKM_ERR_ARGUMENT);

  double tau[N] = {0, 0, 0, NAN, 0, 0};
  EXPECT_EQ(pkm_sim_set_input(s.get(), tau), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_sim_error(s.get())).find("tau[3]"), std::string::npos) << pkm_sim_error(s.get());
  EXPECT_EQ(pkm_sim_set_input(s.get(), nullptr), PKM_ERR_ARGUMENT);

  EXPECT_EQ(pkm_sim_advance(s.get(), NAN), PKM_ERR_ARGUMENT);
  EXPECT_EQ(pkm_sim_advance(s.get(), 0.2), PKM_ERR_ARGUMENT);  // before t = 0.25
  EXPECT_NE(std::string(pkm_sim_error(s.get())).find("before the current time"), std::string::npos)
      << pkm_sim_error(s.get());

  EXPECT_TRUE(same_bits(before, state_of(s.get())));
  // A failed call leaves a message; a good one clears it.
  EXPECT_EQ(pkm_sim_advance(s.get(), 0.25), PKM_OK);
  EXPECT_STREQ(pkm_sim_error(s.get()), "");
}

TEST(SimArgs, ResetRefusesUnreachableAndOutOfStrokeStates) {
  ModelPtr m = make_model();
  DataPtr d = make_data(m.get());
  SimPtr s = make_sim(m.get(), defaults());
  double x[N], xd[N] = {0, 0, 0, 0, 0, 0}, q[N];
  home_of(m.get(), x);
  const State before = state_of(s.get());

  double far[N];
  std::memcpy(far, x, sizeof far);
  far[2] = 1.0;  // 1 m above the rails: no leg reaches
  EXPECT_EQ(pkm_sim_reset(s.get(), 0.0, far, xd), PKM_ERR_UNREACHABLE);
  EXPECT_NE(std::string(pkm_sim_error(s.get())).find("leg"), std::string::npos) << pkm_sim_error(s.get());

  // Slide the platform along the rails until the model's own inverse kinematics says a
  // stroke is out of range: the sim must refuse that start too, naming the leg.
  double shifted[N];
  int st = PKM_OK;
  for (double dx = 0.0; dx < 0.2 && st != PKM_ERR_JOINT_LIMIT; dx += 0.002) {
    std::memcpy(shifted, x, sizeof shifted);
    shifted[0] += dx;
    st = pkm_ik(m.get(), d.get(), shifted, q);
  }
  ASSERT_EQ(st, PKM_ERR_JOINT_LIMIT) << "no stroke limit found along x: " << pkm_data_error(d.get());
  EXPECT_EQ(pkm_sim_reset(s.get(), 0.0, shifted, xd), PKM_ERR_JOINT_LIMIT);
  EXPECT_TRUE(std::regex_search(std::string(pkm_sim_error(s.get())), std::regex("leg [1-6] stroke")))
      << pkm_sim_error(s.get());
  EXPECT_TRUE(same_bits(before, state_of(s.get())));
}

// ----------------------------------------------------------- reproducibility

// CVODE restarts at every advance, so a reset to a saved (t, x, xd) rolls it back; the
// explicit methods carry their step size, so they roll back through the saved state.
TEST(Sim, RollbackReproducesTheTrajectoryBitForBit) {
  for (int method : {PKM_BDF, PKM_ADAMS, PKM_ERK, PKM_ERK23}) {
    const bool explicit_rk = method == PKM_ERK || method == PKM_ERK23;
    ModelPtr m = make_model();
    pkm_sim_options o = defaults();
    o.method = method;
    SimPtr s = make_sim(m.get(), o);
    double x[N], xd[N] = {0.01, -0.02, 0.005, 0.05, -0.03, 0.08}, tau[N];
    home_of(m.get(), x);
    some_input(m.get(), x, tau);
    ASSERT_EQ(pkm_sim_reset(s.get(), 0.0, x, xd), PKM_OK) << pkm_sim_error(s.get());
    ASSERT_EQ(pkm_sim_set_input(s.get(), tau), PKM_OK);
    for (int k = 1; k <= 20; ++k) ASSERT_EQ(pkm_sim_advance(s.get(), 1e-3 * k), PKM_OK) << pkm_sim_error(s.get());
    const State saved = state_of(s.get());
    std::vector<double> saved_state(pkm_sim_state_size(s.get()));
    ASSERT_EQ(pkm_sim_state_save(s.get(), saved_state.data()), PKM_OK);
    auto roll_back = [&](pkm_sim* sim) {
      return explicit_rk ? pkm_sim_state_load(sim, saved_state.data(), saved_state.size())
                         : pkm_sim_reset(sim, saved.t, saved.x, saved.xd);
    };

    std::vector<State> first;
    for (int k = 21; k <= 40; ++k) {
      tau[k % N] += 0.01;  // a new input every step, as a controller would give
      ASSERT_EQ(pkm_sim_set_input(s.get(), tau), PKM_OK);
      ASSERT_EQ(pkm_sim_advance(s.get(), 1e-3 * k), PKM_OK) << pkm_sim_error(s.get());
      first.push_back(state_of(s.get()));
    }
    // Roll back to the saved state, give the same inputs again.
    for (int k = 21; k <= 40; ++k) tau[k % N] -= 0.01;
    ASSERT_EQ(roll_back(s.get()), PKM_OK) << pkm_sim_error(s.get());
    for (int k = 21; k <= 40; ++k) {
      tau[k % N] += 0.01;
      ASSERT_EQ(pkm_sim_set_input(s.get(), tau), PKM_OK);
      ASSERT_EQ(pkm_sim_advance(s.get(), 1e-3 * k), PKM_OK) << pkm_sim_error(s.get());
      EXPECT_TRUE(same_bits(first[k - 21], state_of(s.get()))) << "method " << method << ", step " << k;
    }
    // A fresh simulator started from the saved state gives the same bits too: nothing
    // of the earlier history leaks into an advance.
    SimPtr fresh = make_sim(m.get(), o);
    for (int k = 21; k <= 40; ++k) tau[k % N] -= 0.01;
    ASSERT_EQ(roll_back(fresh.get()), PKM_OK) << pkm_sim_error(fresh.get());
    for (int k = 21; k <= 40; ++k) {
      tau[k % N] += 0.01;
      ASSERT_EQ(pkm_sim_set_input(fresh.get(), tau), PKM_OK);
      ASSERT_EQ(pkm_sim_advance(fresh.get(), 1e-3 * k), PKM_OK) << pkm_sim_error(fresh.get());
      EXPECT_TRUE(same_bits(first[k - 21], state_of(fresh.get()))) << "method " << method << ", step " << k;
    }
  }
}

// The explicit method carries its last stage across a change of the held input, split as
// f(y, 0) + B tau (the accelerations are affine in the effort).  A state saved after the
// new input was set, before the advance, still rolls back bit for bit into a fresh
// simulator (the split depends on the state alone and is recomputed after a load).
TEST(Sim, RollbackSavedAfterANewInputReproducesTheBits) {
  ModelPtr m = make_model();
  SimPtr s = make_sim(m.get(), defaults());
  double x[N], tau[N];
  home_of(m.get(), x);
  some_input(m.get(), x, tau);
  ASSERT_EQ(pkm_sim_set_input(s.get(), tau), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(s.get(), 0.005), PKM_OK) << pkm_sim_error(s.get());
  tau[2] += 0.5;
  ASSERT_EQ(pkm_sim_set_input(s.get(), tau), PKM_OK);
  std::vector<double> saved(pkm_sim_state_size(s.get()));
  ASSERT_EQ(pkm_sim_state_save(s.get(), saved.data()), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(s.get(), 0.006), PKM_OK) << pkm_sim_error(s.get());
  const State first = state_of(s.get());
  SimPtr fresh = make_sim(m.get(), defaults());
  ASSERT_EQ(pkm_sim_state_load(fresh.get(), saved.data(), saved.size()), PKM_OK) << pkm_sim_error(fresh.get());
  ASSERT_EQ(pkm_sim_advance(fresh.get(), 0.006), PKM_OK) << pkm_sim_error(fresh.get());
  EXPECT_TRUE(same_bits(first, state_of(fresh.get())));
}

// Under a 1 kHz PD loop the carried first stage gives the trajectory of fresh forward-
// dynamics calls: the explicit 5(4) loop (6 calls a step with the carried stage, 7
// without it when rotor inertia turns it off) against CVODE BDF at rtol 1e-12, which
// calls the forward dynamics at every stage.
TEST(Sim, CarriedFirstStageMatchesFreshForwardDynamics) {
  for (double rotor : {0.0, 0.05}) {
    pkm_test::Params params;
    for (int i = 1; i <= N; ++i) params.push_back({"rail[" + std::to_string(i) + "].rotor_inertia", rotor});
    ModelPtr m = make_model(params);
    DataPtr d = make_data(m.get());
    double x0[N], q0[N];
    home_of(m.get(), x0);
    ASSERT_EQ(pkm_ik(m.get(), d.get(), x0, q0), PKM_OK);
    auto run = [&](int method, double rtol, pkm_sim_stats* stats) {
      pkm_sim_options o = defaults();
      o.method = method;
      o.rtol = rtol;
      o.atol = rtol * 1e-2;
      SimPtr s = make_sim(m.get(), o);
      std::vector<State> out;
      for (int k = 0; k < 300; ++k) {
        State st = state_of(s.get());
        double q[N], qd[N], tau[N];
        EXPECT_EQ(pkm_ik(m.get(), d.get(), st.x, q), PKM_OK);
        EXPECT_EQ(pkm_joint_velocity(m.get(), d.get(), st.x, st.xd, qd), PKM_OK);
        for (int i = 0; i < N; ++i) {
          const double ph = 2 * M_PI * 2.0 * k * 1e-3 + i;
          tau[i] = 2000 * (q0[i] + 0.003 * std::sin(ph) - q[i]) - 30 * qd[i];
        }
        EXPECT_EQ(pkm_sim_set_input(s.get(), tau), PKM_OK);
        EXPECT_EQ(pkm_sim_advance(s.get(), (k + 1) * 1e-3), PKM_OK) << pkm_sim_error(s.get());
        out.push_back(state_of(s.get()));
      }
      pkm_sim_get_stats(s.get(), stats);
      return out;
    };
    pkm_sim_stats erk{}, bdf{};
    const std::vector<State> a = run(PKM_ERK, 1e-10, &erk), b = run(PKM_BDF, 1e-12, &bdf);
    double err = 0;
    for (size_t k = 0; k < a.size(); ++k) err = std::fmax(err, max_diff(a[k], b[k]));
    EXPECT_LT(err, 1e-9) << "rotor inertia " << rotor;
    const double calls_per_step = (double)erk.rhs_evals / erk.steps;
    if (rotor == 0.0)
      EXPECT_LT(calls_per_step, 6.05) << erk.rhs_evals << " calls in " << erk.steps << " steps";
    else
      EXPECT_GT(calls_per_step, 6.95) << erk.rhs_evals << " calls in " << erk.steps << " steps";
  }
}

// A damaged or foreign saved state is refused and changes nothing.
TEST(Sim, DamagedSavedStatesAreRefused) {
  ModelPtr m = make_model();
  SimPtr s = make_sim(m.get(), defaults());
  ASSERT_EQ(pkm_sim_advance(s.get(), 0.01), PKM_OK) << pkm_sim_error(s.get());
  std::vector<double> saved(pkm_sim_state_size(s.get()));
  ASSERT_EQ(pkm_sim_state_save(s.get(), saved.data()), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(s.get(), 0.02), PKM_OK);
  const State before = state_of(s.get());
  std::vector<double> bad = saved;
  bad[3] = NAN;
  EXPECT_EQ(pkm_sim_state_load(s.get(), bad.data(), bad.size()), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_sim_error(s.get())).find("not finite"), std::string::npos) << pkm_sim_error(s.get());
  EXPECT_EQ(pkm_sim_state_load(s.get(), saved.data(), saved.size() - 1), PKM_ERR_ARGUMENT);
  bad = saved;
  bad[1] = 4;  // a state of a robot with 4 joints
  EXPECT_EQ(pkm_sim_state_load(s.get(), bad.data(), bad.size()), PKM_ERR_ARGUMENT);
  // The next step size (after t, x, xd, tau): a denormal one could never be taken.
  const size_t h_at = 3 + 2 * N + N;
  ASSERT_GT(saved[h_at], 0.0);
  bad = saved;
  bad[h_at] = 5e-324;
  EXPECT_EQ(pkm_sim_state_load(s.get(), bad.data(), bad.size()), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_sim_error(s.get())).find("next step size"), std::string::npos) << pkm_sim_error(s.get());
  bad[h_at] = -1.0;
  EXPECT_EQ(pkm_sim_state_load(s.get(), bad.data(), bad.size()), PKM_ERR_ARGUMENT);
  EXPECT_TRUE(same_bits(before, state_of(s.get())));
}

// The delay line of a saved state is checked: commands in order, none after the state's time.
TEST(Sim, SavedDelayLineOutOfOrderIsRefused) {
  ModelPtr m = make_model({{"actuator.delay", 0.003}});
  SimPtr s = make_sim(m.get(), defaults());
  for (int k = 1; k <= 5; ++k) ASSERT_EQ(pkm_sim_advance(s.get(), k * 1e-3), PKM_OK) << pkm_sim_error(s.get());
  std::vector<double> saved(pkm_sim_state_size(s.get()));
  ASSERT_EQ(pkm_sim_state_save(s.get(), saved.data()), PKM_OK);
  const size_t nh_at = 4 + 2 * N + N;
  ASSERT_GE(saved[nh_at], 2.0);
  ASSERT_EQ(pkm_sim_state_load(s.get(), saved.data(), saved.size()), PKM_OK) << pkm_sim_error(s.get());
  std::vector<double> bad = saved;
  bad[nh_at + 1] = saved[2] + 1.0;  // the first command issued a second after the state's time
  EXPECT_EQ(pkm_sim_state_load(s.get(), bad.data(), bad.size()), PKM_ERR_ARGUMENT);
  EXPECT_NE(std::string(pkm_sim_error(s.get())).find("delay-line command 0"), std::string::npos)
      << pkm_sim_error(s.get());
}

TEST(Sim, ExplicitMethodOutOfStepsNamesTheTimeAndKeepsTheState) {
  ModelPtr m = make_model();
  pkm_sim_options o = defaults();
  o.max_steps = 5;
  o.max_step = 1e-4;
  SimPtr s = make_sim(m.get(), o);
  ASSERT_EQ(pkm_sim_advance(s.get(), 0.05), PKM_ERR_STEP_BUDGET);
  const std::string msg = pkm_sim_error(s.get());
  EXPECT_NE(msg.find("step budget exceeded at t = "), std::string::npos) << msg;
  EXPECT_NE(msg.find("max_steps = 5"), std::string::npos) << msg;
  EXPECT_NE(msg.find("use solver.method = BDF"), std::string::npos) << msg;
  const State st = state_of(s.get());
  EXPECT_NEAR(time_in(msg), st.t, 1e-9) << msg;
  EXPECT_NEAR(st.t, 5e-4, 1e-12);
  double xs[N];
  home_of(m.get(), xs);
  EXPECT_LT(xs[2] - st.x[2], 1e-5);  // fell a little under gravity, from home
  EXPECT_GT(xs[2] - st.x[2], 0.0);
}

TEST(Sim, InterleavedSimulatorsMatchEachRunAlone) {
  ModelPtr ma = make_model();
  ModelPtr mb = make_model({{"platform.m", 0.5}});
  double x[N], xa[N] = {0.02, 0, 0, 0, 0, 0.1}, xb[N] = {0, -0.01, 0.01, 0.05, 0, 0}, ta[N], tb[N];
  home_of(ma.get(), x);
  some_input(ma.get(), x, ta);
  some_input(mb.get(), x, tb);
  pkm_sim_options oa = defaults(), ob = defaults();
  ob.method = PKM_ADAMS;

  auto run_alone = [&](const pkm_model* m, const pkm_sim_options& o, const double* xd, const double* tau) {
    SimPtr s = make_sim(m, o);
    EXPECT_EQ(pkm_sim_reset(s.get(), 0.0, x, xd), PKM_OK);
    EXPECT_EQ(pkm_sim_set_input(s.get(), tau), PKM_OK);
    std::vector<State> out;
    for (int k = 1; k <= 30; ++k) {
      EXPECT_EQ(pkm_sim_advance(s.get(), 2e-3 * k), PKM_OK) << pkm_sim_error(s.get());
      out.push_back(state_of(s.get()));
    }
    return out;
  };
  const std::vector<State> a = run_alone(ma.get(), oa, xa, ta), b = run_alone(mb.get(), ob, xb, tb);

  SimPtr sa = make_sim(ma.get(), oa), sb = make_sim(mb.get(), ob);
  ASSERT_EQ(pkm_sim_reset(sa.get(), 0.0, x, xa), PKM_OK);
  ASSERT_EQ(pkm_sim_reset(sb.get(), 0.0, x, xb), PKM_OK);
  ASSERT_EQ(pkm_sim_set_input(sa.get(), ta), PKM_OK);
  ASSERT_EQ(pkm_sim_set_input(sb.get(), tb), PKM_OK);
  for (int k = 1; k <= 30; ++k) {
    ASSERT_EQ(pkm_sim_advance(sa.get(), 2e-3 * k), PKM_OK);
    ASSERT_EQ(pkm_sim_advance(sb.get(), 2e-3 * k), PKM_OK);
    EXPECT_TRUE(same_bits(a[k - 1], state_of(sa.get()))) << "step " << k;
    EXPECT_TRUE(same_bits(b[k - 1], state_of(sb.get()))) << "step " << k;
  }
  // The two robots differ, so the test would notice a mix-up.
  EXPECT_GT(max_diff(a.back(), b.back()), 1e-6);
}

// Simulators in concurrent threads (one each) share no state: each thread's trajectory
// equals the same run done alone, to the bit.
TEST(Sim, SimulatorsInParallelThreadsMatchEachRunAlone) {
  constexpr int kThreads = 4;
  auto run = [](int which, State* out) {
    ModelPtr m = make_model({{"platform.m", 0.3 + 0.05 * which}});
    pkm_sim_options o = defaults();
    o.method = which % 2 ? PKM_ADAMS : PKM_BDF;
    SimPtr s = make_sim(m.get(), o);
    double x[N], xd[N] = {0.01 * which, -0.01, 0.0, 0.02, 0.0, -0.03}, tau[N];
    home_of(m.get(), x);
    some_input(m.get(), x, tau);
    pkm_sim_reset(s.get(), 0.0, x, xd);
    pkm_sim_set_input(s.get(), tau);
    for (int k = 1; k <= 50; ++k) pkm_sim_advance(s.get(), 1e-3 * k);
    *out = state_of(s.get());
  };
  State alone[kThreads], together[kThreads];
  for (int i = 0; i < kThreads; ++i) run(i, &alone[i]);
  std::vector<std::thread> threads;
  for (int i = 0; i < kThreads; ++i) threads.emplace_back(run, i, &together[i]);
  for (auto& t : threads) t.join();
  for (int i = 0; i < kThreads; ++i) {
    EXPECT_EQ(alone[i].t, 0.05) << i;
    EXPECT_TRUE(same_bits(alone[i], together[i])) << "thread " << i;
  }
}

TEST(Sim, KeepsItsOwnCopyOfTheModel) {
  ModelPtr m = make_model();
  SimPtr s = make_sim(m.get(), defaults());
  char err[512];
  // Change the caller's model after the sim exists: the sim must not see it.
  ASSERT_EQ(pkm_param_set(m.get(), pkm_param_index(m.get(), "platform.m"), 0.9, err, sizeof err), PKM_OK);
  ASSERT_EQ(pkm_model_validate(m.get(), err, sizeof err), PKM_OK) << err;
  ModelPtr ref = make_model();
  SimPtr r = make_sim(ref.get(), defaults());
  ModelPtr heavy = make_model({{"platform.m", 0.9}});
  SimPtr h = make_sim(heavy.get(), defaults());
  for (pkm_sim* p : {s.get(), r.get(), h.get()}) ASSERT_EQ(pkm_sim_advance(p, 0.02), PKM_OK) << pkm_sim_error(p);
  EXPECT_TRUE(same_bits(state_of(s.get()), state_of(r.get())));
  EXPECT_GT(max_diff(state_of(s.get()), state_of(h.get())), 1e-9);
}

// ----------------------------------------------------------------- physics

TEST(Sim, GravityLoadHoldsTheRobotStill) {
  ModelPtr m = make_model();
  SimPtr s = make_sim(m.get(), defaults());
  double x[N], tau[N];
  home_of(m.get(), x);
  DataPtr d = make_data(m.get());
  ASSERT_EQ(pkm_gravity_load(m.get(), d.get(), x, tau), PKM_OK);
  ASSERT_EQ(pkm_sim_set_input(s.get(), tau), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(s.get(), 0.2), PKM_OK) << pkm_sim_error(s.get());
  State st = state_of(s.get());
  for (int i = 0; i < N; ++i) {
    EXPECT_NEAR(st.x[i], x[i], 1e-7) << i;
    EXPECT_NEAR(st.xd[i], 0.0, 1e-6) << i;
  }
  // Without the input the platform would have moved: the check above can fail.
  SimPtr free_fall = make_sim(m.get(), defaults());
  ASSERT_EQ(pkm_sim_advance(free_fall.get(), 0.02), PKM_OK) << pkm_sim_error(free_fall.get());
  EXPECT_LT(state_of(free_fall.get()).x[2], x[2] - 1e-4);
}

// Total energy with no gravity, no friction and no input over 10 s.
TEST(Sim, EnergyIsConservedWithoutGravityFrictionOrInput) {
  ModelPtr m = make_model({{"gravity.z", 0.0}});
  DataPtr d = make_data(m.get());
  pkm_sim_options o = defaults();
  o.rtol = 1e-10;
  o.atol = 1e-12;
  SimPtr s = make_sim(m.get(), o);
  double x[N];
  home_of(m.get(), x);
  // Slow enough to stay inside the strokes for 10 s, with every coordinate moving.
  const double xd[N] = {1.5e-3, -1.0e-3, 1.2e-3, 4e-3, -3e-3, 5e-3};
  ASSERT_EQ(pkm_sim_reset(s.get(), 0.0, x, xd), PKM_OK) << pkm_sim_error(s.get());
  double k0, p0;
  ASSERT_EQ(pkm_energy(m.get(), d.get(), x, xd, &k0, &p0), PKM_OK) << pkm_data_error(d.get());
  const double e0 = k0 + p0;
  ASSERT_GT(k0, 0.0);
  double drift = 0, moved = 0;
  for (int k = 1; k <= 100; ++k) {
    ASSERT_EQ(pkm_sim_advance(s.get(), 0.1 * k), PKM_OK) << pkm_sim_error(s.get());
    State st = state_of(s.get());
    double ke, pe;
    ASSERT_EQ(pkm_energy(m.get(), d.get(), st.x, st.xd, &ke, &pe), PKM_OK);
    drift = std::fmax(drift, std::fabs(ke + pe - e0) / std::fabs(e0));
    moved = std::fmax(moved, std::fabs(st.xd[0] - xd[0]) + std::fabs(st.xd[5] - xd[5]));
  }
  std::printf("[ measured ] energy drift over 10 s: %.3e relative (E0 = %.6e J)\n", drift, e0);
  EXPECT_LT(drift, 1e-6);
  // The rates change along the way (the mass matrix depends on the pose): the energy
  // check is not about a motion that stands still.
  EXPECT_GT(moved, 1e-5);
}

TEST(Sim, ViscousFrictionOnlyDissipates) {
  pkm_test::Params p = {{"gravity.z", 0.0}};
  for (int i = 1; i <= N; ++i) p.push_back({"rail[" + std::to_string(i) + "].viscous", 5.0});
  ModelPtr m = make_model(p);
  DataPtr d = make_data(m.get());
  SimPtr s = make_sim(m.get(), defaults());
  double x[N];
  home_of(m.get(), x);
  const double xd[N] = {0.02, -0.01, 0.01, 0.05, -0.03, 0.08};
  ASSERT_EQ(pkm_sim_reset(s.get(), 0.0, x, xd), PKM_OK) << pkm_sim_error(s.get());
  double e_prev = INFINITY, e_first = NAN;
  for (int k = 0; k <= 50; ++k) {
    if (k) ASSERT_EQ(pkm_sim_advance(s.get(), 0.01 * k), PKM_OK) << pkm_sim_error(s.get());
    State st = state_of(s.get());
    double ke, pe;
    ASSERT_EQ(pkm_energy(m.get(), d.get(), st.x, st.xd, &ke, &pe), PKM_OK);
    if (k == 0) e_first = ke + pe;
    EXPECT_LT(ke + pe, e_prev + 1e-12) << "energy grew at t = " << st.t;
    e_prev = ke + pe;
  }
  EXPECT_LT(e_prev, 0.9 * e_first);
}

// With the default 170 mm rails a free fall reaches the direct singularity first (see
// the next test); with 80 mm rails the platform must stop at a stroke limit.
TEST(Sim, FallsUnderGravityAndStopsAtAStrokeLimit) {
  pkm_test::Params p;
  for (int i = 1; i <= N; ++i) p.push_back({"rail[" + std::to_string(i) + "].qmax", 0.08});
  ModelPtr m = make_model(p);
  DataPtr d = make_data(m.get());
  SimPtr s = make_sim(m.get(), defaults());
  int status = PKM_OK;
  for (int k = 1; k <= 200 && status == PKM_OK; ++k) status = pkm_sim_advance(s.get(), 0.01 * k);
  ASSERT_EQ(status, PKM_ERR_JOINT_LIMIT) << pkm_sim_error(s.get());
  const std::string msg = pkm_sim_error(s.get());
  std::smatch mt;
  ASSERT_TRUE(std::regex_search(msg, mt,
                                std::regex("leg ([1-6]) reached its stroke limit rail\\[([1-6])\\]\\.(qmin|qmax) = "
                                           "([-0-9.eE+]+) m at t = ([0-9.eE+-]+) s")))
      << msg;
  EXPECT_EQ(mt[1], mt[2]);
  const int leg = std::stoi(mt[1]) - 1;
  const double limit = std::stod(mt[4]);
  const State st = state_of(s.get());
  EXPECT_NEAR(time_in(msg), st.t, 1e-9 * (1 + st.t));
  EXPECT_GT(st.t, 0.0);
  const std::string which = mt[3];
  EXPECT_EQ(limit, pkm_param_get(m.get(), pkm_param_index(m.get(), ("rail[" + std::to_string(leg + 1) + "]." +
                                                                     which).c_str())));
  // The state where it stopped is on the limit, and still inside every stroke range,
  // so the caller's inverse kinematics works there.
  double q[N];
  ASSERT_EQ(pkm_ik(m.get(), d.get(), st.x, q), PKM_OK) << pkm_data_error(d.get());
  EXPECT_NEAR(q[leg], limit, 1e-9);
  // It cannot go on from there, and says so again.
  EXPECT_EQ(pkm_sim_advance(s.get(), st.t + 0.01), PKM_ERR_JOINT_LIMIT);
  EXPECT_NE(std::string(pkm_sim_error(s.get())).find("leg " + std::to_string(leg + 1)), std::string::npos)
      << pkm_sim_error(s.get());
  // A reset to that state is accepted (a rollback target).
  EXPECT_EQ(pkm_sim_reset(s.get(), st.t, st.x, st.xd), PKM_OK) << pkm_sim_error(s.get());
}

// The default robot falling freely from home sinks through the plane of its rails, where
// the legs lie flat and cannot hold the platform: a direct singularity (measure -> 0).
TEST(Sim, FallsThroughTheRailPlaneToADirectSingularity) {
  ModelPtr m = make_model();
  DataPtr d = make_data(m.get());
  const pkm_sim_options o = defaults();
  SimPtr s = make_sim(m.get(), o);
  int status = PKM_OK;
  for (int k = 1; k <= 100 && status == PKM_OK; ++k) status = pkm_sim_advance(s.get(), 0.01 * k);
  ASSERT_EQ(status, PKM_ERR_SINGULAR) << pkm_sim_error(s.get());
  const std::string msg = pkm_sim_error(s.get());
  EXPECT_NE(msg.find("direct (type 2) singularity"), std::string::npos) << msg;
  const State st = state_of(s.get());
  EXPECT_NEAR(time_in(msg), st.t, 1e-9);
  double meas[2], q[N];
  ASSERT_EQ(pkm_singularity(m.get(), d.get(), st.x, meas), PKM_OK);
  EXPECT_NEAR(meas[1], o.sing_min, 1e-9);
  // Near the rail plane (z = 0), every stroke still in range.
  EXPECT_LT(std::fabs(st.x[2]), 0.01);
  EXPECT_EQ(pkm_ik(m.get(), d.get(), st.x, q), PKM_OK) << pkm_data_error(d.get());
  EXPECT_EQ(pkm_sim_advance(s.get(), st.t + 0.01), PKM_ERR_SINGULAR);

  // One long advance from home (the measure starts far above sing_min, where the sim
  // skips the per-step singularity check) must find the same crossing.
  SimPtr one = make_sim(m.get(), o);
  ASSERT_EQ(pkm_sim_advance(one.get(), 1.0), PKM_ERR_SINGULAR) << pkm_sim_error(one.get());
  EXPECT_NEAR(state_of(one.get()).t, st.t, 1e-6);
}

// With a tiny sing_min the measure is below it for well under a microsecond at each
// crossing: no CVODE step ends inside, so only the sign change of det J can catch it.
TEST(Sim, CatchesASingularityCrossedWithinOneStep) {
  ModelPtr m = make_model();
  DataPtr d = make_data(m.get());
  pkm_sim_options o = defaults();
  o.sing_min = 1e-6;
  SimPtr s = make_sim(m.get(), o);
  ASSERT_EQ(pkm_sim_advance(s.get(), 1.0), PKM_ERR_SINGULAR) << pkm_sim_error(s.get());
  const std::string msg = pkm_sim_error(s.get());
  EXPECT_NE(msg.find("direct (type 2) singularity"), std::string::npos) << msg;
  const State st = state_of(s.get());
  EXPECT_NEAR(time_in(msg), st.t, 1e-9);
  double meas[2];
  ASSERT_EQ(pkm_singularity(m.get(), d.get(), st.x, meas), PKM_OK);
  EXPECT_NEAR(meas[1], o.sing_min, 1e-9);
  EXPECT_GE(meas[1], o.sing_min);
  // The first of the three crossings of the rail plane (the next ones follow within 3 ms).
  EXPECT_GT(st.t, 0.17);
  EXPECT_LT(st.t, 0.1784);
}

// The direct-singularity stop: with sing_min just below the measure at the start and a
// velocity down the measure's gradient, the motion must stop where measure = sing_min.
TEST(Sim, StopsAtTheDirectSingularityThreshold) {
  ModelPtr m = make_model({{"gravity.z", 0.0}});
  DataPtr d = make_data(m.get());
  double x[N], meas[2];
  home_of(m.get(), x);
  ASSERT_EQ(pkm_singularity(m.get(), d.get(), x, meas), PKM_OK);
  const double m0 = meas[1];
  double grad[N], norm = 0;
  for (int i = 0; i < N; ++i) {
    const double h = 1e-6;
    double xp[N], xm[N], mp[2], mm[2];
    std::memcpy(xp, x, sizeof xp);
    std::memcpy(xm, x, sizeof xm);
    xp[i] += h;
    xm[i] -= h;
    ASSERT_EQ(pkm_singularity(m.get(), d.get(), xp, mp), PKM_OK);
    ASSERT_EQ(pkm_singularity(m.get(), d.get(), xm, mm), PKM_OK);
    grad[i] = (mp[1] - mm[1]) / (2 * h);
    norm += grad[i] * grad[i];
  }
  norm = std::sqrt(norm);
  ASSERT_GT(norm, 0.0);
  double xd[N];
  for (int i = 0; i < N; ++i) xd[i] = -0.01 * grad[i] / norm;
  pkm_sim_options o = defaults();
  o.sing_min = m0 - 2e-4;
  SimPtr s = make_sim(m.get(), o);
  ASSERT_EQ(pkm_sim_reset(s.get(), 0.0, x, xd), PKM_OK) << pkm_sim_error(s.get());
  const int status = pkm_sim_advance(s.get(), 2.0);
  ASSERT_EQ(status, PKM_ERR_SINGULAR) << pkm_sim_error(s.get());
  const std::string msg = pkm_sim_error(s.get());
  EXPECT_NE(msg.find("direct (type 2) singularity"), std::string::npos) << msg;
  const State st = state_of(s.get());
  EXPECT_NEAR(time_in(msg), st.t, 1e-9);
  ASSERT_EQ(pkm_singularity(m.get(), d.get(), st.x, meas), PKM_OK);
  EXPECT_NEAR(meas[1], o.sing_min, 1e-9);
  EXPECT_GE(meas[1], o.sing_min);
}

TEST(Sim, BdfAndAdamsAgree) {
  ModelPtr m = make_model();
  double x[N], xd[N] = {0.01, -0.02, 0.005, 0.05, -0.03, 0.08}, tau[N];
  home_of(m.get(), x);
  some_input(m.get(), x, tau);
  State end[2];
  for (int method : {PKM_BDF, PKM_ADAMS}) {
    pkm_sim_options o = defaults();
    o.method = method;
    SimPtr s = make_sim(m.get(), o);
    ASSERT_EQ(pkm_sim_reset(s.get(), 0.0, x, xd), PKM_OK);
    ASSERT_EQ(pkm_sim_set_input(s.get(), tau), PKM_OK);
    ASSERT_EQ(pkm_sim_advance(s.get(), 0.1), PKM_OK) << pkm_sim_error(s.get());
    end[method] = state_of(s.get());
  }
  const double diff = max_diff(end[0], end[1]);
  std::printf("[ measured ] |BDF - Adams| after 0.1 s: %.3e\n", diff);
  EXPECT_LT(diff, 1e-6);
  double moved = 0;
  for (int i = 0; i < N; ++i) moved = std::fmax(moved, std::fabs(end[0].x[i] - x[i]));
  EXPECT_GT(moved, 1e-4);
}

TEST(Sim, CvodeOutOfStepsIsTheStepBudgetAndNamesTheTime) {
  ModelPtr m = make_model();
  pkm_sim_options o = defaults();
  o.method = PKM_BDF;
  o.max_steps = 5;
  SimPtr s = make_sim(m.get(), o);
  double x[N], xd[N] = {0.01, -0.02, 0.005, 0.05, -0.03, 0.08};
  home_of(m.get(), x);
  ASSERT_EQ(pkm_sim_reset(s.get(), 0.0, x, xd), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(s.get(), 0.05), PKM_ERR_STEP_BUDGET);
  const std::string msg = pkm_sim_error(s.get());
  EXPECT_NE(msg.find("step budget exceeded at t = "), std::string::npos) << msg;
  EXPECT_NE(msg.find("max_steps = 5"), std::string::npos) << msg;
  const State st = state_of(s.get());
  EXPECT_NEAR(time_in(msg), st.t, 1e-9) << msg;
  EXPECT_GT(st.t, 0.0);
  EXPECT_LT(st.t, 0.05);
  for (int i = 0; i < N; ++i) EXPECT_TRUE(std::isfinite(st.x[i]) && std::isfinite(st.xd[i]));
}

// ------------------------------------------------------------- drive layer

TEST(SimDrive, SaturationClipsTheCommand) {
  pkm_test::Params p;
  for (int i = 1; i <= N; ++i) p.push_back({"rail[" + std::to_string(i) + "].effort_max", 2.0});
  ModelPtr sat = make_model(p), plain = make_model();
  SimPtr a = make_sim(sat.get(), defaults()), b = make_sim(plain.get(), defaults());
  const double big[N] = {50, -50, 1.0, 50, -50, -1.5}, clipped[N] = {2, -2, 1.0, 2, -2, -1.5};
  ASSERT_EQ(pkm_sim_set_input(a.get(), big), PKM_OK);
  ASSERT_EQ(pkm_sim_set_input(b.get(), clipped), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(a.get(), 0.02), PKM_OK) << pkm_sim_error(a.get());
  ASSERT_EQ(pkm_sim_advance(b.get(), 0.02), PKM_OK) << pkm_sim_error(b.get());
  EXPECT_TRUE(same_bits(state_of(a.get()), state_of(b.get())));
}

// The drive's dead zone: commands within +-u0 deliver nothing, larger ones lose u0, then
// the saturation clips what is delivered; the sim integrates the delivered effort.
TEST(SimDrive, DeadZoneRemovesTheBandThenSaturationClips) {
  pkm_test::Params p;
  for (int i = 1; i <= N; ++i) {
    p.push_back({"rail[" + std::to_string(i) + "].dead_zone", 0.5});
    p.push_back({"rail[" + std::to_string(i) + "].effort_max", 2.0});
  }
  ModelPtr dz = make_model(p), plain = make_model();
  DataPtr d = make_data(dz.get());
  const double cmd[N] = {0.3, -0.5, 0.8, -1.7, 4.0, -2.49}, want[N] = {0.0, 0.0, 0.3, -1.2, 2.0, -1.99};
  double got[N];
  ASSERT_EQ(pkm_actuator_effort(dz.get(), d.get(), cmd, got), PKM_OK);
  for (int i = 0; i < N; ++i) EXPECT_NEAR(got[i], want[i], 1e-15) << "joint " << i + 1;
  SimPtr a = make_sim(dz.get(), defaults()), b = make_sim(plain.get(), defaults());
  ASSERT_EQ(pkm_sim_set_input(a.get(), cmd), PKM_OK);
  ASSERT_EQ(pkm_sim_set_input(b.get(), got), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(a.get(), 0.02), PKM_OK) << pkm_sim_error(a.get());
  ASSERT_EQ(pkm_sim_advance(b.get(), 0.02), PKM_OK) << pkm_sim_error(b.get());
  EXPECT_TRUE(same_bits(state_of(a.get()), state_of(b.get())));
}

TEST(SimDrive, ActuatorDelayShiftsTheCommand) {
  const double delay = 0.01;
  ModelPtr late = make_model({{"actuator.delay", delay}}), now = make_model();
  double x[N], tau1[N], tau2[N];
  home_of(now.get(), x);
  some_input(now.get(), x, tau1);
  for (int i = 0; i < N; ++i) tau2[i] = tau1[i] * 1.05;
  SimPtr a = make_sim(late.get(), defaults()), b = make_sim(now.get(), defaults());
  // Delayed: tau1 from t = 0, tau2 from t = 0.015; the mechanism feels nothing until
  // 0.01, tau1 until 0.025, then tau2.
  ASSERT_EQ(pkm_sim_set_input(a.get(), tau1), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(a.get(), 0.015), PKM_OK) << pkm_sim_error(a.get());
  ASSERT_EQ(pkm_sim_set_input(a.get(), tau2), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(a.get(), 0.04), PKM_OK) << pkm_sim_error(a.get());
  // The same efforts applied at those times without delay.
  const double zero[N] = {0, 0, 0, 0, 0, 0};
  ASSERT_EQ(pkm_sim_set_input(b.get(), zero), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(b.get(), 0.01), PKM_OK);
  ASSERT_EQ(pkm_sim_set_input(b.get(), tau1), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(b.get(), 0.015), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(b.get(), 0.025), PKM_OK);
  ASSERT_EQ(pkm_sim_set_input(b.get(), tau2), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(b.get(), 0.04), PKM_OK);
  const State sa = state_of(a.get()), sb = state_of(b.get());
  EXPECT_LT(max_diff(sa, sb), 1e-12);
  EXPECT_EQ(sa.t, sb.t);

  // Rollback with a delay replays the commands issued before the rollback point: the
  // saved state carries the delay line (and the explicit method's step size), also into
  // a fresh simulator.
  ASSERT_EQ(pkm_sim_reset(a.get(), 0.0, x, zero), PKM_OK);
  ASSERT_EQ(pkm_sim_set_input(a.get(), tau1), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(a.get(), 0.015), PKM_OK);
  std::vector<double> mid(pkm_sim_state_size(a.get()));
  ASSERT_EQ(pkm_sim_state_save(a.get(), mid.data()), PKM_OK);
  ASSERT_EQ(pkm_sim_set_input(a.get(), tau2), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(a.get(), 0.04), PKM_OK);
  const State end1 = state_of(a.get());
  ASSERT_EQ(pkm_sim_state_load(a.get(), mid.data(), mid.size()), PKM_OK) << pkm_sim_error(a.get());
  ASSERT_EQ(pkm_sim_set_input(a.get(), tau2), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(a.get(), 0.04), PKM_OK);
  EXPECT_TRUE(same_bits(end1, state_of(a.get())));
  SimPtr fresh = make_sim(late.get(), defaults());
  ASSERT_EQ(pkm_sim_state_load(fresh.get(), mid.data(), mid.size()), PKM_OK) << pkm_sim_error(fresh.get());
  ASSERT_EQ(pkm_sim_set_input(fresh.get(), tau2), PKM_OK);
  ASSERT_EQ(pkm_sim_advance(fresh.get(), 0.04), PKM_OK);
  EXPECT_TRUE(same_bits(end1, state_of(fresh.get())));
}

}  // namespace
