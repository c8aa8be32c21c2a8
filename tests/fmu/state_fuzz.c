/*
 * state_fuzz.c -- corrupted serialized FMU states fed back to an FMU (tests/fmu/test_state_fuzz.py).
 *
 *   state_fuzz <binary.so> <modelIdentifier> <guid> <type: me|cs> <real vrs: 1,2,...> <nx> <nz>
 *
 * The driver takes two good states of one FMU interface (right after instantiation, and after
 * initialization and three 1 ms steps or three Model Exchange evaluations), serializes them, and
 * replaces every 8-byte word of each block in turn by each of NaN, +Inf, -Inf, 0, -1, 1e4, 1e9,
 * 1e300 and the smallest denormal.  Each corrupted block is given
 *   - as it is (the checksum no longer matches: it must be refused), and
 *   - sealed again (the checksum recomputed, as an importer editing states on purpose would),
 * to the instance it came from and to a fresh instance (just reset), through
 * fmi2DeSerializeFMUstate and fmi2SetFMUstate.  When a corrupted state is accepted, the instance
 * is used: every Real variable is read, and a Co-Simulation instance reads its last successful
 * time and takes a 1 ms step, a Model Exchange one reads its states, derivatives and event
 * indicators; then the good state is set again (the fresh instance is reset), which must
 * succeed.  When it is refused, the instance must have kept its state: its serialized state
 * must equal, byte for byte, the one it had.
 *
 * What must never happen: a crash (the process dies: the test sees the exit code, and a signal
 * handler prints the case), a value that is not finite returned with fmi2OK, a call refused
 * without a message through the FMI logger, an instance changed by a refused state, or one
 * that cannot be put back to a good state.  Prints one summary line (JSON); exit status 1 if
 * any of that happened.
 *
 * The checksum is found, not assumed: the driver looks for the header word whose value is the
 * FNV-1a 64 hash of the block with that word read as zero, and seals with the same rule (an FMU
 * without one gets the corrupted blocks only as they are; the summary says "checksum": false).
 */
#include <dlfcn.h>
#include <math.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "fmi2Functions.h"

#define NVALUES 9
static const char* const VALUE_NAMES[NVALUES] = {"NaN", "+Inf", "-Inf", "0", "-1", "1e4", "1e9", "1e300", "denormal"};

typedef struct api {
  fmi2InstantiateTYPE* instantiate;
  fmi2FreeInstanceTYPE* free_instance;
  fmi2SetupExperimentTYPE* setup;
  fmi2EnterInitializationModeTYPE* enter_init;
  fmi2ExitInitializationModeTYPE* exit_init;
  fmi2ResetTYPE* reset;
  fmi2GetRealTYPE* get_real;
  fmi2DoStepTYPE* do_step;
  fmi2GetRealStatusTYPE* get_real_status;
  fmi2GetFMUstateTYPE* get_state;
  fmi2SetFMUstateTYPE* set_state;
  fmi2FreeFMUstateTYPE* free_state;
  fmi2SerializedFMUstateSizeTYPE* ser_size;
  fmi2SerializeFMUstateTYPE* serialize;
  fmi2DeSerializeFMUstateTYPE* deserialize;
  fmi2EnterEventModeTYPE* enter_event;
  fmi2NewDiscreteStatesTYPE* new_discrete;
  fmi2EnterContinuousTimeModeTYPE* enter_cont;
  fmi2GetContinuousStatesTYPE* get_states;
  fmi2GetDerivativesTYPE* get_derivatives;
  fmi2GetEventIndicatorsTYPE* get_indicators;
} api;

static struct {
  long cases, accepted, refused, ok_nonfinite, silent_refusals, unrecoverable, changed_by_refusal, calls;
  int checksum;
} stats;
static char current_case[256];
static int errors_logged; /* Error/Discard messages through the logger since the last reset */

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String cat,
                   fmi2String msg, ...) {
  (void)env, (void)name, (void)cat;
  if ((status == fmi2Error || status == fmi2Discard) && msg && *msg) ++errors_logged;
}

static void on_signal(int sig) {
  char buf[400];
  int n = snprintf(buf, sizeof buf, "state_fuzz: signal %d in case %s\n", sig, current_case);
  if (n > 0) (void)!write(2, buf, (size_t)n);
  _exit(3);
}

static void* sym(void* h, const char* name) {
  void* f = dlsym(h, name);
  if (!f) {
    fprintf(stderr, "state_fuzz: %s not exported\n", name);
    exit(2);
  }
  return f;
}

