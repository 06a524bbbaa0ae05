/* The inflow: water poured in from a shape, a lattice point at a time as the water before
 * clears it (an emitter, as Blender's own fluids have). */
#include "internal_fluid.h"
#include <stdlib.h>

void hbk_fluid_inflow_free(hbk_fluid_t *h)
{
    free(h->inflow_pts);
    free(h->inflow_pvel);
    free(h->inflow_head);
    free(h->inflow_next);
    h->inflow_pts = h->inflow_pvel = NULL;
    h->inflow_rate = 0.0;
    h->inflow_jitter = 0.0f;
    h->inflow_head = h->inflow_next = NULL;
    h->inflow_n = 0;
}

static void cross(const double x[3], const double y[3], double out[3])
{
    out[0] = x[1] * y[2] - x[2] * y[1];
    out[1] = x[2] * y[0] - x[0] * y[2];
    out[2] = x[0] * y[1] - x[1] * y[0];
}

/* The frame the inflow's lattice is laid in (axes R[3a..3a+2]): the shape's own axes, turned
 * the least way that lays the one nearest the velocity along it (*along). A stream then
 * leaves in whole columns, a spacing apart at rest density, whichever way it pours: on the
 * world's lattice a stream at an angle passes near the points beside its own and keeps them
 * from pouring (a ball at 1 m/s along (1, 1, 1) poured 42% of what it poured along z).
 * Returns 0 for the world's own axes (no velocity, or one along an axis of an unturned
 * shape): fill_box's lattice, as before. */
static int flow_frame(const hbk_fluid_obstacle_t *shape, const float u[3], double R[9],
                      int *along)
{
    float ax[9];
    hbk_fluid_shape_axes(shape, ax);
    for (int i = 0; i < 9; ++i) R[i] = ax[i];
    const double speed = sqrt((double)u[0] * u[0] + (double)u[1] * u[1] + (double)u[2] * u[2]);
    *along = 2;
    if (!(speed > 0.0)) return 0;
    double d[3], dot[3];
    for (int i = 0; i < 3; ++i) d[i] = u[i] / speed;
    for (int b = 0; b < 3; ++b)
        dot[b] = R[3 * b] * d[0] + R[3 * b + 1] * d[1] + R[3 * b + 2] * d[2];
    int m = 0;
    for (int b = 1; b < 3; ++b) m = fabs(dot[b]) > fabs(dot[m]) ? b : m;
    *along = m;
    const double c = fabs(dot[m]);
    if (c >= 1.0 - 1e-12) return shape->type >= 2; /* along that axis already */
    /* Rodrigues: the turn taking `from` (axis m, signed) onto d, about k = from x d (|k| = sin) */
    double from[3], k[3];
    for (int i = 0; i < 3; ++i) from[i] = (dot[m] < 0.0 ? -1.0 : 1.0) * R[3 * m + i];
    cross(from, d, k);
    const double f = 1.0 / (1.0 + c); /* (1 - cos) / sin^2 */
    for (int b = 0; b < 3; ++b) {
        double *v = R + 3 * b, kv[3], kkv[3];
        cross(k, v, kv);
        cross(k, kv, kkv);
        for (int i = 0; i < 3; ++i) v[i] += kv[i] + f * kkv[i];
    }
    return 1;
}

/* The inflow's points: those of its lattice (flow_frame's: fill_box's over the shape's bounds,
 * or one as fine laid in the turned frame R over the same bounds) inside the shape and the box,
 * half a spacing from its walls; counts them into *n, and writes them when pts is set. */
