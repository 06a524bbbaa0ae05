/* A sprinkler's points: an inflow with a speed along the shape's normal pours from its surface,
 * not its volume. On a lattice inside the shape, streams leaving along the normals cross
 * their neighbours' and keep them from pouring (a ball spraying out of a volume lattice
 * poured 42-71% of its area x speed); from points spread over the surface a spacing apart,
 * neighbouring streams part. */
#include "internal_fluid.h"
#include <stdlib.h>

/* Whether a point kept before lies nearer than s to x (the 27 cells around x's). */
static int crowded(const float *pts, const int32_t *head, const int32_t *next, const int32_t d[3],
                   const int32_t c[3], const float x[3], float s)
{
    const float s2 = s * s * (1.0f - 1e-4f); /* (a lattice's own spacing is not crowded) */
    for (int dz = -1; dz <= 1; ++dz)
        for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx) {
                const int32_t cx = c[0] + dx, cy = c[1] + dy, cz = c[2] + dz;
                if (cx < 0 || cy < 0 || cz < 0 || cx >= d[0] || cy >= d[1] || cz >= d[2])
                    continue;
                for (int32_t p = head[cx + (int64_t)d[0] * (cy + (int64_t)d[1] * cz)]; p >= 0;
                     p = next[p]) {
                    const float *y = pts + 3 * (size_t)p;
                    const float a = y[0] - x[0], b = y[1] - x[1], e = y[2] - x[2];
                    if (a * a + b * b + e * e < s2) return 1;
                }
            }
    return 0;
}

hbk_result_t hbk_fluid_surface_points(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                      const int32_t dims[3], const float *f, float **pts_out,
                                      float **nrm_out, size_t *n_out)
{
    /* Candidates: a lattice of half spacings over the shape's bounds within the box, each
     * within a spacing of the surface moved along its normal to half a spacing in (where a
     * particle of a filled shape would sit); then, in the lattice's order, each kept unless
     * one kept before lies nearer than a spacing. */
    const float s = h->p.particle_spacing, g = 0.5f * s, wall = 0.5f * s;
    float lo[3], hi[3], ax[9];
    hbk_fluid_shape_bounds(shape, lo, hi);
    hbk_fluid_shape_axes(shape, ax);
    int32_t m[3], gd[3];
    size_t cells = 1;
    for (int a = 0; a < 3; ++a) {
        lo[a] = fmaxf(lo[a], h->p.box_min[a] + wall);
        hi[a] = fminf(hi[a], h->p.box_max[a] - wall);
        m[a] = hi[a] >= lo[a] ? (int32_t)floorf((hi[a] - lo[a]) / g) + 1 : 0;
        gd[a] = m[a] ? (int32_t)((hi[a] - lo[a]) / s) + 1 : 1;
        cells *= (size_t)gd[a];
    }
    size_t cap = 64, n = 0;
    float *pts = malloc(3 * cap * sizeof *pts), *nrm = malloc(3 * cap * sizeof *nrm);
    int32_t *head = malloc(cells * sizeof *head), *next = malloc(cap * sizeof *next);
    hbk_result_t r = HBK_OK;
    if (!pts || !nrm || !head || !next) r = HBK_ERR_OUT_OF_MEMORY;
    for (size_t c = 0; !r && c < cells; ++c) head[c] = -1;
    for (int32_t k = 0; !r && k < m[2]; ++k)
        for (int32_t j = 0; !r && j < m[1]; ++j)
            for (int32_t i = 0; !r && i < m[0]; ++i) {
                const int32_t ijk[3] = {i, j, k};
                float x[3], d, nx[3], y[3];
                for (int a = 0; a < 3; ++a) x[a] = lo[a] + (float)ijk[a] * g;
                /* (inside: d < 0, as hbk_fluid_in_shape_ax has it) */
                if (!hbk_fluid_shape_distance(shape, ax, dims, f, x, &d, nx) || !(d < 0.0f) ||
                    d < -s)
                    continue;
                for (int a = 0; a < 3; ++a) y[a] = x[a] - (d + 0.5f * s) * nx[a];
                int inside = 1; /* the box, half a spacing from its walls */
                for (int a = 0; a < 3; ++a) inside &= y[a] >= lo[a] && y[a] <= hi[a];
                int32_t c3[3];
                const int64_t c = inside ? hbk_fluid_grid_cell(lo, s, gd, y, c3) : -1;
                if (c < 0 || !hbk_fluid_shape_distance(shape, ax, dims, f, y, &d, nx) ||
                    !(d < 0.0f) || crowded(pts, head, next, gd, c3, y, s))
                    continue;
                if (n == cap) {
                    cap *= 2;
                    float *p2 = realloc(pts, 3 * cap * sizeof *pts);
                    if (p2) pts = p2;
                    float *n2 = realloc(nrm, 3 * cap * sizeof *nrm);
                    if (n2) nrm = n2;
                    int32_t *x2 = realloc(next, cap * sizeof *next);
                    if (x2) next = x2;
                    if (!p2 || !n2 || !x2) {
                        r = HBK_ERR_OUT_OF_MEMORY;
                        break;
                    }
                }
                memcpy(pts + 3 * n, y, sizeof y);
                memcpy(nrm + 3 * n, nx, sizeof nx);
                next[n] = head[c];
                head[c] = (int32_t)n;
                ++n;
            }
    free(head);
    free(next);
    if (r) {
        free(pts);
        free(nrm);
        return hbk_fail(&h->msg, r, "inflow: out of memory");
    }
    *pts_out = pts;
    *nrm_out = nrm;
    *n_out = n;
    return HBK_OK;
}