static uint64_t fnv(const unsigned char* b, size_t n, size_t skip) {
  uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i < n; ++i) h = (h ^ ((i >= skip && i < skip + 8) ? 0 : b[i])) * 1099511628211ull;
  return h;
}

/* Offset of the checksum word in a good block, or (size_t)-1 when there is none (an FMU
 * without one: the corrupted blocks are then given as they are only). */
static size_t find_checksum(const unsigned char* b, size_t n) {
  for (size_t off = 0; off + 8 <= n && off < 256; off += 8) {
    uint64_t stored;
    memcpy(&stored, b + off, 8);
    if (stored == fnv(b, n, off)) return off;
  }
  return (size_t)-1;
}

/* A call's status: counts a refusal, and a refusal without a logged message. */
static fmi2Status checked(fmi2Status s) {
  ++stats.calls;
  if (s != fmi2OK && s != fmi2Warning && errors_logged == 0) ++stats.silent_refusals;
  errors_logged = 0;
  return s;
}

static void nonfinite(const char* where, double v) {
  if (isfinite(v)) return;
  if (stats.ok_nonfinite < 5) fprintf(stderr, "state_fuzz: %s returned %g with fmi2OK in case %s\n", where, v, current_case);
  ++stats.ok_nonfinite;
}

typedef struct fmu {
  api f;
  const char* id;
  const char* guid;
  fmi2Type type;
  fmi2ValueReference* vrs;
  size_t nvr;
  size_t nx, nz;
  fmi2CallbackFunctions cb;
} fmu;

static fmi2Component instantiate(fmu* u, const char* name) {
  fmi2Component c = u->f.instantiate(name, u->type, u->guid, "", &u->cb, fmi2False, fmi2False);
  if (!c) {
    fprintf(stderr, "state_fuzz: %s: fmi2Instantiate failed\n", u->id);
    exit(2);
  }
  return c;
}

/* Every Real variable: in one call, or one by one when that call is refused (a refusal of
 * one variable stops the call there). */
static void read_all(fmu* u, fmi2Component c, double* v, const char* where) {
  if (checked(u->f.get_real(c, u->vrs, u->nvr, v)) == fmi2OK) {
    for (size_t i = 0; i < u->nvr; ++i) nonfinite(where, v[i]);
    return;
  }
  for (size_t i = 0; i < u->nvr; ++i)
    if (checked(u->f.get_real(c, &u->vrs[i], 1, &v[i])) == fmi2OK) nonfinite(where, v[i]);
}

/* Uses an instance that accepted a state: reads everything, advances once. */
static void exercise(fmu* u, fmi2Component c) {
  double* v = (double*)malloc(sizeof(double) * (u->nvr + u->nx + u->nz + 1));
  read_all(u, c, v, "fmi2GetReal");
  if (u->type == fmi2CoSimulation) {
    double t = 0;
    if (checked(u->f.get_real_status(c, fmi2LastSuccessfulTime, &t)) == fmi2OK) {
      nonfinite("fmi2GetRealStatus(fmi2LastSuccessfulTime)", t);
      if (isfinite(t) && checked(u->f.do_step(c, t, 1e-3, fmi2True)) == fmi2OK)
        read_all(u, c, v, "fmi2GetReal after fmi2DoStep");
    }
  } else {
    if (u->nx && checked(u->f.get_states(c, v, u->nx)) == fmi2OK)
      for (size_t i = 0; i < u->nx; ++i) nonfinite("fmi2GetContinuousStates", v[i]);
    if (u->nx && checked(u->f.get_derivatives(c, v, u->nx)) == fmi2OK)
      for (size_t i = 0; i < u->nx; ++i) nonfinite("fmi2GetDerivatives", v[i]);
    if (u->nz && checked(u->f.get_indicators(c, v, u->nz)) == fmi2OK)
      for (size_t i = 0; i < u->nz; ++i) nonfinite("fmi2GetEventIndicators", v[i]);
  }
  free(v);
}

/* The serialized state of instance c now (malloc'ed, *size bytes), or NULL. */
static unsigned char* snapshot(fmu* u, fmi2Component c, size_t* size) {
  fmi2FMUstate s = NULL;
  if (u->f.get_state(c, &s) != fmi2OK || u->f.ser_size(c, s, size) != fmi2OK) return NULL;
  unsigned char* b = (unsigned char*)malloc(*size);
  if (b && u->f.serialize(c, s, (fmi2Byte*)b, *size) != fmi2OK) {
    free(b);
    b = NULL;
  }
  u->f.free_state(c, &s);
  return b;
}

/* Gives bytes[size] to instance c, whose state is now expect[expect_size].  Accepted: it
 * is used, then c is put back (good state, or fmi2Reset for the fresh instance).  Refused:
 * c must still have the state it had. */
