// core_bench: timings of the reference core for the 6-PUS against the performance targets,
// single thread, through the public C API (what every user pays).
//
//   core_bench [--json] [--quick]
//
// Rows: batched inverse kinematics (ns per pose), forward kinematics from a nearby
// guess (us per solve), inverse and forward dynamics (ns per call, batched), and the
// CVODE simulation rate (simulated seconds per wall second) for a PD-controlled motion
// with 1 ms and 10 ms input updates (each update is one pkm_sim_advance, as inside a
// co-simulation FMU) and for a free motion in one advance.  `cosim bench core` runs this
// program with --json and adds the Python-binding timings and the Python/scipy
// baselines to the same table.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "pkm/pkm.h"

namespace {

using bench::kPi;
using bench::N;
using bench::now;

struct Row {
  std::string key, label, unit;
  double value;
  double target;
  bool higher_is_better;
  std::string note;
};

std::vector<Row> rows;

void add(const std::string& key, const std::string& label, const std::string& unit, double value, double target,
         bool higher_is_better, const std::string& note) {
  rows.push_back({key, label, unit, value, target, higher_is_better, note});
}

bool pass(const Row& r) {
  if (!std::isfinite(r.value)) return false;
  return r.higher_is_better ? r.value >= r.target : r.value <= r.target;
}

[[noreturn]] void die(const std::string& what) { bench::die("core_bench", what); }

// Poses around home within the supported workspace (x, y +-20 mm, z 70..90 mm,
// rotations +-3 deg), all reachable in the default layout.
void random_poses(const double* home, size_t n, std::mt19937_64& rng, std::vector<double>& x) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  x.resize(n * N);
  for (size_t k = 0; k < n; ++k) {
    double* p = &x[k * N];
    p[0] = home[0] + 0.020 * u(rng);
    p[1] = home[1] + 0.020 * u(rng);
    p[2] = 0.080 + 0.010 * u(rng);
    for (int j = 3; j < 6; ++j) p[j] = home[j] + 3.0 * kPi / 180.0 * u(rng);
  }
}

template <class F>
double best_of(int reps, F&& f) {
  double best = 1e300;
  for (int r = 0; r < reps; ++r) {
    const double t0 = now();
    f();
    best = std::min(best, now() - t0);
  }
  return best;
}

struct Ctl {
  const pkm_model* m;
  pkm_data* d;
  double q0[N];
  double kp = 2000.0, kd = 30.0, amp = 0.003, freq = 1.0;
  // PD + gravity compensation in joint space on a sinusoidal stroke reference.
  void tau(double t, const double* x, const double* xd, double* out) const {
    double q[N], qd[N], g[N];
    if (pkm_ik(m, d, x, q) || pkm_joint_velocity(m, d, x, xd, qd) || pkm_gravity_load(m, d, x, g))
      die(std::string("controller: ") + pkm_data_error(d));
    for (int i = 0; i < N; ++i) {
      const double ph = 2 * kPi * freq * t + i * kPi / 3;
      const double qr = q0[i] + amp * std::sin(ph), qdr = amp * 2 * kPi * freq * std::cos(ph);
      out[i] = g[i] + kp * (qr - q[i]) + kd * (qdr - qd[i]);
    }
  }
};

// Simulates t_end seconds with the input updated every dt; returns (wall time of the
// advances only, wall time with the controller, integrator stats).
struct SimRun {
  double wall_sim = 0, wall_total = 0;
  pkm_sim_stats stats{};
};

SimRun run_controlled(const pkm_model* m, pkm_data* d, int method, double t_end, double dt) {
  pkm_sim_options o;
  pkm_sim_default_options(&o);
  o.method = method;
  char err[1024];
  pkm_sim* s = pkm_sim_create(m, &o, err, sizeof err);
  if (!s) die(std::string("pkm_sim_create: ") + err);
  Ctl c{m, d, {}};
  double x[N], xd[N] = {0}, tau[N], t;
  pkm_model_home(m, x);
  if (pkm_ik(m, d, x, c.q0)) die(pkm_data_error(d));
  pkm_sim_reset(s, 0.0, x, xd);
  SimRun r;
  const long n = std::lround(t_end / dt);
  const double t0 = now();
  for (long k = 0; k < n; ++k) {
    pkm_sim_get_state(s, &t, x, xd);
    c.tau(t, x, xd, tau);
    pkm_sim_set_input(s, tau);
    const double a = now();
    const int st = pkm_sim_advance(s, (k + 1) * dt);
    r.wall_sim += now() - a;
    if (st) die(std::string("controlled motion: ") + pkm_sim_error(s));
  }
  r.wall_total = now() - t0;
  pkm_sim_get_stats(s, &r.stats);
  pkm_sim_destroy(s);
  return r;
}

