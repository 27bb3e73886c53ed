/*
 * Volume meshing (dim 3) of parts described through callbacks:
 *
 *  - a box [0, 1] x [0, 0.8] x [0, 0.6]: 8 vertices, 12 lines, 6 planar
 *    faces, one volume without an in/out callback;
 *  - a ball of radius 1: one sphere face given by surface callbacks (closed
 *    by its two singular points), one volume with a `contains` callback
 *    that counts its calls.
 *
 * Checks, for each: every tetrahedron belongs to the volume and has
 * positive volume; the tetrahedra's faces used once are exactly the
 * boundary triangles (the volume mesh conforms to its boundary); the sum of
 * the tetrahedra's volumes equals the volume enclosed by the boundary
 * triangles (divergence theorem) to 1e-9 relative; the box's volume is
 * exact (0.48), the ball's within the chord bound of 4/3 pi; a contains
 * callback that fails gives BM_ERR_CALLBACK naming the volume.
 *
 * Usage: volume [-d SPACING]  (default 0.2). Exit status 0 when every check
 * passes, 1 otherwise.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bubblemesh.h"
#include "check.h"

static void sub(const double *a, const double *b, double *o) {
  o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}
static void cross(const double *a, const double *b, double *o) {
  o[0] = a[1] * b[2] - a[2] * b[1];
  o[1] = a[2] * b[0] - a[0] * b[2];
  o[2] = a[0] * b[1] - a[1] * b[0];
}
static double dot(const double *a, const double *b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
/* 6 x the signed volume of the tetrahedron (a, b, c, d) */
static double vol6(const double *a, const double *b, const double *c,
                   const double *d) {
  double u[3], v[3], w[3], n[3];
  sub(b, a, u), sub(c, a, v), sub(d, a, w);
  cross(u, v, n);
  return dot(n, w);
}

/* ---- the sphere through callbacks ---- */

/* S(u,v) = (cos v cos u, cos v sin u, sin v), u in [0, 2 pi) periodic,
   v in [-pi/2, pi/2] closed by the poles */
static int sphere_eval(void *user, double u, double v, int order, double *o) {
  (void)user;
  double cu = cos(u), su = sin(u), cv = cos(v), sv = sin(v);
  o[0] = cv * cu, o[1] = cv * su, o[2] = sv;
  if (order >= 1) {
    o[3] = -cv * su, o[4] = cv * cu, o[5] = 0;   /* Su */
    o[6] = -sv * cu, o[7] = -sv * su, o[8] = cv; /* Sv */
  }
  if (order >= 2) {
    o[9] = -cv * cu, o[10] = -cv * su, o[11] = 0; /* Suu */
    o[12] = sv * su, o[13] = -sv * cu, o[14] = 0; /* Suv */
    o[15] = -cv * cu, o[16] = -cv * su, o[17] = -sv; /* Svv */
  }
  return 0;
}

typedef struct {
  long calls;
  int fail;
} ball_t;

static int ball_contains(void *user, const double *p, int *inside) {
  ball_t *b = (ball_t *)user;
  b->calls++;
  if (b->fail)
    return 5;
  *inside = dot(p, p) < 1.0;
  return 0;
}

/* ---- checks ---- */

typedef struct {
  uint32_t v[3]; /* sorted */
  int tet;       /* 1 from a tetrahedron, 0 from a boundary triangle */
} tface_t;

static int cmp_tface(const void *x, const void *y) {
  const tface_t *p = x, *q = y;
  for (int k = 0; k < 3; k++)
    if (p->v[k] != q->v[k])
      return p->v[k] < q->v[k] ? -1 : 1;
  return p->tet - q->tet;
}

static tface_t sorted_face(uint32_t a, uint32_t b, uint32_t c, int tet) {
  tface_t f;
  uint32_t t;
  if (a > b)
    t = a, a = b, b = t;
  if (b > c)
    t = b, b = c, c = t;
  if (a > b)
    t = a, a = b, b = t;
  f.v[0] = a, f.v[1] = b, f.v[2] = c, f.tet = tet;
  return f;
}

/* Meshes `model` (one volume, id 0) with dim 3 and checks it; returns the
   tetrahedra's total volume. */
