/*
 * fmi2_host, fmi3_host -- a small FMI importer (Co-Simulation, and Model Exchange stepped by
 * explicit Euler) for the tests of the FMU binaries of every platform and of both FMI
 * versions (tests/fmu/test_platforms.py, tests/fmu/test_fmi3_host.py).  One source: built
 * as fmi2_host, or with -DPKM_HOST_FMI=3 as fmi3_host.  Built for the build machine and
 * cross-compiled with the FMUs (fmu/platform), it runs natively, under Wine (x86_64-windows)
 * or under QEMU (aarch64-linux), and prints what it sees, so the platforms and the FMI
 * versions can be compared.
 *
 *   fmi2_host SCRIPT      fmi3_host SCRIPT
 *
 * SCRIPT has one command a line (whitespace-separated; '#' starts a comment):
 *   fmu NAME LIBRARY GUID RESOURCE_URI   load the binary and instantiate it (Co-Simulation)
 *   me NAME LIBRARY GUID RESOURCE_URI NX the same as Model Exchange with NX continuous states:
 *                                        its steps are explicit Euler steps of this host
 *   real NAME VR VALUE...                fmi2SetReal / fmi3SetFloat64 of one variable (VALUE may be nan, inf;
 *                                        an FMI 3.0 array takes all its values)
 *   int NAME VR VALUE...                 fmi2SetInteger / fmi3SetInt32 of one variable
 *   init NAME                            fmi2SetupExperiment(t = 0), Enter/ExitInitializationMode
 *                                        (Model Exchange: then the event iteration, continuous-time mode)
 *   connect FROM VR... -> TO VR...       copied from FROM's outputs to TO's inputs before each step
 *   step N H                             N communication steps of H seconds: the connections,
 *                                        then fmi2DoStep of every FMU in the order they were loaded
 *                                        (Model Exchange: x += H dx/dt, fmi2SetTime, fmi2SetContinuousStates,
 *                                        fmi2CompletedIntegratorStep)
 *   print NAME VR...                     fmi2GetReal of the variables
 *   save NAME                            fmi2GetFMUstate, serialised into a byte block and freed
 *   restore NAME                         the block deserialised and set back (fmi2SetFMUstate)
 *
 * A VR is a value reference, or for an FMI 3.0 array VR:N, the reference and its number of
 * values (all of them are read, set or copied).  The command names in the output are the
 * FMI 2.0 ones (setReal, doStep...) for either version, so two versions' outputs compare.
 *
 * Output: "status <command> <status>" for every FMI call that is not OK, the FMU's log
 * lines as "log <instance> <status> <category>: <message>", and "values <t> <v>..." for print
 * (every number as %.17g).  Exit status 0 unless the script itself is wrong.
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
#define LOAD(path) ((void*)LoadLibraryA(path))
#define SYM(lib, name) ((void*)GetProcAddress((HMODULE)(lib), name))
#else
#include <dlfcn.h>
#define LOAD(path) dlopen(path, RTLD_NOW | RTLD_LOCAL)
#define SYM(lib, name) dlsym(lib, name)
#endif

#ifndef PKM_HOST_FMI
#define PKM_HOST_FMI 2
#endif

#if PKM_HOST_FMI == 3
#include "fmi3Functions.h"
/* The FMI 3.0 names of what the host uses, under one set of words for both versions. */
typedef fmi3Instance fmi_instance;
typedef fmi3Status fmi_status;
typedef fmi3ValueReference fmi_vr;
typedef fmi3FMUState fmi_state;
typedef fmi3Int32 fmi_int;
typedef fmi3Boolean fmi_bool;
#define FMI_OK fmi3OK
#define FMI_TRUE fmi3True
#define FMI_FALSE fmi3False
#else
#include "fmi2Functions.h"
typedef fmi2Component fmi_instance;
typedef fmi2Status fmi_status;
typedef fmi2ValueReference fmi_vr;
typedef fmi2FMUstate fmi_state;
typedef fmi2Integer fmi_int;
typedef fmi2Boolean fmi_bool;
#define FMI_OK fmi2OK
#define FMI_TRUE fmi2True
#define FMI_FALSE fmi2False
#endif

#define MAX_FMUS 4
#define MAX_LINKS 64
#define MAX_VRS 64
#define MAX_VALUES 512
#define MAX_STATES 64

