/* Fluid handle: life cycle, inputs, the frame step and the volume getters. */
#include "internal_fluid.h"
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void vols_free(hbk_fluid_vols_t *v)
{
    free(v->uvw[0]); free(v->uvw[1]); free(v->wrap[0]); free(v->wrap[1]);
    free(v->base); free(v->paint); free(v->life); free(v->unpainted);
    memset(v, 0, sizeof *v);
}

static int vols_alloc(hbk_fluid_vols_t *v, size_t nv, size_t nvox, size_t rows, int K)
{
    /* Sampled fields get 4 floats of padding: samplers load 4 floats at a time. */
    v->uvw[0] = calloc(3 * nv + 4, sizeof(float));
    v->uvw[1] = calloc(3 * nv + 4, sizeof(float));
    v->wrap[0] = malloc(nvox);
    v->wrap[1] = malloc(nvox);
    v->base = calloc((size_t)K * nv + 4, sizeof(float));
    v->paint = calloc((size_t)K * nv + 4, sizeof(float));
    v->life = calloc(nv + 4, sizeof(float));
    v->unpainted = calloc(rows, 1);
    return v->uvw[0] && v->uvw[1] && v->wrap[0] && v->wrap[1] && v->base && v->paint && v->life &&
           v->unpainted;
}

/* Kernel sum of a cubic lattice of spacing s around one of its points: sets the mass so that
 * the lattice is exactly at rest density (poly6 for the fields, spiky for the SPH step). */
static double lattice_sum(double s, double H, double (*kernel)(double, double))
{
    const int n = (int)ceil(H / s);
    double sum = 0.0;
    for (int k = -n; k <= n; ++k)
        for (int j = -n; j <= n; ++j)
            for (int i = -n; i <= n; ++i)
                sum += kernel(s * s * (double)(i * i + j * j + k * k), H);
    return sum;
}

void hbk_fluid_destroy(hbk_fluid_t *h)
{
    if (!h) return;
    free(h->pos); free(h->vel); free(h->pos0); free(h->vel0);
    free(h->in_vel); free(h->in_surface);
    hbk_fluid_inflow_free(h);
    hbk_fluid_outflow_free(h);
    hbk_fluid_fields_free(h);
    vols_free(&h->v);
    vols_free(&h->scratch);
    free(h->motion); free(h->density); free(h->surface); free(h->features);
    free(h->g_motion); free(h->g_density); free(h->g_surface); free(h->g_features);
    free(h->g_normal);
    free(h->g_sums);
    free(h->splat_ylo);
    free(h->splat_yhi);
    free(h->moving);
    free(h->rule_tex);
    free(h->row_flags);
    free(h->same_vox);
    free(h->sorted);
    free(h->soa);
    free(h->nbr);
    hbk_fluid_cells_free(&h->cells);
    free(h->mesh_pos); free(h->mesh_nrm); free(h->mesh_tri);
    free(h->next_pos); free(h->next_nrm); free(h->next_tri);
    free(h->mc_mask); free(h->mc_in); free(h->mc_row_in); free(h->mc_cfg);
    free(h->mc_first); free(h->mc_row_v); free(h->mc_row_t); free(h->mc_table);
    free(h);
}

/* The splat's four sums (g_wsum, g_mp) in one block, each array starting 64 bytes further
 * into a 4 KB page than the one before. Apart, they all started 16 bytes into one (large
 * mallocs are mapped pages). An Intel core first matches a load against the stores before it
 * by address bits 0-11, so it held each row's load of one sum behind the store to another at
 * the same index (4K aliasing): the splat was about a fifth slower (docs/fluid_performance.md). */
