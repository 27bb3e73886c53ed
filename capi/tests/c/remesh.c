/*
 * Re-meshing through the C ABI (thesis §4.8; the command line's
 * `mesh --save-state` and `remesh`): a host meshes a part, keeps the
 * packing as a state file, changes the part a little and meshes it again
 * from the state.
 *
 * The part: the plate [0, 2] x [0, 1] in z = 0 (four built-in lines) with
 * a hole of radius 0.2 at (HX, 0.5), the hole's circle a curve callback.
 * Meshed with HX = 0.5, its state saved, loaded back (and saved again: the
 * same bytes), then the hole moved to HX = 0.52 and the plate re-meshed
 * from the loaded state:
 *
 *  - locally, in the sphere of radius 0.25 around (0.51, 0.5): triangles;
 *    the report's remesh section matches all 6 entities and counts kept
 *    nodes; every old node farther than 2 spacings from the region is a
 *    node of the new mesh bit for bit (the coordinate arrays compared),
 *    and so says the report (far_kept = far_from_region); some old nodes
 *    near the hole are gone (the comparison is not vacuous);
 *  - continuously (no region): every old node farther than 6 spacings
 *    from the hole's footprint is kept bit for bit;
 *  - the state of the re-meshed mesh saves and loads (a chain of runs).
 *
 * Then the STEP variant on FIXTURES/cube.step: meshed with the default
 * spacing, re-meshed from its state in a box at one corner; old nodes
 * farther than 2 spacings from the box kept bit for bit.
 *
 * Bad inputs give their codes, a message naming the cause, and no handle:
 * a missing state file (BM_ERR_IO), a truncated one written here, one of
 * version 9, a corrupted one, a mesh file (BM_ERR_FORMAT, naming the
 * file); a state of another model (BM_ERR_STATE); a region selecting
 * nothing, a region that does not parse, a face that does not exist
 * (BM_ERR_RANGE); fast (BM_ERR_UNSUPPORTED); NULL and wrong handles; a
 * state saved into a missing directory (BM_ERR_IO).
 *
 * Usage: remesh FIXTURES_DIR OUT_DIR [SPACING [CUBE_SPACING]]  (spacing
 * default 0.04; the cube's default NULL, 1/40 of its diagonal).
 * Exit status 0 when every check passes, 1 otherwise.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bubblemesh.h"
#include "check.h"
#include "circle.h"

static double D = 0.04;
static const double HOLE_R = 0.2;

/* ---- the plate with a hole -------------------------------------------- */


/* The plate with its hole at (hx, 0.5); `hole` must outlive the model. */
static bm_model *plate(double hx, circle_t *hole) {
  bm_model *m = NULL;
  OK(bm_model_new(&m));
  double corner[4][2] = {{0, 0}, {2, 0}, {2, 1}, {0, 1}};
  uint32_t v[4];
  for (int k = 0; k < 4; k++)
    OK(bm_model_add_vertex(m, corner[k][0], corner[k][1], 0.0, &v[k]));
  bm_edge_use uses[5];
  for (int k = 0; k < 4; k++) {
    OK(bm_model_add_line(m, v[k], v[(k + 1) % 4], &uses[k].edge));
    uses[k].forward = 1;
  }
  hole->c[0] = hx, hole->c[1] = 0.5, hole->c[2] = 0.0, hole->r = HOLE_R;
  bm_curve_callbacks cb = {circle_eval};
  uint32_t hv;
  OK(bm_model_add_vertex(m, hx + HOLE_R, 0.5, 0.0, &hv));
  OK(bm_model_add_curve(m, &cb, hole, 0.0, 2 * M_PI, hv, hv, &uses[4].edge));
  uses[4].forward = 0; /* holes run clockwise */
  size_t loops[2] = {4, 1};
  double origin[3] = {0, 0, 0}, normal[3] = {0, 0, 1};
  uint32_t f;
  OK(bm_model_add_plane_face(m, origin, normal, uses, loops, 2, &f));
  OK(bm_model_set_name(m, 2, f, "plate"));
  return m;
}

