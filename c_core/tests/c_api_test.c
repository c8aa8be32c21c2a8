/* The C API used from plain C: handles, named parameters, status codes and messages.
 * Uses the four-bar (the smallest robot) so it does not depend on a robot's details. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "pkm/pkm.h"

static int failures = 0, passed = 0;
#define CHECK(cond, ...)                                     \
  do {                                                       \
    if (cond) {                                              \
      ++passed;                                              \
    } else {                                                 \
      ++failures;                                            \
      printf("FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
      printf(__VA_ARGS__);                                   \
      printf("\n");                                          \
    }                                                        \
  } while (0)

int main(void) {
  char err[512] = "";

  /* Construction fails with a message, not a crash. */
  pkm_model* bad = pkm_model_create("delta", NULL, err, sizeof err);
  CHECK(bad == NULL, "unknown robot accepted");
  CHECK(strstr(err, "unknown robot 'delta'") != NULL, "message: %s", err);
  CHECK(strstr(err, "6pus") != NULL, "message lists the known robots: %s", err);
  CHECK(pkm_model_create(NULL, NULL, err, sizeof err) == NULL, "NULL robot accepted");

  pkm_model* m = pkm_model_create("fourbar", NULL, err, sizeof err);
  CHECK(m != NULL, "fourbar: %s", err);
  if (!m) goto done;
  CHECK(pkm_model_ndof(m) == 1, "ndof %d", pkm_model_ndof(m));
  CHECK(strcmp(pkm_model_robot(m), "fourbar") == 0, "robot %s", pkm_model_robot(m));

  /* Robot-specific functions are asked of the model, not inferred from its name. */
  CHECK(pkm_model_has(m, "fourbar_output") == 1, "fourbar_output not declared");
  CHECK(pkm_model_has(m, "6pus_calib_rows") == 0, "a 6-PUS feature declared by the four-bar");
  CHECK(pkm_model_has(m, NULL) == 0 && pkm_model_has(NULL, "fourbar_output") == 0, "NULL accepted");
  CHECK(pkm_model_feature_count(m) == 1 && strcmp(pkm_model_feature(m, 0), "fourbar_output") == 0,
        "features: %d, %s", pkm_model_feature_count(m), pkm_model_feature(m, 0));
  CHECK(strcmp(pkm_model_feature(m, 1), "") == 0 && strcmp(pkm_model_feature(m, -1), "") == 0,
        "past the end: %s", pkm_model_feature(m, 1));

  /* Named parameters with units; unknown names give -1. */
  int i1 = pkm_param_index(m, "link[1].l");
  CHECK(i1 >= 0, "link[1].l not found");
  CHECK(strcmp(pkm_param_unit(m, i1), "m") == 0, "unit %s", pkm_param_unit(m, i1));
  CHECK(fabs(pkm_param_get(m, i1) - 0.600) < 1e-15, "value %g", pkm_param_get(m, i1));
  CHECK(pkm_param_index(m, "link[9].l") == -1, "unknown parameter found");
  CHECK(pkm_param_index(m, "joint[1].coulomb") >= 0, "drive parameters are appended to every robot");

  /* A value outside its range is refused with the name in the message; NaN too. */
  int s = pkm_param_set(m, i1, -0.1, err, sizeof err);
  CHECK(s == PKM_ERR_PARAMETER, "status %s", pkm_status_name(s));
  CHECK(strstr(err, "link[1].l") != NULL, "message names the parameter: %s", err);
  s = pkm_param_set(m, i1, NAN, err, sizeof err);
  CHECK(s == PKM_ERR_PARAMETER, "NaN parameter: status %s", pkm_status_name(s));
  CHECK(fabs(pkm_param_get(m, i1) - 0.600) < 1e-15, "refused value was stored");
  s = pkm_param_set(m, 10000, 1.0, err, sizeof err);
  CHECK(s == PKM_ERR_ARGUMENT, "bad index: status %s", pkm_status_name(s));

  pkm_data* d = pkm_data_create(m);
  CHECK(d != NULL && pkm_data_check(m, d) == PKM_OK, "data");

  /* A change invalidates the model until it is validated again. */
  CHECK(pkm_param_set(m, i1, 0.601, err, sizeof err) == PKM_OK, "set: %s", err);
  double X = 0, dX[4];
  s = pkm_fourbar_output(m, d, 0.6, &X, dX);
  CHECK(s == PKM_ERR_PARAMETER, "unvalidated model used: %s", pkm_status_name(s));
  CHECK(strstr(pkm_data_error(d), "pkm_model_validate") != NULL, "message: %s", pkm_data_error(d));
  CHECK(pkm_model_validate(m, err, sizeof err) == PKM_OK, "validate: %s", err);
  s = pkm_fourbar_output(m, d, 0.6, &X, dX);
  CHECK(s == PKM_OK && isfinite(X), "output: %s", pkm_data_error(d));

  /* NaN input: an argument error with a message, never a NaN result. */
  X = 123.0;
  s = pkm_fourbar_output(m, d, NAN, &X, dX);
  CHECK(s == PKM_ERR_ARGUMENT, "NaN theta: %s", pkm_status_name(s));
  CHECK(strlen(pkm_data_error(d)) > 0, "empty message");

  /* Functions a robot does not provide say so. */
  double tau[1], z[1] = {0};
  s = pkm_inverse_dynamics(m, d, z, z, z, tau);
  CHECK(s == PKM_ERR_UNSUPPORTED, "fourbar dynamics: %s", pkm_status_name(s));
  CHECK(strstr(pkm_data_error(d), "fourbar") != NULL, "message: %s", pkm_data_error(d));

  /* A data belongs to its model's robot. */
  pkm_model* m6 = pkm_model_create("6pus", NULL, err, sizeof err);
  if (m6) {
    CHECK(pkm_data_check(m6, d) != PKM_OK, "data of another robot accepted");
    double x6[6] = {0}, q6[6];
    s = pkm_ik(m6, d, x6, q6);
    CHECK(s == PKM_ERR_ARGUMENT, "mismatched data: %s", pkm_status_name(s));
    pkm_model_destroy(m6);
  }

  /* Copies are independent. */
  pkm_model* c = pkm_model_copy(m);
  CHECK(c != NULL, "copy");
  if (c) {
    pkm_param_set(c, i1, 0.7, err, sizeof err);
    CHECK(fabs(pkm_param_get(m, i1) - 0.601) < 1e-15, "copy shares parameters");
    pkm_model_destroy(c);
  }
  CHECK(strcmp(pkm_status_name(PKM_ERR_SINGULAR), "PKM_ERR_SINGULAR") == 0, "status name");

  /* The integrators are one table: every pkm_lmm constant once, with a name and a title. */
  {
    int seen[4] = {0, 0, 0, 0}, code = -1, avail = -1;
    const char *name = NULL, *title = NULL;
    CHECK(pkm_sim_method_count() == 4, "method count %d", pkm_sim_method_count());
    for (int k = 0; k < pkm_sim_method_count(); ++k) {
      CHECK(pkm_sim_method(k, &code, &name, &title, &avail) == PKM_OK, "method %d", k);
      CHECK(code >= 0 && code < 4 && name && title && (avail == 0 || avail == 1), "method %d: code %d", k, code);
      if (code >= 0 && code < 4) ++seen[code];
      if (code == PKM_ERK) CHECK(strcmp(name, "erk") == 0, "PKM_ERK is named %s", name);
    }
    CHECK(seen[PKM_BDF] == 1 && seen[PKM_ADAMS] == 1 && seen[PKM_ERK] == 1 && seen[PKM_ERK23] == 1, "a code twice");
    CHECK(pkm_sim_method(4, NULL, NULL, NULL, NULL) == PKM_ERR_ARGUMENT, "index past the table");
  }

  /* The readings' delay line: sensor.delay = 1.5 samples reads halfway between the two
   * samples 1.5 periods back (the first sample's before it). */
  {
    int is = pkm_param_index(m, "sensor.delay");
    CHECK(is >= 0 && pkm_param_set(m, is, 1.5e-3, err, sizeof err) == PKM_OK, "sensor.delay: %s", err);
    CHECK(pkm_model_validate(m, err, sizeof err) == PKM_OK, "validate: %s", err);
    pkm_reading_delay* r = pkm_reading_delay_create(m, err, sizeof err);
    CHECK(r != NULL, "reading delay: %s", err);
    if (r) {
      double q = 0, qd = 0;
      for (int k = 0; k < 4; ++k) {
        q = 10.0 * k, qd = -(double)k;
        CHECK(pkm_reading_delay_read(r, 1e-3 * k, &q, &qd) == PKM_OK, "read %d", k);
      }
      CHECK(fabs(q - 15.0) < 1e-9 && fabs(qd + 1.5) < 1e-12, "sample 3 reads %g, %g", q, qd);
      q = 0;
      CHECK(pkm_reading_delay_read(r, 0.0, &q, &qd) == PKM_ERR_ARGUMENT, "a time going back");
      CHECK(strstr(pkm_reading_delay_error(r), "before the last one") != NULL, "%s", pkm_reading_delay_error(r));
      pkm_reading_delay_destroy(r);
    }
  }

  pkm_data_destroy(d);
  pkm_model_destroy(m);
done:
  printf("%d passed, %d failed\n", passed, failures);
  return failures ? 1 : 0;
}