static void sums_alloc(hbk_fluid_t *h, size_t nv)
{
    const size_t stagger = 64 / sizeof(float);
    const size_t page = 4096 / sizeof(float), span = (nv + page - 1) / page * page;
    const size_t n = 4 * span + (4 * stagger + page - 1) / page * page; /* whole pages */
    h->g_sums = aligned_alloc(4096, n * sizeof(float));
    if (!h->g_sums) return;
    h->g_wsum = h->g_sums;
    for (int a = 0; a < 3; ++a) h->g_mp[a] = h->g_sums + (size_t)(a + 1) * (span + stagger);
}

hbk_result_t hbk_fluid_create(hbk_fluid_t **out, const hbk_fluid_params_t *p, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!out) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out: must not be NULL");
    *out = NULL;
    hbk_result_t r = hbk_fluid_params_check(p, msg);
    if (r) return r;
    hbk_fluid_t *h = calloc(1, sizeof *h);
    if (!h) return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "fluid handle: out of memory");
    h->p = *p;
    h->K = p->textures;
    h->n_vert = h->n_vox = 1;
    for (int a = 0; a < 3; ++a) {
        h->nv[a] = p->resolution[a] + 1;
        h->n_vert *= (size_t)h->nv[a];
        h->n_vox *= (size_t)p->resolution[a];
        h->cell[a] = (p->box_max[a] - p->box_min[a]) / (float)p->resolution[a];
        h->inv_cell[a] = 1.0f / h->cell[a];
    }
    h->mass = p->rest_density / lattice_sum(p->particle_spacing, p->smoothing_length, hbk_poly6);
    h->sph_mass = p->rest_density / lattice_sum(p->particle_spacing, p->smoothing_length, hbk_spiky);
    const size_t np = p->max_particles > 0 ? (size_t)p->max_particles : 1, nv = h->n_vert;
    const int F = HBK_FLUID_FEATURE_COUNT;
    h->pos = malloc(3 * np * sizeof(float));
    h->vel = malloc(3 * np * sizeof(float));
    h->pos0 = malloc(3 * np * sizeof(float));
    h->vel0 = malloc(3 * np * sizeof(float));
    h->sorted = malloc(8 * np * sizeof(float));
    h->soa = calloc(8 * (np + 8), sizeof(float)); /* padded: lanes read 8 at a time */
    h->motion = calloc(3 * nv + 4, sizeof(float)); /* padded as uvw */
    h->density = calloc(nv, sizeof(float));
    h->surface = calloc(nv, sizeof(float));
    h->features = calloc((size_t)F * nv, sizeof(float));
    h->g_motion = calloc(3 * nv + 4, sizeof(float));
    h->g_density = malloc(nv * sizeof(float));
    h->g_surface = malloc(nv * sizeof(float));
    h->g_features = malloc((size_t)F * nv * sizeof(float));
    h->g_normal = malloc(3 * nv * sizeof(float));
    sums_alloc(h, nv);
    h->splat_ylo = malloc((size_t)h->nv[2] * sizeof(int32_t));
    h->splat_yhi = malloc((size_t)h->nv[2] * sizeof(int32_t));
    h->moving = malloc(nv);
    h->rule_tex = calloc(nv + 16, 1); /* + 16: the advection loads sixteen at a time */
    const size_t rows = h->n_rows = (size_t)h->nv[1] * (size_t)h->nv[2];
    h->row_flags = calloc(9, rows);
    if (h->row_flags) {
        h->blank = h->row_flags;
        h->g_blank = h->row_flags + rows;
        h->fz = h->row_flags + 2 * rows;
        h->g_fz = h->row_flags + 3 * rows;
        h->fq = h->row_flags + 4 * rows;
        h->g_fq = h->row_flags + 5 * rows;
        h->quiet = h->row_flags + 6 * rows;
        h->same_rows = h->row_flags + 7 * rows;
        h->rows_hot = h->row_flags + 8 * rows;
        memset(h->rows_hot, 0xff, rows);
        memset(h->blank, 1, rows); /* h->density, motion and surface start zeroed */
        memset(h->fz, 1, rows);
    }
    h->same_vox = calloc((size_t)p->resolution[1] * (size_t)p->resolution[2], 1);
    h->disp = h->g_normal; /* the features are done with it before the advection */
    if (!h->pos || !h->vel || !h->pos0 || !h->vel0 || !h->sorted || !h->soa || !h->motion ||
        !h->density || !h->surface || !h->features || !h->g_motion || !h->g_density ||
        !h->g_surface || !h->g_features || !h->g_normal || !h->g_sums ||
        !h->splat_ylo || !h->splat_yhi || !h->row_flags ||
        !h->moving || !h->rule_tex || !h->same_vox || !vols_alloc(&h->v, nv, h->n_vox, rows, h->K) ||
        !vols_alloc(&h->scratch, nv, h->n_vox, rows, h->K)) {
        hbk_fluid_destroy(h);
        return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "fluid volumes %d x %d x %d: out of memory",
                        p->resolution[0], p->resolution[1], p->resolution[2]);
    }
    const int threads = HBK_OMP_THREADS(h);
    hbk_fluid_splat_rows(h, 1); /* the sum buffers hold garbage */
    /* Every page of the fields now. A row no particle reaches is not written (blank, quiet),
     * so the buffers that start zeroed (calloc: no page touched) were touched row by row as a
     * splash first reached them, every other frame as the buffers swap; a first touch costs
     * 1.4-5 us a page on this VM, and such frames took 45 ms for the fields against 25 (128^3
     * dam break). Here, once, it is about 0.1 s. */
    const struct { void *p; size_t n; } fields[] = {
        {h->motion, 3 * nv}, {h->g_motion, 3 * nv}, {h->density, nv}, {h->g_density, nv},
        {h->surface, nv}, {h->g_surface, nv}, {h->features, (size_t)F * nv},
        {h->g_features, (size_t)F * nv}, {h->g_normal, 3 * nv}, {h->g_wsum, nv},
        {h->g_mp[0], nv}, {h->g_mp[1], nv}, {h->g_mp[2], nv}};
    for (size_t k = 0; k < sizeof fields / sizeof fields[0]; ++k)
        memset(fields[k].p, 0, fields[k].n * sizeof(float));
    hbk_fluid_reset_uvw(h, h->v.uvw[0], h->v.wrap[0], threads);
    memcpy(h->v.uvw[1], h->v.uvw[0], 3 * nv * sizeof(float));
    memcpy(h->v.wrap[1], h->v.wrap[0], h->n_vox);
    for (size_t i = 0; i < nv; ++i)
        for (int t = 0; t < h->K; ++t) h->v.base[(size_t)h->K * i + (size_t)t] = t == p->default_texture;
    *out = h;
    return HBK_OK;
}