/* The unit square: another model. */
static bm_model *square(void) {
  bm_model *m = NULL;
  OK(bm_model_new(&m));
  double corner[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  uint32_t v[4];
  for (int k = 0; k < 4; k++)
    OK(bm_model_add_vertex(m, corner[k][0], corner[k][1], 0.0, &v[k]));
  bm_edge_use uses[4];
  for (int k = 0; k < 4; k++) {
    OK(bm_model_add_line(m, v[k], v[(k + 1) % 4], &uses[k].edge));
    uses[k].forward = 1;
  }
  size_t loops[1] = {4};
  double origin[3] = {0, 0, 0}, normal[3] = {0, 0, 1};
  uint32_t f;
  OK(bm_model_add_plane_face(m, origin, normal, uses, loops, 1, &f));
  return m;
}

/* ---- mesh arrays, exact comparison ------------------------------------- */

typedef struct {
  size_t n;
  double *xyz; /* 3 per node */
} nodes_t;

static nodes_t nodes_of(const bm_mesh *m) {
  nodes_t r;
  OK(bm_mesh_node_count(m, &r.n));
  r.xyz = malloc(3 * r.n * sizeof(double) + 1);
  OK(bm_mesh_nodes(m, r.xyz, 3 * r.n));
  return r;
}

/* Orders points by the bytes of their coordinates: equal means bit for
 * bit equal. */
static int cmp_bits(const void *a, const void *b) {
  return memcmp(a, b, 3 * sizeof(double));
}

/* The nodes sorted for `has_exact`. */
static double *sorted_copy(const nodes_t *n) {
  double *s = malloc(3 * n->n * sizeof(double) + 1);
  memcpy(s, n->xyz, 3 * n->n * sizeof(double));
  qsort(s, n->n, 3 * sizeof(double), cmp_bits);
  return s;
}

static int has_exact(const double *sorted, size_t n, const double *p) {
  return bsearch(p, sorted, n, 3 * sizeof(double), cmp_bits) != NULL;
}

static size_t triangles_of(const bm_mesh *m) {
  size_t nt;
  OK(bm_mesh_triangle_count(m, &nt));
  return nt;
}

/* Distance from p to the ball (c, r); 0 inside. */
static double to_ball(const double *p, double cx, double cy, double cz,
                      double r) {
  double dx = p[0] - cx, dy = p[1] - cy, dz = p[2] - cz;
  double d = sqrt(dx * dx + dy * dy + dz * dz) - r;
  return d > 0 ? d : 0;
}

/* Distance from p to the box [lo, hi]; 0 inside. */
static double to_box(const double *p, const double *lo, const double *hi) {
  double s = 0;
  for (int k = 0; k < 3; k++) {
    double d = lo[k] - p[k];
    if (p[k] - hi[k] > d)
      d = p[k] - hi[k];
    if (d > 0)
      s += d * d;
  }
  return sqrt(s);
}

/* ---- the report --------------------------------------------------------- */

static char *report_of(const bm_mesh *m) {
  size_t n = 0;
  OK(bm_mesh_report_json(m, NULL, 0, &n));
  char *b = malloc(n + 1);
  OK(bm_mesh_report_json(m, b, n + 1, &n));
  return b;
}

/* The end of the JSON value starting at s (an object, array or string;
 * strings and escapes skipped), or NULL. */
static const char *value_end(const char *s) {
  int depth = 0, in_str = 0;
  for (const char *p = s; *p; p++) {
    if (in_str) {
      if (*p == '\\' && p[1])
        p++;
      else if (*p == '"')
        in_str = 0;
      continue;
    }
    if (*p == '"')
      in_str = 1;
    else if (*p == '{' || *p == '[')
      depth++;
    else if (*p == '}' || *p == ']') {
      if (--depth == 0)
        return p + 1;
    }
  }
  return NULL;
}

/* A copy of the value of "key" in json (the first occurrence), or NULL. */
static char *json_value(const char *json, const char *key) {
  char pat[64];
  snprintf(pat, sizeof pat, "\"%s\":", key);
  const char *at = strstr(json, pat);
  if (!at)
    return NULL;
  at += strlen(pat);
  const char *end;
  if (*at == '{' || *at == '[')
    end = value_end(at);
  else
    for (end = at; *end && *end != ',' && *end != '}' && *end != ']'; end++)
      ;
  if (!end)
    return NULL;
  char *v = malloc((size_t)(end - at) + 1);
  memcpy(v, at, (size_t)(end - at));
  v[end - at] = 0;
  return v;
}

/* The number at "key" in json, or -1 when absent. */
static long json_long(const char *json, const char *key) {
  char *v = json_value(json, key);
  long x = v ? strtol(v, NULL, 10) : -1;
  free(v);
  return x;
}

/* The number of strings in the JSON array at "key", or -1. */
static long json_strings(const char *json, const char *key) {
  char *v = json_value(json, key);
  if (!v || v[0] != '[') {
    free(v);
    return -1;
  }
  long n = 0;
  int in_str = 0;
  for (const char *p = v; *p; p++) {
    if (in_str) {
      if (*p == '\\' && p[1])
        p++;
      else if (*p == '"')
        in_str = 0;
    } else if (*p == '"') {
      in_str = 1;
      n++;
    }
  }
  free(v);
  return n;
}

/* The report's remesh section (a copy), or NULL. */
static char *remesh_section(const bm_mesh *m) {
  char *json = report_of(m);
  char *s = json_value(json, "remesh");
  free(json);
  return s;
}

/* ---- files --------------------------------------------------------------- */

static char *read_file(const char *path, size_t *len) {
  FILE *f = fopen(path, "rb");
  if (!f)
    return NULL;
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  char *b = malloc((size_t)n + 1);
  *len = fread(b, 1, (size_t)n, f);
  fclose(f);
  return b;
}

static void write_file(const char *path, const char *bytes, size_t len) {
  FILE *f = fopen(path, "wb");
  if (!f || fwrite(bytes, 1, len, f) != len) {
    fprintf(stderr, "cannot write %s\n", path);
    exit(1);
  }
  fclose(f);
}

static char *join(const char *dir, const char *name) {
  size_t n = strlen(dir) + strlen(name) + 2;
  char *p = malloc(n);
  snprintf(p, n, "%s/%s", dir, name);
  return p;
}

/* ---- the checks ---------------------------------------------------------- */

/* Every old node whose distance to the region is > `beyond` is a node of
 * `now` bit for bit; returns how many such nodes there were, and counts
 * in *gone the old nodes (anywhere) missing from `now`. */
static size_t far_nodes_kept(const nodes_t *old, const nodes_t *now,
                             double (*dist)(const double *, const void *),
                             const void *region, double beyond,
                             size_t *gone, const char *what) {
  double *sorted = sorted_copy(now);
  size_t far = 0, moved = 0;
  *gone = 0;
  for (size_t i = 0; i < old->n; i++) {
    const double *p = old->xyz + 3 * i;
    int kept = has_exact(sorted, now->n, p);
    if (!kept)
      ++*gone;
    if (dist(p, region) > beyond) {
      far++;
      if (!kept) {
        if (moved < 5)
          fprintf(stderr, "  %s: old node (%.17g, %.17g, %.17g) not kept\n",
                  what, p[0], p[1], p[2]);
        moved++;
      }
    }
  }
  free(sorted);
  CHECK(moved == 0, "%s: %zu of the %zu old nodes farther than %g from the "
        "change moved", what, moved, far, beyond);
  printf("%s: %zu old nodes farther than %g from the change, all kept bit "
         "for bit; %zu old nodes gone\n", what, far, beyond, *gone);
  return far;
}

typedef struct {
  double c[3], r;
} ball_t;
typedef struct {
  double lo[3], hi[3];
} box_t;

static double ball_dist(const double *p, const void *r) {
  const ball_t *b = r;
  return to_ball(p, b->c[0], b->c[1], b->c[2], b->r);
}
static double box_dist(const double *p, const void *r) {
  const box_t *b = r;
  return to_box(p, b->lo, b->hi);
}
/* The footprint of the moved hole: the annulus between the old and the
 * new circle, as the distance to the ball around both. */
static double hole_dist(const double *p, const void *r) {
  (void)r;
  return to_ball(p, 0.51, 0.5, 0.0, HOLE_R + 0.01);
}

/* The report of a re-meshing: its section exists, `entities` matched and
 * none not, and kept nodes; returns the section (free it). */
static char *check_report(const bm_mesh *m, long entities, const char *what) {
  char *s = remesh_section(m);
  CHECK(s != NULL, "%s: no remesh section in the report", what);
  if (!s)
    return NULL;
  long matched = json_strings(s, "matched");
  long unmatched = json_strings(s, "unmatched");
  long kept = json_long(s, "kept"), moved = json_long(s, "moved");
  long added = json_long(s, "added"), removed = json_long(s, "removed");
  long steps = json_long(s, "stage2_steps_max");
  printf("%s: matched %ld, unmatched %ld; nodes kept %ld, moved %ld, added "
         "%ld; removed %ld; stage-2 steps at most %ld\n",
         what, matched, unmatched, kept, moved, added, removed, steps);
  CHECK(matched == entities, "%s: %ld entities matched, expected %ld", what,
        matched, entities);
  CHECK(unmatched == 0, "%s: %ld entities unmatched", what, unmatched);
  CHECK(kept > 0, "%s: the report keeps no node (%ld)", what, kept);
  CHECK(moved >= 0 && added >= 0 && removed >= 0 && steps >= 0,
        "%s: counts missing from the report", what);
  return s;
}

int main(int argc, char **argv) {
  if (argc < 3) {
    fprintf(stderr, "usage: remesh FIXTURES_DIR OUT_DIR [SPACING]\n");
    return 2;
  }
  const char *fixtures = argv[1], *dir = argv[2];
  if (argc > 3)
    D = atof(argv[3]);
  const char *cube_text = argc > 4 ? argv[4] : NULL;
  char dtext[32];
  snprintf(dtext, sizeof dtext, "%g", D);
  printf("bubblemesh %s, spacing %s\n", bm_version(), dtext);

  char *old_state = join(dir, "old.state");
  char *again_state = join(dir, "again.state");
  char *new_state = join(dir, "new.state");

  /* ---- the first run, its state saved and loaded back ---- */
  circle_t hole0, hole1;
  bm_model *old_model = plate(0.5, &hole0);
  bm_spacing *sp = NULL;
  OK(bm_spacing_from_expr(dtext, &sp));
  bm_mesh *m0 = NULL;
  OK(bm_mesh_generate(old_model, sp, -1, 0, &m0));
  nodes_t n0 = nodes_of(m0);
  printf("first run: %zu nodes, %zu triangles\n", n0.n, triangles_of(m0));
  CHECK(triangles_of(m0) > 0, "first run: no triangles");

  bm_state *s0 = NULL;
  OK(bm_mesh_state(m0, &s0));
  OK(bm_state_save(s0, old_state));
  bm_state *loaded = NULL;
  OK(bm_state_load(old_state, &loaded));
  OK(bm_state_save(loaded, again_state));
  size_t len_a = 0, len_b = 0;
  char *bytes_a = read_file(old_state, &len_a);
  char *bytes_b = read_file(again_state, &len_b);
  CHECK(bytes_a && bytes_b && len_a == len_b && len_a > 100 &&
            memcmp(bytes_a, bytes_b, len_a) == 0,
        "a state loaded and saved again differs from the file (%zu vs %zu "
        "bytes)", len_a, len_b);
  CHECK(bytes_a && memcmp(bytes_a, "bubblemesh-state 2\n", 19) == 0,
        "the state file does not start with its format line");
  /* the model was freed: the state does not need it */
  bm_model_free(old_model);

  /* ---- the hole moved: a local re-meshing from the loaded state ---- */
  bm_model *new_model = plate(0.52, &hole1);
  const char *region = "sphere:0.51,0.5,0,0.25";
  ball_t ball = {{0.51, 0.5, 0.0}, 0.25};
  bm_mesh *m1 = NULL;
  OK(bm_remesh_generate(new_model, sp, loaded, -1, region, &m1));
  nodes_t n1 = nodes_of(m1);
  printf("local re-meshing: %zu nodes, %zu triangles\n", n1.n,
         triangles_of(m1));
  CHECK(triangles_of(m1) > 0, "local re-meshing: no triangles");
  size_t gone = 0;
  size_t far = far_nodes_kept(&n0, &n1, ball_dist, &ball, 2 * D, &gone,
                              "local re-meshing");
  CHECK(far > n0.n / 2, "local re-meshing: only %zu of %zu old nodes far "
        "from the region", far, n0.n);
  CHECK(gone > 0, "local re-meshing: every old node kept, though the hole "
        "moved");
  char *sec = check_report(m1, 6, "local re-meshing");
  if (sec) {
    long ff = json_long(sec, "far_from_region"), fk = json_long(sec, "far_kept");
    CHECK(ff > 0 && fk == ff, "local re-meshing: the report keeps %ld of "
          "the %ld old bubbles far from the region", fk, ff);
    free(sec);
  }

  /* the state of the re-meshed mesh: a chain of runs */
  bm_state *s1 = NULL, *s1_back = NULL;
  OK(bm_mesh_state(m1, &s1));
  OK(bm_state_save(s1, new_state));
  OK(bm_state_load(new_state, &s1_back));

  /* ---- the same change, a continuous re-meshing (no region) ---- */
  bm_mesh *m2 = NULL;
  OK(bm_remesh_generate(new_model, sp, s0, -1, NULL, &m2));
  nodes_t n2 = nodes_of(m2);
  printf("continuous re-meshing: %zu nodes, %zu triangles\n", n2.n,
         triangles_of(m2));
  CHECK(triangles_of(m2) > 0, "continuous re-meshing: no triangles");
  far = far_nodes_kept(&n0, &n2, hole_dist, NULL, 6 * D, &gone,
                       "continuous re-meshing");
  CHECK(far > n0.n / 5, "continuous re-meshing: only %zu of %zu old nodes "
        "far from the hole", far, n0.n);
  CHECK(gone > 0, "continuous re-meshing: every old node kept, though the "
        "hole moved");
  sec = check_report(m2, 6, "continuous re-meshing");
  if (sec) {
    CHECK(json_value(sec, "far_from_region") == NULL,
          "continuous re-meshing: far_from_region without a region");
    free(sec);
  }
  /* a mesh from scratch has no remesh section */
  sec = remesh_section(m0);
  CHECK(sec == NULL, "a run from scratch has a remesh section");
  free(sec);

  /* ---- the STEP variant: cube.step, a box at one corner ---- */
  char *cube = join(fixtures, "cube.step");
  bm_mesh *c0 = NULL, *c1 = NULL;
  bm_spacing *csp = NULL; /* NULL: the default, 1/40 of the diagonal */
  if (cube_text)
    OK(bm_spacing_from_expr(cube_text, &csp));
  double cube_d = cube_text ? atof(cube_text) : sqrt(3.0) / 40;
  OK(bm_mesh_step_file(cube, csp, -1, 0, &c0));
  bm_state *cs = NULL;
  OK(bm_mesh_state(c0, &cs));
  const char *corner = "box:-0.1,-0.1,-0.1,0.25,0.25,0.25";
  box_t box = {{-0.1, -0.1, -0.1}, {0.25, 0.25, 0.25}};
  OK(bm_remesh_step_file(cube, csp, cs, -1, corner, &c1));
  nodes_t nc0 = nodes_of(c0), nc1 = nodes_of(c1);
  printf("cube: %zu nodes, re-meshed in a corner: %zu nodes, %zu triangles\n",
         nc0.n, nc1.n, triangles_of(c1));
  CHECK(triangles_of(c1) > 0, "cube re-meshing: no triangles");
  far = far_nodes_kept(&nc0, &nc1, box_dist, &box, 2 * cube_d, &gone,
                       "cube re-meshing");
  CHECK(far > nc0.n / 2, "cube re-meshing: only %zu of %zu nodes far", far,
        nc0.n);
  sec = check_report(c1, 12 + 6 + 1, "cube re-meshing"); /* and its solid */
  free(sec);

  /* ---- bad inputs: codes, messages, no handle ---- */
  bm_state *bad = NULL;
  bm_mesh *none = NULL;
  char *path = join(dir, "missing.state");
  EXPECT(bm_state_load(path, &bad), bad, BM_ERR_IO, "missing.state",
         "cannot read");
  free(path);

  /* truncated: the first half of a good state file */
  path = join(dir, "truncated.state");
  write_file(path, bytes_a, len_a / 2);
  EXPECT(bm_state_load(path, &bad), bad, BM_ERR_FORMAT, "truncated.state",
         "truncated");
  free(path);

  /* another version of the format */
  path = join(dir, "v9.state");
  bytes_b[17] = '9'; /* "bubblemesh-state 9" */
  write_file(path, bytes_b, len_b);
  EXPECT(bm_state_load(path, &bad), bad, BM_ERR_FORMAT, "v9.state",
         "version 9");
  free(path);

  /* one byte of the body changed: the checksum */
  path = join(dir, "corrupt.state");
  char *flipped = malloc(len_a + 1);
  memcpy(flipped, bytes_a, len_a);
  flipped[len_a - 20] ^= 0x40;
  write_file(path, flipped, len_a);
  free(flipped);
  EXPECT(bm_state_load(path, &bad), bad, BM_ERR_FORMAT, "corrupt.state",
         "corrupted");
  free(path);

  /* a mesh file is not a state */
  path = join(dir, "mesh.msh");
  OK(bm_mesh_write(m0, path));
  EXPECT(bm_state_load(path, &bad), bad, BM_ERR_FORMAT, "mesh.msh",
         "not a bubblemesh-state");
  free(path);

  /* a state of another model */
  bm_model *sq = square();
  bm_mesh *msq = NULL;
  bm_state *ssq = NULL;
  OK(bm_mesh_generate(sq, sp, -1, 0, &msq));
  OK(bm_mesh_state(msq, &ssq));
  EXPECT(bm_remesh_generate(new_model, sp, ssq, -1, NULL, &none), none,
         BM_ERR_STATE, "another model", "bm_remesh_generate");
  EXPECT(bm_remesh_step_file(cube, NULL, loaded, -1, NULL, &none), none,
         BM_ERR_STATE, "another model", "cube.step");
  EXPECT(bm_remesh_generate(sq, sp, cs, -1, NULL, &none), none, BM_ERR_STATE,
         "another model", "cube.step");

  /* regions */
  EXPECT(bm_remesh_generate(new_model, sp, loaded, -1, "box:5,5,5,6,6,6",
                            &none),
         none, BM_ERR_RANGE, "selects nothing", "box:5,5,5,6,6,6");
  EXPECT(bm_remesh_generate(new_model, sp, loaded, -1, "cube:1", &none), none,
         BM_ERR_RANGE, "region", "unknown region");
  EXPECT(bm_remesh_generate(new_model, sp, loaded, -1, "sphere:0,0,0,-1",
                            &none),
         none, BM_ERR_RANGE, "region", "r > 0");
  EXPECT(bm_remesh_generate(new_model, sp, loaded, -1, "faces:7", &none),
         none, BM_ERR_RANGE, "face 7", "1 faces");
  EXPECT(bm_remesh_step_file(cube, NULL, cs, -1, "sphere:9,9,9,0.1", &none),
         none, BM_ERR_RANGE, "selects nothing", "cube.step");

  /* options and arguments */
  bm_options opts;
  OK(bm_options_init(&opts));
  opts.fast = 1;
  EXPECT(bm_remesh_generate_ex(new_model, sp, loaded, &opts, NULL, &none),
         none, BM_ERR_UNSUPPORTED, "fast", "stage 2");
  opts.fast = 0;
  EXPECT(bm_remesh_generate_ex(new_model, sp, loaded, NULL, NULL, &none),
         none, BM_ERR_NULL, "options", "NULL");
  EXPECT(bm_remesh_generate(new_model, sp, NULL, -1, NULL, &none), none,
         BM_ERR_NULL, "state", "NULL");
  EXPECT(bm_remesh_generate(new_model, sp, (const bm_state *)m0, -1, NULL,
                            &none),
         none, BM_ERR_RANGE, "state", "bm_state");
  EXPECT(bm_mesh_state((const bm_mesh *)loaded, &bad), bad, BM_ERR_RANGE,
         "mesh", "bm_mesh");
  EXPECT(bm_remesh_generate(new_model, sp, loaded, 3, NULL, &none), none,
         BM_ERR_RANGE, "dim = 3", "highest dimension");
  path = join(dir, "missing.step");
  EXPECT(bm_remesh_step_file(path, NULL, cs, -1, NULL, &none), none,
         BM_ERR_IO, "missing.step", "cannot read");
  free(path);
  path = join(dir, "no/such/dir/x.state");
  EXPECT(bm_state_save(loaded, path), bad, BM_ERR_IO, "x.state", "");
  free(path);
  EXPECT(bm_state_save(NULL, new_state), bad, BM_ERR_NULL, "state", "NULL");
  /* a good call after the failures: its state still works */
  bm_mesh *m3 = NULL;
  OK(bm_remesh_generate_ex(new_model, sp, s1_back, &opts, region, &m3));
  CHECK(triangles_of(m3) > 0, "re-meshing from the chained state: no "
        "triangles");
  CHECK(strlen(bm_last_error_message()) == 0,
        "a successful call left an error message");

  bm_state_free(NULL);
  bm_state_free(s0);
  bm_state_free(s1);
  bm_state_free(s1_back);
  bm_state_free(loaded);
  bm_state_free(cs);
  bm_state_free(ssq);
  bm_mesh_free(m0);
  bm_mesh_free(m1);
  bm_mesh_free(m2);
  bm_mesh_free(m3);
  bm_mesh_free(msq);
  bm_mesh_free(c0);
  bm_mesh_free(c1);
  bm_model_free(new_model);
  bm_model_free(sq);
  bm_spacing_free(sp);
  bm_spacing_free(csp);
  free(n0.xyz), free(n1.xyz), free(n2.xyz), free(nc0.xyz), free(nc1.xyz);
  free(bytes_a), free(bytes_b);
  free(old_state), free(again_state), free(new_state), free(cube);

  if (failures) {
    printf("%d check(s) failed\n", failures);
    return 1;
  }
  printf("all checks passed\n");
  return 0;
}
