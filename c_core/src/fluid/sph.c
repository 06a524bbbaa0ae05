/* SPH after Harada et al. 2007 with the kernels of Mueller et al. 2003, in the symmetric
 * (variational) form: density rho_i = m_s sum_j W(x_i - x_j) and pressure acceleration
 * -m_s sum_j (p_i / rho_i^2 + p_j / rho_j^2) grad W, with one kernel, the spiky one, for both.
 * That pair is the exact gradient of the fluid's internal energy, so the pressure forces neither
 * make nor destroy energy (the non-symmetric Mueller form with a poly6 density and a spiky
 * gradient does not: it pumped a column at rest to metres per second even without walls), and
 * the spiky gradient, largest at r = 0, keeps particles from pairing. m_s is the mass that puts
 * a lattice at particle_spacing exactly at rest density under the spiky kernel (h->sph_mass; the
 * grid fields keep h->mass and poly6). Viscosity Laplacian, symplectic Euler, mirror walls and
 * obstacle collisions. Every particle gathers from its neighbours in the counting-sorted order,
 * so sums never depend on threads. */
#include "internal_fluid.h"
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* Pushes a particle out of the walls and obstacles and removes the velocity into them: into a
 * moving obstacle, what it has below the speed of the surface along the normal. */
static void collide(const hbk_fluid_t *h, float *x, float *v)
{
    const float m = 0.5f * h->p.particle_spacing;
    for (int a = 0; a < 3; ++a) {
        const float lo = h->p.box_min[a] + m, hi = h->p.box_max[a] - m;
        if (!(x[a] >= lo)) { x[a] = lo; if (v[a] < 0.0f) v[a] = 0.0f; }
        if (!(x[a] <= hi)) { x[a] = hi; if (v[a] > 0.0f) v[a] = 0.0f; }
    }
    for (int32_t o = 0; o < h->n_obs; ++o) {
        const hbk_fluid_obstacle_t *ob = &h->obs_now[o];
        const float *w = h->obs_rate[o]; /* centre, extent: m/s; turning: rad/s */
        float q[3] = {x[0] - ob->center[0], x[1] - ob->center[1], x[2] - ob->center[2]};
        float n[3] = {0, 0, 0}, push = 0.0f, wn;
        if (ob->type == 0) {
            const float d = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]), R = ob->extent[0] + m;
            if (d >= R) continue;
            if (d > 1e-12f) for (int a = 0; a < 3; ++a) n[a] = q[a] / d;
            else n[2] = 1.0f;
            push = R - d;
            wn = w[0] * n[0] + w[1] * n[1] + w[2] * n[2] + w[3];
        } else if (ob->type == 1) {
            int best = -1;
            for (int a = 0; a < 3; ++a) {
                const float pen = ob->extent[a] + m - fabsf(q[a]);
                if (pen <= 0.0f) { best = -1; push = 0.0f; break; }
                if (best < 0 || pen < push) { best = a; push = pen; }
            }
            if (best < 0) continue;
            n[best] = q[best] < 0.0f ? -1.0f : 1.0f;
            wn = n[best] * w[best] + w[3 + best]; /* the face at centre + n extent */
        } else { /* turned box or mesh: in its own axes */
            const float *ax = h->obs_axes[o];
            float l[3], grow = 0.0f; /* grow: the surface's own speed along n (m/s) */
            for (int a = 0; a < 3; ++a)
                l[a] = ax[3 * a] * q[0] + ax[3 * a + 1] * q[1] + ax[3 * a + 2] * q[2];
            if (ob->type == 2) {
                int best = -1;
                for (int a = 0; a < 3; ++a) {
                    const float pen = ob->extent[a] + m - fabsf(l[a]);
                    if (pen <= 0.0f) { best = -1; push = 0.0f; break; }
                    if (best < 0 || pen < push) { best = a; push = pen; }
                }
                if (best < 0) continue;
                const float sg = l[best] < 0.0f ? -1.0f : 1.0f;
                for (int a = 0; a < 3; ++a) n[a] = sg * ax[3 * best + a];
                grow = w[3 + best];
            } else {
                float nl[3];
                if (!hbk_fluid_field_contact(h, o, ob->extent, l, m, 1, &push, nl, &grow))
                    continue;
                for (int a = 0; a < 3; ++a)
                    n[a] = ax[a] * nl[0] + ax[3 + a] * nl[1] + ax[6 + a] * nl[2];
                /* the field stretches with its box: a point at l moves at l * e' / e */
                for (int k = 0; k < 3; ++k) grow += w[3 + k] / ob->extent[k] * l[k] * nl[k];
            }
            /* the surface's speed where the particle lands: centre + turn x arm */
            const float *om = w + 6;
            float r[3], u[3];
            for (int a = 0; a < 3; ++a) r[a] = q[a] + n[a] * push;
            u[0] = w[0] + om[1] * r[2] - om[2] * r[1];
            u[1] = w[1] + om[2] * r[0] - om[0] * r[2];
            u[2] = w[2] + om[0] * r[1] - om[1] * r[0];
            wn = u[0] * n[0] + u[1] * n[1] + u[2] * n[2] + grow;
        }
        float vn = 0.0f;
        for (int a = 0; a < 3; ++a) { x[a] += n[a] * push; vn += v[a] * n[a]; }
        vn -= wn; /* still obstacles: wn = 0, the plain reflection-free stop */
        if (vn < 0.0f) for (int a = 0; a < 3; ++a) v[a] -= vn * n[a];
    }
}

