/* Prints the C compiler's sizes and offsets of the ABI structs, one
 * "name value" per line; the test compares them with Rust's. */
#include <stddef.h>
#include <stdio.h>
#include "bubblemesh_plugin.h"

#define P(x) printf("%s %zu\n", #x, (size_t)(x))

int main(void) {
    P(sizeof(BmQuery));
    P(offsetof(BmQuery, point));
    P(offsetof(BmQuery, params));
    P(offsetof(BmQuery, dim));
    P(offsetof(BmQuery, id));
    P(offsetof(BmQuery, geom));
    P(offsetof(BmQuery, reserved));
    P(offsetof(BmQuery, tangent));
    P(offsetof(BmQuery, curve_curvature));
    P(offsetof(BmQuery, normal));
    P(offsetof(BmQuery, k1));
    P(offsetof(BmQuery, k2));
    P(offsetof(BmQuery, dir1));
    P(offsetof(BmQuery, dir2));
    P(sizeof(BmPlugin));
    P(offsetof(BmPlugin, flags));
    P(offsetof(BmPlugin, init_info_size));
    P(offsetof(BmPlugin, name));
    P(offsetof(BmPlugin, description));
    P(offsetof(BmPlugin, init));
    P(offsetof(BmPlugin, spacing));
    P(offsetof(BmPlugin, destroy));
    P(sizeof(BmInitInfo));
    P(offsetof(BmInitInfo, bbox_min));
    P(offsetof(BmInitInfo, bbox_max));
    P(offsetof(BmInitInfo, model_size));
    P(sizeof(BmArg));
    P(offsetof(BmArg, value));
    return 0;
}
