/*
 * A host program that describes two parts to bubblemesh through the C ABI
 * and checks the meshes it gets back:
 *
 *  - an analytic torus (R = 1, r = 0.4): one face on a surface periodic in u
 *    and v, with no boundary loops (a closed surface);
 *  - a plate with a hole: the square [-1, 1]^2 in the plane z = -0.8 with a
 *    circular hole of radius 0.5, its five edges (four lines, one circle)
 *    given as curve callbacks.
 *
 * Both are faces of one model, meshed in one call with a spacing callback
 * (d = 0.1). Checks:
 *  - every triangle's source entity is one of the two faces;
 *  - torus: every edge in exactly two triangles, each direction once (a
 *    closed, consistently oriented surface), Euler characteristic 0,
 *    normals outward, nodes on the torus, area 4 pi^2 R r within the chord
 *    bound and within 1 %;
 *  - plate: nodes in the plane, normals +z, the edges used by one triangle
 *    are exactly the boundary segments, area between the exact area and the
 *    exact area plus the circular segments cut off by the hole's chords.
 *
 * Usage: torus_plate [-d SPACING] [OUT.msh]  (spacing default 0.1; writes
 * the mesh to OUT.msh when given).
 * Exit status 0 when every check passes, 1 otherwise.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bubblemesh.h"
#include "check.h"
#include "circle.h"

static const double R_MAJOR = 1.0, R_MINOR = 0.4;
static const double PLATE_Z = -0.8, HALF = 1.0, HOLE_R = 0.5;
static double SPACING = 0.1;

/* ---- geometry callbacks ------------------------------------------------ */

typedef struct {
  double a[3], b[3];
} line_t;

static int line_eval(void *user, double t, int order, double *out) {
  const line_t *l = (const line_t *)user;
  for (int k = 0; k < 3; k++) {
    double d = l->b[k] - l->a[k];
    out[k] = order == 0 ? l->a[k] + t * d : order == 1 ? d : 0.0;
  }
  return 0;
}


typedef struct {
  double R, r;
  long evals;
} torus_t;

/* S(u,v) = ((R + r cos v) cos u, (R + r cos v) sin u, r sin v) */
static int torus_eval(void *user, double u, double v, int order, double *o) {
  torus_t *T = (torus_t *)user;
  double cu = cos(u), su = sin(u), cv = cos(v), sv = sin(v);
  double w = T->R + T->r * cv;
  T->evals++;
  o[0] = w * cu, o[1] = w * su, o[2] = T->r * sv;
  if (order >= 1) {
    o[3] = -w * su, o[4] = w * cu, o[5] = 0.0;                 /* Su */
    o[6] = -T->r * sv * cu, o[7] = -T->r * sv * su, o[8] = T->r * cv; /* Sv */
  }
  if (order >= 2) {
    o[9] = -w * cu, o[10] = -w * su, o[11] = 0.0;              /* Suu */
    o[12] = T->r * sv * su, o[13] = -T->r * sv * cu, o[14] = 0.0; /* Suv */
    o[15] = -T->r * cv * cu, o[16] = -T->r * cv * su, o[17] = -T->r * sv; /* Svv */
  }
  return 0;
}

static int torus_inverse(void *user, const double *p, const double *hint,
                         double *uv) {
  const torus_t *T = (const torus_t *)user;
  (void)hint;
  double u = atan2(p[1], p[0]);
  double rho = hypot(p[0], p[1]) - T->R;
  double v = atan2(p[2], rho);
  uv[0] = u < 0 ? u + 2 * M_PI : u;
  uv[1] = v < 0 ? v + 2 * M_PI : v;
  return 0;
}

typedef struct {
  double d;
  long calls;
} spacing_t;

static int spacing_cb(void *user, double x, double y, double z, int dim,
                      uint32_t id, double u, double v, double *out) {
  spacing_t *s = (spacing_t *)user;
  (void)x, (void)y, (void)z, (void)dim, (void)id, (void)u, (void)v;
  s->calls++;
  *out = s->d;
  return 0;
}

/* ---- mesh checks -------------------------------------------------------- */

typedef struct {
  uint32_t a, b; /* directed a -> b */
} dedge_t;