/* Box walls as mirror images of the fluid (free-slip ghost particles): every neighbour j within
 * reach is also seen reflected across each wall, and across each pair and triple of walls, near
 * particle i. A lattice at particle_spacing that fills the box up to its walls (first layer half
 * a spacing in, as fill_box places it) continues exactly across them, so it is at rest density
 * everywhere, corners and edges included, and the images push with the same kernels and
 * pressures as the fluid. A particle sees its own image too, which keeps it off the wall.
 * (The former continuum half-space walls over-counted density by 2.5% at a wall and 16% in a
 * corner, and their poly6-integral push did not match the spiky pair forces: they pumped energy
 * into a column at rest.) */
typedef struct mirrors {
    int n;              /* images besides the identity, <= 26 */
    float off[26][3];   /* image of x: sgn * x + off, per axis */
    float sgn[26][3];
} mirrors_t;

static inline void mirrors_near(const hbk_fluid_t *h, const float *x, float H, mirrors_t *m)
{
    m->n = 0;
    int any = 0; /* most particles are far from every wall: no images, no tables */
    for (int a = 0; a < 3; ++a)
        any |= (x[a] - h->p.box_min[a] < H) | (h->p.box_max[a] - x[a] < H);
    if (!any) return;
    /* Per axis: identity, reflection at the low wall, at the high wall (when within H). */
    float off[3][3], sgn[3][3];
    int cnt[3];
    for (int a = 0; a < 3; ++a) {
        cnt[a] = 0;
        off[a][cnt[a]] = 0.0f; sgn[a][cnt[a]++] = 1.0f;
        if (x[a] - h->p.box_min[a] < H) { off[a][cnt[a]] = 2.0f * h->p.box_min[a]; sgn[a][cnt[a]++] = -1.0f; }
        if (h->p.box_max[a] - x[a] < H) { off[a][cnt[a]] = 2.0f * h->p.box_max[a]; sgn[a][cnt[a]++] = -1.0f; }
    }
    for (int k = 0; k < cnt[2]; ++k)
        for (int j = 0; j < cnt[1]; ++j)
            for (int i = 0; i < cnt[0]; ++i) {
                if (i == 0 && j == 0 && k == 0) continue;
                const int ijk[3] = {i, j, k};
                for (int a = 0; a < 3; ++a) {
                    m->off[m->n][a] = off[a][ijk[a]];
                    m->sgn[m->n][a] = sgn[a][ijk[a]];
                }
                m->n++;
            }
}

