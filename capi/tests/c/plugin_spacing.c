/*
 * Spacing plugins through the C ABI: bm_spacing_from_plugin loads a plugin
 * shared library (the curvature plugin cargo builds), the torus R = 1,
 * r = 0.4 described through callbacks is meshed with it, and plugins that
 * are missing, not plugins, refuse their arguments or fail while meshing
 * give error codes and messages.
 *
 * Checks:
 *  - curvature plugin, eps = EPS (0.01 unless given): every triangle's
 *    centroid lies within eps of the torus (thesis eq. 4.6.1: the plugin's
 *    d keeps the chords within eps); eps = EPS/2 gives at least 1.5 x the
 *    nodes (the argument reaches the plugin) and stays within EPS/2;
 *  - the same plugin through a configuration file (bm_spacing_from_plugin_
 *    config) gives the same mesh as through bm_spacing_from_plugin;
 *  - a missing library: BM_ERR_IO; a file that is not a shared library:
 *    BM_ERR_FORMAT; an argument without '=': BM_ERR_RANGE; a plugin whose
 *    init refuses its arguments, or that answers NaN or fails while
 *    meshing (the test plugin "testbad"): BM_ERR_SPACING at meshing with a
 *    message naming the plugin; a malformed or missing configuration file:
 *    BM_ERR_FORMAT / BM_ERR_IO.
 *
 * Usage: plugin_spacing CURVATURE_LIB TESTBAD_LIB SCRATCH_DIR [EPS].
 * Exit status 0 when every check passes, 1 otherwise.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bubblemesh.h"
#include "check.h"

static const double R_MAJOR = 1.0, R_MINOR = 0.4;

/* S(u,v) = ((R + r cos v) cos u, (R + r cos v) sin u, r sin v) */
static int torus_eval(void *user, double u, double v, int order, double *o) {
  (void)user;
  const double R = R_MAJOR, r = R_MINOR;
  double cu = cos(u), su = sin(u), cv = cos(v), sv = sin(v);
  double w = R + r * cv;
  o[0] = w * cu, o[1] = w * su, o[2] = r * sv;
  if (order >= 1) {
    o[3] = -w * su, o[4] = w * cu, o[5] = 0.0;
    o[6] = -r * sv * cu, o[7] = -r * sv * su, o[8] = r * cv;
  }
  if (order >= 2) {
    o[9] = -w * cu, o[10] = -w * su, o[11] = 0.0;
    o[12] = r * sv * su, o[13] = -r * sv * cu, o[14] = 0.0;
    o[15] = -r * cv * cu, o[16] = -r * cv * su, o[17] = -r * sv;
  }
  return 0;
}

static bm_model *torus_model(void) {
  bm_model *m = NULL;
  OK(bm_model_new(&m));
  bm_surface_callbacks cb = {torus_eval, NULL, NULL};
  bm_surface_info info;
  memset(&info, 0, sizeof info);
  info.u1 = info.v1 = info.period_u = info.period_v = 2 * M_PI;
  uint32_t f;
  OK(bm_model_add_surface_face(m, &cb, NULL, &info, NULL, NULL, 0, &f));
  return m;
}

/* distance from p to the torus */
static double torus_distance(const double *p) {
  double rho = hypot(p[0], p[1]) - R_MAJOR;
  return fabs(hypot(rho, p[2]) - R_MINOR);
}

typedef struct {
  size_t nodes, triangles;
  double max_dev; /* largest centroid distance to the torus */
  double *xyz;
  uint32_t *tri;
} result_t;

