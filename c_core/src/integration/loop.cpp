// pkm_closed_loop: plant + sampled controller + reference table in one call, the
// compiled back end of cosim.closed_loop.ClosedLoop (whose stepwise back end runs the
// same sequence sample by sample), so that a 1 kHz loop pays no per-sample cost outside
// C (no Python call, no FMI call).
#include <cmath>
#include <sstream>
#include <vector>

#include "common/guard.hpp"
#include "integration/sim.hpp"

using namespace pkm;

namespace {

void put(double* dst, size_t k, int nd, const double* src) {
  if (dst)
    for (int i = 0; i < nd; ++i) dst[k * nd + i] = src[i];
}

}  // namespace

extern "C" int pkm_closed_loop(pkm_sim* s, pkm_ctrl* c, const pkm_loop_reference* ref, const double* q_noise,
                               const double* qd_noise, int measure, pkm_loop_record* out, size_t* n_done) {
  if (n_done) *n_done = 0;
  if (!s) return PKM_ERR_ARGUMENT;
  Sim& sim = s->sim;
  sim.error.clear();
  size_t k = 0;
  double t_k = 0;
  int status = guard_into(sim.error, [&] {
    PKM_REQUIRE(c != nullptr, PKM_ERR_ARGUMENT, "closed loop: controller is NULL");
    PKM_REQUIRE(ref != nullptr && ref->q != nullptr && ref->qd != nullptr, PKM_ERR_ARGUMENT,
            "closed loop: the reference (q and qd) is NULL");
    PKM_REQUIRE(ref->n >= 1, PKM_ERR_ARGUMENT, "closed loop: the reference has no sample");
    PKM_REQUIRE(std::isfinite(ref->t0) && std::isfinite(ref->dt) && ref->dt > 0, PKM_ERR_ARGUMENT,
            "closed loop: t0 = " + num(ref->t0, 6) + " s and dt = " + num(ref->dt, 6) + " s must be finite, dt > 0");
    const int nd = sim.ndof();
    const pkm_model* m = sim.model();
    pkm_data* d = sim.data();
    double t, x[6], xd[6], q[6], qd[6], qr[6], qdr[6], tau[6], applied[6], prev_applied[6] = {0, 0, 0, 0, 0, 0};
    if (ref->tau_before) {
      check_finite(ref->tau_before, nd, "closed loop: tau_before");
      for (int i = 0; i < nd; ++i) prev_applied[i] = ref->tau_before[i];
    }
    sim.get_state(&t, x, xd);
    for (k = 0; k < ref->n; ++k) {
      t_k = ref->t ? ref->t[k] : ref->t0 + (double)k * ref->dt;
      PKM_REQUIRE(std::isfinite(t_k), PKM_ERR_ARGUMENT, "closed loop: sample time " + std::to_string(k) + " is not finite");
      // The plant's joints at the sample (pkm_ik / pkm_joint_velocity on the sim's model).
      int st = pkm_ik(m, d, x, q);
      if (st == PKM_OK) st = pkm_joint_velocity(m, d, x, xd, qd);
      if (st != PKM_OK) throw Error(st, std::string("plant outputs: ") + pkm_data_error(d));
      double qm[6], qdm[6];
      for (int i = 0; i < nd; ++i) qm[i] = q[i], qdm[i] = qd[i];
      if (measure) {
        // The sensor model; a two-body joint's encoder reads its drive body.
        const bool two = sim.two_body();
        double th[6], thd[6];
        if (two) sim.drive_state(th, thd);
        // The compliance deflects under the effort acting now: with an actuator delay the
        // sim's delay line has it, else it is the last command's.
        double acting[6];
        if (sim.actuator_delayed())
          sim.applied_effort(acting);
        else
          for (int i = 0; i < nd; ++i) acting[i] = prev_applied[i];
        st = pkm_sensor_readings(m, d, x, xd, acting, two ? th : nullptr, two ? thd : nullptr, qm,
                                 two ? qdm : nullptr);
        if (st != PKM_OK) throw Error(st, std::string("sensor model: ") + pkm_data_error(d));
      }
      sim.delayed_reading(t_k, qm, qdm);  // sensor.delay: the readings of t_k - delay
      for (int i = 0; i < nd; ++i) {
        if (q_noise) qm[i] += q_noise[k * nd + i];
        if (qd_noise) qdm[i] += qd_noise[k * nd + i];
        qr[i] = ref->q[k * nd + i];
        qdr[i] = ref->qd[k * nd + i];
      }
      double tau_inj[6];
      st = pkm_ctrl_update_injected(c, t_k, qm, qdm, qr, qdr, ref->qdd ? ref->qdd + k * nd : nullptr,
                                    ref->x ? ref->x + k * nd : nullptr, ref->inject ? ref->inject_point : 0,
                                    ref->inject ? ref->inject + k * nd : nullptr, tau, tau_inj);
      if (st != PKM_OK) throw Error(st, pkm_ctrl_error(c));
      st = pkm_actuator_effort(m, d, tau, applied);
      if (st != PKM_OK) throw Error(st, std::string("actuator: ") + pkm_data_error(d));
      if (out) {
        put(out->q, k, nd, qm);
        put(out->qd, k, nd, qdm);
        put(out->q_true, k, nd, q);
        put(out->qd_true, k, nd, qd);
        put(out->x, k, nd, x);
        put(out->xd, k, nd, xd);
        put(out->tau_cmd, k, nd, tau);
        put(out->tau, k, nd, applied);
        put(out->tau_inj, k, nd, tau_inj);
      }
      if (n_done) *n_done = k + 1;
      for (int i = 0; i < nd; ++i) prev_applied[i] = applied[i];
      if (k + 1 == ref->n) break;
      if (ref->f_ext) {
        for (int i = 0; i < nd; ++i)
          PKM_REQUIRE(std::isfinite(ref->f_ext[k * nd + i]), PKM_ERR_ARGUMENT,
                      "closed loop: f_ext of joint " + std::to_string(i + 1) + " at sample " + std::to_string(k) +
                          " is not finite");
        sim.set_external(ref->f_ext + k * nd);
      }
      sim.set_input(tau);
      sim.advance(t_k + ref->dt);
      sim.get_state(&t, x, xd);
    }
  });
  if (status != PKM_OK) {
    // The rows before the failing sample are the result; say where the loop stopped.
    if (n_done) *n_done = k;
    sim.error = "closed loop stopped at sample " + std::to_string(k) + " (t = " + num(t_k, 6) + " s): " + sim.error;
  }
  return status;
}
