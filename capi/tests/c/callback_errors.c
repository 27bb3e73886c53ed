/*
 * Host callbacks that fail, answer NaN, or cancel, and arguments that are
 * wrong: every case must come back as an error code with a message that
 * names the culprit, never as a crash, and the library must stay usable
 * afterwards (run under valgrind by the tests: no leaks on these paths).
 *
 * Exit status 0 when every case behaves, 1 otherwise.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bubblemesh.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static int failures = 0;

/* `call` must return `code` and leave a last-error message containing
   `needle` */
#define EXPECT(call, code, needle)                                             \
  do {                                                                         \
    bm_result rc_ = (call);                                                    \
    const char *msg_ = bm_last_error_message();                                \
    if (rc_ != (code) || strstr(msg_, (needle)) == NULL) {                     \
      fprintf(stderr,                                                          \
              "FAIL %s:%d: %s\n  gave %s \"%s\"\n  expected %s with \"%s\"\n", \
              __FILE__, __LINE__, #call, bm_result_name(rc_), msg_,            \
              bm_result_name(code), (needle));                                 \
      failures++;                                                              \
    } else {                                                                   \
      printf("ok   %-18s %s\n", bm_result_name(rc_), msg_);                    \
    }                                                                          \
  } while (0)

#define OK(call)                                                               \
  do {                                                                         \
    bm_result rc_ = (call);                                                    \
    if (rc_ != BM_OK) {                                                        \
      fprintf(stderr, "FAIL %s:%d: %s -> %s: %s\n", __FILE__, __LINE__, #call, \
              bm_result_name(rc_), bm_last_error_message());                   \
      failures++;                                                              \
    }                                                                          \
  } while (0)

/* ---- callbacks that can be told to misbehave ---- */

typedef enum { FINE, RETURN_ERROR, RETURN_NAN, LEAVE_UNWRITTEN } mode_t_;

typedef struct {
  double a[3], b[3];
  mode_t_ mode;
} line_t;

static int line_eval(void *user, double t, int order, double *out) {
  line_t *l = (line_t *)user;
  if (l->mode == RETURN_ERROR && t > 0.3)
    return 7;
  if (l->mode == LEAVE_UNWRITTEN && t > 0.3)
    return 0;
  for (int k = 0; k < 3; k++) {
    double d = l->b[k] - l->a[k];
    out[k] = order == 0 ? l->a[k] + t * d : order == 1 ? d : 0.0;
  }
  if (l->mode == RETURN_NAN && t > 0.3 && order == 1)
    out[1] = NAN;
  return 0;
}

typedef struct {
  double R, r;
  mode_t_ mode;
  long evals;
} torus_t;

static int torus_eval(void *user, double u, double v, int order, double *o) {
  torus_t *T = (torus_t *)user;
  double cu = cos(u), su = sin(u), cv = cos(v), sv = sin(v);
  double w = T->R + T->r * cv;
  T->evals++;
  if (T->mode == RETURN_ERROR)
    return -1;
  o[0] = w * cu, o[1] = w * su, o[2] = T->r * sv;
  if (order >= 1) {
    o[3] = -w * su, o[4] = w * cu, o[5] = 0.0;
    o[6] = -T->r * sv * cu, o[7] = -T->r * sv * su, o[8] = T->r * cv;
  }
  if (order >= 2) {
    o[9] = -w * cu, o[10] = -w * su, o[11] = 0.0;
    o[12] = T->r * sv * su, o[13] = -T->r * sv * cu, o[14] = 0.0;
    o[15] = -T->r * cv * cu, o[16] = -T->r * cv * su, o[17] = -T->r * sv;
    if (T->mode == RETURN_NAN)
      o[10] = NAN; /* Suu's y */
  }
  return 0;
}

typedef struct {
  double d;
  mode_t_ mode;
  int zero;
} spacing_t;

