/* The water solver: Kass & Miller's implicit height-field scheme in conservative flux form.
 *
 * Along one line (a row for x, a column for y) with faces k between cells k and k+1, one step
 * of length dt with theta = implicitness solves for the surface change delta:
 *     u_k(n)  = a_k - G theta (H_j(n) - H_i(n)),   a_k = damp (u_k + dt Ua_k)
 *                                                        - G (1 - theta) (H_j - H_i)
 *     q_k     = (dt/dx) w_k (theta u_k(n) + (1 - theta) u_k)            (flux, m of depth)
 *     d_i(n)  = d_i - q_k(right of i) + q_k(left of i)
 * with G = g dt/dx and the head H = b + d + footprint. Eliminating u gives the paper's matrix
 * A = I + theta^2 g dt^2/dx^2 L(w): e_k = 1 + c (w_left + w_right), f_k = -c w_k, exactly the
 * e/f of the paper with its (d_k + d_k+1)/2 replaced by the face depth w_k (below). Theta = 1
 * is Kass & Miller's scheme. The paper's second system B (for u) has the same solution as the
 * u_k(n) line above, which we evaluate directly instead of solving B: it saves a solve and keeps
 * u and d exactly consistent, which conservation needs.
 *
 * Conservation and wet/dry: d is updated only through the fluxes q (each leaves one cell and
 * enters the other), so the total depth changes by rounding only. The face depth is the water
 * above the higher of the two grounds, w = max(h_i, h_j) - max(b_i, b_j), clamped at 0 (the
 * usual wet/dry rule of flood models): no flow from a pool into higher dry ground, water runs
 * onto lower dry ground and down slopes. A cell whose outflows would exceed its depth has them
 * scaled down to exactly its depth, so d never goes negative. */
#include "internal_water.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

enum { S_B, S_D, S_U, S_ACC, S_FOOT, S_H, S_W, S_A, S_S, S_DIAG, S_OFF, S_RHS, S_X, S_CP,
       S_Z, S_BB, S_Q, S_SCALE, S_COUNT };

size_t hbk_water_line_scratch(int32_t n) { return (size_t)S_COUNT * (size_t)n; }

typedef struct {
    double dt, G, c, k, theta, damp, wind;
    int periodic, has_acc, has_foot;
} line_coef_t;

/* Thomas algorithm for the symmetric tridiagonal system (diag, off[k] between k and k+1):
 * factor once (cp, and ib = 1 / pivot), then solve for any right-hand side. */
static void thomas_factor(int32_t n, const double *diag, const double *off, double *cp, double *ib)
{
    ib[0] = 1.0 / diag[0];
    for (int32_t i = 1; i < n; ++i) {
        cp[i] = off[i - 1] * ib[i - 1];
        ib[i] = 1.0 / (diag[i] - off[i - 1] * cp[i]);
    }
}

static void thomas_solve(int32_t n, const double *off, const double *cp, const double *ib,
                         const double *r, double *x)
{
    x[0] = r[0] * ib[0];
    for (int32_t i = 1; i < n; ++i) x[i] = (r[i] - off[i - 1] * x[i - 1]) * ib[i];
    for (int32_t i = n - 2; i >= 0; --i) x[i] -= cp[i + 1] * x[i + 1];
}

/* The same with corner entries off[n-1] (periodic), by Sherman-Morrison: one factorisation,
 * two solves. */
static void thomas_cyclic(int32_t n, const double *diag, const double *off, const double *r,
                          double *x, double *s)
{
    double *cp = s + S_CP * (size_t)n, *ib = s + S_BB * (size_t)n;
    const double cc = off[n - 1];
    if (cc == 0.0) {
        thomas_factor(n, diag, off, cp, ib);
        thomas_solve(n, off, cp, ib, r, x);
        return;
    }
    double *bb = s + S_Z * (size_t)n, *u = s + S_SCALE * (size_t)n, *z = s + S_Q * (size_t)n;
    const double gamma = -diag[0];
    memcpy(bb, diag, (size_t)n * sizeof *bb);
    bb[0] = diag[0] - gamma;
    bb[n - 1] = diag[n - 1] - cc * cc / gamma;
    thomas_factor(n, bb, off, cp, ib);
    thomas_solve(n, off, cp, ib, r, x);
    /* Second right-hand side u = (gamma, 0, ..., 0, cc). */
    memset(u, 0, (size_t)n * sizeof *u);
    u[0] = gamma;
    u[n - 1] = cc;
    thomas_solve(n, off, cp, ib, u, z);
    const double fact = (x[0] + cc * x[n - 1] / gamma) / (1.0 + z[0] + cc * z[n - 1] / gamma);
    for (int32_t i = 0; i < n; ++i) x[i] -= fact * z[i];
}