static int cmp_undirected(const void *x, const void *y) {
  const dedge_t *p = x, *q = y;
  uint32_t pa = p->a < p->b ? p->a : p->b, pb = p->a < p->b ? p->b : p->a;
  uint32_t qa = q->a < q->b ? q->a : q->b, qb = q->a < q->b ? q->b : q->a;
  if (pa != qa)
    return pa < qa ? -1 : 1;
  if (pb != qb)
    return pb < qb ? -1 : 1;
  return 0;
}

static void sub(const double *a, const double *b, double *o) {
  o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}
static void cross(const double *a, const double *b, double *o) {
  o[0] = a[1] * b[2] - a[2] * b[1];
  o[1] = a[2] * b[0] - a[0] * b[2];
  o[2] = a[0] * b[1] - a[1] * b[0];
}
static double norm(const double *a) {
  return sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
}

/* The triangles of one face, with their edges counted. */
typedef struct {
  size_t ntri;
  uint32_t *tri; /* 3 per triangle */
  size_t nedge;  /* unique undirected edges */
  size_t boundary_edges, manifold_edges, bad_edges, misoriented;
  dedge_t *boundary; /* the edges used once */
  size_t nodes;      /* distinct nodes */
} face_mesh_t;

static face_mesh_t face_mesh(const uint32_t *tris, const bm_entity *ent,
                             size_t ntri_all, uint32_t face, size_t nnodes) {
  face_mesh_t f;
  memset(&f, 0, sizeof f);
  f.tri = malloc(3 * ntri_all * sizeof(uint32_t) + 1);
  for (size_t t = 0; t < ntri_all; t++)
    if (ent[t].dim == 2 && ent[t].id == face) {
      memcpy(f.tri + 3 * f.ntri, tris + 3 * t, 3 * sizeof(uint32_t));
      f.ntri++;
    }
  dedge_t *e = malloc(3 * f.ntri * sizeof(dedge_t) + 1);
  for (size_t t = 0; t < f.ntri; t++)
    for (int k = 0; k < 3; k++) {
      e[3 * t + k].a = f.tri[3 * t + k];
      e[3 * t + k].b = f.tri[3 * t + (k + 1) % 3];
    }
  size_t ne = 3 * f.ntri;
  qsort(e, ne, sizeof(dedge_t), cmp_undirected);
  f.boundary = malloc(ne * sizeof(dedge_t) + 1);
  for (size_t i = 0; i < ne;) {
    size_t j = i + 1;
    while (j < ne && cmp_undirected(&e[i], &e[j]) == 0)
      j++;
    size_t n = j - i;
    f.nedge++;
    if (n == 1)
      f.boundary[f.boundary_edges++] = e[i];
    else if (n == 2) {
      f.manifold_edges++;
      if (e[i].a == e[i + 1].a) /* same direction twice */
        f.misoriented++;
    } else
      f.bad_edges++;
    i = j;
  }
  free(e);
  char *seen = calloc(nnodes + 1, 1);
  for (size_t k = 0; k < 3 * f.ntri; k++)
    if (!seen[f.tri[k]]) {
      seen[f.tri[k]] = 1;
      f.nodes++;
    }
  free(seen);
  return f;
}

static void face_mesh_free(face_mesh_t *f) {
  free(f->tri);
  free(f->boundary);
}