typedef struct {
  char name[64];
  fmi_instance c;
  int nx; /* Model Exchange: continuous states; 0 for Co-Simulation */
  double t, saved_t;
  char* saved;
  size_t saved_size;
#if PKM_HOST_FMI == 3
  fmi3InstantiateCoSimulationTYPE* instantiate_cs;
  fmi3InstantiateModelExchangeTYPE* instantiate_me;
  fmi3FreeInstanceTYPE* free_instance;
  fmi3EnterInitializationModeTYPE* enter_init;
  fmi3ExitInitializationModeTYPE* exit_init;
  fmi3SetFloat64TYPE* set_real;
  fmi3GetFloat64TYPE* get_real;
  fmi3SetInt32TYPE* set_integer;
  fmi3DoStepTYPE* do_step;
  fmi3GetFMUStateTYPE* get_state;
  fmi3SetFMUStateTYPE* set_state;
  fmi3FreeFMUStateTYPE* free_state;
  fmi3SerializedFMUStateSizeTYPE* state_size;
  fmi3SerializeFMUStateTYPE* serialize;
  fmi3DeserializeFMUStateTYPE* deserialize;
  fmi3SetTimeTYPE* set_time;
  fmi3GetContinuousStatesTYPE* get_states;
  fmi3SetContinuousStatesTYPE* set_states;
  fmi3GetContinuousStateDerivativesTYPE* get_derivatives;
  fmi3CompletedIntegratorStepTYPE* completed_step;
  fmi3UpdateDiscreteStatesTYPE* update_discrete_states;
  fmi3EnterContinuousTimeModeTYPE* enter_continuous;
#else
  fmi2InstantiateTYPE* instantiate;
  fmi2FreeInstanceTYPE* free_instance;
  fmi2SetupExperimentTYPE* setup;
  fmi2EnterInitializationModeTYPE* enter_init;
  fmi2ExitInitializationModeTYPE* exit_init;
  fmi2SetRealTYPE* set_real;
  fmi2GetRealTYPE* get_real;
  fmi2SetIntegerTYPE* set_integer;
  fmi2DoStepTYPE* do_step;
  fmi2GetFMUstateTYPE* get_state;
  fmi2SetFMUstateTYPE* set_state;
  fmi2FreeFMUstateTYPE* free_state;
  fmi2SerializedFMUstateSizeTYPE* state_size;
  fmi2SerializeFMUstateTYPE* serialize;
  fmi2DeSerializeFMUstateTYPE* deserialize;
  fmi2SetTimeTYPE* set_time;
  fmi2GetContinuousStatesTYPE* get_states;
  fmi2SetContinuousStatesTYPE* set_states;
  fmi2GetDerivativesTYPE* get_derivatives;
  fmi2CompletedIntegratorStepTYPE* completed_step;
  fmi2NewDiscreteStatesTYPE* new_discrete_states;
  fmi2EnterContinuousTimeModeTYPE* enter_continuous;
#endif
} fmu;

/* Variables to read or write: value references and (FMI 3.0) their numbers of values. */
typedef struct {
  int n;       /* value references */
  int values;  /* values in all     */
  fmi_vr vr[MAX_VRS];
} vars;

typedef struct {
  int from, to;
  vars src, dst;
} link;

static fmu fmus[MAX_FMUS];
static int nfmus;
static link links[MAX_LINKS];
static int nlinks;

static const char* status_name(fmi_status s) {
  static const char* names[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
  return ((int)s >= 0 && (int)s <= 5) ? names[s] : "?";
}

#if PKM_HOST_FMI == 3
/* FMI 3.0 hands over a finished message; the instance is the one the environment names. */
static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
  printf("log %s %s %s: %s\n", env ? (const char*)env : "?", status_name(status), category ? category : "?",
         message ? message : "");
}
#else
static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
  (void)env;
  char text[4096];
  va_list ap;
  va_start(ap, message);
  vsnprintf(text, sizeof text, message, ap);
  va_end(ap);
  printf("log %s %s %s: %s\n", instance ? instance : "?", status_name(status), category ? category : "?", text);
}
#endif

static void die(int line, const char* what) {
  fprintf(stderr, "script line %d: %s\n", line, what);
  exit(2);
}