SimRun run_free(const pkm_model* m0, double t_end) {
  pkm_model* m = pkm_model_copy(m0);
  char err[1024];
  if (pkm_param_set(m, pkm_param_index(m, "gravity.z"), 0.0, err, sizeof err) ||
      pkm_model_validate(m, err, sizeof err))
    die(err);
  pkm_sim* s = pkm_sim_create(m, nullptr, err, sizeof err);
  if (!s) die(std::string("pkm_sim_create: ") + err);
  // The energy test's drift, 10 times faster: about 15 mm and 3 deg in 1 s.
  double x[N], xd[N] = {1.5e-2, -1.0e-2, 1.2e-2, 4e-2, -3e-2, 5e-2};
  pkm_model_home(m, x);
  pkm_sim_reset(s, 0.0, x, xd);
  SimRun r;
  const double t0 = now();
  if (pkm_sim_advance(s, t_end)) die(std::string("free motion: ") + pkm_sim_error(s));
  r.wall_sim = r.wall_total = now() - t0;
  pkm_sim_get_stats(s, &r.stats);
  pkm_sim_destroy(s);
  pkm_model_destroy(m);
  return r;
}

std::string fmt(double v) {
  char b[64];
  if (!std::isfinite(v)) return "n/a";
  if (std::fabs(v) >= 1e5 || std::fabs(v) < 1e-2)
    std::snprintf(b, sizeof b, "%.3g", v);
  else
    std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

std::string json_str(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    o += c;
  }
  return o + "\"";
}

}  // namespace

