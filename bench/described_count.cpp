// described_count: one robot, one operation, over the poses described_bench samples; meant
// to run under valgrind's callgrind for instruction counts, which do not move with the
// machine's load the way wall times do:
//
//   valgrind --tool=callgrind --toggle-collect=pkm_inverse_dynamics \
//       build/bin/described_count 6pus id
//
// counts pkm_inverse_dynamics's instructions over the 2000 calls (divide by 2000 for one
// call; "collected" in callgrind's summary).  Operations: id (pkm_inverse_dynamics), fd
// (pkm_forward_dynamics), loop (one 2 s joint PD at 1 ms, pkm_closed_loop, as described_bench).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "pkm/pkm.h"

namespace {

[[noreturn]] void die(const std::string& what) { bench::die("described_count", what); }

void closed_loop(pkm_model* m, int n) {
  const double dt = 1e-3;
  const size_t nk = 2001;
  pkm_data* d = pkm_data_create(m);
  double home[6], q0[6];
  pkm_model_home(m, home);
  if (pkm_ik(m, d, home, q0) != PKM_OK) die("home is not reachable");
  const bool ang = std::strcmp(pkm_model_joint_unit(m), "rad") == 0;
  std::vector<double> qref(nk * n), qdref(nk * n), kp(n * n, 0.0), kd(n * n, 0.0), xs(nk * n);
  for (size_t k = 0; k < nk; ++k)
    for (int i = 0; i < n; ++i) {
      const double ph = 2 * bench::kPi * (k * dt) + i * bench::kPi / 3, amp = ang ? 0.02 : 0.003;
      qref[k * n + i] = q0[i] + amp * std::sin(ph);
      qdref[k * n + i] = amp * 2 * bench::kPi * std::cos(ph);
    }
  for (int i = 0; i < n; ++i) kp[i * n + i] = 2000.0, kd[i * n + i] = 30.0;
  pkm_sim_options o;
  pkm_sim_default_options(&o);
  char err[1024];
  pkm_sim* sim = pkm_sim_create(m, &o, err, sizeof err);
  if (!sim) die(err);
  pkm_ctrl_spec c{};
  c.kind = PKM_CTRL_PD;
  c.dt = dt;
  c.kp = kp.data();
  c.kd = kd.data();
  pkm_ctrl* ctrl = pkm_ctrl_create(m, &c, err, sizeof err);
  if (!ctrl) die(err);
  pkm_loop_reference ref{nk, 0.0, dt, nullptr, qref.data(), qdref.data(), nullptr, nullptr, nullptr};
  pkm_loop_record rec{};
  rec.x = xs.data();
  size_t done = 0;
  if (pkm_closed_loop(sim, ctrl, &ref, nullptr, nullptr, 0, &rec, &done) != PKM_OK) die(pkm_sim_error(sim));
  pkm_ctrl_destroy(ctrl);
  pkm_sim_destroy(sim);
  pkm_data_destroy(d);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) die("usage: described_count ROBOT id|fd|loop");
  const std::string op = argv[2];
  char err[512];
  pkm_model* m = pkm_model_create(argv[1], nullptr, err, sizeof err);
  if (!m) die(err);
  const int n = pkm_model_ndof(m);
  if (op == "loop") {
    closed_loop(m, n);
    pkm_model_destroy(m);
    return 0;
  }
  pkm_data* d = pkm_data_create(m);
  double home[6];
  pkm_model_home(m, home);
  const size_t K = 2000;
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<double> X(K * n), XD(K * n), XDD(K * n), T(K * n), out(K * n);
  for (size_t k = 0; k < K; ++k)
    for (int j = 0; j < n; ++j) {
      const bool ang = std::strcmp(pkm_model_pose_unit(m, j), "rad") == 0;
      X[k * n + j] = home[j] + (ang ? 0.05 : 0.01) * u(rng);
      XD[k * n + j] = 0.05 * u(rng);
      XDD[k * n + j] = u(rng);
    }
  // The efforts of the forward dynamics: the inverse dynamics at the sampled accelerations,
  // on a second pkm_data (the first one's kept state stays cold for the counted calls; not
  // done for id, whose count would include them).
  pkm_data* d2 = pkm_data_create(m);
  for (size_t k = 0; k < K && op == "fd"; ++k)
    if (pkm_inverse_dynamics(m, d2, &X[k * n], &XD[k * n], &XDD[k * n], &T[k * n]) != PKM_OK)
      die("a sampled pose fails");
  for (size_t k = 0; k < K; ++k) {
    const int rc = op == "id" ? pkm_inverse_dynamics(m, d, &X[k * n], &XD[k * n], &XDD[k * n], &out[k * n])
                   : op == "fd" ? pkm_forward_dynamics(m, d, &X[k * n], &XD[k * n], &T[k * n], &out[k * n])
                                : (die("unknown operation " + op), 0);
    if (rc != PKM_OK) die(op + " fails at a sampled pose");
  }
  pkm_data_destroy(d2), pkm_data_destroy(d), pkm_model_destroy(m);
  return 0;
}
