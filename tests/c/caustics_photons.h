/* A brute-force photon tracer for caustic maps: the reference the mesh method is tested and
 * benchmarked against. Independent of the library's code on purpose: random photons from the
 * sun hit the water surface (the same triangle mesh through the samples, with normals
 * interpolated across each triangle from central-difference vertex normals), refract by
 * Snell's law at that exact point, travel straight to flat ground and are binned into the map.
 * Periodic surfaces only, all water, no Fresnel, no absorption. Shared by test_caustics.c and
 * bench_caustics.c. */
#ifndef HBK_CAUSTICS_PHOTONS_H
#define HBK_CAUSTICS_PHOTONS_H
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

typedef struct {
    const float *h;  /* W x H surface heights at cell centres, row-major, periodic */
    int W, H;
    double dx;       /* cell size, m */
    double ior;
    double L[3];     /* unit vector towards the sun */
    double E;        /* irradiance facing the sun */
    double ground;   /* z of the flat ground */
    float *normals;  /* 3 per sample, filled by photon_prepare (or NULL: computed each time) */
} photon_scene_t;

static inline double ph_h(const photon_scene_t *s, int i, int j)
{
    i %= s->W;
    j %= s->H;
    if (i < 0) i += s->W;
    if (j < 0) j += s->H;
    return s->h[(size_t)j * (size_t)s->W + (size_t)i];
}

static inline void ph_vnormal(const photon_scene_t *s, int i, int j, double n[3])
{
    if (s->normals) {
        i %= s->W;
        j %= s->H;
        if (i < 0) i += s->W;
        if (j < 0) j += s->H;
        const float *q = s->normals + 3 * ((size_t)j * (size_t)s->W + (size_t)i);
        n[0] = q[0];
        n[1] = q[1];
        n[2] = q[2];
        return;
    }
    const double gx = (ph_h(s, i + 1, j) - ph_h(s, i - 1, j)) / (2.0 * s->dx);
    const double gy = (ph_h(s, i, j + 1) - ph_h(s, i, j - 1)) / (2.0 * s->dx);
    const double l = sqrt(gx * gx + gy * gy + 1.0);
    n[0] = -gx / l;
    n[1] = -gy / l;
    n[2] = 1.0 / l;
}

/* Caches the vertex normals (malloc'd; free s->normals). Returns 0 without memory. */
static inline int photon_prepare(photon_scene_t *s)
{
    float *nr = (float *)malloc(sizeof(float) * 3 * (size_t)s->W * (size_t)s->H);
    if (!nr) return 0;
    s->normals = NULL;
    for (int j = 0; j < s->H; ++j)
        for (int i = 0; i < s->W; ++i) {
            double n[3];
            ph_vnormal(s, i, j, n);
            for (int c = 0; c < 3; ++c) nr[3 * ((size_t)j * (size_t)s->W + (size_t)i) + c] = (float)n[c];
        }
    s->normals = nr;
    return 1;
}

/* Surface height and interpolated normal at (x, y): the mesh of triangles (00, 10, 11) and
 * (00, 11, 01) through the cell-centre samples. */
static inline double ph_surface(const photon_scene_t *s, double x, double y, double n[3])
{
    const double u = x / s->dx - 0.5, v = y / s->dx - 0.5;
    const double fu = floor(u), fv = floor(v), a = u - fu, b = v - fv;
    const int i = (int)fu, j = (int)fv;
    double w[3];
    int ci[3][2];
    if (a >= b) { /* T0: 00, 10, 11 */
        w[0] = 1.0 - a; w[1] = a - b; w[2] = b;
        ci[0][0] = i; ci[0][1] = j; ci[1][0] = i + 1; ci[1][1] = j; ci[2][0] = i + 1; ci[2][1] = j + 1;
    } else { /* T1: 00, 11, 01 */
        w[0] = 1.0 - b; w[1] = a; w[2] = b - a;
        ci[0][0] = i; ci[0][1] = j; ci[1][0] = i + 1; ci[1][1] = j + 1; ci[2][0] = i; ci[2][1] = j + 1;
    }
    double z = 0.0;
    n[0] = n[1] = n[2] = 0.0;
    for (int k = 0; k < 3; ++k) {
        double vn[3];
        ph_vnormal(s, ci[k][0], ci[k][1], vn);
        z += w[k] * ph_h(s, ci[k][0], ci[k][1]);
        for (int c = 0; c < 3; ++c) n[c] += w[k] * vn[c];
    }
    const double l = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int c = 0; c < 3; ++c) n[c] /= l;
    return z;
}

/* SplitMix64: a tiny, good generator for the photons (not the library's RNG on purpose). */
static inline uint64_t ph_next(uint64_t *st)
{
    uint64_t z = (*st += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}
static inline double ph_unit(uint64_t *st) { return (double)(ph_next(st) >> 11) * (1.0 / 9007199254740992.0); }

/* Traces n photons into map (MW x MH doubles, irradiance added, covering the tile). */
static void photon_trace(const photon_scene_t *s, uint64_t seed, size_t n, double *map, int MW,
                         int MH)
{
    const double TW = s->W * s->dx, TH = s->H * s->dx;
    const double power = s->E * s->L[2] * TW * TH / (double)n; /* flux through the tile */
    const double pixel_area = (TW / MW) * (TH / MH);
    double ztop = -INFINITY;
    for (int k = 0; k < s->W * s->H; ++k) ztop = s->h[k] > ztop ? s->h[k] : ztop;
    uint64_t st = seed;
    for (size_t p = 0; p < n; ++p) {
        const double x0 = ph_unit(&st) * TW, y0 = ph_unit(&st) * TH;
        /* Where the ray (x0, y0, ztop) - t L meets the surface: fixed-point iteration on t. */
        double t = 0.0, nrm[3], z = ztop;
        for (int it = 0; it < 30; ++it) {
            z = ph_surface(s, x0 - t * s->L[0], y0 - t * s->L[1], nrm);
            const double tn = (ztop - z) / s->L[2];
            if (fabs(tn - t) < 1e-10) break;
            t = tn;
        }
        const double px = x0 - t * s->L[0], py = y0 - t * s->L[1];
        double ci = nrm[0] * s->L[0] + nrm[1] * s->L[1] + nrm[2] * s->L[2];
        if (ci <= 0.0) continue;
        const double eta = 1.0 / s->ior, k = 1.0 - eta * eta * (1.0 - ci * ci);
        const double f = eta * ci - sqrt(k);
        double r[3];
        for (int c = 0; c < 3; ++c) r[c] = -eta * s->L[c] + f * nrm[c];
        const double tt = (z - s->ground) / -r[2];
        double gx = (px + tt * r[0]) / TW * MW, gy = (py + tt * r[1]) / TH * MH;
        gx -= floor(gx / MW) * MW;
        gy -= floor(gy / MH) * MH;
        int ix = (int)gx, iy = (int)gy;
        if (ix >= MW) ix = MW - 1;
        if (iy >= MH) iy = MH - 1;
        map[(size_t)iy * (size_t)MW + (size_t)ix] += power / pixel_area;
    }
}

#endif