int main(int argc, char** argv) {
  bool json = false, quick = false;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--json"))
      json = true;
    else if (!std::strcmp(argv[i], "--quick"))
      quick = true;
    else {
      std::fprintf(stderr, "usage: core_bench [--json] [--quick]\n");
      return 2;
    }
  }
  char err[1024];
  pkm_model* m = pkm_model_create("6pus", nullptr, err, sizeof err);
  if (!m) die(std::string("6pus model: ") + err);
  pkm_data* d = pkm_data_create(m);
  double home[N];
  pkm_model_home(m, home);
  std::mt19937_64 rng(20240601);
  const int reps = quick ? 1 : 3;

  // --- inverse kinematics, one batched call
  const size_t n_ik = quick ? 100000 : 1000000;
  std::vector<double> x, q(n_ik * N);
  std::vector<int> status(n_ik);
  random_poses(home, n_ik, rng, x);
  pkm_ik_batch(m, d, n_ik, x.data(), q.data(), status.data());  // warm-up
  const double t_ik = best_of(reps, [&] { pkm_ik_batch(m, d, n_ik, x.data(), q.data(), status.data()); });
  const long bad = std::count_if(status.begin(), status.end(), [](int s) { return s != PKM_OK; });
  add("ik_ns", "IK, batched (" + std::to_string(n_ik) + " poses)", "ns/pose", t_ik / n_ik * 1e9, 100, false,
      std::to_string(bad) + " unreachable");

  // --- forward kinematics from a guess 1 mm / 1 mrad away (one control period of a fast motion)
  const size_t n_fk = quick ? 2000 : 20000;
  std::vector<double> xg(n_fk * N), xs(x.begin(), x.begin() + n_fk * N), xo(n_fk * N);
  std::vector<int> fst(n_fk);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (size_t k = 0; k < n_fk * N; ++k) xg[k] = xs[k] + ((k % N) < 3 ? 1e-3 : 1e-3) * u(rng);
  pkm_fk_options fo{1e-13, 50, 1e-9};
  const double t_fk = best_of(reps, [&] {
    pkm_fk_batch(m, d, n_fk, q.data(), xg.data(), &fo, xo.data(), fst.data());
  });
  double fk_err = 0;
  long fk_bad = 0;
  for (size_t k = 0; k < n_fk; ++k) {
    if (fst[k] != PKM_OK) {
      ++fk_bad;
      continue;
    }
    for (int j = 0; j < N; ++j) fk_err = std::max(fk_err, std::fabs(xo[k * N + j] - xs[k * N + j]));
  }
  add("fk_us", "FK, Newton from a guess 1 mm/1 mrad off", "us/solve", t_fk / n_fk * 1e6, 5, false,
      "max pose error " + fmt(fk_err) + ", " + std::to_string(fk_bad) + " failed");

  // --- inverse and forward dynamics, batched
  const size_t n_dyn = quick ? 20000 : 200000;
  std::vector<double> xv(n_dyn * N), xa(n_dyn * N), tau(n_dyn * N), xdd(n_dyn * N);
  std::vector<int> dst(n_dyn);
  for (size_t k = 0; k < n_dyn * N; ++k) {
    xv[k] = 0.1 * u(rng);
    xa[k] = 2.0 * u(rng);
  }
  const double t_id = best_of(reps, [&] {
    pkm_inverse_dynamics_batch(m, d, n_dyn, x.data(), xv.data(), xa.data(), tau.data(), dst.data());
  });
  add("id_ns", "inverse dynamics, batched", "ns/call", t_id / n_dyn * 1e9, 1000, false, "");
  const double t_fd = best_of(reps, [&] {
    pkm_forward_dynamics_batch(m, d, n_dyn, x.data(), xv.data(), tau.data(), xdd.data(), dst.data());
  });
  double fd_err = 0;
  for (size_t k = 0; k < n_dyn * N; ++k) fd_err = std::max(fd_err, std::fabs(xdd[k] - xa[k]) / (1 + std::fabs(xa[k])));
  add("fd_ns", "forward dynamics, batched", "ns/call", t_fd / n_dyn * 1e9, 2000, false,
      "FD(ID(xdd)) - xdd: " + fmt(fd_err));

  // --- CVODE
  const double T = quick ? 1.0 : 10.0;
  struct Case {
    const char* key;
    const char* label;
    int method;
    double dt;
  } cases[] = {{"sim_erk_1ms", "explicit RK (default), PD+G, 1 ms updates", PKM_ERK, 1e-3},
               {"sim_erk_10ms", "explicit RK (default), PD+G, 10 ms updates", PKM_ERK, 1e-2},
               {"sim_bdf_1ms", "CVODE BDF, PD+G, 1 ms updates", PKM_BDF, 1e-3},
               {"sim_adams_1ms", "CVODE Adams, PD+G, 1 ms updates", PKM_ADAMS, 1e-3},
               {"sim_bdf_10ms", "CVODE BDF, PD+G, 10 ms updates", PKM_BDF, 1e-2},
               {"sim_adams_10ms", "CVODE Adams, PD+G, 10 ms updates", PKM_ADAMS, 1e-2}};
  for (const Case& c : cases) {
    SimRun r = run_controlled(m, d, c.method, T, c.dt);
    char note[256];
    std::snprintf(note, sizeof note, "%.0f steps, %.0f RHS per sim s; with controller %.0fx", r.stats.steps / T,
                  r.stats.rhs_evals / T, T / r.wall_total);
    add(c.key, std::string(c.label), "sim s/wall s", T / r.wall_sim, 1000, true, note);
  }
  {
    const double Tf = 1.0;
    SimRun r = run_free(m, Tf);
    char note[256];
    std::snprintf(note, sizeof note, "%.0f steps, %.0f RHS per sim s", r.stats.steps / Tf, r.stats.rhs_evals / Tf);
    add("sim_erk_free", "explicit RK, free motion (g = 0), one 1 s advance", "sim s/wall s", Tf / r.wall_sim, 1000,
        true, note);
  }

  if (json) {
    std::printf("[\n");
    for (size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      std::printf("  {\"key\": %s, \"label\": %s, \"unit\": %s, \"value\": %.6g, \"target\": %g, "
                  "\"higher_is_better\": %s, \"pass\": %s, \"note\": %s}%s\n",
                  json_str(r.key).c_str(), json_str(r.label).c_str(), json_str(r.unit).c_str(), r.value, r.target,
                  r.higher_is_better ? "true" : "false", pass(r) ? "true" : "false", json_str(r.note).c_str(),
                  i + 1 < rows.size() ? "," : "");
    }
    std::printf("]\n");
  } else {
    std::printf("6-PUS reference core, single thread (performance targets)\n");
    std::printf("%-44s %12s  %-13s %10s  %-4s  %s\n", "quantity", "value", "unit", "target", "", "note");
    for (const Row& r : rows)
      std::printf("%-44s %12s  %-13s %10s  %-4s  %s\n", r.label.c_str(), fmt(r.value).c_str(), r.unit.c_str(),
                  ((r.higher_is_better ? ">= " : "<= ") + fmt(r.target)).c_str(), pass(r) ? "PASS" : "MISS",
                  r.note.c_str());
  }
  pkm_data_destroy(d);
  pkm_model_destroy(m);
  return 0;
}
