/*
 * A bubblemesh spacing plugin written in C: view-based spacing
 * d = factor * |viewpoint - x| (thesis eq. 4.6.2), clamped to
 * [d_min, d_max] -- the same as the Rust plugin plugins/view.
 *
 * Build:  cc -std=c99 -O2 -shared -fPIC -I plugins/c-example \
 *             plugins/c-example/view_plugin.c -o libview_c.so -lm
 * Use:    bubblemesh mesh d.toml -o out.msh --plugin ./libview_c.so \
 *             --plugin-arg viewpoint=0,0,5 --plugin-arg factor=0.05
 *
 * Arguments: viewpoint=x,y,z (required), factor (> 0, required),
 * d_min, d_max (optional).
 *
 * It counts the calls it answers in its state, so it is NOT thread-safe:
 * flags = 0, and the host serialises its calls. (A plugin whose state is
 * read-only after init sets BM_PLUGIN_THREAD_SAFE instead.)
 */
#include "bubblemesh_plugin.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    double v[3];
    double factor, d_min, d_max;
    unsigned long calls; /* mutated by every spacing call */
} view_state;

static void set_err(char *err, size_t len, const char *msg) {
    if (err && len > 0) {
        snprintf(err, len, "%s", msg);
    }
}

static int parse_number(const char *s, double *out) {
    char *end = NULL;
    double x = strtod(s, &end);
    if (end == s || *end != '\0' || !isfinite(x)) {
        return 0;
    }
    *out = x;
    return 1;
}

static int32_t view_init(const BmInitInfo *info, const BmArg *args, size_t n_args,
                         void **state, char *err, size_t err_len) {
    (void)info;
    view_state s = {{0, 0, 0}, 0.0, DBL_MIN, INFINITY, 0};
    int have_v = 0;
    char msg[256];
    for (size_t i = 0; i < n_args; i++) {
        const char *k = args[i].key, *val = args[i].value;
        if (strcmp(k, "viewpoint") == 0) {
            char tail;
            if (sscanf(val, "%lf,%lf,%lf%c", &s.v[0], &s.v[1], &s.v[2], &tail) != 3) {
                snprintf(msg, sizeof msg, "argument viewpoint=%s: expected x,y,z", val);
                set_err(err, err_len, msg);
                return BM_ERR;
            }
            have_v = 1;
        } else if (strcmp(k, "factor") == 0 || strcmp(k, "d_min") == 0 ||
                   strcmp(k, "d_max") == 0) {
            double x;
            if (!parse_number(val, &x) || x <= 0) {
                snprintf(msg, sizeof msg, "argument %s=%s: expected a number > 0", k, val);
                set_err(err, err_len, msg);
                return BM_ERR;
            }
            if (k[0] == 'f') {
                s.factor = x;
            } else if (k[2] == 'm' && k[3] == 'i') {
                s.d_min = x;
            } else {
                s.d_max = x;
            }
        } else {
            snprintf(msg, sizeof msg,
                     "unknown argument '%s' (known: viewpoint, factor, d_min, d_max)", k);
            set_err(err, err_len, msg);
            return BM_ERR;
        }
    }
    if (!have_v || s.factor <= 0) {
        set_err(err, err_len, "arguments viewpoint=x,y,z and factor (> 0) are required");
        return BM_ERR;
    }
    view_state *p = malloc(sizeof *p);
    if (!p) {
        set_err(err, err_len, "out of memory");
        return BM_ERR;
    }
    *p = s;
    *state = p;
    return BM_OK;
}

static int32_t view_spacing(void *state, const BmQuery *q, size_t n, double *out, char *err,
                            size_t err_len) {
    view_state *s = state;
    (void)err;
    (void)err_len;
    s->calls++;
    for (size_t i = 0; i < n; i++) {
        double dx = q[i].point[0] - s->v[0];
        double dy = q[i].point[1] - s->v[1];
        double dz = q[i].point[2] - s->v[2];
        double d = s->factor * sqrt(dx * dx + dy * dy + dz * dz);
        out[i] = d < s->d_min ? s->d_min : (d > s->d_max ? s->d_max : d);
    }
    return BM_OK;
}

static void view_destroy(void *state) { free(state); }

static const BmPlugin TABLE = {
    BM_PLUGIN_MAGIC,
    BM_PLUGIN_ABI_VERSION,
    sizeof(BmPlugin),
    sizeof(BmQuery),
    0, /* not thread-safe: the host serialises calls */
    sizeof(BmInitInfo),
    "view-c",
    "view-based spacing in C (thesis eq. 4.6.2); args: viewpoint=x,y,z, factor, d_min, d_max",
    view_init,
    view_spacing,
    view_destroy,
};

const BmPlugin *bubblemesh_plugin_entry(void) { return &TABLE; }
