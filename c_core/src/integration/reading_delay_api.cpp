// C API: the readings' delay line on its own (pkm_reading_delay_*), the same ReadingDelay
// a sim keeps for pkm_closed_loop, for a loop stepped from outside the core.
#include <cmath>
#include <memory>
#include <string>

#include "common/guard.hpp"
#include "common/handles.hpp"
#include "dynamics/drive.hpp"
#include "integration/delay_line.hpp"

struct pkm_reading_delay {
  pkm::ReadingDelay line;
  int nd = 0;
  double last_t = -INFINITY;
  std::string error;
};

using namespace pkm;

extern "C" {

pkm_reading_delay* pkm_reading_delay_create(const pkm_model* m, char* err, size_t errlen) {
  pkm_reading_delay* out = nullptr;
  guard_err(err, errlen, [&] {
    PKM_REQUIRE(m != nullptr, PKM_ERR_ARGUMENT, "reading delay: model is NULL");
    PKM_REQUIRE(m->compiled != nullptr, PKM_ERR_PARAMETER,
                "reading delay: the model's parameters were changed and not validated: call pkm_model_validate first");
    auto r = std::make_unique<pkm_reading_delay>();
    r->nd = pkm_model_ndof(m);
    r->line = ReadingDelay(r->nd, m->drive ? m->drive->sensor_delay : 0.0);
    out = r.release();
  });
  return out;
}

void pkm_reading_delay_destroy(pkm_reading_delay* r) { delete r; }

int pkm_reading_delay_read(pkm_reading_delay* r, double t, double* q, double* qd) {
  if (!r) return PKM_ERR_ARGUMENT;
  r->error.clear();
  return guard_into(r->error, [&] {
    PKM_REQUIRE(q != nullptr && qd != nullptr, PKM_ERR_ARGUMENT, "reading delay: q or qd is NULL");
    PKM_REQUIRE(std::isfinite(t) && t >= r->last_t, PKM_ERR_ARGUMENT,
                "reading delay: sample time t = " + num(t) + " s is not finite or before the last one (" +
                    num(r->last_t) + " s)");
    check_finite(q, r->nd, "reading delay: q");
    check_finite(qd, r->nd, "reading delay: qd");
    r->last_t = t;
    r->line.read(t, q, qd);
  });
}

void pkm_reading_delay_reset(pkm_reading_delay* r) {
  if (!r) return;
  r->line.rollback(-INFINITY);
  r->last_t = -INFINITY;
  r->error.clear();
}

const char* pkm_reading_delay_error(const pkm_reading_delay* r) {
  return r ? r->error.c_str() : "reading delay is NULL";
}

}  // extern "C"