const char *hbk_fluid_message(const hbk_fluid_t *h) { return h ? h->msg.text : "handle is NULL"; }

/* Every value finite and, for positions, inside the box. */
static hbk_result_t check_vectors(hbk_fluid_t *h, const float *v, size_t n, const char *name,
                                  int in_box, float lim)
{
    for (size_t i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
            const float x = v[3 * i + (size_t)a];
            const float lo = in_box ? h->p.box_min[a] : -lim, hi = in_box ? h->p.box_max[a] : lim;
            if (!(x >= lo && x <= hi))
                return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                                "%s[%zu][%d] = %g: must be a finite number in [%g, %g]", name, i, a,
                                (double)x, (double)lo, (double)hi);
        }
    return HBK_OK;
}

hbk_result_t hbk_fluid_set_particles(hbk_fluid_t *h, const float *pos, const float *vel,
                                     int32_t count)
{
    HBK_FLUID_ENTER(h);
    if (count < 0 || count > h->p.max_particles)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "count = %d: must be in [0, %d] "
                        "(max_particles)", count, h->p.max_particles);
    if (count > 0 && !pos)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "pos: must not be NULL");
    hbk_result_t r = check_vectors(h, pos, (size_t)count, "pos", 1, 0);
    if (r || (vel && (r = check_vectors(h, vel, (size_t)count, "vel", 0, 1e4f)))) return r;
    memcpy(h->pos, pos, 3 * (size_t)count * sizeof(float));
    if (vel) memcpy(h->vel, vel, 3 * (size_t)count * sizeof(float));
    else memset(h->vel, 0, 3 * (size_t)count * sizeof(float));
    h->count = count;
    return HBK_OK;
}

