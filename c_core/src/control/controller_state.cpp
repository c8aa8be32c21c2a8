// The state of the sampled joint-space controller (controller.hpp): reset, its layout,
// save and load, and the C API's pkm_ctrl_state_* functions.
#include <algorithm>
#include <cmath>
#include <vector>

#include "control/controller.hpp"

using namespace pkm;
using namespace pkm::control;

namespace {

// A state block's values, appended in order and read back in the same order.
struct Writer {
  double* b;
  size_t k = 0;
  void put(double v) { b[k++] = v; }
  void put(const std::vector<double>& v) {
    for (double x : v) b[k++] = x;
  }
};
struct Reader {
  const double* b;
  size_t k = 0;
  double get() { return b[k++]; }
  void get(std::vector<double>& v) {
    for (double& x : v) x = b[k++];
  }
};

}  // namespace

void pkm_ctrl::reset(const double* x0) {
  integral.setZero(nd);
  deriv.setZero(nd);
  e_prev.setZero(nd);
  xc.setZero(nx);
  x_guess.setZero(nd);
  have_prev = false;
  have_guess = false;
  saturated = 0;
  qf_prev.assign(nd, 0.0);
  queue.assign((size_t)nd * delay, 0.0);
  inj_queue.assign((size_t)nd * delay, 0.0);
  inj_part.setZero(nd);
  pre_part.setZero(nd);
  std::fill(pos.xin.begin(), pos.xin.end(), 0.0);
  std::fill(pos.yout.begin(), pos.yout.end(), 0.0);
  std::fill(vel.xin.begin(), vel.xin.end(), 0.0);
  std::fill(vel.yout.begin(), vel.yout.end(), 0.0);
  started = false;
  if (x0) {
    check_finite(x0, nd, "reset: pose x0");
    for (int i = 0; i < nd; ++i) x_guess[i] = x0[i];
    have_guess = true;
  }
}

std::vector<double> pkm_ctrl::discrete_layout() const {
  return {kDiscreteTag, (double)nd, (double)pos.nx(), (double)pos.ny(), (double)vel.nx(), (double)vel.ny(),
          (double)delay};
}

size_t pkm_ctrl::discrete_size() const {
  if (kind != PKM_CTRL_DISCRETE) return 0;
  return discrete_layout().size() + 1 + qf_prev.size() + pos.xin.size() + pos.yout.size() + vel.xin.size() +
         vel.yout.size() + queue.size();
}

size_t pkm_ctrl::state_size() const { return 4 * (size_t)nd + nx + 3 + discrete_size(); }

void pkm_ctrl::save(double* b) const {
  size_t k = 0;
  for (const VecX* v : {&integral, &deriv, &e_prev, &x_guess, &xc})
    for (int i = 0; i < v->size(); ++i) b[k++] = (*v)[i];
  b[k++] = have_prev ? 1.0 : 0.0;
  b[k++] = have_guess ? 1.0 : 0.0;
  b[k++] = (double)saturated;
  if (kind != PKM_CTRL_DISCRETE) return;
  Writer w{b + k};
  w.put(discrete_layout());
  w.put(started ? 1.0 : 0.0);
  for (const std::vector<double>* v : {&qf_prev, &pos.xin, &pos.yout, &vel.xin, &vel.yout, &queue}) w.put(*v);
}

