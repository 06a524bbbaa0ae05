/* Grids stored x fastest (the kernels' order) copied into z fastest, the [x][y][z] order
 * OpenVDB's dense copies (pyopenvdb's copyFromArray) take. A plain transposing copy reads or
 * writes with a stride of a whole plane; here 16 x 16 tiles of (x, z) go at a time, on
 * threads, so both sides stay in cache. */
#include "internal_base.h"
#include <string.h>

hbk_result_t hbk_grid_to_xyz(const float *src, float *dst, int32_t nx, int32_t ny, int32_t nz,
                             int32_t comps, int32_t threads, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!src || !dst) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "src, dst: must not be NULL");
    if (src == dst)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "dst: must not be src (not in place)");
    const int32_t n[3] = {nx, ny, nz};
    for (int a = 0; a < 3; ++a)
        if (n[a] < 1 || n[a] > 65536)
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "n%c = %d: must be in [1, 65536]",
                            "xyz"[a], n[a]);
    if (comps < 1 || comps > 16)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "comps = %d: must be in [1, 16]", comps);
    if (threads < 0 || threads > 256)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "threads = %d: must be in [0, 256]",
                        threads);
    const int t = threads ? hbk_threads(threads) : 1;
    const size_t c = (size_t)comps, sy = (size_t)nx, sz = (size_t)nx * (size_t)ny;
    enum { TILE = 16 };
    const int32_t tx = (nx + TILE - 1) / TILE;
    /* One task per (y, tile of x): it reads rows of x at every z and writes columns of z. */
#pragma omp parallel for num_threads(t) schedule(static)
    for (int64_t task = 0; task < (int64_t)ny * tx; ++task) {
        const int32_t y = (int32_t)(task / tx), x0 = (int32_t)(task % tx) * TILE;
        const int32_t x1 = x0 + TILE < nx ? x0 + TILE : nx;
        for (int32_t z0 = 0; z0 < nz; z0 += TILE) {
            const int32_t z1 = z0 + TILE < nz ? z0 + TILE : nz;
            for (int32_t x = x0; x < x1; ++x) {
                const size_t at = (size_t)z0 + (size_t)nz * ((size_t)y + (size_t)ny * (size_t)x);
                float *o = dst + c * at;
                const float *i = src + c * ((size_t)x + sy * (size_t)y + sz * (size_t)z0);
                /* constant sizes for the usual scalar and vector grids: inline copies */
                if (c == 1)
                    for (int32_t z = z0; z < z1; ++z, o += 1, i += sz) o[0] = i[0];
                else if (c == 3)
                    for (int32_t z = z0; z < z1; ++z, o += 3, i += 3 * sz) memcpy(o, i, 12);
                else
                    for (int32_t z = z0; z < z1; ++z, o += c, i += c * sz)
                        memcpy(o, i, c * sizeof(float));
            }
        }
    }
    return HBK_OK;
}