static fmu* find(const char* name, int line) {
  for (int i = 0; i < nfmus; ++i)
    if (strcmp(fmus[i].name, name) == 0) return &fmus[i];
  die(line, "no FMU of that name");
  return NULL;
}

static void report(const char* command, fmi_status s) {
  if (s != FMI_OK) printf("status %s %s\n", command, status_name(s));
}

static void* need(void* lib, const char* name, int line) {
  void* f = SYM(lib, name);
  if (!f) die(line, name);
  return f;
}

static double number(const char* s) {
  if (strcmp(s, "nan") == 0) return strtod("NAN", NULL);
  if (strcmp(s, "inf") == 0) return strtod("INF", NULL);
  return strtod(s, NULL);
}

#if PKM_HOST_FMI == 2
static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
#endif

static void load(char** w, int nw, int line) {
  int me = strcmp(w[0], "me") == 0;
  if (nw != 5 + me || nfmus == MAX_FMUS) die(line, "fmu NAME LIBRARY GUID RESOURCE_URI, me ... NX");
  fmu* f = &fmus[nfmus];
  memset(f, 0, sizeof *f);
  f->nx = me ? atoi(w[5]) : 0;
  if (me && (f->nx < 1 || f->nx > MAX_STATES)) die(line, "NX out of range");
  snprintf(f->name, sizeof f->name, "%s", w[1]);
  void* lib = LOAD(w[2]);
  if (!lib) die(line, "cannot load the library");
#if PKM_HOST_FMI == 3
  f->instantiate_cs = (fmi3InstantiateCoSimulationTYPE*)need(lib, "fmi3InstantiateCoSimulation", line);
  f->instantiate_me = (fmi3InstantiateModelExchangeTYPE*)need(lib, "fmi3InstantiateModelExchange", line);
  f->free_instance = (fmi3FreeInstanceTYPE*)need(lib, "fmi3FreeInstance", line);
  f->enter_init = (fmi3EnterInitializationModeTYPE*)need(lib, "fmi3EnterInitializationMode", line);
  f->exit_init = (fmi3ExitInitializationModeTYPE*)need(lib, "fmi3ExitInitializationMode", line);
  f->set_real = (fmi3SetFloat64TYPE*)need(lib, "fmi3SetFloat64", line);
  f->get_real = (fmi3GetFloat64TYPE*)need(lib, "fmi3GetFloat64", line);
  f->set_integer = (fmi3SetInt32TYPE*)need(lib, "fmi3SetInt32", line);
  f->do_step = (fmi3DoStepTYPE*)need(lib, "fmi3DoStep", line);
  f->get_state = (fmi3GetFMUStateTYPE*)need(lib, "fmi3GetFMUState", line);
  f->set_state = (fmi3SetFMUStateTYPE*)need(lib, "fmi3SetFMUState", line);
  f->free_state = (fmi3FreeFMUStateTYPE*)need(lib, "fmi3FreeFMUState", line);
  f->state_size = (fmi3SerializedFMUStateSizeTYPE*)need(lib, "fmi3SerializedFMUStateSize", line);
  f->serialize = (fmi3SerializeFMUStateTYPE*)need(lib, "fmi3SerializeFMUState", line);
  f->deserialize = (fmi3DeserializeFMUStateTYPE*)need(lib, "fmi3DeserializeFMUState", line);
  if (me) {
    f->set_time = (fmi3SetTimeTYPE*)need(lib, "fmi3SetTime", line);
    f->get_states = (fmi3GetContinuousStatesTYPE*)need(lib, "fmi3GetContinuousStates", line);
    f->set_states = (fmi3SetContinuousStatesTYPE*)need(lib, "fmi3SetContinuousStates", line);
    f->get_derivatives =
        (fmi3GetContinuousStateDerivativesTYPE*)need(lib, "fmi3GetContinuousStateDerivatives", line);
    f->completed_step = (fmi3CompletedIntegratorStepTYPE*)need(lib, "fmi3CompletedIntegratorStep", line);
    f->update_discrete_states = (fmi3UpdateDiscreteStatesTYPE*)need(lib, "fmi3UpdateDiscreteStates", line);
    f->enter_continuous = (fmi3EnterContinuousTimeModeTYPE*)need(lib, "fmi3EnterContinuousTimeMode", line);
  }
  /* The instance's name is its environment: the logger prints it. */
  if (me)
    f->c = f->instantiate_me(w[1], w[3], w[4], fmi3False, fmi3False, f->name, logger);
  else
    f->c = f->instantiate_cs(w[1], w[3], w[4], fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0, f->name, logger,
                             NULL);
#else
  f->instantiate = (fmi2InstantiateTYPE*)need(lib, "fmi2Instantiate", line);
  f->free_instance = (fmi2FreeInstanceTYPE*)need(lib, "fmi2FreeInstance", line);
  f->setup = (fmi2SetupExperimentTYPE*)need(lib, "fmi2SetupExperiment", line);
  f->enter_init = (fmi2EnterInitializationModeTYPE*)need(lib, "fmi2EnterInitializationMode", line);
  f->exit_init = (fmi2ExitInitializationModeTYPE*)need(lib, "fmi2ExitInitializationMode", line);
  f->set_real = (fmi2SetRealTYPE*)need(lib, "fmi2SetReal", line);
  f->get_real = (fmi2GetRealTYPE*)need(lib, "fmi2GetReal", line);
  f->set_integer = (fmi2SetIntegerTYPE*)need(lib, "fmi2SetInteger", line);
  f->do_step = (fmi2DoStepTYPE*)need(lib, "fmi2DoStep", line);
  f->get_state = (fmi2GetFMUstateTYPE*)need(lib, "fmi2GetFMUstate", line);
  f->set_state = (fmi2SetFMUstateTYPE*)need(lib, "fmi2SetFMUstate", line);
  f->free_state = (fmi2FreeFMUstateTYPE*)need(lib, "fmi2FreeFMUstate", line);
  f->state_size = (fmi2SerializedFMUstateSizeTYPE*)need(lib, "fmi2SerializedFMUstateSize", line);
  f->serialize = (fmi2SerializeFMUstateTYPE*)need(lib, "fmi2SerializeFMUstate", line);
  f->deserialize = (fmi2DeSerializeFMUstateTYPE*)need(lib, "fmi2DeSerializeFMUstate", line);
  if (me) {
    f->set_time = (fmi2SetTimeTYPE*)need(lib, "fmi2SetTime", line);
    f->get_states = (fmi2GetContinuousStatesTYPE*)need(lib, "fmi2GetContinuousStates", line);
    f->set_states = (fmi2SetContinuousStatesTYPE*)need(lib, "fmi2SetContinuousStates", line);
    f->get_derivatives = (fmi2GetDerivativesTYPE*)need(lib, "fmi2GetDerivatives", line);
    f->completed_step = (fmi2CompletedIntegratorStepTYPE*)need(lib, "fmi2CompletedIntegratorStep", line);
    f->new_discrete_states = (fmi2NewDiscreteStatesTYPE*)need(lib, "fmi2NewDiscreteStates", line);
    f->enter_continuous = (fmi2EnterContinuousTimeModeTYPE*)need(lib, "fmi2EnterContinuousTimeMode", line);
  }
  f->c = f->instantiate(w[1], me ? fmi2ModelExchange : fmi2CoSimulation, w[3], w[4], &callbacks, fmi2False,
                        fmi2False);
#endif
  if (!f->c) {
    printf("status instantiate NULL\n");
    return;
  }
  ++nfmus;
}