/* Calls body(j) for every particle j (sorted index) in the 27 cells around cell (cx, cy, cz);
 * the three cells of a row are one contiguous range of the sorted arrays, from a_. */
#define FOR_NEIGHBOURS(c, cx, cy, cz, j, ...)                                                \
    HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a_, e_, for (int32_t j = a_; j < e_; ++j) { __VA_ARGS__ })

/* Weakly compressible SPH is stable while sound and flow cross under 0.4 h per step (CFL),
 * viscosity diffuses under 0.125 h^2 per step, and gravity alone moves a particle under h / 32.
 * Past these the pressure overshoots and the fluid gains energy, then sprays. */
double hbk_fluid_sph_stable_dt(const hbk_fluid_t *h, int threads)
{
    const hbk_fluid_params_t *p = &h->p;
    const double H = p->smoothing_length;
    const float *v = h->vel;
    const int32_t n = h->count;
    float v2 = 0.0f;
#pragma omp parallel for num_threads(threads) schedule(static) reduction(max : v2)
    for (int32_t i = 0; i < n; ++i) {
        const float *vi = v + 3 * (size_t)i;
        const float s2 = vi[0] * vi[0] + vi[1] * vi[1] + vi[2] * vi[2];
        v2 = s2 > v2 ? s2 : v2;
    }
    /* an inflow pours particles at its speed */
    if (h->inflow_n) {
        v2 = h->inflow_top2 > v2 ? h->inflow_top2 : v2;
    }
    /* an obstacle moving into the fluid sets particles moving at its speed */
    double dt = 0.4 * H / (sqrt((double)p->stiffness) + sqrt((double)v2) + h->obs_speed);
    if (p->viscosity > 0.0f) {
        const double dv = 0.125 * H * H * p->rest_density / p->viscosity;
        dt = dv < dt ? dv : dt;
    }
    const double g = sqrt((double)p->gravity[0] * p->gravity[0] +
                          (double)p->gravity[1] * p->gravity[1] +
                          (double)p->gravity[2] * p->gravity[2]);
    if (g > 0.0) {
        const double dg = 0.25 * sqrt(H / g);
        dt = dg < dt ? dg : dt;
    }
    return dt;
}

hbk_result_t hbk_fluid_sph_substep(hbk_fluid_t *h, float dt, int threads)
{
    const int32_t n = h->count;
    if (n == 0) return HBK_OK;
    hbk_fluid_cells_t *c = &h->cells;
    const float H = h->p.smoothing_length;
    hbk_result_t r = hbk_fluid_cells_build(c, h->pos, n, h->p.box_min, h->p.box_max, H, threads);
    if (r) return r;
    /* Sorted copies: x, y, z, vx, vy, vz, density, pressure. */
    float *s = h->sorted, *soa = h->soa;
    const size_t st = (size_t)(h->p.max_particles > 0 ? h->p.max_particles : 1) + 8;
    const int lanes = hbk_fluid_sph_lanes();
    if (lanes && !h->nbr) { /* only the AVX2 path keeps neighbour lists */
        const size_t np = (size_t)(h->p.max_particles > 0 ? h->p.max_particles : 1);
        if (!(h->nbr = malloc((HBK_FLUID_NBR_CAP + 1) * np * sizeof *h->nbr)))
            return HBK_ERR_OUT_OF_MEMORY;
        h->nbr_n = h->nbr + HBK_FLUID_NBR_CAP * np;
    }
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t k = 0; k < n; ++k) {
        if (k + 16 < n) { /* read by id: a cache miss each, unless fetched ahead */
            __builtin_prefetch(h->pos + 3 * (size_t)c->order[k + 16]);
            __builtin_prefetch(h->vel + 3 * (size_t)c->order[k + 16]);
        }
        const int32_t id = c->order[k];
        memcpy(s + 8 * (size_t)k, h->pos + 3 * (size_t)id, 3 * sizeof(float));
        memcpy(s + 8 * (size_t)k + 3, h->vel + 3 * (size_t)id, 3 * sizeof(float));
        for (int a = 0; a < 6; ++a) soa[(size_t)a * st + (size_t)k] = s[8 * (size_t)k + (size_t)a];
    }
    const float H2 = H * H, m = (float)h->sph_mass, rho0 = h->p.rest_density, k = h->p.stiffness;
    const float wsp = (float)(15.0 / (M_PI * pow(H, 6)));   /* W = wsp (H - r)^3 */
    const float spiky = (float)(45.0 / (M_PI * pow(H, 6))); /* |grad W| = spiky (H - r)^2 */
    const float visc = spiky;                               /* viscosity lap W = visc (H - r) */