void pkm_ctrl::load(const double* b) {
  const size_t n = state_size();
  size_t k = 4 * (size_t)nd + nx + 3;
  if (kind == PKM_CTRL_DISCRETE) {
    // The layout first: a state of another controller is refused before any value is read.
    const std::vector<double> want = discrete_layout();
    const char* what[] = {"tag", "joints", "position filter inputs", "position filter outputs",
                          "velocity filter inputs", "velocity filter outputs", "delay samples"};
    for (size_t i = 0; i < want.size(); ++i)
      PKM_REQUIRE(b[k + i] == want[i], PKM_ERR_ARGUMENT,
                  std::string("controller state: the discrete block's ") + what[i] + " is " + num(b[k + i]) +
                      ", this controller's " + num(want[i]) + ": a state of another controller");
  }
  for (size_t j = 0; j < n; ++j)
    PKM_REQUIRE(std::isfinite(b[j]), PKM_ERR_ARGUMENT, "controller state: entry " + std::to_string(j) + " is not finite");
  k = 0;
  for (VecX* v : {&integral, &deriv, &e_prev, &x_guess, &xc})
    for (int i = 0; i < v->size(); ++i) (*v)[i] = b[k++];
  // The flags and the counter must be what save() writes: 0 or 1, and a whole count
  // (a conversion of a double out of long's range is undefined behaviour).
  for (size_t f = k; f < k + 2; ++f)
    PKM_REQUIRE(b[f] == 0.0 || b[f] == 1.0, PKM_ERR_ARGUMENT,
                "controller state: entry " + std::to_string(f) + " is a flag (0 or 1), got " + num(b[f]));
  PKM_REQUIRE(b[k + 2] >= 0 && b[k + 2] <= 9e15 && b[k + 2] == std::floor(b[k + 2]), PKM_ERR_ARGUMENT,
              "controller state: the saturation count " + num(b[k + 2]) + " is not a count");
  have_prev = b[k++] != 0.0;
  have_guess = b[k++] != 0.0;
  saturated = (long)b[k++];
  if (kind != PKM_CTRL_DISCRETE) return;
  Reader r{b + k + discrete_layout().size()};
  started = r.get() != 0.0;
  for (std::vector<double>* v : {&qf_prev, &pos.xin, &pos.yout, &vel.xin, &vel.yout, &queue}) r.get(*v);
}

extern "C" {

// The saved state starts with a header naming the layout (version, kind, joints, LTI
// states), so that a state is loaded only into a controller of the same law and sizes.
static constexpr size_t kStateHead = 4;
static constexpr double kStateVersion = 1.0;

size_t pkm_ctrl_state_size(const pkm_ctrl* c) { return c ? kStateHead + c->state_size() : 0; }

int pkm_ctrl_state_save(const pkm_ctrl* c, double* buf) {
  if (!c || !buf) return PKM_ERR_ARGUMENT;
  buf[0] = kStateVersion;
  buf[1] = c->kind;
  buf[2] = c->nd;
  buf[3] = c->nx;
  c->save(buf + kStateHead);
  return PKM_OK;
}

int pkm_ctrl_state_load(pkm_ctrl* c, const double* buf, size_t n) {
  if (!c) return PKM_ERR_ARGUMENT;
  c->error.clear();
  return guard_into(c->error, [&] {
    PKM_REQUIRE(buf != nullptr, PKM_ERR_ARGUMENT, "controller state: buffer is NULL");
    const size_t need = kStateHead + c->state_size();
    PKM_REQUIRE(n == need, PKM_ERR_ARGUMENT,
                "controller state: " + std::to_string(n) + " values, this controller's layout has " +
                    std::to_string(need));
    PKM_REQUIRE(buf[0] == kStateVersion && buf[1] == c->kind && buf[2] == c->nd && buf[3] == c->nx, PKM_ERR_ARGUMENT,
                "controller state of another law or size (layout " + num(buf[0]) + ", kind " + num(buf[1]) + ", " +
                    num(buf[2]) + " joints, " + num(buf[3]) + " LTI states; this controller: layout " +
                    num(kStateVersion) + ", kind " + std::to_string(c->kind) + " (" + kind_name(c->kind) + "), " +
                    std::to_string(c->nd) + ", " + std::to_string(c->nx) + ")");
    // A refused state leaves the controller unchanged: load into a copy of the state first.
    std::vector<double> keep(c->state_size());
    c->save(keep.data());
    try {
      c->load(buf + kStateHead);
    } catch (...) {
      c->load(keep.data());
      throw;
    }
  });
}

}  // extern "C"