/* "VR" or (FMI 3.0) "VR:N" words into v. */
static vars parse_vrs(char** w, int nw, int line) {
  vars v;
  if (nw > MAX_VRS) die(line, "too many value references");
  v.n = nw;
  v.values = 0;
  for (int i = 0; i < nw; ++i) {
    char* end = NULL;
    v.vr[i] = (fmi_vr)strtoul(w[i], &end, 10);
    int count = *end == ':' ? atoi(end + 1) : 1;
    if (count < 1 || (PKM_HOST_FMI == 2 && count != 1)) die(line, "VR:N with N >= 1 (FMI 3.0 arrays only)");
    v.values += count;
  }
  if (v.values > MAX_VALUES) die(line, "too many values");
  return v;
}

#if PKM_HOST_FMI == 3
#define GET_REAL(f, v, out) (f)->get_real((f)->c, (v)->vr, (size_t)(v)->n, out, (size_t)(v)->values)
#define SET_REAL(f, v, in) (f)->set_real((f)->c, (v)->vr, (size_t)(v)->n, in, (size_t)(v)->values)
#define SET_INTEGER(f, v, in) (f)->set_integer((f)->c, (v)->vr, (size_t)(v)->n, in, (size_t)(v)->values)
#else
#define GET_REAL(f, v, out) (f)->get_real((f)->c, (v)->vr, (size_t)(v)->n, out)
#define SET_REAL(f, v, in) (f)->set_real((f)->c, (v)->vr, (size_t)(v)->n, in)
#define SET_INTEGER(f, v, in) (f)->set_integer((f)->c, (v)->vr, (size_t)(v)->n, in)
#endif