static void one_case(fmu* u, fmi2Component c, const unsigned char* bytes, size_t size, fmi2FMUstate good,
                     const unsigned char* expect, size_t expect_size) {
  ++stats.cases;
  fmi2FMUstate s = NULL;
  int accepted = 0;
  if (checked(u->f.deserialize(c, (const fmi2Byte*)bytes, size, &s)) == fmi2OK) {
    if (checked(u->f.set_state(c, s)) == fmi2OK) {
      accepted = 1;
      exercise(u, c);
    }
    checked(u->f.free_state(c, &s));
  }
  if (accepted) {
    ++stats.accepted;
    if (checked(good ? u->f.set_state(c, good) : u->f.reset(c)) != fmi2OK) {
      if (stats.unrecoverable < 5) fprintf(stderr, "state_fuzz: the instance was not put back after case %s\n", current_case);
      ++stats.unrecoverable;
      u->f.reset(c);
      if (good) u->f.set_state(c, good);
    }
    return;
  }
  ++stats.refused;
  size_t now_size = 0;
  unsigned char* now = snapshot(u, c, &now_size);
  if (!now || now_size != expect_size || memcmp(now, expect, now_size) != 0) {
    if (stats.changed_by_refusal < 5)
      fprintf(stderr, "state_fuzz: a refused state changed the instance in case %s\n", current_case);
    ++stats.changed_by_refusal;
    u->f.reset(c);
    if (good) u->f.set_state(c, good);
  }
  free(now);
}

/* Brings an instance past initialization and a little further. */
static void run_a_little(fmu* u, fmi2Component c) {
  double* v = (double*)malloc(sizeof(double) * (u->nx + u->nz + 1));
  if (u->f.setup(c, fmi2False, 0, 0, fmi2False, 0) != fmi2OK || u->f.enter_init(c) != fmi2OK ||
      u->f.exit_init(c) != fmi2OK) {
    fprintf(stderr, "state_fuzz: %s cannot be initialized with its start values\n", u->id);
    exit(2);
  }
  if (u->type == fmi2CoSimulation) {
    for (int k = 0; k < 3; ++k)
      if (u->f.do_step(c, k * 1e-3, 1e-3, fmi2True) != fmi2OK) {
        fprintf(stderr, "state_fuzz: %s: step %d from the start values failed\n", u->id, k);
        exit(2);
      }
  } else {
    fmi2EventInfo info;
    u->f.new_discrete(c, &info);
    u->f.enter_cont(c);
    if (u->nx) u->f.get_derivatives(c, v, u->nx);
    if (u->nz) u->f.get_indicators(c, v, u->nz);
  }
  free(v);
  errors_logged = 0;
}

static void fuzz_state(fmu* u, fmi2Component same, fmi2Component fresh, const char* base) {
  fmi2FMUstate good = NULL;
  size_t size = 0;
  if (u->f.get_state(same, &good) != fmi2OK || u->f.ser_size(same, good, &size) != fmi2OK) {
    fprintf(stderr, "state_fuzz: %s: cannot take the %s state\n", u->id, base);
    exit(2);
  }
  unsigned char* bytes = (unsigned char*)malloc(size);
  unsigned char* bad = (unsigned char*)malloc(size);
  u->f.serialize(same, good, (fmi2Byte*)bytes, size);
  const size_t sum = find_checksum(bytes, size);
  stats.checksum = sum != (size_t)-1;
  /* the fresh instance: just reset, and the good state must go into it too */
  size_t fresh_size = 0;
  u->f.reset(fresh);
  unsigned char* fresh_bytes = snapshot(u, fresh, &fresh_size);
  fmi2FMUstate probe = NULL;
  if (!fresh_bytes || u->f.deserialize(fresh, (const fmi2Byte*)bytes, size, &probe) != fmi2OK ||
      u->f.set_state(fresh, probe) != fmi2OK || u->f.reset(fresh) != fmi2OK) {
    fprintf(stderr, "state_fuzz: %s: the good %s state is refused by a fresh instance\n", u->id, base);
    exit(1);
  }
  u->f.free_state(fresh, &probe);
  double values[NVALUES] = {NAN, INFINITY, -INFINITY, 0.0, -1.0, 1e4, 1e9, 1e300, 4.9406564584124654e-324};
  for (size_t w = 0; w + 8 <= size; w += 8) {
    for (int k = 0; k < NVALUES; ++k) {
      memcpy(bad, bytes, size);
      memcpy(bad + w, &values[k], 8);
      for (int seal = 0; seal < 2; ++seal) {
        if (seal && stats.checksum) {
          const uint64_t h = fnv(bad, size, sum);
          if (w != sum) memcpy(bad + sum, &h, 8);
        }
        for (int f = 0; f < 2; ++f) {
          snprintf(current_case, sizeof current_case, "%s %s, %s state, word %zu = %s, %s, %s instance", u->id,
                   u->type == fmi2CoSimulation ? "CS" : "ME", base, w / 8, VALUE_NAMES[k],
                   seal ? "sealed again" : "as corrupted", f ? "fresh" : "same");
          if (f)
            one_case(u, fresh, bad, size, NULL, fresh_bytes, fresh_size);
          else
            one_case(u, same, bad, size, good, bytes, size);
        }
      }
    }
  }
  u->f.free_state(same, &good);
  free(bytes);
  free(bad);
  free(fresh_bytes);
}