static int spacing_cb(void *user, double x, double y, double z, int dim,
                      uint32_t id, double u, double v, double *out) {
  spacing_t *s = (spacing_t *)user;
  (void)y, (void)z, (void)id, (void)u, (void)v;
  if (dim == 2 && x > 0.5) {
    if (s->mode == RETURN_ERROR)
      return 3;
    if (s->mode == RETURN_NAN) {
      *out = NAN;
      return 0;
    }
    if (s->zero) {
      *out = 0.0;
      return 0;
    }
  }
  *out = s->d;
  return 0;
}

typedef struct {
  int fail;
  long calls;
} ball_t;

static int contains_cb(void *user, const double *p, int *inside) {
  ball_t *b = (ball_t *)user;
  b->calls++;
  if (b->fail)
    return 9;
  *inside = p[0] * p[0] + p[1] * p[1] + p[2] * p[2] < 4.0;
  return 0;
}

static int cancel_at_10(void *user, const char *phase, int dim, uint32_t id,
                        size_t step, size_t max_steps) {
  int *calls = (int *)user;
  (void)phase, (void)dim, (void)id, (void)max_steps;
  ++*calls;
  return step >= 10 ? 1 : 0;
}

/* a unit square in z = 0 with line edges given as callbacks */
typedef struct {
  bm_model *model;
  line_t lines[4];
  uint32_t face;
} square_t;

