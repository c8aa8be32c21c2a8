/*
 * fmi2_host -- a small FMI 2.0 Co-Simulation importer for the tests of the FMU binaries of
 * every platform (tests/fmu/test_platforms.py).  Built for the build machine and cross-
 * compiled with the FMUs (fmu/platform), it runs natively, under Wine (x86_64-windows) or
 * under QEMU (aarch64-linux), and prints what it sees, so the platforms can be compared.
 *
 *   fmi2_host SCRIPT
 *
 * SCRIPT has one command a line (whitespace-separated; '#' starts a comment):
 *   fmu NAME LIBRARY GUID RESOURCE_URI   load the binary and instantiate it (Co-Simulation)
 *   me NAME LIBRARY GUID RESOURCE_URI NX the same as Model Exchange with NX continuous states:
 *                                        its steps are explicit Euler steps of this host
 *   real NAME VR VALUE                   fmi2SetReal of one variable (VALUE may be nan, inf)
 *   int NAME VR VALUE                    fmi2SetInteger of one variable
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
 * Output: "status <command> <fmi2Status>" for every FMI call that is not OK, the FMU's log
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

#include "fmi2Functions.h"

#define MAX_FMUS 4
#define MAX_LINKS 64
#define MAX_VRS 64
#define MAX_STATES 64

typedef struct {
  char name[64];
  fmi2Component c;
  int nx; /* Model Exchange: continuous states; 0 for Co-Simulation */
  double t, saved_t;
  char* saved;
  size_t saved_size;
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
} fmu;

typedef struct {
  int from, to, n;
  fmi2ValueReference from_vr[MAX_VRS], to_vr[MAX_VRS];
} link;

static fmu fmus[MAX_FMUS];
static int nfmus;
static link links[MAX_LINKS];
static int nlinks;

