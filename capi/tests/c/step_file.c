/*
 * The STEP shortcut, bm_mesh_step_file: a CadQuery-exported unit cube
 * (fixtures/step/cube.step) meshed into its surface and into tetrahedra,
 * and files that are not good STEP refused with the right code and a
 * message naming the file (and the entity where one is at fault).
 *
 * Checks:
 *  - surface (dim -1, the default for a solid: its faces): no
 *    tetrahedra; triangles on the file's 6 faces; every edge in exactly
 *    two triangles, once in each direction (closed, consistently oriented
 *    outward); the enclosed volume is 1 (planar faces: exact to 1e-9);
 *  - dim 3: every tetrahedron in volume 0 with positive volume; the
 *    tetrahedra fill the volume the boundary triangles enclose (1e-9);
 *  - a missing file: BM_ERR_IO; a file that is not STEP, a truncated one,
 *    one with an entity the reader cannot convert: BM_ERR_FORMAT with the
 *    file and the reason (and `#id TYPE`); dim 3 on a file without a solid:
 *    BM_ERR_RANGE; NULL arguments: BM_ERR_NULL.
 *
 * Usage: step_file FIXTURE_DIR SCRATCH_DIR. FIXTURE_DIR holds cube.step and
 * plate_two_holes.step; the bad files are written into SCRATCH_DIR.
 * Exit status 0 when every check passes, 1 otherwise.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bubblemesh.h"
#include "check.h"

/* `call` must return `code` with a message containing `n1` and `n2`, and
   leave *out NULL */

static void sub(const double *a, const double *b, double *o) {
  o[0] = a[0] - b[0], o[1] = a[1] - b[1], o[2] = a[2] - b[2];
}
static double det3(const double *a, const double *b, const double *c) {
  return a[0] * (b[1] * c[2] - b[2] * c[1]) -
         a[1] * (b[0] * c[2] - b[2] * c[0]) +
         a[2] * (b[0] * c[1] - b[1] * c[0]);
}

typedef struct {
  uint32_t a, b;
} dedge_t;

static int cmp_dedge(const void *x, const void *y) {
  const dedge_t *p = x, *q = y;
  if (p->a != q->a)
    return p->a < q->a ? -1 : 1;
  if (p->b != q->b)
    return p->b < q->b ? -1 : 1;
  return 0;
}

/* Every directed edge once and its reverse once: closed and consistently
   oriented. Returns the number of offending edges. */
static size_t open_or_misoriented(const uint32_t *tri, size_t nt) {
  dedge_t *e = malloc(3 * nt * sizeof(dedge_t) + 1);
  for (size_t t = 0; t < nt; t++)
    for (int k = 0; k < 3; k++)
      e[3 * t + k].a = tri[3 * t + k], e[3 * t + k].b = tri[3 * t + (k + 1) % 3];
  qsort(e, 3 * nt, sizeof(dedge_t), cmp_dedge);
  size_t bad = 0;
  for (size_t i = 0; i < 3 * nt; i++) {
    if (i + 1 < 3 * nt && cmp_dedge(&e[i], &e[i + 1]) == 0) {
      bad++; /* a directed edge twice: misoriented or non-manifold */
      continue;
    }
    dedge_t r = {e[i].b, e[i].a};
    if (bsearch(&r, e, 3 * nt, sizeof(dedge_t), cmp_dedge) == NULL)
      bad++; /* a boundary edge: not closed */
  }
  free(e);
  return bad;
}

static void write_file(const char *path, const char *text, size_t len) {
  FILE *f = fopen(path, "wb");
  if (!f || fwrite(text, 1, len, f) != len) {
    fprintf(stderr, "cannot write %s\n", path);
    exit(1);
  }
  fclose(f);
}

static char *read_file(const char *path, size_t *len) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    fprintf(stderr, "cannot read %s\n", path);
    exit(1);
  }
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *buf = malloc((size_t)n + 1);
  if (fread(buf, 1, (size_t)n, f) != (size_t)n) {
    fprintf(stderr, "cannot read %s\n", path);
    exit(1);
  }
  fclose(f);
  buf[n] = 0;
  *len = (size_t)n;
  return buf;
}

static const char *STEP_HEAD =
    "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('t'),'2;1');\n"
    "FILE_NAME('t','2000-01-01T00:00:00',('A'),('O'),'p','s','U');\n"
    "FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));\n"
    "ENDSEC;\nDATA;\n";
