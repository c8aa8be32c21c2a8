/*
 * fmu_state.c -- the FMU state of every PKM FMU (fmu_instance.h, "FMU state"): one flat block
 * (a header tying it to the model, interface and layout, then the model's snapshot) taken,
 * checked, restored, sized, serialised and read back, for the FMI 2.0 and the FMI 3.0 layer.
 *
 * A block is checked whole before anything of it is used (header, checksum, every value);
 * a restore the model refuses leaves the instance as it was.
 */
#include "fmu_instance.h"

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---------------------------------------------------------------- FMU state */

/* The header ties a state block to this model (GUID or token), layout (version), FMI
 * layer (magic) and interface; the model writes the rest.  A checksum over the whole
 * block (its own field read as zero) catches a block damaged in storage or transit; every
 * value is checked again when the state is restored (a block edited on purpose and sealed
 * again must not crash or poison the instance either). */
#define STATE_VERSION 2u
typedef struct fmu_state {
  char magic[8];
  char guid[48];
  int32_t type;       /* 0 Model Exchange, 1 Co-Simulation      */
  int32_t mode;       /* state-machine state                   */
  uint64_t nmodel;    /* doubles in model[]                     */
  double start_time, stop_time, last_successful_time;
  int32_t stop_defined, terminated;
  uint32_t version;   /* STATE_VERSION                          */
  uint32_t reserved;  /* 0                                      */
  uint64_t checksum;  /* FNV-1a 64 of the block, this field as 0 */
  double model[];
} fmu_state;

static size_t state_bytes(size_t nmodel) { return sizeof(fmu_state) + nmodel * sizeof(double); }

/* FNV-1a (64 bit) of the n bytes of a state block, its checksum field read as zero. */
static uint64_t state_checksum(const unsigned char* bytes, size_t n) {
  const size_t skip = offsetof(fmu_state, checksum);
  uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i < n; ++i) {
    const unsigned char b = (i >= skip && i < skip + sizeof(uint64_t)) ? 0 : bytes[i];
    h = (h ^ b) * 1099511628211ull;
  }
  return h;
}

/* The state-machine states a state of this interface can be taken in. */
static int mode_ok(int cosimulation, int32_t mode) {
  const int common = S_INSTANTIATED | S_INIT | S_TERMINATED | S_ERROR;
  const int allowed = common | (cosimulation ? S_STEP_COMPLETE | S_STEP_FAILED : S_EVENT | S_CONT);
  return mode > 0 && (mode & (mode - 1)) == 0 && (mode & allowed) != 0;
}

/* The header s of a state block (block: its bytes, size of them; size 0: the size the
 * header declares, for a block this FMU made in memory): magic, GUID, interface, layout
 * version, the model's length against this model's, the checksum, and every header value
 * in its range. */