/* Adds the lattice of particle_spacing over [lo, hi] (clipped to the box, half a spacing from
 * its walls), jittered, at rest: the points outside the obstacles and, with a shape, inside
 * it (a mesh's field: dims and f). `what` names the call in its errors. */
static hbk_result_t fill(hbk_fluid_t *h, const float lo[3], const float hi[3], float jitter,
                         const char *what, const hbk_fluid_obstacle_t *shape,
                         const int32_t *dims, const float *f)
{
    if (!(jitter >= 0.0f && jitter <= 0.5f))
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "jitter = %g: must be in [0, 0.5]",
                        (double)jitter);
    hbk_result_t ready = hbk_fluid_fields_ready(h, what);
    if (ready) return ready;
    const float s = h->p.particle_spacing;
    for (int a = 0; a < 3; ++a)
        if (!isfinite(lo[a]) || !isfinite(hi[a]))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "lo[%d], hi[%d]: must be finite", a, a);
    double a0[3];
    int32_t n[3];
    hbk_fluid_lattice(h, lo, hi, a0, n);
    /* Two passes, the first counting: lattice points inside an obstacle are left out (there
     * the collision would throw them out at once, a burst of spray at the first step), and
     * the rest must fit. Each point's jitter is keyed by its place in the lattice. */
    size_t at = (size_t)h->count;
    for (int pass = 0; pass < 2; ++pass) {
        size_t lattice = (size_t)h->count;
        at = (size_t)h->count;
        for (int32_t k = 0; k < n[2]; ++k)
            for (int32_t j = 0; j < n[1]; ++j)
                for (int32_t i = 0; i < n[0]; ++i, ++lattice) {
                    uint32_t rnd[4];
                    hbk_philox(h->p.seed, HBK_FLUID_STREAM_JITTER, (uint64_t)lattice, rnd);
                    const int32_t ijk[3] = {i, j, k};
                    float x[3];
                    for (int a = 0; a < 3; ++a) {
                        const float jit = jitter * s * (2.0f * hbk_u32_to_unit(rnd[a]) - 1.0f);
                        x[a] = (float)(a0[a] + (double)ijk[a] * s) + jit;
                    }
                    hbk_fluid_into_box(h, x);
                    if (hbk_fluid_in_obstacle(h, x)) continue;
                    if (shape && !hbk_fluid_in_shape(shape, dims, f, x)) continue;
                    if (pass)
                        for (int a = 0; a < 3; ++a) {
                            h->pos[3 * at + (size_t)a] = x[a];
                            h->vel[3 * at + (size_t)a] = 0.0f;
                        }
                    ++at;
                }
        if (!pass && at > (size_t)h->p.max_particles)
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "%s: %zu particles plus the %d present exceed max_particles = %d",
                            what, at - (size_t)h->count, h->count, h->p.max_particles);
    }
    h->count = (int32_t)at;
    return HBK_OK;
}

hbk_result_t hbk_fluid_fill_box(hbk_fluid_t *h, const float lo[3], const float hi[3], float jitter)
{
    HBK_FLUID_ENTER(h);
    if (!lo || !hi) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "lo, hi: must not be NULL");
    return fill(h, lo, hi, jitter, "fill_box", NULL, NULL, NULL);
}

