// loop_bench: a 6-PUS under a sampled joint PD, 10 s at a 1 ms period, through the C API:
//
//   loop_bench [--json] [--seconds T] [--period DT] [--repeats R]
//
//   compiled   pkm_closed_loop: plant + pkm_ctrl + reference table in one call
//   stepwise   the same loop advanced period by period (what an FMU's doStep does):
//              pkm_ik + pkm_joint_velocity for the readings, pkm_ctrl_update, then
//              pkm_sim_set_input + pkm_sim_advance
// each with the explicit Runge-Kutta method (the default) and CVODE BDF (the default
// before it), plus the trajectory error of each against a tight-tolerance reference
// (rtol 1e-12) and the loop-closure error (| |P_i - S_i| - L_i |, max over the run).
// Medians of R repeats.  bench/closed_loop_bench.py runs it beside a MuJoCo loop.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "pkm/pkm.h"

namespace {

using bench::kPi;
using bench::N;
using bench::now;

[[noreturn]] void die(const std::string& what) { bench::die("loop_bench", what); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Setup {
  pkm_model* m;
  pkm_data* d;
  double home[N];
  size_t n;
  double dt;
  std::vector<double> qref, qdref;
  std::vector<double> kp, kd;
};

// The reference: each stroke a 3 mm, 1 Hz sine about home, phases 60 deg apart (the
// platform translates and tilts); the PD of bench/closed_loop_bench.py's MuJoCo loop.
Setup setup(double seconds, double dt) {
  Setup s{};
  char err[1024];
  s.m = pkm_model_create("6pus", nullptr, err, sizeof err);
  if (!s.m) die(err);
  s.d = pkm_data_create(s.m);
  pkm_model_home(s.m, s.home);
  double q0[N];
  if (pkm_ik(s.m, s.d, s.home, q0)) die(pkm_data_error(s.d));
  s.dt = dt;
  s.n = (size_t)std::llround(seconds / dt) + 1;
  s.qref.resize(s.n * N);
  s.qdref.resize(s.n * N);
  for (size_t k = 0; k < s.n; ++k)
    for (int i = 0; i < N; ++i) {
      const double ph = 2 * kPi * 1.0 * (k * dt) + i * kPi / 3;
      s.qref[k * N + i] = q0[i] + 0.003 * std::sin(ph);
      s.qdref[k * N + i] = 0.003 * 2 * kPi * std::cos(ph);
    }
  s.kp.assign(N * N, 0.0);
  s.kd.assign(N * N, 0.0);
  for (int i = 0; i < N; ++i) s.kp[i * N + i] = 2000.0, s.kd[i * N + i] = 30.0;
  return s;
}

pkm_ctrl* make_ctrl(const Setup& s) {
  pkm_ctrl_spec c{};
  c.kind = PKM_CTRL_PD;
  c.dt = s.dt;
  c.kp = s.kp.data();
  c.kd = s.kd.data();
  char err[512];
  pkm_ctrl* ctrl = pkm_ctrl_create(s.m, &c, err, sizeof err);
  if (!ctrl) die(err);
  return ctrl;
}

pkm_sim* make_sim(const Setup& s, int method, double rtol, double atol) {
  pkm_sim_options o;
  pkm_sim_default_options(&o);
  o.method = method;
  o.rtol = rtol;
  o.atol = atol;
  char err[1024];
  pkm_sim* sim = pkm_sim_create(s.m, &o, err, sizeof err);
  if (!sim) die(err);
  return sim;
}

struct Run {
  double wall;
  std::vector<double> x;  // poses [n, N]
  pkm_sim_stats stats;
};

Run compiled(const Setup& s, int method, double rtol, double atol) {
  pkm_sim* sim = make_sim(s, method, rtol, atol);
  pkm_ctrl* c = make_ctrl(s);
  Run r;
  r.x.resize(s.n * N);
  pkm_loop_reference ref{s.n, 0.0, s.dt, nullptr, s.qref.data(), s.qdref.data(), nullptr, nullptr, nullptr};
  pkm_loop_record rec{};
  rec.x = r.x.data();
  size_t done = 0;
  const double t0 = now();
  if (pkm_closed_loop(sim, c, &ref, nullptr, nullptr, 0, &rec, &done)) die(pkm_sim_error(sim));
  r.wall = now() - t0;
  pkm_sim_get_stats(sim, &r.stats);
  pkm_ctrl_destroy(c);
  pkm_sim_destroy(sim);
  return r;
}

Run stepwise(const Setup& s, int method, double rtol, double atol) {
  pkm_sim* sim = make_sim(s, method, rtol, atol);
  pkm_ctrl* c = make_ctrl(s);
  Run r;
  r.x.resize(s.n * N);
  double t, x[N], xd[N], q[N], qd[N], tau[N];
  const double t0 = now();
  for (size_t k = 0; k < s.n; ++k) {
    pkm_sim_get_state(sim, &t, x, xd);
    std::memcpy(&r.x[k * N], x, sizeof x);
    if (pkm_ik(s.m, s.d, x, q) || pkm_joint_velocity(s.m, s.d, x, xd, qd)) die(pkm_data_error(s.d));
    if (pkm_ctrl_update(c, k * s.dt, q, qd, &s.qref[k * N], &s.qdref[k * N], nullptr, nullptr, tau))
      die(pkm_ctrl_error(c));
    if (k + 1 == s.n) break;
    pkm_sim_set_input(sim, tau);
    if (pkm_sim_advance(sim, k * s.dt + s.dt)) die(pkm_sim_error(sim));
  }
  r.wall = now() - t0;
  pkm_sim_get_stats(sim, &r.stats);
  pkm_ctrl_destroy(c);
  pkm_sim_destroy(sim);
  return r;
}

double max_error(const std::vector<double>& a, const std::vector<double>& b) {
  double e = 0;
  for (size_t i = 0; i < a.size(); ++i) e = std::max(e, std::fabs(a[i] - b[i]));
  return e;
}

double closure_error(const Setup& s, const std::vector<double>& x) {
  double e = 0, P[N * 3], S[N * 3];
  std::vector<double> L(N);
  for (int i = 0; i < N; ++i)
    L[i] = pkm_param_get(s.m, pkm_param_index(s.m, ("leg[" + std::to_string(i + 1) + "].L").c_str()));
  for (size_t k = 0; k < s.n; ++k) {
    if (pkm_6pus_leg_points(s.m, s.d, &x[k * N], P, S)) die(pkm_data_error(s.d));
    for (int i = 0; i < N; ++i) {
      const double dx = P[3 * i] - S[3 * i], dy = P[3 * i + 1] - S[3 * i + 1], dz = P[3 * i + 2] - S[3 * i + 2];
      e = std::max(e, std::fabs(std::sqrt(dx * dx + dy * dy + dz * dz) - L[i]));
    }
  }
  return e;
}

}  // namespace

int main(int argc, char** argv) {
  bool json = false;
  double seconds = 10.0, dt = 1e-3;
  int repeats = 5;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json"))
      json = true;
    else if (!std::strcmp(argv[i], "--seconds") && i + 1 < argc)
      seconds = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--period") && i + 1 < argc)
      dt = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--repeats") && i + 1 < argc)
      repeats = std::max(1, std::atoi(argv[++i]));
    else {
      std::fprintf(stderr, "usage: loop_bench [--json] [--seconds T] [--period DT] [--repeats R]\n");
      return 2;
    }
  }
  if (!(seconds > 0) || !(dt > 0) || dt > seconds) die("--seconds and --period must be > 0, period <= seconds");
  Setup s = setup(seconds, dt);
  // The reference trajectory: BDF at rtol 1e-12 (and ERK at 1e-12 as a cross-check).
  const Run ref = compiled(s, PKM_BDF, 1e-12, 1e-14);
  const Run ref_erk = compiled(s, PKM_ERK, 1e-12, 1e-14);