static const char* status_name(fmi2Status s) {
  static const char* names[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
  return (s >= 0 && s <= fmi2Pending) ? names[s] : "?";
}

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

static void report(const char* command, fmi2Status s) {
  if (s != fmi2OK) printf("status %s %s\n", command, status_name(s));
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

static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

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
  if (!f->c) {
    printf("status instantiate NULL\n");
    return;
  }
  ++nfmus;
}

static int parse_vrs(char** w, int nw, fmi2ValueReference* vr, int line) {
  if (nw > MAX_VRS) die(line, "too many value references");
  for (int i = 0; i < nw; ++i) vr[i] = (fmi2ValueReference)strtoul(w[i], NULL, 10);
  return nw;
}

/* One explicit Euler step of a Model Exchange FMU: the same arithmetic on every platform,
 * so the comparison is of the FMU's derivatives, events and state handling. */
static fmi2Status euler_step(fmu* f, double h) {
  double x[MAX_STATES], dx[MAX_STATES];
  fmi2Boolean enter_event = fmi2False, terminate = fmi2False;
  fmi2Status s = f->get_states(f->c, x, f->nx);
  if (s == fmi2OK) s = f->get_derivatives(f->c, dx, f->nx);
  if (s != fmi2OK) return s;
  for (int k = 0; k < f->nx; ++k) x[k] += h * dx[k];
  s = f->set_time(f->c, f->t + h);
  if (s == fmi2OK) s = f->set_states(f->c, x, f->nx);
  if (s == fmi2OK) s = f->completed_step(f->c, fmi2True, &enter_event, &terminate);
  if (s == fmi2OK && (enter_event || terminate)) printf("event %s %.17g\n", f->name, f->t + h);
  return s;
}

static void step(int n, double h) {
  for (int k = 0; k < n; ++k) {
    for (int l = 0; l < nlinks; ++l) {
      double v[MAX_VRS];
      link* c = &links[l];
      report("get", fmus[c->from].get_real(fmus[c->from].c, c->from_vr, c->n, v));
      report("set", fmus[c->to].set_real(fmus[c->to].c, c->to_vr, c->n, v));
    }
    for (int i = 0; i < nfmus; ++i) {
      fmi2Status s = fmus[i].nx ? euler_step(&fmus[i], h) : fmus[i].do_step(fmus[i].c, fmus[i].t, h, fmi2True);
      report("doStep", s);
      if (s != fmi2OK) return;
      fmus[i].t += h;
    }
  }
}

int main(int argc, char** argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: fmi2_host SCRIPT\n");
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
    char* w[MAX_VRS * 2 + 4];
    int nw = 0;
    for (char* tok = strtok(buf, " \t\r\n"); tok && nw < (int)(sizeof w / sizeof *w); tok = strtok(NULL, " \t\r\n"))
      w[nw++] = tok;
    if (nw == 0) continue;
    if (strcmp(w[0], "fmu") == 0 || strcmp(w[0], "me") == 0) {
      load(w, nw, line);
    } else if (strcmp(w[0], "real") == 0 && nw == 4) {
      fmu* f = find(w[1], line);
      fmi2ValueReference vr = (fmi2ValueReference)strtoul(w[2], NULL, 10);
      double v = number(w[3]);
      report("setReal", f->set_real(f->c, &vr, 1, &v));
    } else if (strcmp(w[0], "int") == 0 && nw == 4) {
      fmu* f = find(w[1], line);
      fmi2ValueReference vr = (fmi2ValueReference)strtoul(w[2], NULL, 10);
      fmi2Integer v = (fmi2Integer)strtol(w[3], NULL, 10);
      report("setInteger", f->set_integer(f->c, &vr, 1, &v));
    } else if (strcmp(w[0], "init") == 0 && nw == 2) {
      fmu* f = find(w[1], line);
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
    } else if (strcmp(w[0], "connect") == 0) {
      int arrow = 0;
      while (arrow < nw && strcmp(w[arrow], "->") != 0) ++arrow;
      if (arrow >= nw - 1 || nlinks == MAX_LINKS) die(line, "connect FROM VR... -> TO VR...");
      link* c = &links[nlinks];
      c->from = (int)(find(w[1], line) - fmus);
      c->to = (int)(find(w[arrow + 1], line) - fmus);
      c->n = parse_vrs(w + 2, arrow - 2, c->from_vr, line);
      if (parse_vrs(w + arrow + 2, nw - arrow - 2, c->to_vr, line) != c->n) die(line, "unequal lists");
      ++nlinks;
    } else if (strcmp(w[0], "step") == 0 && nw == 3) {
      step(atoi(w[1]), number(w[2]));
    } else if (strcmp(w[0], "print") == 0 && nw >= 3) {
      fmu* f = find(w[1], line);
      fmi2ValueReference vr[MAX_VRS];
      double v[MAX_VRS];
      int n = parse_vrs(w + 2, nw - 2, vr, line);
      report("getReal", f->get_real(f->c, vr, n, v));
      printf("values %.17g", f->t);
      for (int i = 0; i < n; ++i) printf(" %.17g", v[i]);
      printf("\n");
    } else if (strcmp(w[0], "save") == 0 && nw == 2) {
      fmu* f = find(w[1], line);
      fmi2FMUstate s = NULL;
      report("getFMUstate", f->get_state(f->c, &s));
      report("serializedFMUstateSize", f->state_size(f->c, s, &f->saved_size));
      free(f->saved);
      f->saved = (char*)malloc(f->saved_size);
      report("serializeFMUstate", f->serialize(f->c, s, (fmi2Byte*)f->saved, f->saved_size));
      report("freeFMUstate", f->free_state(f->c, &s));
      f->saved_t = f->t;
      printf("saved %s %.17g\n", f->name, f->t);
    } else if (strcmp(w[0], "restore") == 0 && nw == 2) {
      fmu* f = find(w[1], line);
      fmi2FMUstate s = NULL;
      report("deSerializeFMUstate", f->deserialize(f->c, (const fmi2Byte*)f->saved, f->saved_size, &s));
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