static void square(square_t *s) {
  double c[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  uint32_t v[4];
  bm_edge_use uses[4];
  bm_curve_callbacks cb = {line_eval};
  OK(bm_model_new(&s->model));
  for (int k = 0; k < 4; k++)
    OK(bm_model_add_vertex(s->model, c[k][0], c[k][1], c[k][2], &v[k]));
  for (int k = 0; k < 4; k++) {
    memcpy(s->lines[k].a, c[k], sizeof c[k]);
    memcpy(s->lines[k].b, c[(k + 1) % 4], sizeof c[k]);
    s->lines[k].mode = FINE;
    uint32_t e;
    OK(bm_model_add_curve(s->model, &cb, &s->lines[k], 0, 1, v[k],
                          v[(k + 1) % 4], &e));
    uses[k].edge = e, uses[k].forward = 1;
  }
  size_t len = 4;
  double o[3] = {0, 0, 0}, n[3] = {0, 0, 1};
  OK(bm_model_add_plane_face(s->model, o, n, uses, &len, 1, &s->face));
}

int main(void) {
  bm_spacing *coarse = NULL;
  OK(bm_spacing_from_expr("0.25", &coarse));
  bm_mesh *mesh = NULL;

  /* ---- curve callbacks failing during meshing ---- */
  square_t sq;
  square(&sq);
  sq.lines[2].mode = RETURN_ERROR;
  EXPECT(bm_mesh_generate(sq.model, coarse, -1, 0, &mesh), BM_ERR_CALLBACK,
         "curve callback 'eval' of edge 2");
  EXPECT(bm_mesh_generate(sq.model, coarse, -1, 0, &mesh), BM_ERR_CALLBACK,
         "returned 7");
  sq.lines[2].mode = RETURN_NAN;
  EXPECT(bm_mesh_generate(sq.model, coarse, -1, 0, &mesh), BM_ERR_CALLBACK,
         "non-finite value (");
  sq.lines[2].mode = LEAVE_UNWRITTEN;
  EXPECT(bm_mesh_generate(sq.model, coarse, -1, 0, &mesh), BM_ERR_CALLBACK,
         "NaN");
  if (mesh != NULL) {
    fprintf(stderr, "FAIL: a failed call wrote its out-parameter\n");
    failures++;
  }
  /* the same model meshes once the callback behaves again */
  sq.lines[2].mode = FINE;
  OK(bm_mesh_generate(sq.model, coarse, -1, 0, &mesh));
  size_t nt = 0;
  OK(bm_mesh_triangle_count(mesh, &nt));
  if (nt < 8) {
    fprintf(stderr, "FAIL: %zu triangles on the square\n", nt);
    failures++;
  }
  bm_mesh_free(mesh);
  mesh = NULL;

  /* ---- spacing callbacks ---- */
  spacing_t sp = {0.25, RETURN_NAN, 0};
  bm_spacing *cbs = NULL;
  OK(bm_spacing_from_callback(spacing_cb, &sp, &cbs));
  EXPECT(bm_mesh_generate(sq.model, cbs, -1, 0, &mesh), BM_ERR_CALLBACK,
         "spacing callback (at (");
  EXPECT(bm_mesh_generate(sq.model, cbs, -1, 0, &mesh), BM_ERR_CALLBACK,
         "on face 0");
  sp.mode = RETURN_ERROR;
  EXPECT(bm_mesh_generate(sq.model, cbs, -1, 0, &mesh), BM_ERR_CALLBACK,
         "returned 3 (failure)");
  sp.mode = FINE, sp.zero = 1;
  EXPECT(bm_mesh_generate(sq.model, cbs, -1, 0, &mesh), BM_ERR_CALLBACK,
         "must be finite and > 0");
  sp.zero = 0;
  OK(bm_mesh_generate(sq.model, cbs, 1, 0, &mesh)); /* edges only */
  size_t nl = 0;
  OK(bm_mesh_line_count(mesh, &nl));
  OK(bm_mesh_triangle_count(mesh, &nt));
  if (nl < 16 || nt != 0) {
    fprintf(stderr, "FAIL: dim 1 gave %zu lines, %zu triangles\n", nl, nt);
    failures++;
  }
  bm_mesh_free(mesh);
  mesh = NULL;

  /* ---- progress callback cancels ---- */
  bm_options opts;
  OK(bm_options_init(&opts));
  int progress_calls = 0;
  opts.progress = cancel_at_10;
  opts.progress_user = &progress_calls;
  bm_spacing *fine = NULL;
  OK(bm_spacing_from_expr("0.05", &fine));
  EXPECT(bm_mesh_generate_ex(sq.model, fine, &opts, &mesh), BM_ERR_CANCELLED,
         "cancelled by the progress callback");

  /* ---- surface callbacks failing during meshing ---- */
  bm_model *tm = NULL;
  OK(bm_model_new(&tm));
  torus_t torus = {1.0, 0.4, FINE, 0};
  bm_surface_callbacks tcb = {torus_eval, NULL, NULL};
  bm_surface_info info;
  memset(&info, 0, sizeof info);
  info.u1 = info.v1 = info.period_u = info.period_v = 2 * M_PI;
  uint32_t tf;
  OK(bm_model_add_surface_face(tm, &tcb, &torus, &info, NULL, NULL, 0, &tf));
  torus.mode = RETURN_ERROR;
  EXPECT(bm_mesh_generate(tm, coarse, -1, 0, &mesh), BM_ERR_CALLBACK,
         "surface callback 'eval' of face 0");
  torus.mode = RETURN_NAN;
  EXPECT(bm_mesh_generate(tm, coarse, -1, 0, &mesh), BM_ERR_CALLBACK,
         "Suu[1] = NaN");
  /* checked already when the face is added */
  uint32_t tf2;
  torus.mode = RETURN_ERROR;
  EXPECT(bm_model_add_surface_face(tm, &tcb, &torus, &info, NULL, NULL, 0,
                                   &tf2),
         BM_ERR_CALLBACK, "returned -1");
  size_t nfaces = 0;
  OK(bm_model_entity_count(tm, 2, &nfaces));
  if (nfaces != 1) {
    fprintf(stderr, "FAIL: a refused face was added (%zu faces)\n", nfaces);
    failures++;
  }

  /* ---- wrong arguments ---- */
  uint32_t id;
  bm_curve_callbacks lcb = {line_eval};
  line_t bad = {{0, 0, 0}, {2, 0, 0}, FINE};
  EXPECT(bm_model_add_vertex(NULL, 0, 0, 0, &id), BM_ERR_NULL,
         "argument 'model' is NULL");
  EXPECT(bm_model_add_vertex(sq.model, 0, NAN, 0, &id), BM_ERR_RANGE,
         "not finite");
  EXPECT(bm_model_add_curve(sq.model, &lcb, &bad, 0, 1, 0, 99, &id),
         BM_ERR_RANGE, "end_vertex = 99 is not a vertex id");
  EXPECT(bm_model_add_curve(sq.model, &lcb, &bad, 1, 0, 0, 1, &id),
         BM_ERR_RANGE, "t0 < t1");
  EXPECT(bm_model_add_curve(sq.model, &lcb, &bad, 0, 1, 0, 1, &id),
         BM_ERR_GEOMETRY, "its end vertex 1");
  bm_edge_use open_loop[2] = {{0, 1}, {2, 1}};
  size_t two = 2;
  double o[3] = {0, 0, 0}, n[3] = {0, 0, 1};
  EXPECT(bm_model_add_plane_face(sq.model, o, n, open_loop, &two, 1, &id),
         BM_ERR_GEOMETRY, "loop 0 is not closed");
  EXPECT(bm_model_add_plane_face(sq.model, o, NULL, open_loop, &two, 1, &id),
         BM_ERR_NULL, "'normal'");
  EXPECT(bm_mesh_generate(sq.model, coarse, 7, 0, &mesh), BM_ERR_RANGE,
         "dim = 7");
  EXPECT(bm_mesh_generate((const bm_model *)coarse, coarse, -1, 0, &mesh),
         BM_ERR_RANGE, "not a live bm_model handle");
  EXPECT(bm_mesh_generate(sq.model, coarse, -1, 0, NULL), BM_ERR_NULL,
         "'out'");
  EXPECT(bm_spacing_from_expr("0.1 + (x", &cbs), BM_ERR_SPACING,
         "0.1 + (x");
  EXPECT(bm_spacing_from_expr("-1", &cbs), BM_ERR_SPACING, "> 0");
  const char *no_equals[1] = {"eps"};
  EXPECT(bm_spacing_from_plugin("libspacing.so", no_equals, 1, &cbs),
         BM_ERR_RANGE, "expected KEY=VALUE");
  EXPECT(bm_spacing_from_plugin("libspacing.so", NULL, 1, &cbs), BM_ERR_NULL,
         "'args'");
  EXPECT(bm_spacing_from_plugin("libspacing.so", NULL, 0, &cbs), BM_ERR_IO,
         "no such file");
  EXPECT(bm_mesh_step_file("part.step", coarse, 7, 0, &mesh), BM_ERR_RANGE,
         "dim = 7");
  EXPECT(bm_mesh_step_file("part.step", coarse, -1, 0, NULL), BM_ERR_NULL,
         "'out'");
  bm_spacing_free(cbs); /* still the callback spacing: untouched by failures */

  /* a volume whose in/out callback fails */
  uint32_t vol;
  ball_t inout = {0};
  bm_volume_callbacks vcb = {contains_cb};
  OK(bm_model_add_volume(tm, &tf, 1, &vcb, &inout, &vol));
  torus.mode = FINE;
  inout.fail = 1;
  EXPECT(bm_mesh_generate(tm, coarse, 3, 0, &mesh), BM_ERR_CALLBACK,
         "the volume callback 'contains' of volume 0");
  EXPECT(bm_mesh_generate(tm, coarse, -1, 1, &mesh), BM_ERR_CALLBACK,
         "returned 9 (failure)");
  if (inout.calls == 0) {
    fprintf(stderr, "FAIL: the contains callback was never called\n");
    failures++;
  }

  /* the last error survives reading it, and truncates into short buffers */
  char small[8];
  size_t full = 0;
  OK(bm_last_error(small, sizeof small, &full));
  if (strlen(small) != 7 || full <= 7) {
    fprintf(stderr, "FAIL: bm_last_error truncation (%s, %zu)\n", small, full);
    failures++;
  }

  bm_model_free(tm);
  bm_model_free(sq.model);
  bm_spacing_free(coarse);
  bm_spacing_free(fine);
  bm_model_free(NULL); /* accepted */

  if (failures) {
    fprintf(stderr, "%d case(s) failed\n", failures);
    return 1;
  }
  printf("all cases behaved\n");
  return 0;
}