hbk_result_t hbk_fluid_fill_shape(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                  const int32_t dims[3], const float *distance, float jitter)
{
    HBK_FLUID_ENTER(h);
    if (!shape) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "shape: must not be NULL");
    size_t points;
    hbk_result_t r = hbk_fluid_shape_check(h, shape, dims, distance, &points);
    if (r) return r;
    float lo[3], hi[3];
    hbk_fluid_shape_bounds(shape, lo, hi);
    return fill(h, lo, hi, jitter, "fill_shape", shape, shape->type == 3 ? dims : NULL,
                shape->type == 3 ? distance : NULL);
}

int32_t hbk_fluid_particle_count(const hbk_fluid_t *h) { return h ? h->count : 0; }

hbk_result_t hbk_fluid_get_particles(hbk_fluid_t *h, float *pos, float *vel, int32_t capacity)
{
    HBK_FLUID_ENTER(h);
    if (capacity < h->count)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "capacity = %d: must be >= particle count %d", capacity, h->count);
    if (pos) memcpy(pos, h->pos, 3 * (size_t)h->count * sizeof(float));
    if (vel) memcpy(vel, h->vel, 3 * (size_t)h->count * sizeof(float));
    return HBK_OK;
}

hbk_result_t hbk_fluid_set_velocity_grid(hbk_fluid_t *h, const float *velocity, const float *surface)
{
    HBK_FLUID_ENTER(h);
    const size_t nv = h->n_vert;
    if (!velocity) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "velocity: must not be NULL");
    hbk_result_t r = check_vectors(h, velocity, nv, "velocity", 0, 1e4f);
    if (r) return r;
    if (surface)
        for (size_t i = 0; i < nv; ++i)
            if (!(fabsf(surface[i]) <= 1e9f))
                return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                                "surface[%zu] = %g: must be a finite number in [-1e9, 1e9]",
                                i, (double)surface[i]);
    if (!h->in_vel && !(h->in_vel = malloc(3 * nv * sizeof(float))))
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "velocity: out of memory");
    if (surface && !h->in_surface && !(h->in_surface = malloc(nv * sizeof(float))))
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "surface: out of memory");
    memcpy(h->in_vel, velocity, 3 * nv * sizeof(float));
    if (surface) memcpy(h->in_surface, surface, nv * sizeof(float));
    else { free(h->in_surface); h->in_surface = NULL; }
    return HBK_OK;
}

size_t hbk_fluid_grid_vertices(const hbk_fluid_t *h, int32_t vertices[3])
{
    if (!h) return 0;
    if (vertices) for (int a = 0; a < 3; ++a) vertices[a] = h->nv[a];
    return h->n_vert;
}

uint64_t hbk_fluid_frame(const hbk_fluid_t *h) { return h ? h->frame : 0; }

/* g_density, g_motion (clamped), g_surface and g_features from the current input. */
static hbk_result_t build_fields(hbk_fluid_t *h, int threads)
{
    const size_t nv = h->n_vert;
    if (h->p.source == HBK_FLUID_VELOCITY_GRID) {
        const float vmax = hbk_fluid_vmax(h);
        hbk_fluid_splat_rows(h, 1); /* put_motion writes every plane */
        memset(h->g_blank, 0, h->n_rows);
#pragma omp parallel for num_threads(threads) schedule(static)
        for (size_t i = 0; i < nv; ++i) {
            float v[3] = {0.0f, 0.0f, 0.0f};
            if (h->in_vel) memcpy(v, h->in_vel + 3 * i, sizeof v);
            hbk_fluid_put_motion(h, i, v, vmax);
        }
        if (h->in_surface) {
            memcpy(h->g_surface, h->in_surface, nv * sizeof(float));
            memcpy(h->g_density, h->in_surface, nv * sizeof(float));
        } else {
            memset(h->g_surface, 0, nv * sizeof(float));
            memset(h->g_density, 0, nv * sizeof(float));
        }
    } else {
        hbk_result_t r = hbk_fluid_particles_to_grid(h, threads);
        if (r) return hbk_fail(&h->msg, r, "particle grid: out of memory");
    }
    hbk_fluid_features(h, threads);
    return HBK_OK;
}

