/* A circle of centre c and radius r in the plane z = c[2], as a curve
 * callback of the C ABI: C(t) = c + r (cos t, sin t, 0) and its first and
 * second derivatives (order 0, 1, 2). Shared by the C test programs. */
#ifndef BM_TEST_CIRCLE_H
#define BM_TEST_CIRCLE_H

#include <math.h>

typedef struct {
  double c[3], r;
} circle_t;

static int circle_eval(void *user, double t, int order, double *out) {
  const circle_t *c = (const circle_t *)user;
  double ct = cos(t), st = sin(t);
  switch (order) {
  case 0:
    out[0] = c->c[0] + c->r * ct;
    out[1] = c->c[1] + c->r * st;
    out[2] = c->c[2];
    break;
  case 1:
    out[0] = -c->r * st;
    out[1] = c->r * ct;
    out[2] = 0.0;
    break;
  default:
    out[0] = -c->r * ct;
    out[1] = -c->r * st;
    out[2] = 0.0;
  }
  return 0;
}

#endif