/* a face on an offset of an offset surface, which the reader does not convert */
static const char *STEP_OFFSET =
    "#1 = ADVANCED_FACE('',(#6),#2,.T.);\n#6 = FACE_BOUND('',#7,.T.);\n"
    "#7 = VERTEX_LOOP('',#8);\n#8 = VERTEX_POINT('',#5);\n"
    "#2 = OFFSET_SURFACE('',#3,1.,.F.);\n"
    "#3 = OFFSET_SURFACE('',#9,1.,.F.);\n#9 = PLANE('',#4);\n"
    "#4 = AXIS2_PLACEMENT_3D('',#5,$,$);\n"
    "#5 = CARTESIAN_POINT('',(0.,0.,0.));\nENDSEC;\nEND-ISO-10303-21;\n";

int main(int argc, char **argv) {
  if (argc != 3) {
    fprintf(stderr, "usage: step_file FIXTURE_DIR SCRATCH_DIR\n");
    return 2;
  }
  char cube[4096], sheet[4096], path[4096];
  snprintf(cube, sizeof cube, "%s/cube.step", argv[1]);
  snprintf(sheet, sizeof sheet, "%s/plate_two_holes.step", argv[1]);
  bm_spacing *spacing = NULL;
  OK(bm_spacing_from_expr("0.25", &spacing));

  /* ---- the cube's surface ---- */
  bm_mesh *mesh = NULL;
  OK(bm_mesh_step_file(cube, spacing, -1, 0, &mesh));
  size_t nn, nt, ntet;
  OK(bm_mesh_node_count(mesh, &nn));
  OK(bm_mesh_triangle_count(mesh, &nt));
  OK(bm_mesh_tetrahedron_count(mesh, &ntet));
  double *xyz = malloc(3 * nn * sizeof(double));
  uint32_t *tri = malloc(3 * nt * sizeof(uint32_t) + 1);
  bm_entity *ent = malloc(nt * sizeof(bm_entity) + 1);
  OK(bm_mesh_nodes(mesh, xyz, 3 * nn));
  OK(bm_mesh_triangles(mesh, tri, 3 * nt));
  OK(bm_mesh_triangle_entities(mesh, ent, nt));
  CHECK(ntet == 0 && nt >= 6 * 8, "cube surface: %zu triangles, %zu tets",
        nt, ntet);
  int faces_seen[6] = {0};
  size_t off_face = 0;
  for (size_t t = 0; t < nt; t++) {
    if (ent[t].dim == 2 && ent[t].id < 6)
      faces_seen[ent[t].id] = 1;
    else
      off_face++;
  }
  int nfaces = 0;
  for (int f = 0; f < 6; f++)
    nfaces += faces_seen[f];
  CHECK(off_face == 0 && nfaces == 6,
        "cube surface: triangles on %d of 6 faces, %zu elsewhere", nfaces,
        off_face);
  size_t bad = open_or_misoriented(tri, nt);
  CHECK(bad == 0, "cube surface: %zu edges open or misoriented", bad);
  double v6 = 0.0, c[3] = {0.5, 0.5, 0.5};
  for (size_t t = 0; t < nt; t++) {
    double a[3], b[3], d[3];
    sub(xyz + 3 * tri[3 * t], c, a);
    sub(xyz + 3 * tri[3 * t + 1], c, b);
    sub(xyz + 3 * tri[3 * t + 2], c, d);
    v6 += det3(a, b, d);
  }
  CHECK(fabs(v6 / 6.0 - 1.0) < 1e-9, "cube surface encloses %.12f, not 1",
        v6 / 6.0);
  printf("cube.step surface: %zu nodes, %zu triangles, closed, encloses "
         "%.12f\n",
         nn, nt, v6 / 6.0);
  free(xyz), free(tri), free(ent);
  bm_mesh_free(mesh);

  /* ---- the cube's volume ---- */
  mesh = NULL;
  OK(bm_mesh_step_file(cube, spacing, 3, 0, &mesh));
  OK(bm_mesh_node_count(mesh, &nn));
  OK(bm_mesh_tetrahedron_count(mesh, &ntet));
  xyz = malloc(3 * nn * sizeof(double));
  uint32_t *tet = malloc(4 * ntet * sizeof(uint32_t) + 1);
  bm_entity *tent = malloc(ntet * sizeof(bm_entity) + 1);
  OK(bm_mesh_nodes(mesh, xyz, 3 * nn));
  OK(bm_mesh_tetrahedra(mesh, tet, 4 * ntet));
  OK(bm_mesh_tetrahedron_entities(mesh, tent, ntet));
  double sum = 0.0, vmin = INFINITY;
  size_t wrong = 0;
  for (size_t t = 0; t < ntet; t++) {
    const uint32_t *q = tet + 4 * t;
    double a[3], b[3], d[3];
    sub(xyz + 3 * q[1], xyz + 3 * q[0], a);
    sub(xyz + 3 * q[2], xyz + 3 * q[0], b);
    sub(xyz + 3 * q[3], xyz + 3 * q[0], d);
    double v = det3(a, b, d) / 6.0;
    sum += v;
    vmin = v < vmin ? v : vmin;
    if (tent[t].dim != 3 || tent[t].id != 0)
      wrong++;
  }
  CHECK(ntet > 20 && vmin > 0.0 && wrong == 0,
        "cube volume: %zu tets, smallest %g, %zu not in volume 0", ntet, vmin,
        wrong);
  CHECK(fabs(sum - 1.0) < 1e-9, "cube tetrahedra fill %.12f, not 1", sum);
  printf("cube.step volume: %zu nodes, %zu tetrahedra, volume %.12f, "
         "smallest %.3e\n",
         nn, ntet, sum, vmin);
  free(xyz), free(tet), free(tent);
  bm_mesh_free(mesh);

  /* ---- files that are not good STEP ---- */
  mesh = NULL;
  snprintf(path, sizeof path, "%s/no_such_part.step", argv[2]);
  EXPECT(bm_mesh_step_file(path, spacing, -1, 0, &mesh), mesh, BM_ERR_IO,
         "no_such_part.step", "cannot read the STEP file");

  snprintf(path, sizeof path, "%s/garbage.step", argv[2]);
  const char *garbage = "solid cube\n  facet normal 0 0 1\nendsolid\n";
  write_file(path, garbage, strlen(garbage));
  EXPECT(bm_mesh_step_file(path, spacing, -1, 0, &mesh), mesh, BM_ERR_FORMAT,
         "garbage.step", "not a STEP file");

  size_t len = 0;
  char *text = read_file(cube, &len);
  snprintf(path, sizeof path, "%s/truncated.step", argv[2]);
  write_file(path, text, len / 2);
  EXPECT(bm_mesh_step_file(path, spacing, -1, 0, &mesh), mesh, BM_ERR_FORMAT,
         "truncated.step", "truncated");
  free(text);

  snprintf(path, sizeof path, "%s/offset.step", argv[2]);
  char body[2048];
  snprintf(body, sizeof body, "%s%s", STEP_HEAD, STEP_OFFSET);
  write_file(path, body, strlen(body));
  EXPECT(bm_mesh_step_file(path, spacing, -1, 0, &mesh), mesh, BM_ERR_FORMAT,
         "offset.step: #2 OFFSET_SURFACE", "unsupported");

  /* a syntax error inside an otherwise well-framed file */
  snprintf(path, sizeof path, "%s/syntax.step", argv[2]);
  snprintf(body, sizeof body, "%s#1 = CARTESIAN_POINT('',(0.,0.,;\n"
                              "ENDSEC;\nEND-ISO-10303-21;\n",
           STEP_HEAD);
  write_file(path, body, strlen(body));
  EXPECT(bm_mesh_step_file(path, spacing, -1, 0, &mesh), mesh, BM_ERR_FORMAT,
         "syntax.step", "syntax error");

  EXPECT(bm_mesh_step_file(sheet, spacing, 3, 0, &mesh), mesh, BM_ERR_RANGE,
         "dim = 3", "plate_two_holes.step");
  EXPECT(bm_mesh_step_file(NULL, spacing, -1, 0, &mesh), mesh, BM_ERR_NULL,
         "'path'", "NULL");
  EXPECT(bm_mesh_step_file(cube, spacing, 9, 0, &mesh), mesh, BM_ERR_RANGE,
         "dim = 9", "");
  bm_options opts;
  OK(bm_options_init(&opts));
  EXPECT(bm_mesh_step_file_ex(cube, spacing, NULL, &mesh), mesh, BM_ERR_NULL,
         "'options'", "");

  bm_spacing_free(spacing);
  if (failures) {
    fprintf(stderr, "%d check(s) failed\n", failures);
    return 1;
  }
  printf("all checks passed\n");
  return 0;
}