static double check_volume_mesh(const char *what, bm_model *model,
                                const bm_spacing *spacing) {
  bm_mesh *mesh = NULL;
  OK(bm_mesh_generate(model, spacing, 3, 0, &mesh));
  size_t nn, nt, ntet;
  OK(bm_mesh_node_count(mesh, &nn));
  OK(bm_mesh_triangle_count(mesh, &nt));
  OK(bm_mesh_tetrahedron_count(mesh, &ntet));
  double *xyz = malloc(3 * nn * sizeof(double));
  uint32_t *tri = malloc(3 * nt * sizeof(uint32_t));
  uint32_t *tet = malloc(4 * ntet * sizeof(uint32_t) + 1);
  bm_entity *tet_ent = malloc(ntet * sizeof(bm_entity) + 1);
  OK(bm_mesh_nodes(mesh, xyz, 3 * nn));
  OK(bm_mesh_triangles(mesh, tri, 3 * nt));
  OK(bm_mesh_tetrahedra(mesh, tet, 4 * ntet));
  OK(bm_mesh_tetrahedron_entities(mesh, tet_ent, ntet));
  CHECK(ntet > 20, "%s: only %zu tetrahedra", what, ntet);

  /* positive tetrahedra, all in volume 0 */
  double sum6 = 0.0, min6 = INFINITY;
  size_t wrong_entity = 0;
  for (size_t t = 0; t < ntet; t++) {
    const uint32_t *q = tet + 4 * t;
    double v = vol6(xyz + 3 * q[0], xyz + 3 * q[1], xyz + 3 * q[2],
                    xyz + 3 * q[3]);
    sum6 += v;
    if (v < min6)
      min6 = v;
    if (tet_ent[t].dim != 3 || tet_ent[t].id != 0)
      wrong_entity++;
  }
  CHECK(min6 > 0.0, "%s: a tetrahedron has volume %g (<= 0)", what,
        min6 / 6.0);
  CHECK(wrong_entity == 0, "%s: %zu tetrahedra not tagged volume 0", what,
        wrong_entity);

  /* the volume enclosed by the boundary triangles (outward for a volume's
     faces): sum of det(a, b, c) / 6 */
  double enclosed6 = 0.0;
  for (size_t t = 0; t < nt; t++) {
    const uint32_t *q = tri + 3 * t;
    double o[3] = {0, 0, 0};
    enclosed6 += vol6(o, xyz + 3 * q[0], xyz + 3 * q[1], xyz + 3 * q[2]);
  }
  double rel = fabs(sum6 - enclosed6) / fabs(enclosed6);
  CHECK(rel < 1e-9,
        "%s: tetrahedra fill %.12g but the boundary encloses %.12g (rel %.2e)",
        what, sum6 / 6.0, enclosed6 / 6.0, rel);

  /* tetrahedron faces used once == boundary triangles, each once */
  size_t nf = 4 * ntet + nt;
  tface_t *f = malloc(nf * sizeof(tface_t));
  size_t k = 0;
  for (size_t t = 0; t < ntet; t++) {
    const uint32_t *q = tet + 4 * t;
    f[k++] = sorted_face(q[1], q[2], q[3], 1);
    f[k++] = sorted_face(q[0], q[2], q[3], 1);
    f[k++] = sorted_face(q[0], q[1], q[3], 1);
    f[k++] = sorted_face(q[0], q[1], q[2], 1);
  }
  for (size_t t = 0; t < nt; t++)
    f[k++] = sorted_face(tri[3 * t], tri[3 * t + 1], tri[3 * t + 2], 0);
  qsort(f, nf, sizeof(tface_t), cmp_tface);
  size_t boundary_ok = 0, interior = 0, bad = 0;
  for (size_t i = 0; i < nf;) {
    size_t j = i, tets = 0, tris = 0;
    while (j < nf && memcmp(f[j].v, f[i].v, sizeof f[i].v) == 0) {
      if (f[j].tet)
        tets++;
      else
        tris++;
      j++;
    }
    if (tris == 1 && tets == 1)
      boundary_ok++;
    else if (tris == 0 && tets == 2)
      interior++;
    else
      bad++;
    i = j;
  }
  CHECK(bad == 0 && boundary_ok == nt,
        "%s: %zu tetrahedron faces are neither interior nor a boundary "
        "triangle (%zu of %zu triangles matched)",
        what, bad, boundary_ok, nt);
  printf("%s: %zu nodes, %zu boundary triangles, %zu tetrahedra "
         "(%zu interior faces); volume %.9f, boundary encloses %.9f "
         "(rel %.1e), smallest tet %.3e\n",
         what, nn, nt, ntet, interior, sum6 / 6.0, enclosed6 / 6.0, rel,
         min6 / 6.0);

  free(f);
  free(xyz), free(tri), free(tet), free(tet_ent);
  bm_mesh_free(mesh);
  return sum6 / 6.0;
}