static int state_ok(fmu_instance* c, const char* fn, const char* magic, const fmu_state* s, const void* block,
                    size_t size) {
  size_t n = fmu_model_snapshot_min_size(c->model);
  if (!s || memcmp(s->magic, magic, 8) != 0) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: not an FMU state of %s", fn, FMU_MODEL.identifier);
    return 0;
  }
  if (memchr(s->guid, 0, sizeof s->guid) == NULL || strcmp(s->guid, c->token) != 0 ||
      s->type != (int32_t)c->cosimulation || s->version != STATE_VERSION || s->reserved != 0) {
    /* The block's GUID as printable ASCII: a message is UTF-8 text, whatever the block holds. */
    char guid[41];
    size_t k = 0;
    for (; k < sizeof guid - 1 && s->guid[k]; ++k) guid[k] = (s->guid[k] >= 32 && s->guid[k] < 127) ? s->guid[k] : '?';
    guid[k] = '\0';
    fmu_log(c, FMU_ERROR, LOG_ERROR,
            "%s: FMU state of another model, interface or layout (GUID %s, type %d, layout %u; this instance: %s, "
            "%d, %u)",
            fn, guid, (int)s->type, (unsigned)s->version, c->token, c->cosimulation, STATE_VERSION);
    return 0;
  }
  if (s->nmodel < n || s->nmodel > n + (1u << 24) || (size && size != state_bytes(s->nmodel))) {
    fmu_log(c, FMU_ERROR, LOG_ERROR,
            "%s: FMU state of %zu bytes declares %llu model values (this model: %zu + the "
            "integrator's): it is truncated or damaged",
            fn, size ? size : state_bytes(s->nmodel), (unsigned long long)s->nmodel, n);
    return 0;
  }
  const uint64_t sum = state_checksum((const unsigned char*)block, state_bytes(s->nmodel));
  if (sum != s->checksum) {
    fmu_log(c, FMU_ERROR, LOG_ERROR,
            "%s: FMU state checksum %016llx does not match its content (%016llx): the block "
            "was damaged or edited",
            fn, (unsigned long long)s->checksum, (unsigned long long)sum);
    return 0;
  }
  const char* bad = NULL;
  if (!mode_ok(c->cosimulation, s->mode))
    bad = "state-machine state";
  else if (!isfinite(s->start_time) || !isfinite(s->stop_time) || !isfinite(s->last_successful_time))
    bad = "start, stop or last successful time (not finite)";
  else if ((s->stop_defined != 0 && s->stop_defined != 1) || (s->terminated != 0 && s->terminated != 1))
    bad = "stop-defined or terminated flag";
  else if (s->stop_defined && !(s->stop_time >= s->start_time))
    bad = "stop time (before the start time)";
  if (bad) {
    fmu_log(c, FMU_ERROR, LOG_ERROR,
            "%s: FMU state has an invalid %s (mode %d, start %g s, stop %g s, last successful "
            "%g s)",
            fn, bad, (int)s->mode, s->start_time, s->stop_time, s->last_successful_time);
    return 0;
  }
  return 1;
}

fmu_status fmu_state_get(fmu_instance* c, const char* fn, const char* magic, void** state) {
  if (fmu_bad_call(c, fn, S_ANY)) return FMU_ERROR;
  if (!state) return fmu_error(c, fn, "FMUstate pointer is NULL");
  size_t n = fmu_model_snapshot_size(c->model);
  fmu_state* s = (fmu_state*)*state;
  /* A state handed back for overwriting is reused; anything else gets a new block. */
  if (!s || memcmp(s->magic, magic, 8) != 0 || s->nmodel != n) {
    s = (fmu_state*)calloc(1, state_bytes(n));
    if (!s) return fmu_error(c, fn, "out of memory");
  }
  memcpy(s->magic, magic, 8);
  memset(s->guid, 0, sizeof s->guid);
  strncpy(s->guid, c->token, sizeof s->guid - 1);
  s->type = (int32_t)c->cosimulation;
  s->mode = c->state;
  s->nmodel = n;
  s->start_time = c->start_time;
  s->stop_time = c->stop_time;
  s->last_successful_time = c->last_successful_time;
  s->stop_defined = c->stop_defined;
  s->terminated = c->terminated;
  s->version = STATE_VERSION;
  s->reserved = 0;
  fmu_model_snapshot_save(c->model, s->model);
  s->checksum = state_checksum((const unsigned char*)s, state_bytes(n));
  *state = s;
  return FMU_OK;
}

/* Is the restored instance one the state machine can go on from?  Past initialization
 * the model must be started (its model validated, its state checked); a Co-Simulation
 * step's last successful time is the model's time. */
static const char* restored_inconsistency(const fmu_instance* c) {
  const int running = c->state & (S_EVENT | S_CONT | S_STEP_COMPLETE | S_STEP_FAILED);
  if (running && fmu_model_dirty(c->model))
    return "its state-machine state is past initialization but the model was not started";
  if ((c->state & (S_STEP_COMPLETE | S_STEP_FAILED)) && c->last_successful_time != fmu_model_time(c->model))
    return "its last successful time differs from the model's time";
  return NULL;
}

