// described_bench: a description-compiled robot against its hand-written twin, same
// process, calls alternated, medians of repeats (the machines are noisy).
//
//   described_bench [HAND DESCRIBED] [--repeats R]     (default: 6pus_hand 6pus)
//
// The hand-written models are test oracles (c_core/tests/oracles/, "6pus_hand", "quattro_hand":
// described_bench quattro_hand quattro): the program
// links libpkm_oracle.so, the core plus those oracles.
//
// Rows: inverse kinematics, inverse dynamics, forward dynamics and the Jacobian, ns per
// call through the public C API over 2000 poses and rates around home; the ratio
// described / hand-written and this program's bound (within 2x for IK, ID and FD; the
// Jacobian row is for information).  Exit 1 if a target or the agreement fails.  Both models must have
// the same parameters: the program checks that the outputs agree to 1e-10 first.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "pkm/pkm.h"

namespace {

[[noreturn]] void die(const std::string& what) { bench::die("described_bench", what); }

struct Robot {
  pkm_model* m;
  pkm_data* d;
  int n;
};

Robot open(const char* name) {
  char err[512];
  pkm_model* m = pkm_model_create(name, nullptr, err, sizeof err);
  if (!m) die(err);
  return {m, pkm_data_create(m), pkm_model_ndof(m)};
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const char* hand_name = "6pus_hand";
  const char* desc_name = "6pus";
  int repeats = 9;
  std::vector<const char*> pos;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--repeats") && i + 1 < argc) repeats = std::atoi(argv[++i]);
    else pos.push_back(argv[i]);
  }
  if (pos.size() == 2) hand_name = pos[0], desc_name = pos[1];
  Robot a = open(hand_name), b = open(desc_name);
  if (a.n != b.n) die("the two robots have different numbers of coordinates");
  const int n = a.n;
  const size_t K = 2000;
  std::vector<double> X, XD, XDD;
  bench::sample_states(a.m, K, X, XD, XDD);
  std::vector<double> T(K * n), out(K * n * n), out2(K * n * n);
  for (size_t k = 0; k < K; ++k)
    if (pkm_inverse_dynamics(a.m, a.d, &X[k * n], &XD[k * n], &XDD[k * n], &T[k * n]) != PKM_OK)
      die("a sampled pose fails in the hand-written model");

  struct Op {
    const char* name;
    int width;
    bool targeted;  // this program's bound (within 2x) covers IK, inverse and forward dynamics
    int (*call)(Robot&, size_t, const std::vector<double>&, const std::vector<double>&, const std::vector<double>&,
                const std::vector<double>&, double*);
  };
  const Op ops[] = {
      {"inverse kinematics", 1, true,
       [](Robot& r, size_t k, const std::vector<double>& x, const std::vector<double>&, const std::vector<double>&,
          const std::vector<double>&, double* o) { return pkm_ik(r.m, r.d, &x[k * r.n], o); }},
      {"inverse dynamics", 1, true,
       [](Robot& r, size_t k, const std::vector<double>& x, const std::vector<double>& xd,
          const std::vector<double>& xdd, const std::vector<double>&, double* o) {
         return pkm_inverse_dynamics(r.m, r.d, &x[k * r.n], &xd[k * r.n], &xdd[k * r.n], o);
       }},
      {"forward dynamics", 1, true,
       [](Robot& r, size_t k, const std::vector<double>& x, const std::vector<double>& xd, const std::vector<double>&,
          const std::vector<double>& t, double* o) {
         return pkm_forward_dynamics(r.m, r.d, &x[k * r.n], &xd[k * r.n], &t[k * r.n], o);
       }},
      {"Jacobian J", n, false,
       [](Robot& r, size_t k, const std::vector<double>& x, const std::vector<double>&, const std::vector<double>&,
          const std::vector<double>&, double* o) { return pkm_jacobians(r.m, r.d, &x[k * r.n], nullptr, nullptr, o); }},
  };
  std::printf("described_bench: %s (hand-written) vs %s (description), %zu poses, median of %d alternated repeats\n\n",
              hand_name, desc_name, K, repeats);
  std::printf("| operation | hand-written [ns/call] | described [ns/call] | ratio | target | max rel. difference |\n");
  std::printf("|---|---:|---:|---:|---:|---:|\n");
  bool all = true;
  for (const Op& op : ops) {
    const size_t w = (size_t)n * op.width;
    double worst = 0, scale = 0;
    for (size_t k = 0; k < K; ++k) {
      if (op.call(a, k, X, XD, XDD, T, &out[k * w]) != PKM_OK || op.call(b, k, X, XD, XDD, T, &out2[k * w]) != PKM_OK)
        die(std::string(op.name) + " fails at a sampled pose");
      for (size_t j = 0; j < w; ++j) {
        worst = std::max(worst, std::abs(out[k * w + j] - out2[k * w + j]));
        scale = std::max(scale, std::abs(out[k * w + j]));
      }
    }
    std::vector<double> ta, tb;
    for (int r = 0; r < repeats; ++r) {
      for (int which = 0; which < 2; ++which) {
        Robot& rb = (r + which) % 2 ? b : a;
        double* o = (&rb == &a) ? out.data() : out2.data();
        const double t0 = bench::now();
        for (size_t k = 0; k < K; ++k) op.call(rb, k, X, XD, XDD, T, &o[k * w]);
        ((&rb == &a) ? ta : tb).push_back((bench::now() - t0) / K * 1e9);
      }
    }
    const double ma = median(ta), mb = median(tb), ratio = mb / ma;
    const bool ok = (!op.targeted || ratio <= 2.0) && worst <= 1e-10 * std::max(1.0, scale);
    all &= ok;
    std::printf("| %s | %.0f | %.0f | %.2f | %s | %.1e |%s\n", op.name, ma, mb, ratio, op.targeted ? "<= 2" : "-",
                worst / std::max(1e-300, scale), ok ? "" : "  <- over target");
  }
  // The closed loop users run (bench::pd_loop): 2 s of a joint PD at 1 ms.
  {
    const bench::PdLoop L = bench::pd_loop(a.m, "described_bench");
    std::vector<double> xa, xb;
    auto loop = [&](Robot& r, std::vector<double>& xs) { return bench::run_pd_loop(r.m, L, xs, "described_bench"); };
    std::vector<double> ta, tb;
    for (int r = 0; r < std::max(3, repeats / 2); ++r) {
      if (r % 2) tb.push_back(loop(b, xb)), ta.push_back(loop(a, xa));
      else ta.push_back(loop(a, xa)), tb.push_back(loop(b, xb));
    }
    double worst = 0;
    for (size_t k = 0; k < xa.size(); ++k) worst = std::max(worst, std::abs(xa[k] - xb[k]));
    const double ma = median(ta), mb = median(tb);
    std::printf("| closed loop, 2 s PD at 1 ms [ms/run] | %.1f | %.1f | %.2f | - | %.1e (pose, abs.) |\n", ma * 1e3,
                mb * 1e3, mb / ma, worst);
  }
  pkm_data_destroy(a.d), pkm_data_destroy(b.d), pkm_model_destroy(a.m), pkm_model_destroy(b.m);
  return all ? 0 : 1;
}
