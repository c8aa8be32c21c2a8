/* The plain-C tests' check: counts passes and failures, prints a failure with its place. */
#ifndef PKM_TESTS_C_CHECK_H
#define PKM_TESTS_C_CHECK_H
#include <stdio.h>

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

#endif