int main(int argc, char** argv) {
  if (argc != 8) {
    fprintf(stderr, "usage: state_fuzz <binary.so> <modelIdentifier> <guid> <me|cs> <real vrs> <nx> <nz>\n");
    return 2;
  }
  signal(SIGSEGV, on_signal);
  signal(SIGBUS, on_signal);
  signal(SIGFPE, on_signal);
  signal(SIGABRT, on_signal);
  signal(SIGILL, on_signal);
  void* h = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
  if (!h) {
    fprintf(stderr, "state_fuzz: %s\n", dlerror());
    return 2;
  }
  fmu u;
  memset(&u, 0, sizeof u);
  u.id = argv[2];
  u.guid = argv[3];
  u.type = strcmp(argv[4], "me") == 0 ? fmi2ModelExchange : fmi2CoSimulation;
  u.vrs = (fmi2ValueReference*)calloc(strlen(argv[5]) + 1, sizeof(fmi2ValueReference));
  for (char* p = argv[5]; *p;) {
    char* end;
    unsigned long vr = strtoul(p, &end, 10);
    if (end == p) break;
    u.vrs[u.nvr++] = (fmi2ValueReference)vr;
    p = *end ? end + 1 : end;
  }
  u.nx = strtoul(argv[6], NULL, 10);
  u.nz = strtoul(argv[7], NULL, 10);
  u.cb.logger = logger;
  u.cb.allocateMemory = calloc;
  u.cb.freeMemory = free;
#define F(field, name) u.f.field = (name##TYPE*)sym(h, #name)
  F(instantiate, fmi2Instantiate);
  F(free_instance, fmi2FreeInstance);
  F(setup, fmi2SetupExperiment);
  F(enter_init, fmi2EnterInitializationMode);
  F(exit_init, fmi2ExitInitializationMode);
  F(reset, fmi2Reset);
  F(get_real, fmi2GetReal);
  F(do_step, fmi2DoStep);
  F(get_real_status, fmi2GetRealStatus);
  F(get_state, fmi2GetFMUstate);
  F(set_state, fmi2SetFMUstate);
  F(free_state, fmi2FreeFMUstate);
  F(ser_size, fmi2SerializedFMUstateSize);
  F(serialize, fmi2SerializeFMUstate);
  F(deserialize, fmi2DeSerializeFMUstate);
  F(enter_event, fmi2EnterEventMode);
  F(new_discrete, fmi2NewDiscreteStates);
  F(enter_cont, fmi2EnterContinuousTimeMode);
  F(get_states, fmi2GetContinuousStates);
  F(get_derivatives, fmi2GetDerivatives);
  F(get_indicators, fmi2GetEventIndicators);
#undef F
  fmi2Component same = instantiate(&u, "fuzzed");
  fmi2Component fresh = instantiate(&u, "fresh");
  fuzz_state(&u, same, fresh, "instantiated");
  run_a_little(&u, same);
  fuzz_state(&u, same, fresh, "running");
  u.f.free_instance(same);
  u.f.free_instance(fresh);
  printf("{\"fmu\": \"%s\", \"type\": \"%s\", \"cases\": %ld, \"accepted\": %ld, \"refused\": %ld, \"calls\": %ld, "
         "\"ok_nonfinite\": %ld, \"silent_refusals\": %ld, \"unrecoverable\": %ld, \"changed_by_refusal\": %ld, "
         "\"checksum\": %s}\n",
         u.id, argv[4], stats.cases, stats.accepted, stats.refused, stats.calls, stats.ok_nonfinite,
         stats.silent_refusals, stats.unrecoverable, stats.changed_by_refusal, stats.checksum ? "true" : "false");
  return stats.ok_nonfinite || stats.silent_refusals || stats.unrecoverable || stats.changed_by_refusal ? 1 : 0;
}
