// Shared by the C++ benchmark programs of bench/ (not a benchmark itself: CMake builds
// only bench/*.cpp): the 6-PUS size, a monotonic clock, the one-line failure exit, and
// what described_bench times and described_count counts (the sampled states, the closed loop).
#pragma once

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "pkm/pkm.h"

namespace bench {

constexpr int N = 6;  // 6-PUS joints and pose coordinates
constexpr double kPi = 3.14159265358979323846;

inline double now() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

// Prints "<program>: <what>" and exits with status 2 (a benchmark that cannot run).
[[noreturn]] inline void die(const char* program, const std::string& what) {
  std::fprintf(stderr, "%s: %s\n", program, what.c_str());
  std::exit(2);
}

// K states around m's home (seed 1): poses home +- 0.01 m or 0.05 rad, rates +- 0.05,
// accelerations +- 1 per coordinate, uniform; X, XD, XDD resized to K x n (row k the state k).
inline void sample_states(pkm_model* m, size_t K, std::vector<double>& X, std::vector<double>& XD,
                          std::vector<double>& XDD) {
  const int n = pkm_model_ndof(m);
  double home[6];
  pkm_model_home(m, home);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  X.resize(K * n), XD.resize(K * n), XDD.resize(K * n);
  for (size_t k = 0; k < K; ++k)
    for (int j = 0; j < n; ++j) {
      const bool ang = std::strcmp(pkm_model_pose_unit(m, j), "rad") == 0;
      X[k * n + j] = home[j] + (ang ? 0.05 : 0.01) * u(rng);
      XD[k * n + j] = 0.05 * u(rng);
      XDD[k * n + j] = u(rng);
    }
}

// The closed loop users run (as bench/loop_bench): 2 s of a joint PD (kp 2000, kd 30 on the
// diagonal) at 1 ms through pkm_closed_loop with the default (explicit Runge-Kutta) options,
// each joint a 1 Hz sine about its home value (3 mm or 0.02 rad, phases pi/3 apart).
struct PdLoop {
  static constexpr size_t nk = 2001;
  static constexpr double dt = 1e-3;
  int n = 0;
  std::vector<double> qref, qdref, kp, kd;
};
// The reference from m's joints at home.
inline PdLoop pd_loop(pkm_model* m, const char* program) {
  PdLoop L;
  const int n = L.n = pkm_model_ndof(m);
  double home[6], q0[6];
  pkm_model_home(m, home);
  pkm_data* d = pkm_data_create(m);
  const int rc = pkm_ik(m, d, home, q0);
  pkm_data_destroy(d);
  if (rc != PKM_OK) die(program, "home is not reachable");
  const bool ang = std::strcmp(pkm_model_joint_unit(m), "rad") == 0;
  L.qref.resize(L.nk * n), L.qdref.resize(L.nk * n), L.kp.assign(n * n, 0.0), L.kd.assign(n * n, 0.0);
  for (size_t k = 0; k < L.nk; ++k)
    for (int i = 0; i < n; ++i) {
      const double ph = 2 * kPi * (k * L.dt) + i * kPi / 3, amp = ang ? 0.02 : 0.003;
      L.qref[k * n + i] = q0[i] + amp * std::sin(ph);
      L.qdref[k * n + i] = amp * 2 * kPi * std::cos(ph);
    }
  for (int i = 0; i < n; ++i) L.kp[i * n + i] = 2000.0, L.kd[i * n + i] = 30.0;
  return L;
}
// Runs the loop L on m, its poses into xs (nk x n); the wall time of pkm_closed_loop [s].
inline double run_pd_loop(pkm_model* m, const PdLoop& L, std::vector<double>& xs, const char* program) {
  pkm_sim_options o;
  pkm_sim_default_options(&o);
  char err[1024];
  pkm_sim* sim = pkm_sim_create(m, &o, err, sizeof err);
  if (!sim) die(program, err);
  pkm_ctrl_spec c{};
  c.kind = PKM_CTRL_PD;
  c.dt = L.dt;
  c.kp = L.kp.data();
  c.kd = L.kd.data();
  pkm_ctrl* ctrl = pkm_ctrl_create(m, &c, err, sizeof err);
  if (!ctrl) die(program, err);
  pkm_loop_reference ref{L.nk, 0.0, L.dt, nullptr, L.qref.data(), L.qdref.data(), nullptr, nullptr, nullptr};
  pkm_loop_record rec{};
  xs.resize(L.nk * L.n);
  rec.x = xs.data();
  size_t done = 0;
  const double t0 = now();
  if (pkm_closed_loop(sim, ctrl, &ref, nullptr, nullptr, 0, &rec, &done) != PKM_OK) die(program, pkm_sim_error(sim));
  const double wall = now() - t0;
  pkm_ctrl_destroy(ctrl);
  pkm_sim_destroy(sim);
  return wall;
}

}  // namespace bench
