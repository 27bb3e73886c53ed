/* A plugin whose table is wrong as BAD says: 1 wrong ABI version, 2 wrong
 * BmQuery size, 3 wrong magic, 4 NULL table, 5 NULL spacing function. */
#include "bubblemesh_plugin.h"

static int32_t init(const BmInitInfo *i, const BmArg *a, size_t n, void **s, char *e, size_t l) {
    (void)i; (void)a; (void)n; (void)e; (void)l;
    *s = 0;
    return BM_OK;
}
static int32_t spacing(void *s, const BmQuery *q, size_t n, double *o, char *e, size_t l) {
    (void)s; (void)q; (void)e; (void)l;
    for (size_t i = 0; i < n; i++) o[i] = 1.0;
    return BM_OK;
}
static void destroy(void *s) { (void)s; }

static const BmPlugin TABLE = {
    BAD == 3 ? 0x12345678u : BM_PLUGIN_MAGIC,
    BAD == 1 ? BM_PLUGIN_ABI_VERSION + 98 : BM_PLUGIN_ABI_VERSION,
    sizeof(BmPlugin),
    BAD == 2 ? sizeof(BmQuery) - 8 : sizeof(BmQuery),
    0,
    sizeof(BmInitInfo),
    "bad",
    "a bad table",
    init,
    BAD == 5 ? 0 : spacing,
    destroy,
};

const BmPlugin *bubblemesh_plugin_entry(void) { return BAD == 4 ? 0 : &TABLE; }