/* One explicit Euler step of a Model Exchange FMU: the same arithmetic on every platform,
 * so the comparison is of the FMU's derivatives, events and state handling. */
static fmi_status euler_step(fmu* f, double h) {
  double x[MAX_STATES], dx[MAX_STATES];
  fmi_bool enter_event = FMI_FALSE, terminate = FMI_FALSE;
  fmi_status s = f->get_states(f->c, x, f->nx);
  if (s == FMI_OK) s = f->get_derivatives(f->c, dx, f->nx);
  if (s != FMI_OK) return s;
  for (int k = 0; k < f->nx; ++k) x[k] += h * dx[k];
  s = f->set_time(f->c, f->t + h);
  if (s == FMI_OK) s = f->set_states(f->c, x, f->nx);
  if (s == FMI_OK) s = f->completed_step(f->c, FMI_TRUE, &enter_event, &terminate);
  if (s == FMI_OK && (enter_event || terminate)) printf("event %s %.17g\n", f->name, f->t + h);
  return s;
}

static fmi_status do_step(fmu* f, double h) {
#if PKM_HOST_FMI == 3
  fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
  fmi3Float64 last = 0;
  return f->do_step(f->c, f->t, h, fmi3True, &event, &terminate, &early, &last);
#else
  return f->do_step(f->c, f->t, h, fmi2True);
#endif
}

static void step(int n, double h) {
  for (int k = 0; k < n; ++k) {
    for (int l = 0; l < nlinks; ++l) {
      double v[MAX_VALUES];
      link* c = &links[l];
      report("get", GET_REAL(&fmus[c->from], &c->src, v));
      report("set", SET_REAL(&fmus[c->to], &c->dst, v));
    }
    for (int i = 0; i < nfmus; ++i) {
      fmi_status s = fmus[i].nx ? euler_step(&fmus[i], h) : do_step(&fmus[i], h);
      report("doStep", s);
      if (s != FMI_OK) return;
      fmus[i].t += h;
    }
  }
}