static void swap_f(float **a, float **b) { float *t = *a; *a = *b; *b = t; }
static void swap_u8(uint8_t **a, uint8_t **b) { uint8_t *t = *a; *a = *b; *b = t; }

static void commit_fields(hbk_fluid_t *h)
{
    swap_f(&h->motion, &h->g_motion);
    swap_f(&h->density, &h->g_density);
    swap_f(&h->surface, &h->g_surface);
    swap_f(&h->features, &h->g_features);
    swap_u8(&h->blank, &h->g_blank);
    swap_u8(&h->fz, &h->g_fz);
    swap_u8(&h->fq, &h->g_fq);
    h->have_fields = 1;
}

hbk_result_t hbk_fluid_update_fields(hbk_fluid_t *h)
{
    HBK_FLUID_ENTER(h);
    const int threads = HBK_OMP_THREADS(h);
    const int had = h->have_fields;
    h->have_fields = 0; /* no time passes: the rates are zero */
    hbk_result_t r = build_fields(h, threads);
    h->have_fields = had;
    if (r) return r;
    commit_fields(h);
    return HBK_OK;
}

/* The particles as the step found them (`count` of them: those an inflow added go, those an
 * outflow took come back). */
static void restore_particles(hbk_fluid_t *h, int sim, int32_t count)
{
    if (!sim) return;
    h->count = count;
    h->inflow_added = h->inflow_capped = h->outflow_removed = 0;
    memcpy(h->pos, h->pos0, 3 * (size_t)h->count * sizeof(float));
    memcpy(h->vel, h->vel0, 3 * (size_t)h->count * sizeof(float));
}