static void lattice(const hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                    const int32_t *dims, const float *f, int turned, const double R[9],
                    float *pts, size_t *n)
{
    const float s = h->p.particle_spacing;
    float lo[3], hi[3];
    hbk_fluid_shape_bounds(shape, lo, hi);
    double a0[3], c[3] = {0, 0, 0}, e[3];
    int32_t m[3];
    if (!turned) {
        hbk_fluid_lattice(h, lo, hi, a0, m);
    } else { /* centred on the clipped bounds, reaching over them along R's axes */
        for (int a = 0; a < 3; ++a) {
            const double l = fmax(lo[a], h->p.box_min[a]), u = fmin(hi[a], h->p.box_max[a]);
            c[a] = 0.5 * (l + u);
            e[a] = 0.5 * (u - l);
        }
        for (int a = 0; a < 3; ++a) {
            double reach = 0.0;
            for (int b = 0; b < 3; ++b) reach += fabs(R[3 * a + b]) * e[b];
            m[a] = e[0] >= 0.0 && e[1] >= 0.0 && e[2] >= 0.0 && 2.0 * reach >= s
                       ? (int32_t)floor((2.0 * reach - s) / s + 1e-6) + 1 : 0;
            a0[a] = -0.5 * (double)(m[a] - 1) * s;
        }
    }
    const float wall = 0.5f * s;
    *n = 0;
    for (int32_t k = 0; k < m[2]; ++k)
        for (int32_t j = 0; j < m[1]; ++j)
            for (int32_t i = 0; i < m[0]; ++i) {
                const int32_t ijk[3] = {i, j, k};
                float x[3];
                if (!turned) {
                    for (int a = 0; a < 3; ++a) x[a] = (float)(a0[a] + (double)ijk[a] * s);
                } else {
                    int inside = 1;
                    for (int b = 0; b < 3; ++b) {
                        double v = c[b];
                        for (int a = 0; a < 3; ++a)
                            v += (a0[a] + (double)ijk[a] * s) * R[3 * a + b];
                        x[b] = (float)v;
                        inside &= x[b] >= h->p.box_min[b] + wall && x[b] <= h->p.box_max[b] - wall;
                    }
                    if (!inside) continue;
                }
                if (!hbk_fluid_in_shape(shape, dims, f, x)) continue;
                if (pts) memcpy(pts + 3 * *n, x, sizeof x);
                ++*n;
            }
}

/* The lattice columns the points make along R's axis `along`: the points' places across it
 * (from the first, in whole spacings), each counted once. */
static int cmp_i64(const void *a, const void *b)
{
    const int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

static int64_t columns(const float *pts, size_t n, const double R[9], int along, float s,
                       int64_t *keys)
{
    if (n == 0) return 0;
    const double *e1 = R + 3 * ((along + 1) % 3), *e2 = R + 3 * ((along + 2) % 3);
    for (size_t i = 0; i < n; ++i) {
        double q1 = 0.0, q2 = 0.0;
        for (int a = 0; a < 3; ++a) {
            const double x = (double)pts[3 * i + (size_t)a] - (double)pts[a];
            q1 += x * e1[a];
            q2 += x * e2[a];
        }
        const int64_t k1 = (int64_t)floor(q1 / s + 0.5), k2 = (int64_t)floor(q2 / s + 0.5);
        keys[i] = k1 * (int64_t)4294967296 + (k2 + (int64_t)2147483648);
    }
    qsort(keys, n, sizeof *keys, cmp_i64);
    int64_t c = 1;
    for (size_t i = 1; i < n; ++i) c += keys[i] != keys[i - 1];
    return c;
}

hbk_result_t hbk_fluid_set_inflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                  const int32_t dims[3], const float *distance,
                                  const float velocity[3], float jitter)
{
    return hbk_fluid_set_inflow_normal(h, shape, dims, distance, velocity, 0.0f, jitter);
}

/* A sprinkler's points and velocities: those of the surface (hbk_fluid_surface_points) whose
 * velocity, `velocity` plus `normal` along the normal, leaves the shape; the others would
 * pour into it. */
static hbk_result_t sprinkler(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                              const int32_t *d, const float *f, const float velocity[3],
                              float normal, float **pts, float **pvel, size_t *n)
{
    float *nrm;
    hbk_result_t r = hbk_fluid_surface_points(h, shape, d, f, pts, &nrm, n);
    if (r) return r;
    size_t kept = 0;
    for (size_t i = 0; i < *n; ++i) {
        const float *e = nrm + 3 * i;
        float u[3];
        for (int a = 0; a < 3; ++a) u[a] = velocity[a] + normal * e[a];
        if (!(u[0] * e[0] + u[1] * e[1] + u[2] * e[2] > 0.0f)) continue;
        memmove(*pts + 3 * kept, *pts + 3 * i, 3 * sizeof **pts);
        memcpy(nrm + 3 * kept, u, sizeof u); /* (nrm now holds the velocities) */
        ++kept;
    }
    *n = kept;
    *pvel = nrm;
    return HBK_OK;
}

/* A column pours each time the particle before has gone a spacing: s / speed without
 * gravity; with it, the t of speed t + g t^2 / 2 = s for g gravity's part along the flow
 * (sooner pouring down, later up; never, for a jet too slow to rise a spacing). */
