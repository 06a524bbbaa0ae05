/* The inflow: water poured in from a shape, a lattice point at a time as the water before
 * clears it (an emitter, as Blender's own fluids have). */
#include "internal_fluid.h"
#include <stdlib.h>

void hbk_fluid_inflow_free(hbk_fluid_t *h)
{
    free(h->inflow_pts);
    free(h->inflow_head);
    free(h->inflow_next);
    h->inflow_pts = NULL;
    h->inflow_head = h->inflow_next = NULL;
    h->inflow_n = 0;
}

/* The lattice points of fill_box over the shape's bounds (clipped to the box, half a spacing
 * from its walls) that lie inside it; counts them into *n, and writes them when pts is set. */
static void lattice(const hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                    const int32_t *dims, const float *f, float *pts, size_t *n)
{
    const float s = h->p.particle_spacing;
    float lo[3], hi[3];
    hbk_fluid_shape_bounds(shape, lo, hi);
    double a0[3];
    int32_t m[3];
    hbk_fluid_lattice(h, lo, hi, a0, m);
    *n = 0;
    for (int32_t k = 0; k < m[2]; ++k)
        for (int32_t j = 0; j < m[1]; ++j)
            for (int32_t i = 0; i < m[0]; ++i) {
                const int32_t ijk[3] = {i, j, k};
                float x[3];
                for (int a = 0; a < 3; ++a) x[a] = (float)(a0[a] + (double)ijk[a] * s);
                if (!hbk_fluid_in_shape(shape, dims, f, x)) continue;
                if (pts) memcpy(pts + 3 * *n, x, sizeof x);
                ++*n;
            }
}

hbk_result_t hbk_fluid_set_inflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                  const int32_t dims[3], const float *distance,
                                  const float velocity[3], float jitter)
{
    HBK_FLUID_ENTER(h);
    if (!shape) {
        hbk_fluid_inflow_free(h);
        return HBK_OK;
    }
    if (h->p.source != HBK_FLUID_SIMULATE)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "inflow: source = %d: only the simulation (0) pours an inflow",
                        h->p.source);
    size_t points;
    hbk_result_t r = hbk_fluid_shape_check(h, shape, dims, distance, &points);
    if (r) return r;
    if (!velocity) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "velocity: must not be NULL");
    for (int a = 0; a < 3; ++a)
        if (!(fabsf(velocity[a]) <= 1000.0f))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "velocity[%d] = %g: must be a finite number in [-1000, 1000] m/s", a,
                            (double)velocity[a]);
    if (!(jitter >= 0.0f && jitter <= 0.5f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "jitter = %g: must be in [0, 0.5]",
                        (double)jitter);
    const int32_t *d = shape->type == 3 ? dims : NULL;
    const float *f = shape->type == 3 ? distance : NULL;
    size_t n;
    lattice(h, shape, d, f, NULL, &n);
    if (n > (size_t)h->p.max_particles)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "inflow: the shape holds %zu particles at once: must hold at most "
                        "max_particles = %d", n, h->p.max_particles);
    /* Cells of at least two spacings, so that the 27 around a point hold every particle
     * within two spacings of it (the nearest, if it is under s + a substep's travel away),
     * over the points' reach plus their jitter; larger for a thin turned shape whose box
     * holds many more cells than points. */
    const float s = h->p.particle_spacing, reach = 3.0f * s;
    float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
    float *pts = malloc((3 * n + 3) * sizeof *pts);
    if (!pts) return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "inflow: out of memory");
    lattice(h, shape, d, f, pts, &n);
    for (size_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
            const float x = pts[3 * i + (size_t)a];
            lo[a] = i == 0 || x < lo[a] ? x : lo[a];
            hi[a] = i == 0 || x > hi[a] ? x : hi[a];
        }
    double span = 1.0;
    for (int a = 0; a < 3; ++a) span *= (double)(hi[a] - lo[a] + 2.0f * reach) / s;
    double cell = s * fmax(2.0, cbrt(span / (8.0 * (double)n + 64.0)));
    int32_t gd[3];
    size_t cells = 1;
    for (int a = 0; a < 3; ++a) {
        gd[a] = (int32_t)ceil((hi[a] - lo[a] + 2.0f * reach) / cell) + 1;
        cells *= (size_t)gd[a];
    }
    int32_t *head = malloc((cells + 1) * sizeof *head);
    int32_t *next = h->inflow_next ? h->inflow_next
                                   : malloc((size_t)(h->p.max_particles + 1) * sizeof *next);
    if (!head || !next) {
        free(pts);
        free(head);
        if (next != h->inflow_next) free(next);
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "inflow: out of memory");
    }
    free(h->inflow_pts);
    free(h->inflow_head);
    h->inflow_pts = pts;
    h->inflow_head = head;
    h->inflow_next = next;
    h->inflow_n = (int32_t)n;
    h->inflow_cell = (float)cell;
    h->inflow_jitter = jitter;
    for (int a = 0; a < 3; ++a) {
        h->inflow_vel[a] = velocity[a];
        h->inflow_lo[a] = lo[a] - reach;
        h->inflow_dims[a] = gd[a];
    }
    return HBK_OK;
}