#pragma omp parallel for num_threads(threads) schedule(static, 256)
    for (int32_t i = 0; i < n; ++i) {
        const float *xi = s + 8 * (size_t)i;
        /* the cell from the sorted copy of the position, as cells_build found it (integer
         * divisions of cell_of cost more) */
        const int32_t cx = hbk_fluid_cell_coord(c, xi[0], 0),
                      cy = hbk_fluid_cell_coord(c, xi[1], 1),
                      cz = hbk_fluid_cell_coord(c, xi[2], 2);
        mirrors_t mi;
        mirrors_near(h, xi, H, &mi);
        float sum = 0.0f, part[8] = {0, 0, 0, 0, 0, 0, 0, 0};
        if (lanes)
            sum = hbk_fluid_density_lanes(lanes, c, soa, s, st, cx, cy, cz, i, xi, H, mi.n,
                                          (const float (*)[3])mi.sgn, (const float (*)[3])mi.off,
                                          h->nbr + HBK_FLUID_NBR_CAP * (size_t)i, h->nbr_n + i);
        else FOR_NEIGHBOURS(c, cx, cy, cz, j, {
            const float *xj = s + 8 * (size_t)j;
            for (int im = -1; im < mi.n; ++im) {
                float d3[3];
                for (int a = 0; a < 3; ++a)
                    d3[a] = xi[a] - (im < 0 ? xj[a] : mi.sgn[im][a] * xj[a] + mi.off[im][a]);
                const float r2 = d3[0] * d3[0] + d3[1] * d3[1] + d3[2] * d3[2];
                if (r2 < H2) {
                    const float q = H - sqrtf(r2);
                    part[hbk_fluid_lane_of(j, a_)] += q * q * q;
                }
            }
        })
        if (!lanes) sum = hbk_fluid_lane_sum(part);
        const float rho = m * wsp * sum;
        s[8 * (size_t)i + 6] = rho;
        /* p >= 0: a free surface must not pull particles together (tensile instability).
         * Stored as p / rho^2, the factor of the symmetric pressure term. */
        s[8 * (size_t)i + 7] = rho > rho0 ? k * (rho - rho0) / (rho * rho) : 0.0f;
        soa[6 * st + (size_t)i] = rho;
        soa[7 * st + (size_t)i] = s[8 * (size_t)i + 7];
    }
    const float *g = h->p.gravity;
    const float decay = expf(-h->p.damping * dt), mu = h->p.viscosity;