/* One implicit sweep along a line of n cells whose fields are `stride` apart in the grid. */
static void sweep_line(const line_coef_t *C, int32_t n, size_t stride, const float *b_g,
                       double *d_g, double *u_g, const float *acc_g, const float *foot_g,
                       double *s)
{
    const size_t N = (size_t)n;
    double *b = s + S_B * N, *d = s + S_D * N, *u = s + S_U * N, *acc = s + S_ACC * N;
    double *foot = s + S_FOOT * N, *H = s + S_H * N, *w = s + S_W * N, *a = s + S_A * N;
    double *ex = s + S_S * N, *diag = s + S_DIAG * N, *off = s + S_OFF * N;
    double *rhs = s + S_RHS * N, *x = s + S_X * N, *q = s + S_Q * N;
    for (size_t i = 0; i < N; ++i) {
        b[i] = b_g[i * stride];
        d[i] = d_g[i * stride];
        u[i] = u_g[i * stride];
        acc[i] = C->has_acc ? acc_g[2 * i * stride] : 0.0;
        foot[i] = C->has_foot ? foot_g[i * stride] : 0.0;
        H[i] = b[i] + d[i] + foot[i];
    }
    const int32_t nf = C->periodic ? n : n - 1; /* face n-1 is a wall unless periodic */
    const double th = C->theta, G = C->G, c = C->c, k = C->k;
    for (int32_t f = 0; f < n; ++f) {
        const int32_t i = f, j = f + 1 == n ? 0 : f + 1;
        double hi = b[i] + d[i], hj = b[j] + d[j];
        double wf = (hi > hj ? hi : hj) - (b[i] > b[j] ? b[i] : b[j]);
        if (f >= nf || !(wf > 0.0)) {
            w[f] = 0.0;
            a[f] = ex[f] = 0.0;
            continue;
        }
        const double ua = C->wind + 0.5 * (acc[i] + acc[j]);
        a[f] = C->damp * (u[f] + C->dt * ua) - G * (1.0 - th) * (H[j] - H[i]);
        ex[f] = th * a[f] + (1.0 - th) * u[f];
        w[f] = wf;
    }
    for (int32_t i = 0; i < n; ++i) {
        const int32_t l = i == 0 ? n - 1 : i - 1, r = i + 1 == n ? 0 : i + 1;
        const double wl = w[l], wr = w[i]; /* w[n-1] is 0 at walls */
        diag[i] = 1.0 + c * (wl + wr);
        off[i] = -c * wr;
        rhs[i] = -k * (wr * ex[i] - wl * ex[l]) - c * (wr * (H[i] - H[r]) + wl * (H[i] - H[l]));
    }
    thomas_cyclic(n, diag, off, rhs, x, s);
    /* New face velocities (kept in a[]) and fluxes. */
    for (int32_t f = 0; f < n; ++f) {
        if (w[f] == 0.0) {
            q[f] = a[f] = 0.0;
            continue;
        }
        const int32_t i = f, j = f + 1 == n ? 0 : f + 1;
        const double un = a[f] - G * th * ((H[j] + x[j]) - (H[i] + x[i]));
        q[f] = k * w[f] * (th * un + (1.0 - th) * u[f]);
        a[f] = un;
    }
    /* No cell gives more than it holds: scale its outflows to its depth. */
    double *scale = s + S_SCALE * N;
    for (int32_t i = 0; i < n; ++i) {
        const int32_t l = i == 0 ? n - 1 : i - 1;
        const double out = (q[i] > 0.0 ? q[i] : 0.0) + (q[l] < 0.0 ? -q[l] : 0.0);
        scale[i] = out > d[i] ? d[i] / out : 1.0;
    }
    for (int32_t f = 0; f < n; ++f) {
        const int32_t j = f + 1 == n ? 0 : f + 1;
        const double sc = q[f] > 0.0 ? scale[f] : q[f] < 0.0 ? scale[j] : 1.0;
        if (sc < 1.0) {
            q[f] *= sc;
            a[f] *= sc;
        }
    }
    for (int32_t i = 0; i < n; ++i) {
        const int32_t l = i == 0 ? n - 1 : i - 1;
        double dn = d[i] - q[i] + q[l];
        d_g[(size_t)i * stride] = dn > 0.0 ? dn : 0.0; /* only rounding can go below 0 */
        u_g[(size_t)i * stride] = a[i];
    }
}

