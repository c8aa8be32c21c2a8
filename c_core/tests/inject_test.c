/* Signals injected into the loop (pkm_ctrl_update_injected) and the drive's command-to-
 * effort map (pkm_effort_map), used from plain C.  Oracles: a PD law worked by hand on the
 * four-bar's one joint, and the first-order step response in closed form. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "c_check.h"
#include "pkm/pkm.h"

int main(void) {
  char err[512];
  pkm_model* m = pkm_model_create("fourbar", NULL, err, sizeof err);
  CHECK(m != NULL, "fourbar: %s", err);
  if (!m) return 1;
  /* PD, kp = 10, kd = 0, saturation 5: at q = 0, qref = 0.3 the law gives 3. */
  const double kp = 10.0, kd = 0.0, sat = 5.0;
  pkm_ctrl_spec spec;
  memset(&spec, 0, sizeof spec);
  spec.kind = PKM_CTRL_PD;
  spec.dt = 1e-3;
  spec.kp = &kp;
  spec.kd = &kd;
  spec.saturation = &sat;
  pkm_ctrl* c = pkm_ctrl_create(m, &spec, err, sizeof err);
  CHECK(c != NULL, "pd: %s", err);
  if (!c) return 1;
  const double q = 0.0, qd = 0.0, qref = 0.3, qdref = 0.0;
  struct {
    int point;
    double w, tau, part;
  } cases[] = {
      {PKM_INJECT_NONE, 0.0, 3.0, 0.0},
      {PKM_INJECT_COMMAND, 4.0, 5.0, 2.0},           /* 3 + 4 clipped at 5: the signal adds 2 */
      {PKM_INJECT_COMMAND_AFTER_SAT, 4.0, 7.0, 4.0}, /* after the clip: all of it */
      {PKM_INJECT_REFERENCE, 0.1, 4.0, 0.0},         /* 10 (0.3 + 0.1) */
      {PKM_INJECT_MEASUREMENT, 0.1, 2.0, 0.0},       /* 10 (0.3 - 0.1) */
  };
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
    double tau = -1, part = -1;
    const int s = pkm_ctrl_update_injected(c, 0.0, &q, &qd, &qref, &qdref, NULL, NULL, cases[i].point, &cases[i].w,
                                           &tau, &part);
    CHECK(s == PKM_OK, "point %d: %s", cases[i].point, pkm_ctrl_error(c));
    CHECK(fabs(tau - cases[i].tau) < 1e-12 && fabs(part - cases[i].part) < 1e-12, "point %d: tau %g, part %g",
          cases[i].point, tau, part);
  }
  double tau = 0;
  const double w = 1.0;
  CHECK(pkm_ctrl_update_injected(c, 0.0, &q, &qd, &qref, &qdref, NULL, NULL, 9, &w, &tau, NULL) == PKM_ERR_ARGUMENT,
        "point 9 accepted");
  CHECK(strstr(pkm_ctrl_error(c), "injection point 9") != NULL, "message: %s", pkm_ctrl_error(c));
  CHECK(pkm_ctrl_update_injected(c, 0.0, &q, &qd, &qref, &qdref, NULL, NULL, PKM_INJECT_COMMAND, NULL, &tau, NULL) ==
            PKM_ERR_ARGUMENT,
        "a NULL signal accepted");
  pkm_ctrl_destroy(c);
  pkm_model_destroy(m);

  /* The map: a unit step through gain 0.5, offset 0.1, lag 2 ms. */
  double u[50], y[50];
  for (int k = 0; k < 50; ++k) u[k] = 1.0;
  CHECK(pkm_effort_map(50, 1e-3, u, 0.5, 0.1, 2e-3, 0.0, 0.0, y, err, sizeof err) == PKM_OK, "%s", err);
  double worst = 0;
  for (int k = 0; k < 50; ++k) worst = fmax(worst, fabs(y[k] - 0.6 * (1 - exp(-(k + 1) * 1e-3 / 2e-3))));
  CHECK(worst < 1e-14, "step response off by %g", worst);
  u[3] = NAN;
  CHECK(pkm_effort_map(50, 1e-3, u, 0.5, 0.1, 2e-3, 0.0, 0.0, y, err, sizeof err) == PKM_ERR_ARGUMENT, "NaN taken");
  CHECK(strstr(err, "u[3] is not finite") != NULL, "message: %s", err);

  printf("%d passed, %d failed\n", passed, failures);
  return failures ? 1 : 0;
}
