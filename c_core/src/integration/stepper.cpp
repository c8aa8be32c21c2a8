// The table of a sim's integrators: pkm_sim_options.method -> its stepper.
#include "integration/stepper.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "common/guard.hpp"

namespace pkm {

namespace {

std::unique_ptr<Stepper> make_explicit(int method, Ivp& ivp) {
  return make_erk_stepper(method, ivp, stepper_available(PKM_BDF));
}

struct Method {
  int id;
  const char* name;   // the pkm_lmm constant
  const char* label;  // how a message names it
  const char* key;    // its short name (pkm_sim_method: cosim's method=, a scenario's [integrator])
  const char* title;  // its title (pkm_sim_method)
  const char* needs;  // what a build must link to have it
  std::unique_ptr<Stepper> (*make)(int method, Ivp& ivp);  // nullptr: not in this build
};

#ifdef PKM_NO_CVODE  // the FMU binaries of platforms without a SUNDIALS library (fmu/platform)
constexpr auto kCvode = nullptr;
#else
constexpr auto kCvode = &make_cvode_stepper;
#endif

const Method kMethods[] = {
    {PKM_BDF, "PKM_BDF", "BDF", "bdf", "CVODE BDF", "SUNDIALS CVODE", kCvode},
    {PKM_ADAMS, "PKM_ADAMS", "Adams", "adams", "CVODE Adams", "SUNDIALS CVODE", kCvode},
    {PKM_ERK, "PKM_ERK", "RK 5(4)", "erk", "explicit Runge-Kutta 5(4)", nullptr, &make_explicit},
    {PKM_ERK23, "PKM_ERK23", "RK 3(2)", "erk23", "explicit Runge-Kutta 3(2)", nullptr, &make_explicit},
};

const Method* find(int method) {
  for (const Method& m : kMethods)
    if (m.id == method) return &m;
  return nullptr;
}

}  // namespace

bool stepper_available(int method) {
  const Method* m = find(method);
  return m && m->make;
}

void check_method(int method) {
  const Method* m = find(method);
  if (m && m->make) return;
  std::string msg = "pkm_sim options: method = " + std::to_string(method);
  if (!m) {
    msg += " is none of ";
    for (const Method& k : kMethods)
      msg += std::string(&k == kMethods ? "" : ", ") + k.name + " (" + std::to_string(k.id) + ")";
  } else {
    msg += std::string(" (") + m->label + ") needs " + m->needs + ", which this binary";
#ifdef PKM_NO_CVODE
    msg += " (" PKM_NO_CVODE ")";
#endif
    msg += " does not carry: use ";
    int n = 0;
    for (const Method& k : kMethods)
      if (k.make) msg += std::string(n++ ? " or " : "") + k.name + " (" + std::to_string(k.id) + ")";
  }
  throw Error(PKM_ERR_ARGUMENT, msg);
}

void check_next_step(double h, double t) {
  PKM_REQUIRE(h == 0 || h > 4 * DBL_EPSILON * std::max(1.0, std::fabs(t)), PKM_ERR_ARGUMENT,
              "state: the next step size " + num(h) + " s is neither 0 nor a step that can be taken at t = " + num(t) +
                  " s");
}

std::unique_ptr<Stepper> make_stepper(int method, Ivp& ivp) {
  check_method(method);
  return find(method)->make(method, ivp);
}

}  // namespace pkm

extern "C" {

int pkm_sim_method_count(void) { return (int)(sizeof(pkm::kMethods) / sizeof(pkm::kMethods[0])); }

int pkm_sim_method(int i, int* code, const char** name, const char** title, int* available) {
  if (i < 0 || i >= pkm_sim_method_count()) return PKM_ERR_ARGUMENT;
  const pkm::Method& m = pkm::kMethods[i];
  if (code) *code = m.id;
  if (name) *name = m.key;
  if (title) *title = m.title;
  if (available) *available = m.make ? 1 : 0;
  return PKM_OK;
}

}  // extern "C"