static void sweep_x(hbk_water_t *h, const line_coef_t *C, int threads)
{
    const int32_t W = h->p.width, Ht = h->p.height;
    const size_t per = hbk_water_line_scratch(W > Ht ? W : Ht);
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t y = 0; y < Ht; ++y) {
        const size_t o = (size_t)y * (size_t)W;
        double *s = h->scratch + per * (size_t)omp_get_thread_num();
        sweep_line(C, W, 1, h->ground + o, h->depth + o, h->vel_x + o,
                   h->accel ? h->accel + 2 * o : NULL, h->footprint ? h->footprint + o : NULL, s);
    }
}

static void sweep_y(hbk_water_t *h, const line_coef_t *C, int threads)
{
    const int32_t W = h->p.width, Ht = h->p.height;
    const size_t per = hbk_water_line_scratch(W > Ht ? W : Ht);
    /* Chunks of 16 neighbouring columns: a chunk reuses its cache lines row after row, and two
     * threads share at most one line per row and array at a chunk boundary. */
#pragma omp parallel for num_threads(threads) schedule(static, 16)
    for (int32_t x = 0; x < W; ++x) {
        double *s = h->scratch + per * (size_t)omp_get_thread_num();
        sweep_line(C, Ht, (size_t)W, h->ground + x, h->depth + x, h->vel_y + x,
                   h->accel ? h->accel + 2 * (size_t)x + 1 : NULL,
                   h->footprint ? h->footprint + x : NULL, s);
    }
}

/* A raindrop: a dent of `rain_depth` (never deeper than the water) whose volume is put back in
 * a ring R <= r < 2R around it, so drops disturb the surface without adding or removing water.
 * Pass 0 weighs the wet ring cells (no wet ring: no drop), pass 1 dents, pass 2 fills the ring;
 * dent and ring never overlap, so the ring's wet cells are the same in passes 0 and 2. */
static void rain_drop(hbk_water_t *h, double cx, double cy)
{
    const int32_t W = h->p.width, Ht = h->p.height;
    double R = (double)h->p.rain_radius / (double)h->p.cell_size;
    if (R < 0.75) R = 0.75; /* reach at least the nearest cell centre */
    const int32_t reach = (int32_t)ceil(2.0 * R);
    const int32_t x0 = (int32_t)floor(cx) - reach, y0 = (int32_t)floor(cy) - reach;
    const int32_t span = 2 * reach + 2;
    /* On a periodic grid smaller than the drop, visit each cell once. */
    const int32_t nx = h->p.periodic && span > W ? W : span;
    const int32_t ny = h->p.periodic && span > Ht ? Ht : span;
    double removed = 0.0, ring = 0.0;
    for (int pass = 0; pass < 3; ++pass) {
        if (pass == 1 && !(ring > 0.0)) return;
        for (int32_t yy = y0; yy < y0 + ny; ++yy)
            for (int32_t xx = x0; xx < x0 + nx; ++xx) {
                int32_t x = xx, y = yy;
                if (h->p.periodic) {
                    x = ((x % W) + W) % W;
                    y = ((y % Ht) + Ht) % Ht;
                } else if (x < 0 || y < 0 || x >= W || y >= Ht) {
                    continue;
                }
                double *d = &h->depth[(size_t)y * (size_t)W + (size_t)x];
                if (!(*d > 0.0)) continue;
                const double ddx = xx + 0.5 - cx, ddy = yy + 0.5 - cy;
                const double r = sqrt(ddx * ddx + ddy * ddy);
                if (r < R) {
                    if (pass != 1) continue;
                    const double t = 1.0 - (r * r) / (R * R);
                    double take = (double)h->p.rain_depth * t * t;
                    if (take > *d) take = *d;
                    *d -= take;
                    removed += take;
                } else if (r < 2.0 * R && pass != 1) {
                    const double t = (r - 1.5 * R) / (0.5 * R), g = (1.0 - t * t) * (1.0 - t * t);
                    if (pass == 0) ring += g;
                    else *d += removed * (g / ring);
                }
            }
    }
}