static double column_rate(const float u[3], const float g[3], double s)
{
    const double speed = sqrt((double)u[0] * u[0] + (double)u[1] * u[1] + (double)u[2] * u[2]);
    if (!(speed > 0.0)) return 0.0;
    const double along = ((double)g[0] * u[0] + (double)g[1] * u[1] + (double)g[2] * u[2]) / speed,
                 disc = speed * speed + 2.0 * along * s;
    return disc > 0.0 ? (speed + sqrt(disc)) / (2.0 * s) : 0.0; /* 1 / t */
}

/* One inflow's points, checked as set_inflow_normal says (the source too): its lattice's (pouring at
 * `velocity`, *pvel NULL) or a sprinkler's (each at its own, in *pvel); *rate its particles a
 * second (hbk_fluid_inflow_rate's). The caller frees *pts and *pvel. */
static hbk_result_t one_inflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                               const int32_t dims[3], const float *distance,
                               const float velocity[3], float normal, float **pts, float **pvel,
                               size_t *n, double *rate)
{
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
    if (!(normal >= 0.0f && normal <= 1000.0f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "normal = %g: must be in [0, 1000] m/s", (double)normal);
    const int32_t *d = shape->type == 3 ? dims : NULL;
    const float *f = shape->type == 3 ? distance : NULL;
    const double s = h->p.particle_spacing;
    *pts = *pvel = NULL;
    *rate = 0.0;
    if (normal > 0.0f) { /* a sprinkler's points pour each along its own velocity */
        r = sprinkler(h, shape, d, f, velocity, normal, pts, pvel, n);
        for (size_t i = 0; !r && i < *n; ++i)
            *rate += column_rate(*pvel + 3 * i, h->p.gravity, s);
        return r;
    }
    double R[9];
    int along = 2;
    const int turned = flow_frame(shape, velocity, R, &along);
    lattice(h, shape, d, f, turned, R, NULL, n);
    if (*n > (size_t)h->p.max_particles) return HBK_OK; /* (refused by the caller) */
    *pts = malloc((3 * *n + 3) * sizeof **pts);
    int64_t *keys = malloc((*n + 1) * sizeof *keys);
    if (!*pts || !keys) {
        free(*pts);
        free(keys);
        *pts = NULL;
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "inflow: out of memory");
    }
    lattice(h, shape, d, f, turned, R, *pts, n);
    /* every column at the one velocity (no velocity: the rate's 0) */
    *rate = (double)columns(*pts, *n, R, along, (float)s, keys) *
            column_rate(velocity, h->p.gravity, s);
    free(keys);
    return HBK_OK;
}

/* Makes `pts` (n points pouring at `vel`, or each at its own in `pvel`) the inflow, with the
 * grid listing the particles near them; takes pts and pvel (freed on failure). */
static hbk_result_t install(hbk_fluid_t *h, float *pts, float *pvel, size_t n,
                            const float vel[3], float jitter, double rate)
{
    if (n > (size_t)h->p.max_particles) {
        free(pts);
        free(pvel);
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "inflow: the shape holds %zu particles at once: must hold at most "
                        "max_particles = %d", n, h->p.max_particles);
    }
    /* Cells of at least two spacings, so that the 27 around a point hold every particle
     * within two spacings of it (the nearest, if it is under s + a substep's travel away),
     * over the points' reach plus their jitter; larger for a thin turned shape whose box
     * holds many more cells than points. */
    const float s = h->p.particle_spacing, reach = 3.0f * s;
    float lo[3] = {0, 0, 0}, hi[3] = {0, 0, 0};
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
        free(pvel);
        free(head);
        if (next != h->inflow_next) free(next);
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "inflow: out of memory");
    }
    free(h->inflow_pts);
    free(h->inflow_pvel);
    free(h->inflow_head);
    h->inflow_pts = pts;
    h->inflow_pvel = pvel;
    h->inflow_head = head;
    h->inflow_next = next;
    h->inflow_n = (int32_t)n;
    h->inflow_rate = rate;
    h->inflow_cell = (float)cell;
    h->inflow_jitter = jitter;
    for (int a = 0; a < 3; ++a) {
        h->inflow_vel[a] = vel[a];
        h->inflow_lo[a] = lo[a] - reach;
        h->inflow_dims[a] = gd[a];
    }
    float top2 = vel[0] * vel[0] + vel[1] * vel[1] + vel[2] * vel[2];
    for (size_t i = 0; pvel && i < n; ++i) {
        const float *u = pvel + 3 * i, u2 = u[0] * u[0] + u[1] * u[1] + u[2] * u[2];
        top2 = u2 > top2 ? u2 : top2;
    }
    h->inflow_top2 = top2;
    return HBK_OK;
}