hbk_result_t hbk_fluid_step(hbk_fluid_t *h, hbk_progress_t *progress)
{
    HBK_FLUID_ENTER(h);
    const int threads = HBK_OMP_THREADS(h);
    const int sim = h->p.source == HBK_FLUID_SIMULATE;
    if (sim) {
        hbk_result_t ready = hbk_fluid_fields_ready(h, "step");
        if (ready) return ready;
    }
    double t0 = omp_get_wtime();
    hbk_report(progress, 0.0f);
    int32_t taken = 0;
    const int32_t count0 = h->count;
    h->inflow_added = h->inflow_capped = h->outflow_removed = 0;
    if (sim) {
        memcpy(h->pos0, h->pos, 3 * (size_t)h->count * sizeof(float));
        memcpy(h->vel0, h->vel, 3 * (size_t)h->count * sizeof(float));
        /* The rest of the frame is cut into equal steps, each no longer than the stable step
         * for the particles' speeds now; at least `substeps` of them. */
        const double frame_dt = h->p.dt, longest = frame_dt / h->p.substeps;
        double left = frame_dt;
        hbk_fluid_obstacles_at(h, 0.0); /* their speed, for the stable step */
        while (left > 0.0) {
            if (hbk_cancelled(progress)) {
                restore_particles(h, sim, count0);
                return hbk_fail(&h->msg, HBK_ERR_CANCELLED, "step: cancelled");
            }
            double step = hbk_fluid_sph_stable_dt(h, threads);
            step = step < longest ? step : longest;
            double parts = ceil(left / step * (1.0 - 1e-9)); /* no extra step for rounding */
            const double room = (double)(HBK_FLUID_MAX_SUBSTEPS - taken);
            parts = parts < 1.0 ? 1.0 : parts > room ? room : parts;
            step = parts == 1.0 ? left : left / parts;
            hbk_fluid_inflow_emit(h, taken, step); /* (its speed counted for the step) */
            /* collide places the particles at the substep's end: the obstacles too */
            hbk_fluid_obstacles_at(h, parts == 1.0 ? 1.0 : (frame_dt - (left - step)) / frame_dt);
            hbk_result_t r = hbk_fluid_sph_substep(h, (float)step, threads);
            if (r) {
                restore_particles(h, sim, count0);
                return hbk_fail(&h->msg, r, "SPH: out of memory");
            }
            hbk_fluid_outflow_drain(h);
            left = parts == 1.0 ? 0.0 : left - step;
            ++taken;
            hbk_report(progress, 0.7f * (float)(1.0 - left / frame_dt));
        }
    }
    double t1 = omp_get_wtime();
    hbk_result_t r = build_fields(h, threads);
    if (r) { restore_particles(h, sim, count0); return r; }
    double t2 = omp_get_wtime();
    if (hbk_cancelled(progress)) {
        restore_particles(h, sim, count0);
        return hbk_fail(&h->msg, HBK_ERR_CANCELLED, "step: cancelled");
    }
    hbk_report(progress, 0.8f);
    /* Advect with the new V_m: the swap makes it h->motion for the advection; undone on
     * cancel below. */
    swap_f(&h->motion, &h->g_motion);
    hbk_fluid_advect(h, h->p.dt, threads);
    swap_f(&h->motion, &h->g_motion);
    hbk_fluid_vols_t *n = &h->scratch;
    const uint64_t frame = h->frame + 1, P = hbk_fluid_period_frames(&h->p);
    const int reset_a = P && frame % P == 0, reset_b = P && frame % P == P / 2;
    if (reset_a) hbk_fluid_reset_uvw(h, n->uvw[0], n->wrap[0], threads);
    if (reset_b) hbk_fluid_reset_uvw(h, n->uvw[1], n->wrap[1], threads);
    if (reset_a || reset_b) hbk_fluid_vols_differ(h);
    int paint_active = h->paint_active;
    if (paint_active) {
        int any = 0;
        const float dt = h->p.dt;
        const size_t nx = (size_t)h->nv[0];
        /* by rows: a row the advection found clean stays so (most of the box) */
#pragma omp parallel for num_threads(threads) schedule(static) reduction(| : any)
        for (size_t r = 0; r < h->n_rows; ++r) {
            if (n->unpainted[r]) continue;
            for (size_t i = r * nx; i < (r + 1) * nx; ++i) {
                const float l = n->life[i] - dt;
                n->life[i] = l > 0.0f ? l : 0.0f;
                any |= l > 0.0f;
            }
        }
        paint_active = any;
    }
    double t3 = omp_get_wtime();
    if (hbk_cancelled(progress)) {
        restore_particles(h, sim, count0);
        return hbk_fail(&h->msg, HBK_ERR_CANCELLED, "step: cancelled");
    }
    hbk_fluid_vols_t tmp = h->v;
    h->v = h->scratch;
    h->scratch = tmp;
    commit_fields(h);
    if (sim) hbk_fluid_obstacles_moved(h);
    if (h->paint_active && !paint_active) hbk_fluid_paint_off(h); /* the last paint faded */
    h->paint_active = paint_active;
    h->frame = frame;
    h->substeps_taken = taken;
    h->ms[0] = (t1 - t0) * 1e3;
    h->ms[1] = (t2 - t1) * 1e3;
    h->ms[2] = (t3 - t2) * 1e3;
    hbk_report(progress, 1.0f);
    return HBK_OK;
}

int32_t hbk_fluid_substeps_taken(const hbk_fluid_t *h) { return h ? h->substeps_taken : 0; }

void hbk_fluid_timings(const hbk_fluid_t *h, double ms[4])
{
    if (!ms) return;
    for (int i = 0; i < 4; ++i) ms[i] = h ? h->ms[i] : 0.0;
}

float hbk_fluid_uvw_weight(const hbk_fluid_t *h) { return h ? hbk_fluid_weight_at(&h->p, h->frame) : 0.0f; }