int main(int argc, char **argv) {
  const char *out_path = NULL;
  for (int i = 1; i < argc; i++) {
    if (strcmp(argv[i], "-d") == 0 && i + 1 < argc)
      SPACING = atof(argv[++i]);
    else
      out_path = argv[i];
  }
  printf("bubblemesh %s, spacing %g\n", bm_version(), SPACING);

  /* ---- the model ---- */
  bm_model *model = NULL;
  OK(bm_model_new(&model));

  /* face 0: the torus */
  torus_t torus = {R_MAJOR, R_MINOR, 0};
  bm_surface_callbacks tcb = {torus_eval, NULL, torus_inverse};
  bm_surface_info tinfo;
  memset(&tinfo, 0, sizeof tinfo);
  tinfo.u0 = 0, tinfo.u1 = 2 * M_PI, tinfo.v0 = 0, tinfo.v1 = 2 * M_PI;
  tinfo.period_u = 2 * M_PI, tinfo.period_v = 2 * M_PI;
  uint32_t torus_face;
  OK(bm_model_add_surface_face(model, &tcb, &torus, &tinfo, NULL, NULL, 0,
                               &torus_face));
  OK(bm_model_set_name(model, 2, torus_face, "torus"));

  /* face 1: the plate; corners counter-clockwise seen from +z */
  double corner[4][3] = {{-HALF, -HALF, PLATE_Z},
                         {HALF, -HALF, PLATE_Z},
                         {HALF, HALF, PLATE_Z},
                         {-HALF, HALF, PLATE_Z}};
  uint32_t cv[4];
  for (int k = 0; k < 4; k++)
    OK(bm_model_add_vertex(model, corner[k][0], corner[k][1], corner[k][2],
                           &cv[k]));
  line_t lines[4];
  bm_curve_callbacks line_cb = {line_eval};
  bm_edge_use uses[5];
  for (int k = 0; k < 4; k++) {
    memcpy(lines[k].a, corner[k], sizeof corner[k]);
    memcpy(lines[k].b, corner[(k + 1) % 4], sizeof corner[k]);
    uint32_t e;
    OK(bm_model_add_curve(model, &line_cb, &lines[k], 0.0, 1.0, cv[k],
                          cv[(k + 1) % 4], &e));
    uses[k].edge = e, uses[k].forward = 1;
  }
  circle_t hole = {{0.0, 0.0, PLATE_Z}, HOLE_R};
  bm_curve_callbacks circle_cb = {circle_eval};
  uint32_t hv, hole_edge;
  OK(bm_model_add_vertex(model, HOLE_R, 0.0, PLATE_Z, &hv));
  OK(bm_model_add_curve(model, &circle_cb, &hole, 0.0, 2 * M_PI, hv, hv,
                        &hole_edge));
  uses[4].edge = hole_edge, uses[4].forward = 0; /* holes run clockwise */
  size_t loop_lengths[2] = {4, 1};
  double origin[3] = {0, 0, PLATE_Z}, normal[3] = {0, 0, 1};
  uint32_t plate_face;
  OK(bm_model_add_plane_face(model, origin, normal, uses, loop_lengths, 2,
                             &plate_face));
  OK(bm_model_set_name(model, 2, plate_face, "plate"));

  /* ---- mesh ---- */
  spacing_t sp = {SPACING, 0};
  bm_spacing *spacing = NULL;
  OK(bm_spacing_from_callback(spacing_cb, &sp, &spacing));
  bm_mesh *mesh = NULL;
  OK(bm_mesh_generate(model, spacing, -1, 0, &mesh));
  printf("callbacks: %ld torus evaluations, %ld spacing queries\n",
         torus.evals, sp.calls);

  size_t nn, nl, nt, ntet;
  OK(bm_mesh_node_count(mesh, &nn));
  OK(bm_mesh_line_count(mesh, &nl));
  OK(bm_mesh_triangle_count(mesh, &nt));
  OK(bm_mesh_tetrahedron_count(mesh, &ntet));
  printf("mesh: %zu nodes, %zu lines, %zu triangles, %zu tetrahedra\n", nn,
         nl, nt, ntet);
  CHECK(nn > 0 && nt > 0 && nl > 0, "empty mesh");
  CHECK(ntet == 0, "tetrahedra in a surface mesh");

  double *xyz = malloc(3 * nn * sizeof(double));
  uint32_t *tri = malloc(3 * nt * sizeof(uint32_t));
  bm_entity *tri_ent = malloc(nt * sizeof(bm_entity));
  uint32_t *lin = malloc(2 * nl * sizeof(uint32_t));
  bm_entity *lin_ent = malloc(nl * sizeof(bm_entity));
  bm_entity *node_ent = malloc(nn * sizeof(bm_entity));
  OK(bm_mesh_nodes(mesh, xyz, 3 * nn));
  OK(bm_mesh_triangles(mesh, tri, 3 * nt));
  OK(bm_mesh_triangle_entities(mesh, tri_ent, nt));
  OK(bm_mesh_lines(mesh, lin, 2 * nl));
  OK(bm_mesh_line_entities(mesh, lin_ent, nl));
  OK(bm_mesh_node_entities(mesh, node_ent, nn));
  /* a short buffer is refused, not overrun */
  CHECK(bm_mesh_nodes(mesh, xyz, 3 * nn - 1) == BM_ERR_RANGE,
        "short buffer accepted");

  for (size_t t = 0; t < nt; t++) {
    CHECK(tri_ent[t].dim == 2 &&
              (tri_ent[t].id == torus_face || tri_ent[t].id == plate_face),
          "triangle %zu has entity (%d, %u)", t, tri_ent[t].dim,
          tri_ent[t].id);
    for (int k = 0; k < 3; k++)
      CHECK(tri[3 * t + k] < nn, "triangle %zu: node index out of range", t);
  }
  for (size_t n = 0; n < nn; n++)
    CHECK(node_ent[n].dim >= 0 && node_ent[n].dim <= 2, "node entity dim");

  /* ---- torus ---- */
  face_mesh_t T = face_mesh(tri, tri_ent, nt, torus_face, nn);
  long euler = (long)T.nodes - (long)T.nedge + (long)T.ntri;
  printf("torus: %zu triangles, %zu nodes, %zu edges (%zu boundary, %zu "
         "non-manifold, %zu misoriented), Euler characteristic %ld\n",
         T.ntri, T.nodes, T.nedge, T.boundary_edges, T.bad_edges,
         T.misoriented, euler);
  CHECK(T.ntri > 100, "too few torus triangles");
  CHECK(T.boundary_edges == 0 && T.bad_edges == 0,
        "the torus is not closed: %zu edges in one triangle, %zu in more "
        "than two",
        T.boundary_edges, T.bad_edges);
  CHECK(T.misoriented == 0, "%zu torus edges used twice in one direction",
        T.misoriented);
  CHECK(euler == 0, "torus Euler characteristic %ld, expected 0", euler);
  double area = 0, bound = 0, worst_off = 0;
  size_t inward = 0;
  for (size_t t = 0; t < T.ntri; t++) {
    const double *p[3];
    for (int k = 0; k < 3; k++)
      p[k] = xyz + 3 * T.tri[3 * t + k];
    double e1[3], e2[3], e3[3], c[3];
    sub(p[1], p[0], e1), sub(p[2], p[0], e2), sub(p[2], p[1], e3);
    cross(e1, e2, c);
    double a = 0.5 * norm(c);
    area += a;
    /* chord bound: a flat triangle with circumradius rc inscribed in a
       surface whose principal curvature radii are >= r leaves out at most
       the fraction 1 - cos(theta) ~ (rc/r)^2 / 2 of the patch's area */
    double rc = norm(e1) * norm(e2) * norm(e3) / (4 * a);
    bound += a * (rc / R_MINOR) * (rc / R_MINOR) / 2;
    /* outward: the normal points away from the tube's centre line */
    double m[3] = {(p[0][0] + p[1][0] + p[2][0]) / 3,
                   (p[0][1] + p[1][1] + p[2][1]) / 3,
                   (p[0][2] + p[1][2] + p[2][2]) / 3};
    double rho = hypot(m[0], m[1]);
    double axis[3] = {R_MAJOR * m[0] / rho, R_MAJOR * m[1] / rho, 0};
    double out[3];
    sub(m, axis, out);
    if (c[0] * out[0] + c[1] * out[1] + c[2] * out[2] <= 0)
      inward++;
  }
  for (size_t n = 0; n < nn; n++)
    if (node_ent[n].dim == 2 && node_ent[n].id == torus_face) {
      const double *q = xyz + 3 * n;
      double off = fabs(hypot(hypot(q[0], q[1]) - R_MAJOR, q[2]) - R_MINOR);
      if (off > worst_off)
        worst_off = off;
    }
  double exact = 4 * M_PI * M_PI * R_MAJOR * R_MINOR;
  double rel = (area - exact) / exact;
  printf("torus area %.6f, exact %.6f, relative error %.3e, chord bound "
         "%.3e; worst node off the surface %.1e\n",
         area, exact, rel, bound / exact, worst_off);
  CHECK(area <= exact * (1 + 1e-9), "inscribed torus mesh larger than the "
                                    "torus");
  CHECK(exact - area <= bound, "torus area deficit %.3e exceeds the chord "
                               "bound %.3e",
        exact - area, bound);
  CHECK(fabs(rel) < 0.01, "torus area off by %.2f %%", 100 * rel);
  CHECK(inward == 0, "%zu torus triangles face inward", inward);
  CHECK(worst_off < 1e-9, "torus node %.1e off the surface", worst_off);

  /* ---- plate ---- */
  face_mesh_t P = face_mesh(tri, tri_ent, nt, plate_face, nn);
  double parea = 0;
  size_t down = 0;
  for (size_t t = 0; t < P.ntri; t++) {
    const double *p[3];
    for (int k = 0; k < 3; k++)
      p[k] = xyz + 3 * P.tri[3 * t + k];
    double e1[3], e2[3], c[3];
    sub(p[1], p[0], e1), sub(p[2], p[0], e2);
    cross(e1, e2, c);
    parea += 0.5 * norm(c);
    if (c[2] <= 0)
      down++;
  }
  double caps = 0, worst_plane = 0;
  size_t hole_segments = 0, outer_segments = 0;
  for (size_t l = 0; l < nl; l++) {
    const double *a = xyz + 3 * lin[2 * l], *b = xyz + 3 * lin[2 * l + 1];
    if (lin_ent[l].dim == 1 && lin_ent[l].id == hole_edge) {
      double ab[3];
      sub(b, a, ab);
      double theta = 2 * asin(norm(ab) / (2 * HOLE_R));
      caps += HOLE_R * HOLE_R / 2 * (theta - sin(theta));
      hole_segments++;
    } else {
      outer_segments++;
    }
  }
  for (size_t k = 0; k < 3 * P.ntri; k++) {
    double off = fabs(xyz[3 * P.tri[k] + 2] - PLATE_Z);
    if (off > worst_plane)
      worst_plane = off;
  }
  double pexact = 4 * HALF * HALF - M_PI * HOLE_R * HOLE_R;
  printf("plate: %zu triangles, %zu boundary edges (%zu + %zu segments); "
         "area %.6f, exact %.6f, chord bound %.3e\n",
         P.ntri, P.boundary_edges, outer_segments, hole_segments, parea,
         pexact, caps);
  CHECK(P.ntri > 50, "too few plate triangles");
  CHECK(P.bad_edges == 0 && P.misoriented == 0, "plate mesh not manifold");
  CHECK(P.boundary_edges == nl,
        "plate: %zu edges in one triangle but %zu boundary segments",
        P.boundary_edges, nl);
  /* each edge in one triangle is a boundary segment */
  for (size_t i = 0; i < P.boundary_edges; i++) {
    int found = 0;
    for (size_t l = 0; l < nl && !found; l++)
      found = (lin[2 * l] == P.boundary[i].a && lin[2 * l + 1] == P.boundary[i].b) ||
              (lin[2 * l] == P.boundary[i].b && lin[2 * l + 1] == P.boundary[i].a);
    CHECK(found, "plate edge %u-%u is on no boundary segment",
          P.boundary[i].a, P.boundary[i].b);
  }
  CHECK(down == 0, "%zu plate triangles face -z", down);
  CHECK(worst_plane < 1e-12, "plate node %.1e off its plane", worst_plane);
  CHECK(parea >= pexact - 1e-12 && parea <= pexact + caps * (1 + 1e-9) + 1e-12,
        "plate area %.9f outside [%.9f, %.9f]", parea, pexact, pexact + caps);

  /* ---- write ---- */
  if (out_path) {
    OK(bm_mesh_write(mesh, out_path));
    printf("wrote %s\n", out_path);
  }
  size_t json_len = 0;
  OK(bm_mesh_report_json(mesh, NULL, 0, &json_len));
  char *json = malloc(json_len + 1);
  OK(bm_mesh_report_json(mesh, json, json_len + 1, &json_len));
  CHECK(strstr(json, "\"triangles\"") != NULL, "report without triangles");
  free(json);

  face_mesh_free(&T);
  face_mesh_free(&P);
  free(xyz), free(tri), free(tri_ent), free(lin), free(lin_ent), free(node_ent);
  bm_mesh_free(mesh);
  bm_spacing_free(spacing);
  bm_model_free(model);

  if (failures) {
    fprintf(stderr, "%d check(s) failed\n", failures);
    return 1;
  }
  printf("all checks passed\n");
  return 0;
}
