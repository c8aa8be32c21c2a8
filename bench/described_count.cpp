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
#include <string>
#include <vector>

#include "bench_support.hpp"
#include "pkm/pkm.h"

namespace {

[[noreturn]] void die(const std::string& what) { bench::die("described_count", what); }

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) die("usage: described_count ROBOT id|fd|loop");
  const std::string op = argv[2];
  char err[512];
  pkm_model* m = pkm_model_create(argv[1], nullptr, err, sizeof err);
  if (!m) die(err);
  const int n = pkm_model_ndof(m);
  if (op == "loop") {
    std::vector<double> xs;
    bench::run_pd_loop(m, bench::pd_loop(m, "described_count"), xs, "described_count");
    pkm_model_destroy(m);
    return 0;
  }
  pkm_data* d = pkm_data_create(m);
  const size_t K = 2000;
  std::vector<double> X, XD, XDD;
  bench::sample_states(m, K, X, XD, XDD);
  std::vector<double> T(K * n), out(K * n);
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