  struct Row {
    std::string key, label;
    double wall, err, closure, steps_per_ms, rhs_per_ms;
  };
  std::vector<Row> rows;
  // The default, the throughput setting (Bogacki-Shampine at rtol 1e-6: one step and
  // three forward-dynamics calls per millisecond) and the default before.
  struct Config {
    int method;
    double rtol;
    const char *key, *name;
  };
  const Config configs[] = {{PKM_ERK, 1e-8, "erk", "explicit RK 5(4) (default)"},
                            {PKM_ERK23, 1e-6, "erk23", "explicit RK 3(2), rtol 1e-6"},
                            {PKM_BDF, 1e-8, "bdf", "CVODE BDF (before)"}};
  for (const Config& cfg : configs) {
    const int method = cfg.method;
    const char* mname = cfg.name;
    const char* mkey = cfg.key;
    for (int loop = 0; loop < 2; ++loop) {
      std::vector<double> walls;
      Run last;
      for (int r = 0; r < repeats; ++r) {
        last = loop == 0 ? compiled(s, method, cfg.rtol, cfg.rtol * 1e-2) : stepwise(s, method, cfg.rtol, cfg.rtol * 1e-2);
        walls.push_back(last.wall);
      }
      const double ms = seconds * 1e3;
      rows.push_back({std::string(loop == 0 ? "compiled_" : "stepwise_") + mkey,
                      std::string(loop == 0 ? "compiled loop, " : "stepwise loop, ") + mname, median(walls),
                      max_error(last.x, ref.x), closure_error(s, last.x), last.stats.steps / ms,
                      last.stats.rhs_evals / ms});
    }
  }
  const double ref_diff = max_error(ref.x, ref_erk.x);
  if (json) {
    std::printf("{\"seconds\": %g, \"period\": %g, \"repeats\": %d, \"reference_bdf_vs_erk\": %.3e, \"rows\": [\n",
                seconds, dt, repeats, ref_diff);
    for (size_t i = 0; i < rows.size(); ++i)
      std::printf("  {\"key\": \"%s\", \"label\": \"%s\", \"wall_s\": %.6g, \"pose_error_m\": %.3e, "
                  "\"closure_error_m\": %.3e, \"steps_per_ms\": %.4g, \"rhs_per_ms\": %.4g}%s\n",
                  rows[i].key.c_str(), rows[i].label.c_str(), rows[i].wall, rows[i].err, rows[i].closure,
                  rows[i].steps_per_ms, rows[i].rhs_per_ms, i + 1 < rows.size() ? "," : "");
    std::printf("]}\n");
  } else {
    std::printf("6-PUS, joint PD, %g s at a %g ms period, median of %d (reference: BDF rtol 1e-12; it differs "
                "from ERK rtol 1e-12 by %.2e m)\n",
                seconds, dt * 1e3, repeats, ref_diff);
    std::printf("%-44s %10s %12s %12s %10s %9s %9s\n", "loop", "wall [s]", "sim s/wall s", "pose err [m]",
                "closure [m]", "steps/ms", "RHS/ms");
    for (const Row& r : rows)
      std::printf("%-44s %10.4f %12.0f %12.2e %10.1e %9.3f %9.2f\n", r.label.c_str(), r.wall, seconds / r.wall, r.err,
                  r.closure, r.steps_per_ms, r.rhs_per_ms);
  }
  pkm_data_destroy(s.d);
  pkm_model_destroy(s.m);
  return 0;
}