fmu_status fmu_state_set(fmu_instance* c, const char* fn, const char* magic, const void* state) {
  if (fmu_bad_call(c, fn, S_ANY)) return FMU_ERROR;
  const fmu_state* s = (const fmu_state*)state;
  if (!state_ok(c, fn, magic, s, s, 0)) return FMU_ERROR;
  if (fmu_model_snapshot_check(c->model, s->model, s->nmodel)) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: %s; the instance keeps its previous state", fn, fmu_model_error(c->model));
    return FMU_ERROR;
  }
  /* What the core refuses while loading leaves the instance as it was too: keep what it
   * has now to put back. */
  fmu_instance before = *c;
  const size_t nkeep = fmu_model_snapshot_size(c->model);
  double* keep = (double*)malloc(nkeep * sizeof(double));
  if (!keep) return fmu_error(c, fn, "out of memory");
  fmu_model_snapshot_save(c->model, keep);
  const char* why = NULL;
  char msg[2600];
  if (fmu_model_snapshot_load(c->model, s->model, s->nmodel)) {
    snprintf(msg, sizeof msg, "%s", fmu_model_error(c->model));
    why = msg;
  } else {
    c->start_time = s->start_time;
    c->stop_time = s->stop_time;
    c->last_successful_time = s->last_successful_time;
    c->stop_defined = s->stop_defined;
    c->terminated = s->terminated;
    c->state = s->mode;
    if ((why = restored_inconsistency(c)) != NULL) {
      snprintf(msg, sizeof msg, "FMU state refused: %s", why);
      why = msg;
    }
  }
  if (why) {
    const int restored = fmu_model_snapshot_load(c->model, keep, nkeep) == 0;
    free(keep);
    *c = before;
    if (!restored) return fmu_error(c, fn, "%s (and the previous state could not be put back)", why);
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: %s; the instance keeps its previous state", fn, why);
    return FMU_ERROR;
  }
  free(keep);
  return FMU_OK;
}

fmu_status fmu_state_free(fmu_instance* c, const char* fn, void** state) {
  if (fmu_bad_call(c, fn, S_ANY)) return FMU_ERROR;
  if (state) {
    free(*state);
    *state = NULL;
  }
  return FMU_OK;
}

fmu_status fmu_state_size(fmu_instance* c, const char* fn, const char* magic, const void* state, size_t* size) {
  if (fmu_bad_call(c, fn, S_ANY)) return FMU_ERROR;
  const fmu_state* s = (const fmu_state*)state;
  if (!size || !state_ok(c, fn, magic, s, s, 0)) return FMU_ERROR;
  *size = state_bytes(s->nmodel);
  return FMU_OK;
}

fmu_status fmu_state_serialize(fmu_instance* c, const char* fn, const char* magic, const void* state,
                               unsigned char* bytes, size_t size) {
  if (fmu_bad_call(c, fn, S_ANY)) return FMU_ERROR;
  const fmu_state* s = (const fmu_state*)state;
  if (!bytes || !state_ok(c, fn, magic, s, s, 0)) return FMU_ERROR;
  if (size < state_bytes(s->nmodel)) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: buffer of %zu bytes, %zu needed", fn, size, state_bytes(s->nmodel));
    return FMU_ERROR;
  }
  memcpy(bytes, s, state_bytes(s->nmodel));
  return FMU_OK;
}

fmu_status fmu_state_deserialize(fmu_instance* c, const char* fn, const char* magic, const unsigned char* bytes,
                                 size_t size, void** state) {
  if (fmu_bad_call(c, fn, S_ANY)) return FMU_ERROR;
  if (!bytes || !state || size < sizeof(fmu_state)) {
    fmu_log(c, FMU_ERROR, LOG_ERROR, "%s: %zu bytes are too few for an FMU state", fn, size);
    return FMU_ERROR;
  }
  fmu_state head;
  memcpy(&head, bytes, sizeof head); /* bytes need not be aligned */
  if (!state_ok(c, fn, magic, &head, bytes, size)) return FMU_ERROR;
  /* A state of ours handed back for overwriting is reused (same model: same size). */
  fmu_state* s = (fmu_state*)*state;
  if (!s || memcmp(s->magic, magic, 8) != 0 || s->nmodel != head.nmodel) {
    s = (fmu_state*)malloc(size);
    if (!s) return fmu_error(c, fn, "out of memory");
  }
  memcpy(s, bytes, size);
  *state = s;
  return FMU_OK;
}