int32_t hbk_fluid_inflow_points(const hbk_fluid_t *h) { return h ? h->inflow_n : 0; }

int32_t hbk_fluid_inflow_added(const hbk_fluid_t *h, int32_t *capped)
{
    if (capped) *capped = h ? h->inflow_capped : 0;
    return h ? h->inflow_added : 0;
}

/* The cell of x in the inflow's grid, or -1 outside it. */
static inline int64_t cell_of(const hbk_fluid_t *h, const float x[3], int32_t c[3])
{
    for (int a = 0; a < 3; ++a) {
        const float t = (x[a] - h->inflow_lo[a]) / h->inflow_cell;
        if (!(t >= 0.0f && t < (float)h->inflow_dims[a])) return -1;
        c[a] = (int32_t)t;
    }
    return c[0] + (int64_t)h->inflow_dims[0] * (c[1] + (int64_t)h->inflow_dims[1] * c[2]);
}

/* A point pours once the water before has left it by a spacing: at a substep's start, the
 * nearest particle is d >= s away. The new one starts d - s further along the flow (at most
 * what one substep carries it), where it would be had it left the moment the point cleared:
 * so a stream's particles follow one another a spacing apart and the tap pours speed x
 * cross-section whatever the substep, not one row per whole number of substeps. */
void hbk_fluid_inflow_emit(hbk_fluid_t *h, int32_t substep, double dt)
{
    if (!h->inflow_n) return;
    const int32_t *gd = h->inflow_dims;
    const size_t cells = (size_t)gd[0] * (size_t)gd[1] * (size_t)gd[2];
    for (size_t c = 0; c < cells; ++c) h->inflow_head[c] = -1;
    /* The particles near the points, listed by cell (the order within a cell does not
     * matter: a point takes the nearest). */
    for (int32_t p = 0; p < h->count; ++p) {
        int32_t c3[3];
        const int64_t c = cell_of(h, h->pos + 3 * (size_t)p, c3);
        if (c < 0) continue;
        h->inflow_next[p] = h->inflow_head[c];
        h->inflow_head[c] = p;
    }
    const float s = h->p.particle_spacing, jit = h->inflow_jitter * s;
    const float *u = h->inflow_vel;
    const float speed = sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    float most = (float)(speed * dt); /* the farthest a substep carries it (under s, so the
                                       * nearest, if nearer than s + that, is within reach) */
    most = most < s ? most : s;
    const int32_t before = h->count;
    for (int32_t i = 0; i < h->inflow_n; ++i) {
        float x[3];
        const uint32_t ctr[4] = {(uint32_t)i, (uint32_t)substep, HBK_FLUID_STREAM_INFLOW,
                                 (uint32_t)h->frame},
                       key[2] = {(uint32_t)h->p.seed, (uint32_t)(h->p.seed >> 32)};
        uint32_t rnd[4];
        hbk_philox4x32(ctr, key, rnd);
        for (int a = 0; a < 3; ++a)
            x[a] = h->inflow_pts[3 * (size_t)i + (size_t)a] +
                   jit * (2.0f * hbk_u32_to_unit(rnd[a]) - 1.0f);
        hbk_fluid_into_box(h, x);
        int32_t c3[3];
        if (cell_of(h, x, c3) < 0 || hbk_fluid_in_obstacle(h, x)) continue;
        float d2 = INFINITY; /* to the nearest particle, from the cells within reach */
        for (int dz = -1; dz <= 1; ++dz)
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx) {
                    const int32_t cx = c3[0] + dx, cy = c3[1] + dy, cz = c3[2] + dz;
                    if (cx < 0 || cy < 0 || cz < 0 || cx >= gd[0] || cy >= gd[1] || cz >= gd[2])
                        continue;
                    const int64_t c = cx + (int64_t)gd[0] * (cy + (int64_t)gd[1] * cz);
                    for (int32_t p = h->inflow_head[c]; p >= 0; p = h->inflow_next[p]) {
                        const float *y = h->pos + 3 * (size_t)p;
                        const float d0 = y[0] - x[0], d1 = y[1] - x[1], d2_ = y[2] - x[2];
                        const float r2 = d0 * d0 + d1 * d1 + d2_ * d2_;
                        d2 = r2 < d2 ? r2 : d2;
                    }
                }
        if (d2 < s * s) continue;
        if (h->count >= h->p.max_particles) { /* a point was ready: the room ran out */
            h->inflow_capped = 1;
            break;
        }
        /* (nothing within the cells' reach, 2 s: the first of a stream, a substep's travel) */
        float ahead = sqrtf(d2) - s;
        ahead = ahead < most ? ahead : most;
        const float k = speed > 0.0f ? ahead / speed : 0.0f;
        for (int a = 0; a < 3; ++a) x[a] += k * u[a];
        hbk_fluid_into_box(h, x);
        memcpy(h->pos + 3 * (size_t)h->count, x, sizeof x);
        memcpy(h->vel + 3 * (size_t)h->count, u, 3 * sizeof *u);
        ++h->count;
    }
    h->inflow_added += h->count - before;
}