hbk_result_t hbk_fluid_set_inflow_normal(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                         const int32_t dims[3], const float *distance,
                                         const float velocity[3], float normal, float jitter)
{
    HBK_FLUID_ENTER(h);
    if (!shape) {
        hbk_fluid_inflow_free(h);
        return HBK_OK;
    }
    float *pts, *pvel;
    size_t n;
    double rate;
    hbk_result_t r = one_inflow(h, shape, dims, distance, velocity, normal, &pts, &pvel, &n,
                                &rate);
    if (r) return r;
    if (!(jitter >= 0.0f && jitter <= 0.5f)) {
        free(pts);
        free(pvel);
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "jitter = %g: must be in [0, 0.5]",
                        (double)jitter);
    }
    return install(h, pts, pvel, n, velocity, jitter, rate);
}

hbk_result_t hbk_fluid_add_inflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                  const int32_t dims[3], const float *distance,
                                  const float velocity[3], float normal)
{
    HBK_FLUID_ENTER(h);
    if (!shape) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "shape: must not be NULL");
    float *pts, *pvel;
    size_t n;
    double rate;
    hbk_result_t r = one_inflow(h, shape, dims, distance, velocity, normal, &pts, &pvel, &n,
                                &rate);
    if (r) return r;
    const size_t had = (size_t)h->inflow_n;
    if (had == 0) return install(h, pts, pvel, n, velocity, h->inflow_jitter, rate);
    if (had + n > (size_t)h->p.max_particles) {
        free(pts);
        free(pvel);
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "inflow: the shapes hold %zu particles at once: must hold at most "
                        "max_particles = %d", had + n, h->p.max_particles);
    }
    /* Both sets of points, each with its velocity (a lattice's all at its one). */
    const size_t all = had + n;
    float *apts = malloc((3 * all + 3) * sizeof *apts), *avel = malloc((3 * all + 3) * sizeof *avel);
    if (!apts || !avel) {
        free(pts);
        free(pvel);
        free(apts);
        free(avel);
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "inflow: out of memory");
    }
    memcpy(apts, h->inflow_pts, 3 * had * sizeof *apts);
    memcpy(apts + 3 * had, pts, 3 * n * sizeof *apts);
    for (size_t i = 0; i < all; ++i) {
        const float *u = i < had ? (h->inflow_pvel ? h->inflow_pvel + 3 * i : h->inflow_vel)
                                 : (pvel ? pvel + 3 * (i - had) : velocity);
        memcpy(avel + 3 * i, u, 3 * sizeof *u);
    }
    free(pts);
    free(pvel);
    const float none[3] = {0.0f, 0.0f, 0.0f};
    return install(h, apts, avel, all, none, h->inflow_jitter, h->inflow_rate + rate);
}

int32_t hbk_fluid_inflow_points(const hbk_fluid_t *h) { return h ? h->inflow_n : 0; }

double hbk_fluid_inflow_rate(const hbk_fluid_t *h)
{
    return h && h->inflow_n ? h->inflow_rate : 0.0;
}

int32_t hbk_fluid_inflow_added(const hbk_fluid_t *h, int32_t *capped)
{
    if (capped) *capped = h ? h->inflow_capped : 0;
    return h ? h->inflow_added : 0;
}

/* The cell of x in the inflow's grid, or -1 outside it. */
static inline int64_t cell_of(const hbk_fluid_t *h, const float x[3], int32_t c[3])
{
    return hbk_fluid_grid_cell(h->inflow_lo, h->inflow_cell, h->inflow_dims, x, c);
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
    const int32_t before = h->count;
    for (int32_t i = 0; i < h->inflow_n; ++i) {
        const float *u = h->inflow_pvel ? h->inflow_pvel + 3 * (size_t)i : h->inflow_vel;
        const float speed = sqrtf(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
        float most = (float)(speed * dt); /* the farthest a substep carries it (under s, so
                                           * the nearest, if nearer than s + that, is within
                                           * reach) */
        most = most < s ? most : s;
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
