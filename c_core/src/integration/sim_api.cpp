// C API: the simulator (pkm_sim_*).  Exceptions of pkm::Sim become a status
// and a message kept in the sim (pkm_sim_error); nothing throws across the boundary.
#include "common/guard.hpp"
#include "integration/sim.hpp"

using namespace pkm;

namespace {

template <class F>
int sim_guard(pkm_sim* s, F&& f) {
  if (!s) return PKM_ERR_ARGUMENT;
  s->sim.error.clear();
  return guard_into(s->sim.error, f);
}

}  // namespace

extern "C" {

void pkm_sim_default_options(pkm_sim_options* opt) {
  if (!opt) return;
  opt->method = PKM_ERK;
  opt->rtol = 1e-8;
  opt->atol = 1e-10;
  opt->max_step = 0.0;
  opt->max_steps = 100000;
  opt->sing_min = 1e-4;
}

pkm_sim* pkm_sim_create(const pkm_model* m, const pkm_sim_options* opt, char* err, size_t errlen) {
  pkm_sim* out = nullptr;
  guard_err(err, errlen, [&] {
    pkm_sim_options o;
    if (opt)
      o = *opt;
    else
      pkm_sim_default_options(&o);
    out = new pkm_sim(m, o);
  });
  return out;
}

void pkm_sim_destroy(pkm_sim* s) { delete s; }

int pkm_sim_reset(pkm_sim* s, double t0, const double* x, const double* xd) {
  return sim_guard(s, [&] { s->sim.reset(t0, x, xd); });
}

int pkm_sim_set_time_limit(pkm_sim* s, double seconds) {
  return sim_guard(s, [&] { s->sim.set_time_limit(seconds); });
}

int pkm_sim_set_input(pkm_sim* s, const double* tau) {
  return sim_guard(s, [&] { s->sim.set_input(tau); });
}

int pkm_sim_advance(pkm_sim* s, double t_end) {
  return sim_guard(s, [&] { s->sim.advance(t_end); });
}

int pkm_sim_get_state(const pkm_sim* s, double* t, double* x, double* xd) {
  if (!s) return PKM_ERR_ARGUMENT;
  s->sim.get_state(t, x, xd);
  return PKM_OK;
}

int pkm_sim_drive_state(pkm_sim* s, double* theta, double* theta_d) {
  if (!s) return PKM_ERR_ARGUMENT;
  return guard_into(s->sim.error, [&] { s->sim.drive_state(theta, theta_d); });
}

int pkm_sim_set_external(pkm_sim* s, const double* f) {
  return sim_guard(s, [&] {
    PKM_REQUIRE(f != nullptr, PKM_ERR_ARGUMENT, "external effort: f is NULL");
    s->sim.set_external(f);
  });
}

int pkm_sim_applied_effort(const pkm_sim* s, double* tau) {
  if (!s || !tau) return PKM_ERR_ARGUMENT;
  s->sim.applied_effort(tau);
  return PKM_OK;
}

int pkm_sim_acceleration(pkm_sim* s, const double* tau, double* xdd) {
  if (!s) return PKM_ERR_ARGUMENT;
  return guard_into(s->sim.error, [&] {
    PKM_REQUIRE(tau != nullptr && xdd != nullptr, PKM_ERR_ARGUMENT, "acceleration: tau or xdd is NULL");
    s->sim.acceleration(tau, xdd);
  });
}

int pkm_sim_get_stats(const pkm_sim* s, pkm_sim_stats* stats) {
  if (!s || !stats) return PKM_ERR_ARGUMENT;
  *stats = s->sim.stats();
  return PKM_OK;
}

size_t pkm_sim_state_size(const pkm_sim* s) { return s ? s->sim.state_size() : 0; }

int pkm_sim_state_save(const pkm_sim* s, double* buf) {
  if (!s || !buf) return PKM_ERR_ARGUMENT;
  s->sim.state_save(buf);
  return PKM_OK;
}

int pkm_sim_state_load(pkm_sim* s, const double* buf, size_t n) {
  return sim_guard(s, [&] { s->sim.state_load(buf, n); });
}

const char* pkm_sim_error(const pkm_sim* s) { return s ? s->sim.error.c_str() : "sim is NULL"; }

}  // extern "C"
