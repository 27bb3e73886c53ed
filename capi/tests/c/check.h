/* Checking helpers shared by the C test programs (each includes it once).
 *
 * CHECK(cond, fmt, ...)  counts a failure and goes on;
 * OK(call)               a bm_* call that must succeed (exits otherwise);
 * EXPECT(call, out, code, n1, n2)
 *                        a bm_* call that must fail with `code`, leave the
 *                        handle `out` NULL and name n1 and n2 in its
 *                        message. */
#ifndef BM_TEST_CHECK_H
#define BM_TEST_CHECK_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bubblemesh.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static int failures = 0;

#define CHECK(cond, ...)                                                       \
  do {                                                                         \
    if (!(cond)) {                                                             \
      fprintf(stderr, "FAIL %s:%d: ", __FILE__, __LINE__);                     \
      fprintf(stderr, __VA_ARGS__);                                            \
      fprintf(stderr, "\n");                                                   \
      failures++;                                                              \
    }                                                                          \
  } while (0)

#define OK(call)                                                               \
  do {                                                                         \
    bm_result rc_ = (call);                                                    \
    if (rc_ != BM_OK) {                                                        \
      fprintf(stderr, "FAIL %s:%d: %s -> %s: %s\n", __FILE__, __LINE__, #call, \
              bm_result_name(rc_), bm_last_error_message());                   \
      exit(1);                                                                 \
    }                                                                          \
  } while (0)

#define EXPECT(call, out, code, n1, n2)                                        \
  do {                                                                         \
    bm_result rc_ = (call);                                                    \
    const char *msg_ = bm_last_error_message();                                \
    if (rc_ != (code) || strstr(msg_, (n1)) == NULL ||                         \
        strstr(msg_, (n2)) == NULL || (out) != NULL) {                         \
      fprintf(stderr,                                                          \
              "FAIL %s:%d: %s\n  gave %s \"%s\"\n  expected %s with \"%s\" "   \
              "and \"%s\"\n",                                                  \
              __FILE__, __LINE__, #call, bm_result_name(rc_), msg_,            \
              bm_result_name(code), (n1), (n2));                               \
      failures++;                                                              \
    } else {                                                                   \
      printf("ok   %-16s %s\n", bm_result_name(rc_), msg_);                    \
    }                                                                          \
  } while (0)

#endif