int main(int argc, char** argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: fmi%d_host SCRIPT\n", PKM_HOST_FMI);
    return 2;
  }
  FILE* in = fopen(argv[1], "r");
  if (!in) {
    fprintf(stderr, "cannot read %s\n", argv[1]);
    return 2;
  }
  setvbuf(stdout, NULL, _IOLBF, 0);
  char buf[8192];
  int line = 0;
  while (fgets(buf, sizeof buf, in)) {
    ++line;
    char* hash = strchr(buf, '#');
    if (hash) *hash = 0;
    char* w[MAX_VALUES + 4];
    int nw = 0;
    for (char* tok = strtok(buf, " \t\r\n"); tok && nw < (int)(sizeof w / sizeof *w); tok = strtok(NULL, " \t\r\n"))
      w[nw++] = tok;
    if (nw == 0) continue;
    if (strcmp(w[0], "fmu") == 0 || strcmp(w[0], "me") == 0) {
      load(w, nw, line);
    } else if ((strcmp(w[0], "real") == 0 || strcmp(w[0], "int") == 0) && nw >= 4) {
      fmu* f = find(w[1], line);
      vars v = parse_vrs(w + 2, 1, line);
      if (nw - 3 != v.values) die(line, "real|int NAME VR VALUE... (one value per value of the variable)");
      if (w[0][0] == 'r') {
        double x[MAX_VALUES];
        for (int i = 0; i < v.values; ++i) x[i] = number(w[3 + i]);
        report("setReal", SET_REAL(f, &v, x));
      } else {
        fmi_int x[MAX_VALUES];
        for (int i = 0; i < v.values; ++i) x[i] = (fmi_int)strtol(w[3 + i], NULL, 10);
        report("setInteger", SET_INTEGER(f, &v, x));
      }
    } else if (strcmp(w[0], "init") == 0 && nw == 2) {
      fmu* f = find(w[1], line);
#if PKM_HOST_FMI == 3
      report("enterInitializationMode", f->enter_init(f->c, fmi3False, 0.0, 0.0, fmi3False, 0.0));
      report("exitInitializationMode", f->exit_init(f->c));
      if (f->nx) {
        fmi3Boolean again = fmi3True, terminate, nominals, values, next_defined;
        fmi3Float64 next;
        for (int k = 0; k < 100 && again; ++k)
          report("newDiscreteStates",
                 f->update_discrete_states(f->c, &again, &terminate, &nominals, &values, &next_defined, &next));
        report("enterContinuousTimeMode", f->enter_continuous(f->c));
      }
#else
      report("setupExperiment", f->setup(f->c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
      report("enterInitializationMode", f->enter_init(f->c));
      report("exitInitializationMode", f->exit_init(f->c));
      if (f->nx) {
        fmi2EventInfo ev;
        memset(&ev, 0, sizeof ev);
        ev.newDiscreteStatesNeeded = fmi2True;
        for (int k = 0; k < 100 && ev.newDiscreteStatesNeeded; ++k)
          report("newDiscreteStates", f->new_discrete_states(f->c, &ev));
        report("enterContinuousTimeMode", f->enter_continuous(f->c));
      }
#endif
    } else if (strcmp(w[0], "connect") == 0) {
      int arrow = 0;
      while (arrow < nw && strcmp(w[arrow], "->") != 0) ++arrow;
      if (arrow >= nw - 1 || nlinks == MAX_LINKS) die(line, "connect FROM VR... -> TO VR...");
      link* c = &links[nlinks];
      c->from = (int)(find(w[1], line) - fmus);
      c->to = (int)(find(w[arrow + 1], line) - fmus);
      c->src = parse_vrs(w + 2, arrow - 2, line);
      c->dst = parse_vrs(w + arrow + 2, nw - arrow - 2, line);
      if (c->src.values != c->dst.values) die(line, "unequal lists");
      ++nlinks;
    } else if (strcmp(w[0], "step") == 0 && nw == 3) {
      step(atoi(w[1]), number(w[2]));
    } else if (strcmp(w[0], "print") == 0 && nw >= 3) {
      fmu* f = find(w[1], line);
      vars vr = parse_vrs(w + 2, nw - 2, line);
      double v[MAX_VALUES];
      report("getReal", GET_REAL(f, &vr, v));
      printf("values %.17g", f->t);
      for (int i = 0; i < vr.values; ++i) printf(" %.17g", v[i]);
      printf("\n");
    } else if (strcmp(w[0], "save") == 0 && nw == 2) {
      fmu* f = find(w[1], line);
      fmi_state s = NULL;
      report("getFMUstate", f->get_state(f->c, &s));
      report("serializedFMUstateSize", f->state_size(f->c, s, &f->saved_size));
      free(f->saved);
      f->saved = (char*)malloc(f->saved_size);
      report("serializeFMUstate", f->serialize(f->c, s, (void*)f->saved, f->saved_size));
      report("freeFMUstate", f->free_state(f->c, &s));
      f->saved_t = f->t;
      printf("saved %s %.17g\n", f->name, f->t);
    } else if (strcmp(w[0], "restore") == 0 && nw == 2) {
      fmu* f = find(w[1], line);
      fmi_state s = NULL;
      report("deSerializeFMUstate", f->deserialize(f->c, (const void*)f->saved, f->saved_size, &s));
      report("setFMUstate", f->set_state(f->c, s));
      report("freeFMUstate", f->free_state(f->c, &s));
      f->t = f->saved_t;
      printf("restored %s %.17g\n", f->name, f->t);
    } else {
      die(line, "unknown command or wrong number of words");
    }
  }
  for (int i = 0; i < nfmus; ++i) {
    fmus[i].free_instance(fmus[i].c);
    free(fmus[i].saved);
  }
  fclose(in);
  return 0;
}