#pragma omp parallel for num_threads(threads) schedule(static, 256)
    for (int32_t i = 0; i < n; ++i) {
        const float *xi = s + 8 * (size_t)i;
        if (i + 4 < n) { /* the result goes back by id: fetch its lines while we work */
            const size_t ahead = 3 * (size_t)c->order[i + 4];
            __builtin_prefetch(h->pos + ahead, 1);
            __builtin_prefetch(h->vel + ahead, 1);
        }
        const int32_t id = c->order[i], cx = hbk_fluid_cell_coord(c, xi[0], 0),
                      cy = hbk_fluid_cell_coord(c, xi[1], 1),
                      cz = hbk_fluid_cell_coord(c, xi[2], 2);
        mirrors_t mi;
        mirrors_near(h, xi, H, &mi);
        float ap[3] = {0, 0, 0}, fv[3] = {0, 0, 0}, part[6][8];
        if (!lanes) memset(part, 0, sizeof part); /* the lanes keep their own (a rep stos per
                                                   * particle was a sixth of this loop) */
        int32_t nk = 0; /* pairs in reach so far: the k-th adds to lane k mod 8 */
        if (lanes)
            hbk_fluid_forces_lanes(lanes, c, soa, s, h->nbr + HBK_FLUID_NBR_CAP * (size_t)i,
                                   h->nbr_n[i], st, cx, cy, cz, i, xi, H, m, spiky, visc, mi.n,
                                   (const float (*)[3])mi.sgn, (const float (*)[3])mi.off, ap,
                                   fv);
        /* The pairs (neighbour j, image im) in reach in sph_lanes.c's order: eight candidates
         * of a row at a time; per image (-1: j itself, which i is not, but its images are);
         * per candidate. */
        else HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a_, e_, {
            for (int32_t b = a_; b < e_; b += 8)
                for (int im = -1; im < mi.n; ++im)
                    for (int32_t j = b; j < e_ && j < b + 8; ++j) {
                        if (im < 0 && j == i) continue;
                        const float *xj = s + 8 * (size_t)j;
                        const float sg3[3] = {im < 0 ? 1.0f : mi.sgn[im][0],
                                              im < 0 ? 1.0f : mi.sgn[im][1],
                                              im < 0 ? 1.0f : mi.sgn[im][2]};
                        float d3[3], vj[3];
                        for (int a = 0; a < 3; ++a) {
                            const float of = im < 0 ? 0.0f : mi.off[im][a];
                            d3[a] = xi[a] - (sg3[a] * xj[a] + of);
                            vj[a] = sg3[a] * xj[3 + a];
                        }
                        const float r2 = d3[0] * d3[0] + d3[1] * d3[1] + d3[2] * d3[2];
                        if (r2 >= H2) continue;
                        float *pa = part[0] + (nk++ & 7);
                        const float rr = sqrtf(r2), q = H - rr;
                        if (rr > 1e-9f * H) {
                            /* -m (P_i + P_j) grad_i W, grad_i W = -spiky q^2 (x_i - x_j) / r:
                             * apart. */
                            const float f = m * (xi[7] + xj[7]) * spiky * q * q / rr;
                            for (int a = 0; a < 3; ++a) pa[8 * a] += f * d3[a];
                        }
                        const float w = m / xj[6] * visc * q;
                        for (int a = 0; a < 3; ++a) pa[8 * (3 + a)] += w * (vj[a] - xi[3 + a]);
                    }
        })
        if (!lanes)
            for (int a = 0; a < 3; ++a) {
                ap[a] = hbk_fluid_lane_sum(part[a]);
                fv[a] = hbk_fluid_lane_sum(part[3 + a]);
            }
        const float rhoi = xi[6];
        float v[3], x[3];
        for (int a = 0; a < 3; ++a) {
            const float acc = ap[a] + mu * fv[a] / rhoi + g[a];
            v[a] = (xi[3 + a] + acc * dt) * decay;
            x[a] = xi[a] + v[a] * dt;
        }
        collide(h, x, v);
        /* float by float: collide wrote them so, and memcpy's 8-byte load of two waited for
         * both stores to retire (a failed store forward: 0.1-0.3 ms of a 21 ms step) */
        for (int a = 0; a < 3; ++a) {
            h->pos[3 * (size_t)id + (size_t)a] = x[a];
            h->vel[3 * (size_t)id + (size_t)a] = v[a];
        }
    }
    return HBK_OK;
}