/* the box [0, X] x [0, Y] x [0, Z] from lines and planar faces */
static bm_model *box_model(double X, double Y, double Z) {
  bm_model *m = NULL;
  OK(bm_model_new(&m));
  uint32_t v[8];
  for (int k = 0; k < 8; k++)
    OK(bm_model_add_vertex(m, (k & 1) ? X : 0, (k & 2) ? Y : 0,
                           (k & 4) ? Z : 0, &v[k]));
  /* faces as corner cycles */
  static const int faces[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                  {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  int edge_of[8][8];
  memset(edge_of, -1, sizeof edge_of);
  uint32_t fid[6];
  for (int f = 0; f < 6; f++) {
    bm_edge_use uses[4];
    for (int k = 0; k < 4; k++) {
      int a = faces[f][k], b = faces[f][(k + 1) % 4];
      if (edge_of[a][b] < 0) {
        uint32_t e;
        OK(bm_model_add_line(m, v[a], v[b], &e));
        edge_of[a][b] = (int)e;
        edge_of[b][a] = (int)e | 0x10000; /* reversed use */
      }
      uses[k].edge = (uint32_t)(edge_of[a][b] & 0xffff);
      uses[k].forward = (edge_of[a][b] & 0x10000) == 0;
    }
    /* origin and normal from the first three corners */
    double p[3][3];
    for (int k = 0; k < 3; k++) {
      int c = faces[f][k];
      p[k][0] = (c & 1) ? X : 0, p[k][1] = (c & 2) ? Y : 0;
      p[k][2] = (c & 4) ? Z : 0;
    }
    double a[3], b[3], n[3];
    sub(p[1], p[0], a), sub(p[2], p[0], b), cross(a, b, n);
    size_t four = 4;
    OK(bm_model_add_plane_face(m, p[0], n, uses, &four, 1, &fid[f]));
  }
  uint32_t vol;
  OK(bm_model_add_volume(m, fid, 6, NULL, NULL, &vol));
  return m;
}

int main(int argc, char **argv) {
  double d = 0.2;
  for (int i = 1; i < argc; i++)
    if (strcmp(argv[i], "-d") == 0 && i + 1 < argc)
      d = atof(argv[++i]);
  char text[64];
  snprintf(text, sizeof text, "%g", d);
  bm_spacing *spacing = NULL;
  OK(bm_spacing_from_expr(text, &spacing));

  /* ---- the box ---- */
  bm_model *box = box_model(1.0, 0.8, 0.6);
  double vbox = check_volume_mesh("box", box, spacing);
  CHECK(fabs(vbox - 0.48) < 1e-12, "box: volume %.15g, exact 0.48", vbox);
  bm_model_free(box);

  /* ---- the ball ---- */
  bm_model *ball = NULL;
  OK(bm_model_new(&ball));
  bm_surface_callbacks scb = {sphere_eval, NULL, NULL};
  double poles[6] = {0, 0, -1, 0, 0, 1};
  bm_surface_info info;
  memset(&info, 0, sizeof info);
  info.u0 = 0, info.u1 = 2 * M_PI, info.period_u = 2 * M_PI;
  info.v0 = -M_PI / 2, info.v1 = M_PI / 2;
  info.singular_points = poles, info.singular_count = 2;
  uint32_t sf, vol;
  OK(bm_model_add_surface_face(ball, &scb, NULL, &info, NULL, NULL, 0, &sf));
  ball_t bu = {0, 0};
  bm_volume_callbacks vcb = {ball_contains};
  OK(bm_model_add_volume(ball, &sf, 1, &vcb, &bu, &vol));
  double vball = check_volume_mesh("ball", ball, spacing);
  /* the inscribed polyhedron loses at most the chord segment: each
     triangle of circumradius <= ~d lies within d^2/2 of the sphere */
  double exact = 4.0 / 3.0 * M_PI;
  CHECK(vball < exact && vball > exact * (1.0 - 3.0 * d * d / 2.0),
        "ball: volume %.9f outside (%.9f, %.9f)", vball,
        exact * (1.0 - 3.0 * d * d / 2.0), exact);
  CHECK(bu.calls > 0, "ball: the contains callback was never called");
  printf("ball: contains called %ld times\n", bu.calls);

  /* a contains callback that fails stops meshing with BM_ERR_CALLBACK */
  bu.fail = 1;
  bm_mesh *mesh = NULL;
  bm_result rc = bm_mesh_generate(ball, spacing, 3, 0, &mesh);
  const char *msg = bm_last_error_message();
  CHECK(rc == BM_ERR_CALLBACK &&
            strstr(msg, "callback 'contains' of volume 0") != NULL &&
            strstr(msg, "returned 5") != NULL && mesh == NULL,
        "failing contains: %s \"%s\"", bm_result_name(rc), msg);
  printf("failing contains: %s \"%s\"\n", bm_result_name(rc), msg);
  bm_model_free(ball);
  bm_spacing_free(spacing);

  if (failures) {
    fprintf(stderr, "%d check(s) failed\n", failures);
    return 1;
  }
  printf("all checks passed\n");
  return 0;
}