size_t hbk_fluid_volume_size(const hbk_fluid_t *h, int32_t volume)
{
    if (!h) return 0;
    switch (volume) {
    case HBK_FLUID_VOL_UVW_A: case HBK_FLUID_VOL_UVW_B: case HBK_FLUID_VOL_MOTION:
    case HBK_FLUID_VOL_UVW_A_UNWRAPPED: case HBK_FLUID_VOL_UVW_B_UNWRAPPED: return 3 * h->n_vert;
    case HBK_FLUID_VOL_BLEND: return (size_t)h->K * h->n_vert;
    case HBK_FLUID_VOL_DENSITY: case HBK_FLUID_VOL_SURFACE: case HBK_FLUID_VOL_UVW_WEIGHT:
        return h->n_vert;
    case HBK_FLUID_VOL_FEATURES: return (size_t)HBK_FLUID_FEATURE_COUNT * h->n_vert;
    case HBK_FLUID_VOL_WRAP: case HBK_FLUID_VOL_WRAP_B: return 3 * h->n_vox;
    default: return 0;
    }
}

hbk_result_t hbk_fluid_get_volume(hbk_fluid_t *h, int32_t volume, float *out, size_t count)
{
    HBK_FLUID_ENTER(h);
    const size_t need = hbk_fluid_volume_size(h, volume);
    if (!need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "volume = %d: must be in [0, %d]",
                        volume, HBK_FLUID_VOL_COUNT - 1);
    if (!out) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "out: must not be NULL");
    if (count != need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "count = %zu: volume %d needs exactly %zu floats", count, volume, need);
    const float *src = NULL;
    switch (volume) {
    case HBK_FLUID_VOL_UVW_A: src = h->v.uvw[0]; break;
    case HBK_FLUID_VOL_UVW_B: src = h->v.uvw[1]; break;
    case HBK_FLUID_VOL_MOTION: src = h->motion; break;
    case HBK_FLUID_VOL_DENSITY: src = h->density; break;
    case HBK_FLUID_VOL_SURFACE: src = h->surface; break;
    case HBK_FLUID_VOL_FEATURES: src = h->features; break;
    case HBK_FLUID_VOL_UVW_WEIGHT:
        hbk_fluid_weights(h, out, HBK_OMP_THREADS(h));
        return HBK_OK;
    case HBK_FLUID_VOL_UVW_A_UNWRAPPED: case HBK_FLUID_VOL_UVW_B_UNWRAPPED:
        hbk_fluid_uvw_unwrapped(h, h->v.uvw[volume == HBK_FLUID_VOL_UVW_A_UNWRAPPED ? 0 : 1], out,
                                HBK_OMP_THREADS(h));
        return HBK_OK;
    case HBK_FLUID_VOL_BLEND:
        for (size_t i = 0; i < h->n_vert; ++i)
            hbk_fluid_blend_at(h, h->v.base, h->v.paint, h->v.life, i, out + (size_t)h->K * i);
        return HBK_OK;
    default: {
        const uint8_t *w = h->v.wrap[volume == HBK_FLUID_VOL_WRAP ? 0 : 1];
        for (size_t i = 0; i < h->n_vox; ++i)
            for (int a = 0; a < 3; ++a) out[3 * i + (size_t)a] = (float)((w[i] >> a) & 1u);
        return HBK_OK;
    }
    }
    memcpy(out, src, need * sizeof(float));
    return HBK_OK;
}

hbk_result_t hbk_fluid_sample_uvw(hbk_fluid_t *h, int32_t which, const float pos[3], float uvw[3])
{
    HBK_FLUID_ENTER(h);
    if (which != 0 && which != 1)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "which = %d: must be 0 (A) or 1 (B)", which);
    if (!pos || !uvw) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "pos, uvw: must not be NULL");
    float x[3];
    hbk_fluid_grid_coords(h, pos, x);
    hbk_fluid_sample_wrapped(h, h->v.uvw[which], h->v.wrap[which], x, uvw);
    return HBK_OK;
}