static result_t mesh_torus(bm_model *m, const bm_spacing *s) {
  result_t r;
  memset(&r, 0, sizeof r);
  bm_mesh *mesh = NULL;
  OK(bm_mesh_generate(m, s, 2, 0, &mesh));
  OK(bm_mesh_node_count(mesh, &r.nodes));
  OK(bm_mesh_triangle_count(mesh, &r.triangles));
  r.xyz = malloc(3 * r.nodes * sizeof(double));
  r.tri = malloc(3 * r.triangles * sizeof(uint32_t) + 1);
  OK(bm_mesh_nodes(mesh, r.xyz, 3 * r.nodes));
  OK(bm_mesh_triangles(mesh, r.tri, 3 * r.triangles));
  for (size_t t = 0; t < r.triangles; t++) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++)
      for (int j = 0; j < 3; j++)
        c[j] += r.xyz[3 * r.tri[3 * t + k] + j] / 3.0;
    double dev = torus_distance(c);
    if (dev > r.max_dev)
      r.max_dev = dev;
  }
  bm_mesh_free(mesh);
  return r;
}

static void free_result(result_t *r) {
  free(r->xyz), free(r->tri);
  r->xyz = NULL, r->tri = NULL;
}

int main(int argc, char **argv) {
  if (argc != 4 && argc != 5) {
    fprintf(stderr, "usage: plugin_spacing CURVATURE_LIB TESTBAD_LIB "
                    "SCRATCH_DIR [EPS]\n");
    return 2;
  }
  const char *curv = argv[1], *bad = argv[2], *dir = argv[3];
  double eps = argc == 5 ? atof(argv[4]) : 0.01;
  if (!(eps > 0.0 && eps < 0.2)) {
    fprintf(stderr, "EPS must be in (0, 0.2)\n");
    return 2;
  }
  bm_model *torus = torus_model();

  /* ---- the curvature plugin ---- */
  char coarse_eps[64], fine_eps[64];
  snprintf(coarse_eps, sizeof coarse_eps, "eps=%.17g", eps);
  snprintf(fine_eps, sizeof fine_eps, "eps=%.17g", eps / 2);
  const char *coarse_args[] = {coarse_eps};
  const char *fine_args[] = {fine_eps, "d_max=0.5"};
  bm_spacing *coarse = NULL, *fine = NULL;
  OK(bm_spacing_from_plugin(curv, coarse_args, 1, &coarse));
  OK(bm_spacing_from_plugin(curv, fine_args, 2, &fine));
  result_t a = mesh_torus(torus, coarse);
  result_t b = mesh_torus(torus, fine);
  printf("curvature plugin eps=%g: %zu nodes, %zu triangles, largest "
         "centroid deviation %.5f\n",
         eps, a.nodes, a.triangles, a.max_dev);
  printf("curvature plugin eps=%g: %zu nodes, %zu triangles, largest "
         "centroid deviation %.5f\n",
         eps / 2, b.nodes, b.triangles, b.max_dev);
  CHECK(a.triangles > 100, "eps=%g: only %zu triangles", eps, a.triangles);
  CHECK(a.max_dev <= eps, "eps=%g: a centroid is %.5f off the torus", eps,
        a.max_dev);
  CHECK(b.max_dev <= eps / 2, "eps=%g: a centroid is %.5f off the torus",
        eps / 2, b.max_dev);
  CHECK(2 * b.nodes > 3 * a.nodes, "eps=%g gave %zu nodes, eps=%g %zu",
        eps / 2, b.nodes, eps, a.nodes);
  free_result(&b);
  bm_spacing_free(fine);

  /* ---- the same through a configuration file ---- */
  char cfg[4096];
  snprintf(cfg, sizeof cfg, "%s/plugins.toml", dir);
  FILE *f = fopen(cfg, "w");
  if (!f)
    return 1;
  fprintf(f, "[[plugin]]\npath = \"%s\"\nargs = { eps = %.17g }\n", curv,
          eps);
  fclose(f);
  bm_spacing *from_cfg = NULL;
  OK(bm_spacing_from_plugin_config(cfg, &from_cfg));
  result_t c = mesh_torus(torus, from_cfg);
  int same = c.nodes == a.nodes && c.triangles == a.triangles &&
             memcmp(c.xyz, a.xyz, 3 * a.nodes * sizeof(double)) == 0;
  CHECK(same, "config file: %zu nodes, %zu triangles; direct: %zu, %zu",
        c.nodes, c.triangles, a.nodes, a.triangles);
  free_result(&a);
  free_result(&c);
  bm_spacing_free(from_cfg);
  bm_spacing_free(coarse);

  /* ---- plugins that cannot be used ---- */
  bm_spacing *s = NULL;
  char path[4096];
  snprintf(path, sizeof path, "%s/libno_such_plugin.so", dir);
  EXPECT(bm_spacing_from_plugin(path, NULL, 0, &s), s, BM_ERR_IO,
         "libno_such_plugin.so", "no such file");
  snprintf(path, sizeof path, "%s/libnot_a_library.so", dir);
  f = fopen(path, "w");
  if (!f)
    return 1;
  fputs("this is text, not a shared library\n", f);
  fclose(f);
  EXPECT(bm_spacing_from_plugin(path, NULL, 0, &s), s, BM_ERR_FORMAT,
         "libnot_a_library.so", "cannot load");
  const char *no_equals[] = {"eps"};
  EXPECT(bm_spacing_from_plugin(curv, no_equals, 1, &s), s, BM_ERR_RANGE,
         "args[0] = 'eps'", "KEY=VALUE");
  EXPECT(bm_spacing_from_plugin(curv, NULL, 1, &s), s, BM_ERR_NULL, "'args'",
         "NULL");
  EXPECT(bm_spacing_from_plugin(NULL, NULL, 0, &s), s, BM_ERR_NULL, "'path'",
         "NULL");

  /* init refuses: reported when meshing, with the plugin's message */
  bm_mesh *mesh = NULL;
  const char *unknown_mode[] = {"mode=sideways"};
  OK(bm_spacing_from_plugin(bad, unknown_mode, 1, &s));
  EXPECT(bm_mesh_generate(torus, s, 2, 0, &mesh), mesh, BM_ERR_SPACING,
         "unknown mode 'sideways'", "testbad");
  bm_spacing_free(s);
  const char *no_eps[] = {"d_max=0.5"};
  OK(bm_spacing_from_plugin(curv, no_eps, 1, &s));
  EXPECT(bm_mesh_generate(torus, s, 2, 0, &mesh), mesh, BM_ERR_SPACING,
         "init refused its arguments", "eps");
  bm_spacing_free(s);

  /* failures while meshing */
  const char *nan_mode[] = {"mode=nan", "d=0.2", "after=50"};
  OK(bm_spacing_from_plugin(bad, nan_mode, 3, &s));
  EXPECT(bm_mesh_generate(torus, s, 2, 0, &mesh), mesh, BM_ERR_SPACING,
         "testbad", "a spacing must be finite and > 0");
  /* the same handle again: a fresh instance per meshing call */
  EXPECT(bm_mesh_generate(torus, s, 2, 0, &mesh), mesh, BM_ERR_SPACING,
         "testbad", "on face 0");
  bm_spacing_free(s);
  const char *fail_mode[] = {"mode=fail", "d=0.2"};
  OK(bm_spacing_from_plugin(bad, fail_mode, 2, &s));
  EXPECT(bm_mesh_generate(torus, s, 2, 0, &mesh), mesh, BM_ERR_SPACING,
         "testbad", "failed (");
  bm_spacing_free(s);
  s = NULL;

  /* configuration files */
  snprintf(cfg, sizeof cfg, "%s/bad.toml", dir);
  f = fopen(cfg, "w");
  if (!f)
    return 1;
  fputs("[[plugin]]\npth = \"x.so\"\n", f);
  fclose(f);
  EXPECT(bm_spacing_from_plugin_config(cfg, &s), s, BM_ERR_FORMAT,
         "bad.toml", "'pth'");
  snprintf(cfg, sizeof cfg, "%s/missing.toml", dir);
  EXPECT(bm_spacing_from_plugin_config(cfg, &s), s, BM_ERR_IO, "missing.toml",
         "cannot read");

  bm_model_free(torus);
  if (failures) {
    fprintf(stderr, "%d check(s) failed\n", failures);
    return 1;
  }
  printf("all checks passed\n");
  return 0;
}