static hbk_result_t rain(hbk_water_t *h, double dt, const hbk_progress_t *progress)
{
    const hbk_water_params_t *p = &h->p;
    if (!(p->rain_rate > 0.0f) || !(p->rain_depth > 0.0f)) return HBK_OK;
    const double area = (double)p->width * p->height * (double)p->cell_size * p->cell_size;
    const double expected = (double)p->rain_rate * area * dt;
    /* Rounding the expected count up or down at random keeps the mean exact. */
    double count = floor(expected + (double)hbk_rng_uniform(p->seed, HBK_WATER_STREAM_RAIN_COUNT,
                                                            h->steps, 0));
    if (count > 1048575.0) count = 1048575.0;
    for (uint32_t k = 0; k < (uint32_t)count; ++k) {
        /* Up to a million drops of up to 1000^2 cells each: a cancel must not wait for them. */
        if ((k & 63) == 0 && hbk_cancelled(progress)) return HBK_ERR_CANCELLED;
        uint32_t r[4];
        hbk_philox(p->seed, HBK_WATER_STREAM_RAIN_DROP, (h->steps << 20) | k, r);
        const double cx = (double)hbk_u32_to_unit(r[0]) * p->width;
        const double cy = (double)hbk_u32_to_unit(r[1]) * p->height;
        rain_drop(h, cx, cy);
    }
    return HBK_OK;
}

hbk_result_t hbk_water_substep(hbk_water_t *h, double dt, int threads, hbk_progress_t *progress)
{
    const hbk_water_params_t *p = &h->p;
    if (h->sources) {
        for (size_t i = 0; i < h->n; ++i) {
            double d = h->depth[i] + dt * (double)h->sources[i];
            h->depth[i] = d > 0.0 ? d : 0.0; /* a drain takes what is there, no more */
        }
    }
    if (rain(h, dt, progress)) return HBK_ERR_CANCELLED;
    const double dx = p->cell_size, g = p->gravity, th = p->implicitness;
    line_coef_t C = {dt, g * dt / dx, th * th * g * dt * dt / (dx * dx), dt / dx, th,
                     1.0 / (1.0 + (double)p->damping * dt), 0.0, p->periodic,
                     h->accel != NULL, h->footprint != NULL};
    /* Alternate the sweep order every step so neither axis leads. */
    for (int pass = 0; pass < 2; ++pass) {
        if (hbk_cancelled(progress)) return HBK_ERR_CANCELLED;
        const int along_x = (pass == 0) == ((h->steps & 1) == 0);
        C.wind = p->wind[along_x ? 0 : 1];
        if (along_x) sweep_x(h, &C, threads);
        else sweep_y(h, &C, threads);
    }
    h->steps++;
    return HBK_OK;
}

hbk_result_t hbk_water_step(hbk_water_t *h, hbk_progress_t *progress)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    /* Small grids are not worth waking threads for (the result is the same either way). */
    const int threads = h->n < 16384 ? 1 : hbk_threads(h->p.threads);
    if (threads > h->scratch_threads) {
        const int32_t n = h->p.width > h->p.height ? h->p.width : h->p.height;
        double *s = realloc(h->scratch, (size_t)threads * hbk_water_line_scratch(n) * sizeof *s);
        if (!s)
            return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "threads = %d: no memory for the "
                            "solver scratch", threads);
        h->scratch = s;
        h->scratch_threads = threads;
    }
    const size_t n = h->n;
    memcpy(h->backup, h->depth, n * sizeof *h->backup);
    memcpy(h->backup + n, h->vel_x, n * sizeof *h->backup);
    memcpy(h->backup + 2 * n, h->vel_y, n * sizeof *h->backup);
    const uint64_t steps0 = h->steps;
    const double dt = (double)h->p.dt / (double)h->p.substeps;
    for (int32_t s = 0; s < h->p.substeps; ++s) {
        hbk_result_t r = hbk_cancelled(progress) ? HBK_ERR_CANCELLED
                                                 : hbk_water_substep(h, dt, threads, progress);
        if (r) {
            memcpy(h->depth, h->backup, n * sizeof *h->backup);
            memcpy(h->vel_x, h->backup + n, n * sizeof *h->backup);
            memcpy(h->vel_y, h->backup + 2 * n, n * sizeof *h->backup);
            h->steps = steps0;
            return hbk_fail(&h->msg, r, "step cancelled; the water is as before the call");
        }
        hbk_report(progress, (float)(s + 1) / (float)h->p.substeps);
    }
    return HBK_OK;
}
