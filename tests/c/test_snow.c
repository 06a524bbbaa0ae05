#include "test.h"
#include "snow/internal_snow.h"
#include <stdlib.h>
/* The BVH is internal (hidden symbols): compile a private copy to test it against brute
 * force. */
#include "snow/bvh.c"
/* The paper's box contact (§3.2.1), likewise. */
#include "snow/box.c"
/* And the HBK_PATHS switch the BVH reads. */
#include "base/paths.c"

/* ---- helpers ---- */

static hbk_snow_params_t small_params(void)
{
    hbk_snow_params_t p;
    hbk_snow_params_default(&p);
    p.flake_count = 2000;
    p.threads = 1;
    p.texture_width = p.texture_height = 64;
    p.wind[0] = p.wind[1] = p.wind[2] = 0.0f;
    return p;
}

typedef struct {
    float pos[256 * 3];
    int32_t tri[256 * 3];
    float uv[256 * 6];
    int32_t mat[256];
    int32_t nv, nt;
} mesh_t;

/* Horizontal quad at height z over [x0, x1] x [y0, y1], UV [u0, u1] x [v0, v1]. */
static void add_quad(mesh_t *m, float x0, float y0, float x1, float y1, float z, float u0,
                     float v0, float u1, float v1, int32_t mat)
{
    const float P[4][3] = {{x0, y0, z}, {x1, y0, z}, {x1, y1, z}, {x0, y1, z}};
    const float U[4][2] = {{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}};
    const int c[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int i = 0; i < 4; ++i) memcpy(m->pos + 3 * (m->nv + i), P[i], sizeof P[i]);
    for (int t = 0; t < 2; ++t) {
        for (int k = 0; k < 3; ++k) {
            m->tri[3 * m->nt + k] = m->nv + c[t][k];
            memcpy(m->uv + 6 * m->nt + 2 * k, U[c[t][k]], sizeof U[0]);
        }
        m->mat[m->nt] = mat;
        m->nt++;
    }
    m->nv += 4;
}

/* Axis-aligned cube [lo, hi]; face f (0 +X, 1 -X, 2 +Y, 3 -Y, 4 +Z, 5 -Z) mapped to the UV
 * rectangle uvr[f] = {u0, v0, u1, v1}. */
static void add_cube(mesh_t *m, const float lo[3], const float hi[3], const float uvr[6][4])
{
    for (int f = 0; f < 6; ++f) {
        const int ax = f / 2, s = (f & 1) ? 0 : 1;
        const int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
        float P[4][3];
        const float q[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
        for (int i = 0; i < 4; ++i) {
            P[i][ax] = s ? hi[ax] : lo[ax];
            P[i][a1] = q[i][0] ? hi[a1] : lo[a1];
            P[i][a2] = q[i][1] ? hi[a2] : lo[a2];
        }
        const int c[2][3] = {{0, 1, 2}, {0, 2, 3}};
        for (int i = 0; i < 4; ++i) memcpy(m->pos + 3 * (m->nv + i), P[i], sizeof P[i]);
        for (int t = 0; t < 2; ++t) {
            for (int k = 0; k < 3; ++k) {
                const int v = c[t][k];
                m->tri[3 * m->nt + k] = m->nv + v;
                m->uv[6 * m->nt + 2 * k] = uvr[f][0] + (uvr[f][2] - uvr[f][0]) * q[v][0];
                m->uv[6 * m->nt + 2 * k + 1] = uvr[f][1] + (uvr[f][3] - uvr[f][1]) * q[v][1];
            }
            m->mat[m->nt] = 0;
            m->nt++;
        }
        m->nv += 4;
    }
}

static hbk_result_t set_mesh(hbk_snow_t *h, const mesh_t *m)
{
    return hbk_snow_set_mesh(h, m->pos, m->nv, m->tri, m->uv, m->mat, m->nt);
}

/* Coverage (0..255) and depth of the whole texture. */
static float *get_cov(hbk_snow_t *h, int32_t *w, int32_t *ht)
{
    hbk_snow_texture_size(h, w, ht);
    size_t n = (size_t)*w * (size_t)*ht;
    float *rgba = malloc(4 * n * sizeof(float)), *a = malloc(n * sizeof(float));
    hbk_image_t img = {rgba, *w, *ht, 4, 4 * (size_t)*w};
    if (hbk_snow_coverage(h, &img) != HBK_OK) { free(rgba); free(a); return NULL; }
    for (size_t i = 0; i < n; ++i) a[i] = rgba[4 * i + 3] * 255.0f;
    free(rgba);
    return a;
}

static float *get_depth(hbk_snow_t *h)
{
    int32_t w, ht;
    hbk_snow_texture_size(h, &w, &ht);
    float *d = malloc((size_t)w * ht * sizeof(float));
    hbk_image_t img = {d, w, ht, 1, (size_t)w};
    if (hbk_snow_depth(h, &img) != HBK_OK) { free(d); return NULL; }
    return d;
}

static double sum_region(const float *a, int32_t w, int x0, int y0, int x1, int y1)
{
    double s = 0;
    for (int y = y0; y < y1; ++y)
        for (int x = x0; x < x1; ++x) s += a[(size_t)y * w + x];
    return s;
}

/* ---- formulas ---- */

void test_snow_formulas(void)
{
    /* Water content: 5 % at -2 degC to 25 % at 3 degC, linear; dry below -2. */
    CHECK_NEAR(hbk_snow_water_content(NULL, -2.0f), 5.0, 1e-5);
    CHECK_NEAR(hbk_snow_water_content(NULL, 3.0f), 25.0, 1e-5);
    CHECK_NEAR(hbk_snow_water_content(NULL, 0.5f), 15.0, 1e-5);
    CHECK_NEAR(hbk_snow_water_content(NULL, -0.75f), 10.0, 1e-5);
    CHECK_NEAR(hbk_snow_water_content(NULL, -2.5f), 0.0, 0);
    /* Surface tension: 7 % at 5, 25 % at 15, 7 % at 25, linear between, ~0 beyond. */
    CHECK_NEAR(hbk_snow_tension_chance(NULL, 5.0f), 0.07, 1e-6);
    CHECK_NEAR(hbk_snow_tension_chance(NULL, 15.0f), 0.25, 1e-6);
    CHECK_NEAR(hbk_snow_tension_chance(NULL, 25.0f), 0.07, 1e-6);
    CHECK_NEAR(hbk_snow_tension_chance(NULL, 10.0f), 0.16, 1e-6);
    CHECK_NEAR(hbk_snow_tension_chance(NULL, 20.0f), 0.16, 1e-6);
    CHECK_NEAR(hbk_snow_tension_chance(NULL, 7.5f), 0.115, 1e-6);
    CHECK_NEAR(hbk_snow_tension_chance(NULL, 26.0f), 0.0, 0);
    CHECK_NEAR(hbk_snow_tension_chance(NULL, 2.5f), 0.035, 1e-6); /* rising from 0 at 0 % */
    /* Sintering: 2 % at -10, 10 % at -2, linear. */
    CHECK_NEAR(hbk_snow_sinter_chance(NULL, -10.0f), 0.02, 1e-6);
    CHECK_NEAR(hbk_snow_sinter_chance(NULL, -2.0f), 0.10, 1e-6);
    CHECK_NEAR(hbk_snow_sinter_chance(NULL, -6.0f), 0.06, 1e-6);
    /* The temperature chance switches mechanism at -2 degC. */
    CHECK_NEAR(hbk_snow_stick_chance(NULL, -10.0f), 0.02, 1e-6);
    CHECK_NEAR(hbk_snow_stick_chance(NULL, -2.5f), 0.095, 1e-6);
    CHECK_NEAR(hbk_snow_stick_chance(NULL, -2.0f), 0.07, 1e-6);
    CHECK_NEAR(hbk_snow_stick_chance(NULL, -0.75f), 0.16, 1e-6);
    CHECK_NEAR(hbk_snow_stick_chance(NULL, 0.5f), 0.25, 1e-6);
    CHECK_NEAR(hbk_snow_stick_chance(NULL, 1.75f), 0.16, 1e-6);
    CHECK_NEAR(hbk_snow_stick_chance(NULL, 3.0f), 0.07, 1e-6);
    /* Independent mechanisms: 1 - (1 - p_T)(1 - p_C). */
    CHECK_NEAR(hbk_snow_hit_chance(NULL, -6.0f, 0.4f), 1.0 - 0.94 * 0.6, 1e-6);
    CHECK_NEAR(hbk_snow_hit_chance(NULL, 0.5f, 0.0f), 0.25, 1e-6);
    CHECK_NEAR(hbk_snow_hit_chance(NULL, 0.5f, 0.25f), 1.0 - 0.75 * 0.75, 1e-6);
    /* Bleed: 0.1 at 5 %, 1 at 25 %, linear. */
    CHECK_NEAR(hbk_snow_bleed(NULL, 5.0f), 0.1, 1e-6);
    CHECK_NEAR(hbk_snow_bleed(NULL, 25.0f), 1.0, 1e-6);
    CHECK_NEAR(hbk_snow_bleed(NULL, 15.0f), 0.55, 1e-6);
    CHECK_NEAR(hbk_snow_bleed(NULL, 30.0f), 1.0, 1e-6);
    /* Stamps: wet u + vR + wD, dry m + nR. */
    float a[9];
    hbk_snow_stamp_alpha(NULL, 0.5f, 0.5f, a); /* D = 0.55 */
    CHECK_NEAR(a[4], 110 + 25 * 0.5 - 48 * 0.55, 1e-4);
    CHECK_NEAR(a[1], 25 + 10 * 0.5 + 12 * 0.55, 1e-4);
    CHECK_NEAR(a[0], 10 + 5 * 0.5 + 9 * 0.55, 1e-4);
    CHECK(a[1] == a[3] && a[3] == a[5] && a[5] == a[7] && a[0] == a[2] && a[2] == a[6]);
    hbk_snow_stamp_alpha(NULL, -5.0f, 0.25f, a);
    CHECK_NEAR(a[4], 90 + 90 * 0.25, 1e-4);
    CHECK_NEAR(a[5], 10 + 15 * 0.25, 1e-4);
    CHECK_NEAR(a[8], 5 + 10 * 0.25, 1e-4);
    /* The params' figures are the ones used. */
    hbk_snow_params_t p;
    hbk_snow_params_default(&p);
    p.tension_chance[1] = 40.0f;
    p.sinter_chance[0] = 0.0f;
    CHECK_NEAR(hbk_snow_stick_chance(&p, 0.5f), 0.40, 1e-6);
    CHECK_NEAR(hbk_snow_stick_chance(&p, -6.0f), 0.05, 1e-6);
}

void test_snow_params(void)
{
    hbk_snow_params_t p;
    hbk_snow_params_default(&p);
    CHECK(p.size == sizeof p);
    CHECK(p.temperature == -1.0f && p.wet_temperature == -2.0f);
    CHECK(p.wet_stamp[0] == 110.0f && p.wet_stamp[2] == -48.0f && p.dry_stamp[1] == 90.0f);
    size_t n;
    const hbk_param_info_t *t = hbk_snow_params_info(&n);
    /* A row for every field but size: the rows tile the struct after it. */
    size_t bytes = 0;
    for (size_t i = 0; i < n; ++i) {
        bytes += t[i].count * (t[i].type == HBK_PARAM_U64 ? 8u : 4u);
        CHECK(t[i].description && strlen(t[i].description) > 10);
        CHECK(t[i].unit && t[i].name);
    }
    CHECK(bytes == sizeof p - 4);
    hbk_message_t m;
    hbk_snow_t *h = NULL;
    p.flake_count = 100;
    p.texture_width = p.texture_height = 16;
    CHECK_OK(hbk_snow_create(&h, &p, &m));
    hbk_snow_destroy(h);

    p.temperature = 9.0f;
    CHECK(hbk_snow_create(&h, &p, &m) == HBK_ERR_INVALID_ARGUMENT && h == NULL);
    CHECK(!strcmp(m.text, "temperature = 9: must be in [-10, 3] degC"));
    /* Every field, above its range, below it, and NaN for floats: refused by name. */
    for (size_t i = 0; i < n; ++i) {
        if (t[i].type == HBK_PARAM_U64) continue; /* every seed is valid */
        for (int side = 0; side < 3; ++side) {
            hbk_snow_params_t q = p;
            q.temperature = -1.0f;
            unsigned char *at = (unsigned char *)&q + t[i].offset;
            const double v = side == 0 ? t[i].max + 1 : t[i].min - 1;
            if (t[i].type == HBK_PARAM_F32) {
                const float f = side == 2 ? NAN : (float)v;
                memcpy(at, &f, 4);
            } else {
                if (side == 2) continue;
                const int32_t k = (int32_t)v;
                memcpy(at, &k, 4);
            }
            CHECK(hbk_snow_create(&h, &q, &m) == HBK_ERR_INVALID_ARGUMENT && h == NULL);
            /* "name = v: ..." or "name[0] = v: ..." (NaN in a vector gives no index). */
            const size_t len = strlen(t[i].name);
            if (strncmp(m.text, t[i].name, len) ||
                (strncmp(m.text + len, " = ", 3) && strncmp(m.text + len, "[0] = ", 6))) {
                fprintf(stderr, "field %s: message '%s'\n", t[i].name, m.text);
                CHECK(0);
            }
        }
    }
    /* Relations between fields. */
    hbk_snow_params_t q = p;
    q.temperature = -1.0f;
    q.volume_max[2] = q.volume_min[2];
    CHECK(hbk_snow_create(&h, &q, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "volume_max[2] = 0: must be > volume_min[2]", 42));
    q = p;
    q.temperature = -1.0f;
    q.tension_water[2] = 10.0f;
    CHECK(hbk_snow_create(&h, &q, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "tension_water[2] = 10: must be > tension_water[1] = 15", 53));
    q = p;
    q.temperature = -1.0f;
    q.sinter_temperature[0] = 0.0f;
    CHECK(hbk_snow_create(&h, &q, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "sinter_temperature[1]") != NULL);
    q = p;
    q.temperature = -1.0f;
    q.contact_mode = HBK_SNOW_CONTACT_BOX;
    q.texture_width = 2;
    CHECK(hbk_snow_create(&h, &q, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "texture_width") != NULL);
    q = p;
    q.temperature = -1.0f;
    q.size = 8;
    CHECK(hbk_snow_create(&h, &q, &m) == HBK_ERR_VERSION);
    CHECK(hbk_snow_create(&h, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(hbk_snow_create(NULL, &p, &m) == HBK_ERR_INVALID_ARGUMENT);
}

/* ---- statistics of sticking on a flat target ---- */

/* Fraction of contacts that stick on a large flat quad of catch chance `catch_`. */
static void measure_sticking(float temp, float catch_, double want)
{
    hbk_snow_params_t p = small_params();
    p.temperature = temp;
    p.flake_count = 10000;
    p.volume_min[0] = p.volume_min[1] = -1.0f;
    p.volume_max[0] = p.volume_max[1] = 1.0f;
    p.volume_max[2] = 1.0f;
    p.time_step = 0.05f;
    p.seed = (uint64_t)(1000 + 10 * temp + 100 * catch_);
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    mesh_t *m = calloc(1, sizeof *m);
    add_quad(m, -2, -2, 2, 2, 0.2f, 0, 0, 1, 1, 0);
    hbk_snow_material_t mat = {catch_, 0, 0};
    CHECK_OK(hbk_snow_set_materials(h, &mat, 1));
    CHECK_OK(set_mesh(h, m));
    hbk_snow_stats_t s;
    do {
        CHECK_OK(hbk_snow_step(h, 20, NULL));
        hbk_snow_stats(h, &s);
    } while (s.hits < 30000);
    const double n = (double)(s.stuck + s.bounced), got = (double)s.stuck / n;
    const double se = sqrt(want * (1 - want) / n);
    if (fabs(got - want) > 4 * se)
        fprintf(stderr, "T = %g, catch = %g: %.5f stuck per contact, want %.5f (se %.5f, n %.0f)\n",
                temp, catch_, got, want, se, n);
    CHECK(fabs(got - want) <= 4 * se);
    CHECK(s.melted == 0 && s.shed == 0 && s.hits == s.stuck + s.bounced);
    free(m);
    hbk_snow_destroy(h);
}

void test_snow_sticking_statistics(void)
{
    /* Sintering (below -2 degC): 2 % at -10, 10 % at -2, linear. */
    measure_sticking(-10.0f, 0.0f, 0.02);
    measure_sticking(-6.0f, 0.0f, 0.06);
    measure_sticking(-2.5f, 0.0f, 0.095);
    /* Surface tension: water content 5 % at -2 .. 25 % at 3 degC; 7 % -> 25 % -> 7 %. */
    measure_sticking(-2.0f, 0.0f, 0.07);
    measure_sticking(-0.75f, 0.0f, 0.16);
    measure_sticking(0.5f, 0.0f, 0.25);
    measure_sticking(1.75f, 0.0f, 0.16);
    measure_sticking(3.0f, 0.0f, 0.07);
    /* Rough materials: an independent catch chance on top. */
    measure_sticking(-6.0f, 0.4f, 1.0 - 0.94 * 0.6);
    measure_sticking(0.5f, 0.25f, 1.0 - 0.75 * 0.75);
}

/* ---- stamps ---- */

/* One flake onto a 1 m quad mapped to the middle of a 64x64 texture (32 texels per metre);
 * returns the coverage and depth after the first flake stuck, and its R. */
static int one_stamp(float temp, float radius, float **cov, float **dep, float *r)
{
    hbk_snow_params_t p = small_params();
    p.temperature = temp;
    p.flake_count = 1;
    p.flake_radius = radius;
    p.volume_min[0] = p.volume_min[1] = -0.5f;
    p.volume_max[0] = p.volume_max[1] = 0.5f;
    p.volume_max[2] = 1.0f;
    p.seed = 77;
    hbk_snow_t *h;
    if (hbk_snow_create(&h, &p, NULL)) return 0;
    mesh_t *m = calloc(1, sizeof *m);
    add_quad(m, -0.5f, -0.5f, 0.5f, 0.5f, 0.5f, 0.25f, 0.25f, 0.75f, 0.75f, 0);
    hbk_snow_material_t mat = {0.5f, 0, 0};
    int ok = hbk_snow_set_materials(h, &mat, 1) == HBK_OK && set_mesh(h, m) == HBK_OK;
    hbk_snow_stats_t s = {0};
    uint64_t step = 0;
    for (; ok && s.stuck == 0 && step < 10000; ++step) {
        ok = hbk_snow_step(h, 1, NULL) == HBK_OK;
        hbk_snow_stats(h, &s);
    }
    ok = ok && s.stuck == 1;
    /* The R of that contact: flake 0, the substep it happened in. */
    *r = hbk_rng_uniform(p.seed, 0, snow_rng_counter(step - 1, SNOW_RNG_CONTACT), 1);
    int32_t w, ht;
    *cov = ok ? get_cov(h, &w, &ht) : NULL;
    *dep = ok ? get_depth(h) : NULL;
    free(m);
    hbk_snow_destroy(h);
    return ok && *cov && *dep;
}

/* The coverage holds exactly one 3x3 stamp with cell alphas want[kind] (0 centre, 1 side,
 * 2 corner), and the depth matches it. */
static void check_stamp_3x3(const float *cov, const float *dep, const float want[3], float dpf)
{
    int cx = 0, cy = 0;
    for (int i = 0; i < 64 * 64; ++i)
        if (cov[i] > cov[cy * 64 + cx]) { cx = i % 64; cy = i / 64; }
    CHECK(cx >= 16 && cx < 48 && cy >= 16 && cy < 48); /* inside the quad's UV rectangle */
    double total = 0, stamp = 0;
    for (int i = 0; i < 64 * 64; ++i) total += cov[i];
    for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
            const int kind = (dx != 0) + (dy != 0);
            const float a = cov[(cy + dy) * 64 + cx + dx];
            CHECK_NEAR(a, want[kind], 1e-4);
            CHECK_NEAR(dep[(cy + dy) * 64 + cx + dx], dpf * want[kind] / 255.0, 1e-9);
            stamp += a;
        }
    CHECK_NEAR(total, stamp, 1e-3); /* nothing outside the 3x3 */
}

void test_snow_stamp_formulas(void)
{
    float *cov, *dep, r;
    /* Wet, 0.5 degC: water content 15 %, D = 0.55; alpha = u + vR + wD. */
    CHECK(one_stamp(0.5f, 1.0f / 64.0f, &cov, &dep, &r));
    const float D = 0.55f;
    const float wet[3] = {110.0f + 25.0f * r + -48.0f * D, 25.0f + 10.0f * r + 12.0f * D,
                          10.0f + 5.0f * r + 9.0f * D};
    check_stamp_3x3(cov, dep, wet, 0.001f);
    free(cov);
    free(dep);
    /* Dry, -5 degC: alpha = m + nR. */
    CHECK(one_stamp(-5.0f, 1.0f / 64.0f, &cov, &dep, &r));
    const float dry[3] = {90.0f + 90.0f * r, 10.0f + 15.0f * r, 5.0f + 10.0f * r};
    check_stamp_3x3(cov, dep, dry, 0.001f);
    free(cov);
    free(dep);
}

void test_snow_stamp_scaling(void)
{
    /* A flake of half a texel adds a quarter of the alpha to the 3x3 texels. */
    float *cov, *dep, r;
    CHECK(one_stamp(-5.0f, 0.5f / 64.0f, &cov, &dep, &r));
    int nz = 0;
    double mx = 0, total = 0;
    for (int i = 0; i < 64 * 64; ++i) {
        nz += cov[i] > 0;
        mx = fmax(mx, cov[i]);
        total += cov[i];
    }
    CHECK(nz == 9);
    CHECK_NEAR(mx, 0.25 * (90.0 + 90.0 * r), 1e-3);
    CHECK_NEAR(total, 0.25 * ((90 + 90 * r) + 4 * (10 + 15 * r) + 4 * (5 + 10 * r)), 1e-3);
    free(cov);
    free(dep);
    /* A flake of 3 texels: cells of 3x3 texels, 9x9 in all, full alpha. */
    CHECK(one_stamp(-5.0f, 3.0f / 64.0f, &cov, &dep, &r));
    nz = 0;
    total = 0;
    mx = 0;
    for (int i = 0; i < 64 * 64; ++i) {
        nz += cov[i] > 0;
        mx = fmax(mx, cov[i]);
        total += cov[i];
    }
    CHECK(nz == 81);
    CHECK_NEAR(mx, 90.0 + 90.0 * r, 1e-3);
    CHECK_NEAR(total, 9 * ((90 + 90 * r) + 4 * (10 + 15 * r) + 4 * (5 + 10 * r)), 1e-2);
    free(cov);
    free(dep);
}

/* ---- materials, shelter, depth, wind ---- */

void test_snow_melts_and_sheds(void)
{
    for (int mode = 0; mode < 2; ++mode) { /* TRIANGLES and BOX */
        hbk_snow_params_t p = small_params();
        p.contact_mode = mode;
        p.temperature = 0.5f;
        p.volume_min[0] = p.volume_min[1] = -1.0f;
        p.volume_max[0] = p.volume_max[1] = 1.0f;
        p.volume_max[2] = 1.0f;
        hbk_snow_t *h;
        CHECK_OK(hbk_snow_create(&h, &p, NULL));
        mesh_t *m = calloc(1, sizeof *m);
        add_quad(m, -2, -2, 0, 2, 0.3f, 0, 0, 0.5f, 1, 0); /* warm skin */
        add_quad(m, 0, -2, 2, 2, 0.3f, 0.5f, 0, 1, 1, 1);  /* spinning tyre */
        /* Rough as a coat: they would catch half the flakes if they took snow at all. */
        hbk_snow_material_t mat[2] = {{0.5f, 1, 0}, {0.5f, 0, 1}};
        CHECK_OK(hbk_snow_set_materials(h, mat, 2));
        CHECK_OK(set_mesh(h, m));
        CHECK_OK(hbk_snow_step(h, 100, NULL));
        hbk_snow_stats_t s;
        hbk_snow_stats(h, &s);
        CHECK(s.melted > 1000 && s.shed > 1000);
        CHECK(s.stuck == 0 && s.bounced == 0);
        int32_t w, ht;
        float *cov = get_cov(h, &w, &ht), *dep = get_depth(h);
        CHECK(cov && dep);
        CHECK(sum_region(cov, w, 0, 0, w, ht) == 0.0 && sum_region(dep, w, 0, 0, w, ht) == 0.0);
        /* Removed, not resting on the surface: every flake is above it. */
        static float xyz[2000 * 3];
        int32_t n;
        CHECK_OK(hbk_snow_flakes(h, xyz, 2000, &n));
        CHECK(n == 2000);
        for (int i = 0; i < n; ++i) CHECK(xyz[3 * i + 2] > 0.3f);
        free(cov);
        free(dep);
        free(m);
        hbk_snow_destroy(h);
    }
}

void test_snow_roof_shelter(void)
{
    for (int roof = 0; roof < 2; ++roof) {
        hbk_snow_params_t p = small_params();
        p.temperature = 0.5f;
        p.flake_count = 20000;
        p.flutter_amplitude = 0.2f;
        p.volume_max[2] = 2.0f;
        hbk_snow_t *h;
        CHECK_OK(hbk_snow_create(&h, &p, NULL));
        mesh_t *m = calloc(1, sizeof *m);
        add_quad(m, -0.5f, -0.5f, 0.5f, 0.5f, 0.05f, 0, 0, 0.4f, 1, 0); /* ground */
        if (roof) add_quad(m, -1.5f, -1.5f, 1.5f, 1.5f, 0.5f, 0.6f, 0, 1, 1, 0);
        CHECK_OK(set_mesh(h, m));
        CHECK_OK(hbk_snow_step(h, 150, NULL));
        int32_t w, ht;
        float *cov = get_cov(h, &w, &ht);
        CHECK(cov);
        const double ground = sum_region(cov, w, 0, 0, (int)(0.45 * w), ht);
        const double top = sum_region(cov, w, (int)(0.55 * w), 0, w, ht);
        if (roof) {
            CHECK(ground == 0.0);
            CHECK(top > 1000.0);
        } else {
            CHECK(ground > 1000.0);
        }
        free(cov);
        free(m);
        hbk_snow_destroy(h);
    }
}

void test_snow_depth_grows(void)
{
    hbk_snow_params_t p = small_params();
    p.temperature = -5.0f;
    p.texture_width = p.texture_height = 32;
    p.flake_radius = 0.04f; /* 1.28 texels at 16 texels per metre */
    p.volume_min[0] = p.volume_min[1] = -0.5f;
    p.volume_max[0] = p.volume_max[1] = 0.5f;
    p.volume_max[2] = 1.0f;
    p.depth_per_flake = 0.002f;
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    mesh_t *m = calloc(1, sizeof *m);
    add_quad(m, -0.5f, -0.5f, 0.5f, 0.5f, 0.5f, 0.25f, 0.25f, 0.75f, 0.75f, 0);
    hbk_snow_material_t mat = {0.5f, 0, 0};
    CHECK_OK(hbk_snow_set_materials(h, &mat, 1));
    CHECK_OK(set_mesh(h, m));
    CHECK_OK(hbk_snow_step(h, 300, NULL));
    hbk_snow_stats_t s1, s2;
    hbk_snow_stats(h, &s1);
    int32_t w, ht;
    float *c1 = get_cov(h, &w, &ht), *d1 = get_depth(h);
    CHECK_OK(hbk_snow_step(h, 300, NULL));
    hbk_snow_stats(h, &s2);
    float *c2 = get_cov(h, &w, &ht), *d2 = get_depth(h);
    CHECK(c1 && c2 && d1 && d2);
    /* The quad's texels (8..24) are white: coverage saturated at 255 and stays there... */
    for (int y = 9; y < 23; ++y)
        for (int x = 9; x < 23; ++x) {
            CHECK(c1[y * w + x] == 255.0f && c2[y * w + x] == 255.0f);
            CHECK(d2[y * w + x] > d1[y * w + x]); /* ...while the depth keeps growing */
        }
    /* Depth is the sum of all alpha stamped: per flake 245 on average (dry look: centre
     * 90 + 45, sides 4 (10 + 7.5), corners 4 (5 + 5)) times the cell area s^2 = 1.28^2. */
    const double per_flake = p.depth_per_flake * 245.0 / 255.0 * 1.28 * 1.28;
    const double dsum = sum_region(d2, w, 0, 0, w, ht) - sum_region(d1, w, 0, 0, w, ht);
    const double want = per_flake * (double)(s2.stuck - s1.stuck);
    CHECK(s2.stuck - s1.stuck > 5000);
    CHECK_NEAR(dsum / want, 1.0, 0.03);
    free(c1); free(c2); free(d1); free(d2);
    free(m);
    hbk_snow_destroy(h);
}

void test_snow_wind_windward(void)
{
    hbk_snow_params_t p = small_params();
    p.temperature = 0.5f;
    p.flake_count = 20000;
    p.wind[0] = 3.0f;
    p.flutter_amplitude = 0.1f;
    p.volume_max[2] = 3.0f;
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    mesh_t *m = calloc(1, sizeof *m);
    const float lo[3] = {-0.5f, -0.5f, 0.5f}, hi[3] = {0.5f, 0.5f, 1.5f};
    const float uvr[6][4] = {{0.35f, 0, 0.65f, 0.3f}, /* +X: leeward */
                             {0.0f, 0, 0.3f, 0.3f},   /* -X: windward */
                             {0.7f, 0, 1, 0.3f},     {0.7f, 0.35f, 1, 0.65f},
                             {0.0f, 0.7f, 0.3f, 1},  {0.35f, 0.7f, 0.65f, 1}};
    add_cube(m, lo, hi, uvr);
    CHECK_OK(set_mesh(h, m));
    CHECK_OK(hbk_snow_step(h, 150, NULL));
    int32_t w, ht;
    float *cov = get_cov(h, &w, &ht);
    CHECK(cov);
    const int th = (int)(0.32f * ht);
    const double windward = sum_region(cov, w, 0, 0, (int)(0.32f * w), th);
    const double leeward = sum_region(cov, w, (int)(0.33f * w), 0, (int)(0.67f * w), th);
    const double top = sum_region(cov, w, 0, (int)(0.68f * ht), (int)(0.32f * w), ht);
    CHECK(windward > 1000.0 && top > 1000.0);
    CHECK(leeward <= 0.01 * windward);
    free(cov);
    free(m);
    hbk_snow_destroy(h);
}

void test_snow_moving_mesh(void)
{
    /* A cube set again each frame somewhere else: flakes it moves onto start again at the
     * top instead of snowing on its inner faces. */
    hbk_snow_params_t p = small_params();
    p.flake_count = 20000;
    p.volume_max[2] = 2.0f;
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    static const float uvr[6][4] = {{0, 0, 1, 1}, {0, 0, 1, 1}, {0, 0, 1, 1},
                                    {0, 0, 1, 1}, {0, 0, 1, 1}, {0, 0, 1, 1}};
    static float xyz[20000 * 3];
    for (int frame = 0; frame < 6; ++frame) {
        mesh_t *m = calloc(1, sizeof *m);
        const float x = -1.5f + 0.5f * frame;
        const float lo[3] = {x, -0.5f, 0.5f}, hi[3] = {x + 1.0f, 0.5f, 1.5f};
        add_cube(m, lo, hi, uvr);
        CHECK_OK(set_mesh(h, m));
        CHECK_OK(hbk_snow_step(h, 1, NULL));
        int32_t n, inside = 0;
        CHECK_OK(hbk_snow_flakes(h, xyz, 20000, &n));
        for (int i = 0; i < n; ++i) {
            const float *q = xyz + 3 * i;
            inside += q[0] > lo[0] && q[0] < hi[0] && q[1] > lo[1] && q[1] < hi[1] &&
                      q[2] > lo[2] && q[2] < hi[2];
        }
        if (inside) fprintf(stderr, "frame %d: %d flakes inside\n", frame, inside);
        CHECK(inside == 0);
        free(m);
    }
    hbk_snow_destroy(h);
}

/* ---- determinism, state ---- */

static hbk_snow_t *scene(int threads, int32_t flakes)
{
    hbk_snow_params_t p = small_params();
    p.flake_count = flakes;
    p.threads = threads;
    p.wind[0] = 1.5f;
    p.wind[1] = -0.5f;
    p.volume_max[2] = 2.0f;
    p.flake_radius = 0.02f;
    p.seed = 4242;
    hbk_snow_t *h;
    if (hbk_snow_create(&h, &p, NULL)) return NULL;
    static mesh_t m;
    memset(&m, 0, sizeof m);
    const float lo[3] = {-0.5f, -0.5f, 0.2f}, hi[3] = {0.5f, 0.5f, 1.0f};
    const float uvr[6][4] = {{0, 0, 0.3f, 0.3f},   {0.35f, 0, 0.65f, 0.3f}, {0.7f, 0, 1, 0.3f},
                             {0, 0.35f, 0.3f, 0.65f}, {0.35f, 0.35f, 0.65f, 0.65f},
                             {0.7f, 0.35f, 1, 0.65f}};
    add_cube(&m, lo, hi, uvr);
    add_quad(&m, -2, -2, 2, 2, 0.1f, 0, 0.7f, 1, 1, 1);
    hbk_snow_material_t mat[2] = {{0.3f, 0, 0}, {0.0f, 0, 0}};
    if (hbk_snow_set_materials(h, mat, 2) || set_mesh(h, &m)) {
        hbk_snow_destroy(h);
        return NULL;
    }
    return h;
}

static int same_output(hbk_snow_t *a, hbk_snow_t *b)
{
    int32_t w, ht;
    float *ca = get_cov(a, &w, &ht), *cb = get_cov(b, &w, &ht);
    float *da = get_depth(a), *db = get_depth(b);
    const size_t n = (size_t)w * ht;
    int same = ca && cb && da && db && !memcmp(ca, cb, n * 4) && !memcmp(da, db, n * 4);
    hbk_snow_stats_t sa, sb;
    hbk_snow_stats(a, &sa);
    hbk_snow_stats(b, &sb);
    same = same && !memcmp(&sa, &sb, sizeof sa);
    int32_t na, nb;
    hbk_snow_flakes(a, NULL, 0, &na);
    hbk_snow_flakes(b, NULL, 0, &nb);
    float *fa = malloc((size_t)na * 12), *fb = malloc((size_t)nb * 12);
    same = same && na == nb && fa && fb && !hbk_snow_flakes(a, fa, na, &na) &&
           !hbk_snow_flakes(b, fb, nb, &nb) && !memcmp(fa, fb, (size_t)na * 12);
    /* Something happened at all. */
    same = same && sa.stuck > 100 && sa.bounced > 100;
    free(ca); free(cb); free(da); free(db); free(fa); free(fb);
    return same;
}

/* Whether the handle's slots hold the flakes by id (see snow_flakes_step's sort by place). */
static int slots_by_id(const hbk_snow_t *h)
{
    for (int32_t j = 0; j < h->p.flake_count; ++j)
        if (h->ids[j] != (uint32_t)j) return 0;
    return 1;
}

void test_snow_determinism_threads(void)
{
    hbk_snow_t *a = scene(1, 30000), *b = scene(2, 30000), *c = scene(2, 30000);
    CHECK(a && b && c);
    CHECK_OK(hbk_snow_step(a, 60, NULL));
    CHECK_OK(hbk_snow_step(b, 60, NULL));
    for (int i = 0; i < 60; ++i) CHECK_OK(hbk_snow_step(c, 1, NULL));
    CHECK(!slots_by_id(a) && !slots_by_id(c)); /* sorted by place, at other times */
    setenv("HBK_PATHS", "scalar", 1); /* read when the mesh is set */
    hbk_snow_t *d = scene(1, 30000);
    unsetenv("HBK_PATHS");
    CHECK(d && d->mesh.bvh.plain);
    CHECK_OK(hbk_snow_step(d, 60, NULL));
    CHECK(same_output(a, b)); /* any thread count */
    CHECK(same_output(a, c)); /* any split of the substeps */
    CHECK(same_output(a, d)); /* the BVH's walk with or without vector lanes */
    hbk_snow_destroy(a);
    hbk_snow_destroy(b);
    hbk_snow_destroy(c);
    hbk_snow_destroy(d);
}

void test_snow_state_roundtrip(void)
{
    hbk_snow_t *a = scene(2, 5000), *b = scene(1, 5000), *c = scene(1, 4000);
    CHECK(a && b && c);
    CHECK_OK(hbk_snow_step(a, 40, NULL));
    CHECK_OK(hbk_snow_step(b, 10, NULL));
    /* Both in slots by place: b takes the state back in slots by id. */
    CHECK(!slots_by_id(a) && !slots_by_id(b));
    const size_t n = hbk_snow_state_size(a);
    unsigned char *buf = malloc(n + 1);
    CHECK(buf);
    CHECK(hbk_snow_save_state(a, buf, n - 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK_OK(hbk_snow_save_state(a, buf + 1, n)); /* unaligned on purpose */
    CHECK_OK(hbk_snow_step(a, 40, NULL));
    /* A fresh handle, same params and mesh, continues bit-identically. */
    CHECK(hbk_snow_load_state(c, buf + 1, n) == HBK_ERR_STATE); /* other flake count */
    CHECK(hbk_snow_load_state(b, buf + 1, n - 1) == HBK_ERR_FORMAT);
    buf[1 + n / 2] ^= 0x10;
    CHECK(hbk_snow_load_state(b, buf + 1, n) == HBK_ERR_FORMAT);
    CHECK(strstr(hbk_snow_message(b), "checksum") != NULL);
    buf[1 + n / 2] ^= 0x10;
    /* A damaged header size is named as such, not as the version it still holds. */
    buf[1 + 12] ^= 0xff;
    CHECK(hbk_snow_load_state(b, buf + 1, n) == HBK_ERR_FORMAT);
    CHECK(strstr(hbk_snow_message(b), "snow state header size") != NULL);
    buf[1 + 12] ^= 0xff;
    CHECK_OK(hbk_snow_load_state(b, buf + 1, n));
    CHECK_OK(hbk_snow_step(b, 40, NULL));
    CHECK(same_output(a, b));
    free(buf);
    hbk_snow_destroy(a);
    hbk_snow_destroy(b);
    hbk_snow_destroy(c);
}

/* Where flakes meet the mesh (a hit in SNOW_SORT_HITS flake-steps or more), a step leaves them
 * in slots by place, so that the BVH walks of flakes stepped one after another share their nodes:
 * every id in one slot, neighbouring slots much nearer each other than neighbouring ids, and
 * the positions given by id. Nothing else may depend on the slots: the tests above step such
 * scenes split differently, on other thread counts, and from a state loaded by id. Where
 * flakes almost never meet anything the slots stay by id (a sort would cost more than it
 * saves). */
void test_snow_slots_by_place(void)
{
    enum { N = 30000 };
    hbk_snow_t *h = scene(1, N);
    CHECK(h);
    CHECK_OK(hbk_snow_step(h, 60, NULL));
    hbk_snow_stats_t s;
    hbk_snow_stats(h, &s);
    CHECK(s.hits * SNOW_SORT_HITS >= s.flake_steps);
    char *seen = calloc(N, 1);
    float *xyz = malloc(sizeof(float) * 3 * N);
    int32_t n = 0, once = 1, moved = 0, where = 1;
    CHECK(seen && xyz);
    CHECK_OK(hbk_snow_flakes(h, xyz, N, &n));
    double by_slot = 0.0, by_id = 0.0;
    for (int32_t j = 0; j < N; ++j) {
        const uint32_t id = h->ids[j];
        once &= id < N && !seen[id];
        if (id >= N) break;
        seen[id] = 1;
        moved += id != (uint32_t)j;
        where &= !memcmp(xyz + 3 * (size_t)id, h->flakes[j].p, sizeof(float) * 3);
        if (j == 0) continue;
        double a = 0.0, b = 0.0;
        for (int k = 0; k < 3; ++k) {
            const double ds = h->flakes[j].p[k] - h->flakes[j - 1].p[k];
            const double di = xyz[3 * j + k] - xyz[3 * (j - 1) + k];
            a += ds * ds;
            b += di * di;
        }
        by_slot += sqrt(a);
        by_id += sqrt(b);
    }
    CHECK(n == N && once && where);
    CHECK(moved > N / 2);
    CHECK(by_slot < 0.25 * by_id);
    hbk_snow_destroy(h);
    /* A small roof in a large volume: few flakes meet it. */
    hbk_snow_params_t p = small_params();
    p.flake_count = N;
    static mesh_t m;
    memset(&m, 0, sizeof m);
    add_quad(&m, -0.1f, -0.1f, 0.1f, 0.1f, 1.0f, 0, 0, 1, 1, 0);
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    CHECK_OK(set_mesh(h, &m));
    CHECK_OK(hbk_snow_step(h, 60, NULL));
    hbk_snow_stats(h, &s);
    CHECK(s.hits > 0 && s.hits * SNOW_SORT_HITS < s.flake_steps);
    CHECK(slots_by_id(h));
    hbk_snow_destroy(h);
    free(seen);
    free(xyz);
}

void test_snow_cancel(void)
{
    hbk_snow_t *h = scene(2, 20000);
    CHECK(h);
    CHECK_OK(hbk_snow_step(h, 10, NULL));
    float *before = malloc(20000 * 12), *after = malloc(20000 * 12);
    int32_t n;
    CHECK_OK(hbk_snow_flakes(h, before, 20000, &n));
    hbk_snow_stats_t s0, s1;
    hbk_snow_stats(h, &s0);
    hbk_progress_t pr = {1, 0.0f};
    CHECK(hbk_snow_step(h, 50, &pr) == HBK_ERR_CANCELLED);
    CHECK_OK(hbk_snow_flakes(h, after, 20000, &n));
    hbk_snow_stats(h, &s1);
    CHECK(!memcmp(before, after, 20000 * 12) && !memcmp(&s0, &s1, sizeof s0));
    pr.cancel = 0;
    CHECK_OK(hbk_snow_step(h, 5, &pr));
    CHECK(pr.fraction == 1.0f);
    free(before);
    free(after);
    hbk_snow_destroy(h);
}

/* ---- mesh and materials input ---- */

void test_snow_mesh_rejects_far_vertices(void)
{
    /* Finite positions whose span passes FLT_MAX (a ground quad 2e38 m either side) made the
     * occupancy grid's cell count NaN, converted to int (undefined); such a mesh is refused
     * by name, and the largest accepted one still steps. */
    hbk_snow_params_t p = small_params();
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    mesh_t *m = calloc(1, sizeof *m);
    add_quad(m, -2e38f, -2e38f, 2e38f, 2e38f, 0.5f, 0, 0, 1, 1, 0);
    CHECK(set_mesh(h, m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(hbk_snow_message(h), "positions[0] = (-2e+38, -2e+38, 0.5): must be finite, "
                   "|x|, |y|, |z| <= 1e6 m", 80));
    m->nv = m->nt = 0;
    add_quad(m, -1e6f, -1e6f, 1e6f, 1e6f, 0.5f, 0, 0, 1, 1, 0);
    CHECK_OK(set_mesh(h, m));
    CHECK_OK(hbk_snow_step(h, 4, NULL));
    free(m);
    hbk_snow_destroy(h);
}

void test_snow_mesh_rejects(void)
{
    hbk_snow_params_t p = small_params();
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    mesh_t *m = calloc(1, sizeof *m);
    add_quad(m, -1, -1, 1, 1, 0.5f, 0, 0, 1, 1, 0);
    CHECK_OK(set_mesh(h, m));
    m->tri[4] = 7;
    CHECK(set_mesh(h, m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(hbk_snow_message(h), "triangles[4] = 7: must be in [0, 4) (vertex_count)"));
    m->tri[4] = -1;
    CHECK(set_mesh(h, m) == HBK_ERR_INVALID_ARGUMENT);
    m->tri[4] = 2;
    CHECK(hbk_snow_set_mesh(h, NULL, 4, m->tri, m->uv, NULL, 2) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "positions") != NULL);
    CHECK(hbk_snow_set_mesh(h, m->pos, 4, NULL, m->uv, NULL, 2) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "triangles") != NULL);
    CHECK(hbk_snow_set_mesh(h, m->pos, 4, m->tri, NULL, NULL, 2) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "uvs") != NULL);
    CHECK(hbk_snow_set_mesh(h, m->pos, 4, m->tri, m->uv, NULL, -1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "triangle_count") != NULL);
    CHECK(hbk_snow_set_mesh(h, m->pos, 0, m->tri, m->uv, NULL, 2) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "vertex_count") != NULL);
    m->mat[1] = 1; /* only one slot set */
    CHECK(set_mesh(h, m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(hbk_snow_message(h), "material_index[1] = 1: must be in [0, 1)", 40));
    m->mat[1] = 0;
    m->pos[5] = NAN;
    CHECK(set_mesh(h, m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "positions[1]") != NULL);
    m->pos[5] = 0.5f;
    m->uv[3] = INFINITY;
    CHECK(set_mesh(h, m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "uvs[3]") != NULL);
    m->uv[3] = 0.0f;
    CHECK(hbk_snow_set_mesh(NULL, m->pos, 4, m->tri, m->uv, NULL, 2) == HBK_ERR_INVALID_ARGUMENT);
    /* Materials. */
    hbk_snow_material_t mat[2] = {{0.7f, 0, 0}, {0.1f, 0, 0}};
    CHECK(hbk_snow_set_materials(h, mat, 2) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(hbk_snow_message(h), "materials[0].catch_chance = 0.7: must be in [0, 0.5]"));
    mat[0].catch_chance = 0.4f;
    mat[1].melts = 2;
    CHECK(hbk_snow_set_materials(h, mat, 2) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "materials[1].melts = 2") != NULL);
    mat[1].melts = 0;
    mat[1].sheds = -1;
    CHECK(hbk_snow_set_materials(h, mat, 2) == HBK_ERR_INVALID_ARGUMENT);
    mat[1].sheds = 0;
    CHECK(hbk_snow_set_materials(h, NULL, 2) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(hbk_snow_set_materials(h, mat, 0) == HBK_ERR_INVALID_ARGUMENT);
    CHECK_OK(hbk_snow_set_materials(h, mat, 2));
    m->mat[1] = 1;
    CHECK_OK(set_mesh(h, m));
    CHECK(hbk_snow_set_materials(h, mat, 1) == HBK_ERR_INVALID_ARGUMENT); /* slot 1 in use */
    /* Outputs. */
    float buf[16];
    hbk_image_t small = {buf, 2, 2, 4, 8};
    CHECK(hbk_snow_coverage(h, &small) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "must be 64x64") != NULL);
    CHECK(hbk_snow_coverage(h, NULL) == HBK_ERR_INVALID_ARGUMENT);
    int32_t n;
    CHECK(hbk_snow_flakes(h, NULL, 5, &n) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(hbk_snow_flakes(h, buf, 1, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(hbk_snow_step(h, 0, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "substeps = 0") != NULL);
    CHECK_OK(hbk_snow_set_mesh(h, NULL, 0, NULL, NULL, NULL, 0)); /* removes the mesh */
    free(m);
    hbk_snow_destroy(h);
}

/* ---- the paper's box mode ---- */

void test_snow_box_mode(void)
{
    hbk_snow_params_t p = small_params();
    p.contact_mode = HBK_SNOW_CONTACT_BOX;
    p.temperature = 0.5f;
    p.texture_width = 60;
    p.texture_height = 40; /* tiles of 20 x 20 */
    p.flake_count = 5000;
    p.volume_max[2] = 2.0f;
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    hbk_snow_material_t mat[2] = {{0.2f, 0, 0}, {0.0f, 1, 0}}; /* a part, and warm skin */
    CHECK_OK(hbk_snow_set_materials(h, mat, 2));
    int32_t w, ht;
    hbk_snow_texture_size(h, &w, &ht);
    CHECK(w == 60 && ht == 80); /* one 60 x 40 block per slot */
    mesh_t *m = calloc(1, sizeof *m);
    add_quad(m, -1.0f, -1.0f, 0.0f, 1.0f, 0.5f, 0, 0, 1, 1, 0);
    add_quad(m, 0.5f, -1.0f, 1.5f, 1.0f, 0.5f, 0, 0, 1, 1, 1);
    CHECK_OK(hbk_snow_set_mesh(h, m->pos, m->nv, m->tri, NULL, m->mat, m->nt)); /* no UVs */
    CHECK_OK(hbk_snow_step(h, 100, NULL));
    hbk_snow_stats_t s;
    hbk_snow_stats(h, &s);
    CHECK(s.stuck > 100 && s.melted > 100);
    float *cov = get_cov(h, &w, &ht);
    CHECK(cov);
    /* Flakes fall down onto the +Z face: block 0, top row, third column. Nothing else. */
    const double ztile = sum_region(cov, w, 40, 20, 60, 40);
    CHECK(ztile > 1000.0);
    CHECK_NEAR(sum_region(cov, w, 0, 0, w, ht), ztile, 1e-6 * ztile);
    /* The whole tile is used: the part spans it. */
    CHECK(sum_region(cov, w, 40, 20, 45, 40) > 0 && sum_region(cov, w, 55, 20, 60, 40) > 0);
    CHECK(sum_region(cov, w, 40, 20, 60, 25) > 0 && sum_region(cov, w, 40, 35, 60, 40) > 0);
    /* The mesh uses slot 1; and snow was laid, so the slot count can no longer change. */
    CHECK(hbk_snow_set_materials(h, mat, 1) == HBK_ERR_INVALID_ARGUMENT);
    hbk_snow_material_t three[3] = {mat[0], mat[1], mat[0]};
    CHECK(hbk_snow_set_materials(h, three, 3) == HBK_ERR_STATE);
    CHECK(strstr(hbk_snow_message(h), "before the first step") != NULL);
    mat[0].catch_chance = 0.1f; /* same count: settings may change at any time */
    CHECK_OK(hbk_snow_set_materials(h, mat, 2));
    free(cov);
    free(m);
    hbk_snow_destroy(h);
}

/* ---- BVH against brute force ---- */

/* The nearest hit over every triangle (no tree to get wrong); of equally near ones the first
 * in leaf order. */
static int brute_hit(const bvh_t *b, const float o[3], const float d[3], float *tbest,
                     int32_t *which)
{
    int found = 0;
    float tmax = 1.0f;
    for (int32_t i = 0; i < b->tri_count; ++i) {
        float tt, u, v;
        if (snow_ray_tri(&b->tris[i], o, d, &tt, &u, &v) && (tt < tmax || (tt == tmax && !found))) {
            tmax = tt;
            *which = i;
            found = 1;
        }
    }
    *tbest = tmax;
    return found;
}

/* Random triangles, every fifth one twice (the copies fall in leaves of their own, and a
 * segment through them meets both at the same parameter): the walk of the four-wide tree
 * finds what brute force finds, the same triangle of two equally near ones too, for short
 * steps and long rays; and with HBK_PATHS=scalar (no vector lanes) the same bits. */
void test_snow_bvh_brute_force(void)
{
    enum { NT = 3000, NS = 20000 };
    float *pos = malloc(sizeof(float) * 9 * NT);
    int32_t *tri = malloc(sizeof(int32_t) * 3 * NT);
    float u[12];
    for (int i = 0; i < NT; ++i) {
        hbk_rng_fill_uniform(5, 1, (uint64_t)(i % 5 == 4 ? i - 1 : i) * 3, u, 12);
        for (int c = 0; c < 3; ++c)
            for (int k = 0; k < 3; ++k)
                pos[9 * i + 3 * c + k] = u[k] * 4.0f - 2.0f + (u[3 + 3 * c + k] - 0.5f) * 0.3f;
        for (int c = 0; c < 3; ++c) tri[3 * i + c] = 3 * i + c;
    }
    bvh_t b, plain;
    CHECK(snow_bvh_build(&b, pos, tri, NT) == HBK_OK);
    CHECK(b.tri_count == NT && b.node_count < 2 * NT && b.wide_count < b.node_count / 2);
    setenv("HBK_PATHS", "scalar", 1);
    CHECK(snow_bvh_build(&plain, pos, tri, NT) == HBK_OK);
    unsetenv("HBK_PATHS");
    CHECK(plain.plain && !b.plain);
    int hits = 0, mismatch = 0, ties = 0;
    for (int s = 0; s < NS; ++s) {
        hbk_rng_fill_uniform(6, 2, (uint64_t)s * 2, u, 8);
        const float o[3] = {u[0] * 5 - 2.5f, u[1] * 5 - 2.5f, u[2] * 5 - 2.5f};
        const float len = s % 2 ? 0.2f : 3.0f; /* short steps and long rays */
        const float d[3] = {(u[3] - 0.5f) * len, (u[4] - 0.5f) * len, (u[5] - 0.5f) * len};
        bvh_hit_t h;
        float tb;
        int32_t which = -1;
        const int a = snow_bvh_hit(&b, o, d, &h), c = brute_hit(&b, o, d, &tb, &which);
        bvh_hit_t hp;
        const int ap = snow_bvh_hit(&plain, o, d, &hp); /* without vector lanes: the same bits */
        if (ap != a || (a && memcmp(&hp, &h, sizeof h))) ++mismatch;
        hits += c;
        if (c) ties += b.tris[which].id % 5 >= 3; /* one of a pair: the other as near */
        if (a != c || (a && (h.t != tb || h.tri != which))) ++mismatch;
    }
    CHECK(hits > 1000 && ties > 100);
    CHECK(mismatch == 0);
    snow_bvh_free(&b);
    snow_bvh_free(&plain);
    free(pos);
    free(tri);
}

/* BOX mode stacks a block per slot: no more slots than the image the outputs take (65536
 * texels high) holds, refused by name with the count allowed. */
void test_snow_box_slots_fit_the_image(void)
{
    hbk_snow_params_t p = small_params();
    p.contact_mode = HBK_SNOW_CONTACT_BOX;
    p.texture_width = 4;
    p.texture_height = 8192;
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    hbk_snow_material_t mat[9];
    for (int i = 0; i < 9; ++i) mat[i] = (hbk_snow_material_t){0.1f, 0, 0};
    CHECK(hbk_snow_set_materials(h, mat, 9) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_snow_message(h), "count = 9") &&
          strstr(hbk_snow_message(h), "must be in [1, 8] at this texture_height"));
    CHECK_OK(hbk_snow_set_materials(h, mat, 8));
    int32_t w, ht;
    hbk_snow_texture_size(h, &w, &ht);
    CHECK(w == 4 && ht == 65536);
    hbk_snow_destroy(h);
}

/* ---- flake motion (§3.1): fall, flutter, wind; the volume wraps on its sides (§4.1.10) ---- */

/* One substep of chosen flakes against the model by hand: the velocity relaxes towards the
 * air velocity (wind + flutter (cos, sin) * amplitude, - own fall speed) with the time
 * constant of a flake at terminal speed, tau = fall_speed / g (exactly: v += (a - v)
 * (1 - exp(-dt / tau))); the position moves by the new velocity; the flutter direction turns
 * by 2 pi f (0.7 + 0.6 c / 15) dt for class c, clockwise with bit 4. A flake crossing a side
 * comes in at the opposite one; one leaving the bottom starts again within one substep's fall
 * of the top. Then the statistics of many flakes: own fall speeds uniform in +-20 % (mean
 * fall_speed), flutter phases and classes uniform, and after a while every flake falls at its
 * own speed with the wind, its sideways speed about the wind the flutter amplitude (less the
 * lag of following a turning air speed). */
void test_snow_flake_motion(void)
{
    hbk_snow_params_t p = small_params();
    p.flake_count = 4;
    p.fall_speed = 1.0f;
    p.flutter_amplitude = 0.3f;
    p.flutter_frequency = 0.5f;
    p.time_step = 0.04f;
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    const snow_flake_t f0 = {{0.0f, 0.0f, 2.0f}, {0.0f, 0.0f, 0.0f}, 1.0f, 0.0f, 1.0f, 0};
    const snow_flake_t f1 = {{0.5f, -1.0f, 3.0f}, {0.5f, -0.2f, 0.1f}, 0.6f, 0.8f, 1.1f, 16 + 15};
    const snow_flake_t f2 = {{1.99f, 0.0f, 2.0f}, {1.0f, 0.0f, -1.0f}, 0.0f, 1.0f, 1.0f, 3};
    const snow_flake_t f3 = {{0.0f, 0.0f, 0.01f}, {0.0f, 0.0f, -1.0f}, 1.0f, 0.0f, 1.0f, 3};
    h->flakes[0] = f0; h->flakes[1] = f1; h->flakes[2] = f2; h->flakes[3] = f3;
    CHECK_OK(hbk_snow_step(h, 1, NULL));
    const double dt = p.time_step, r = 1.0 - exp(-dt * 9.81 / p.fall_speed);
    const snow_flake_t *in[3] = {&f0, &f1, &f2};
    for (int i = 0; i < 3; ++i) {
        const snow_flake_t *a = in[i], *b = &h->flakes[i];
        const double air[3] = {p.flutter_amplitude * a->fc, p.flutter_amplitude * a->fs, -a->fall};
        for (int k = 0; k < 3; ++k) {
            const double v = a->v[k] + (air[k] - a->v[k]) * r;
            double x = a->p[k] + v * dt;
            if (k == 0 && x >= p.volume_max[0]) x -= p.volume_max[0] - p.volume_min[0];
            CHECK_NEAR(b->v[k], v, 1e-6);
            CHECK_NEAR(b->p[k], x, 2e-6);
        }
        const int c = (int)(a->cls & 15);
        const double ang = (a->cls & 16 ? -1.0 : 1.0) * 2.0 * M_PI * p.flutter_frequency *
                           (0.7 + 0.6 * c / 15.0) * dt;
        CHECK_NEAR(b->fc, a->fc * cos(ang) - a->fs * sin(ang), 1e-6);
        CHECK_NEAR(b->fs, a->fs * cos(ang) + a->fc * sin(ang), 1e-6);
    }
    CHECK(h->flakes[2].p[0] < -1.9f); /* came in at the other side */
    const snow_flake_t *g = &h->flakes[3];
    CHECK(g->p[2] <= p.volume_max[2] && g->p[2] >= p.volume_max[2] - 1.2f * p.fall_speed * dt);
    CHECK(g->fall >= 0.8f * p.fall_speed && g->fall <= 1.2f * p.fall_speed);
    hbk_snow_stats_t s;
    hbk_snow_stats(h, &s);
    CHECK(s.fell == 1 && s.hits == 0);
    hbk_snow_destroy(h);

    enum { N = 20000 };
    p = small_params();
    p.flake_count = N;
    p.wind[0] = 1.0f;
    p.wind[1] = 0.5f;
    p.seed = 31;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    double mf = 0.0, mz = 0.0, mc = 0.0, ms = 0.0;
    int cls[32] = {0};
    for (int i = 0; i < N; ++i) {
        const snow_flake_t *f = &h->flakes[i];
        CHECK(f->fall >= 0.8f * p.fall_speed && f->fall <= 1.2f * p.fall_speed);
        CHECK_NEAR(f->fc * f->fc + f->fs * f->fs, 1.0, 1e-6);
        CHECK(f->p[2] >= p.volume_min[2] && f->p[2] <= p.volume_max[2]);
        mf += f->fall / N;
        mz += f->p[2] / N;
        mc += f->fc / N;
        ms += f->fs / N;
        cls[f->cls & 31]++;
    }
    /* four standard errors of a uniform +-0.2, of z uniform over 4 m, of a unit phasor */
    CHECK(fabs(mf - p.fall_speed) <= 4 * 0.4 / sqrt(12.0 * N));
    CHECK(fabs(mz - 2.0) <= 4 * 4.0 / sqrt(12.0 * N));
    CHECK(fabs(mc) <= 4 * sqrt(0.5 / N) && fabs(ms) <= 4 * sqrt(0.5 / N));
    for (int c = 0; c < 32; ++c) CHECK(fabs(cls[c] - N / 32.0) <= 4 * sqrt(N / 32.0 * (31.0 / 32)));
    CHECK_OK(hbk_snow_step(h, 100, NULL));
    double mvx = 0.0, mvy = 0.0;
    for (int i = 0; i < N; ++i) {
        const snow_flake_t *f = &h->flakes[i];
        CHECK_NEAR(f->v[2], -f->fall, 1e-5); /* terminal: own fall speed, no vertical wind */
        const double side = hypot(f->v[0] - p.wind[0], f->v[1] - p.wind[1]);
        CHECK(side >= 0.9 * p.flutter_amplitude && side <= 1.0001 * p.flutter_amplitude);
        mvx += f->v[0] / N;
        mvy += f->v[1] / N;
    }
    CHECK(fabs(mvx - p.wind[0]) <= 4 * p.flutter_amplitude * sqrt(0.5 / N));
    CHECK(fabs(mvy - p.wind[1]) <= 4 * p.flutter_amplitude * sqrt(0.5 / N));
    hbk_snow_destroy(h);
}

/* ---- BOX mode (§3.2.1, §3.3.1): the face between Q and P, the hit point R, six tiles ---- */

/* For every face of a part's box: a segment Q -> P across it at a known point X is found to
 * enter through that face, at R = X, where the paper's s = (D - D1) / (D2 - D1) puts it
 * (R = P' - s (P' - Q')); R maps into the face's own tile (bottom row -X -Y -Z, top row +X +Y
 * +Z), at the point's fractions along the tile's axes, which are the face seen from outside:
 * not mirrored (u x v = the outward normal), the sides upright (v = +Z). Then flakes in a wind
 * along +x snow on the windward -X and the top +Z tiles, never on the leeward +X or the
 * bottom -Z. */
void test_snow_box_faces(void)
{
    hbk_snow_params_t p = small_params();
    p.contact_mode = HBK_SNOW_CONTACT_BOX;
    p.texture_width = 60;
    p.texture_height = 40; /* tiles of 20 x 20 */
    p.flake_radius = 0.001f;
    p.temperature = 0.5f;
    p.flake_count = 20000;
    p.wind[0] = 3.0f;
    p.flutter_amplitude = 0.1f;
    p.volume_max[2] = 2.0f;
    hbk_snow_t *h;
    CHECK_OK(hbk_snow_create(&h, &p, NULL));
    mesh_t *m = calloc(1, sizeof *m);
    const float lo[3] = {-0.5f, -0.25f, 0.2f}, hi[3] = {0.5f, 0.25f, 0.7f};
    static const float uvr[6][4] = {{0, 0, 1, 1}, {0, 0, 1, 1}, {0, 0, 1, 1},
                                    {0, 0, 1, 1}, {0, 0, 1, 1}, {0, 0, 1, 1}};
    add_cube(m, lo, hi, uvr);
    CHECK_OK(hbk_snow_set_mesh(h, m->pos, m->nv, m->tri, NULL, m->mat, m->nt));
    for (int f = 0; f < 6; ++f) {
        const int ax = f / 2;
        const double sg = (f & 1) ? -1.0 : 1.0;
        float n[3];
        snow_box_normal(f, n);
        CHECK(n[ax] == (float)sg);
        /* the face's texel axes, measured: which world axis moves tx, and ty */
        float c[3];
        for (int k = 0; k < 3; ++k) c[k] = 0.5f * (lo[k] + hi[k]);
        c[ax] = sg > 0 ? hi[ax] : lo[ax];
        float tx0, ty0, sx, sy, U[3] = {0}, V[3] = {0};
        snow_box_face_texel(h, 0, f, c, &tx0, &ty0, &sx, &sy);
        for (int k = 0; k < 3; ++k) {
            if (k == ax) continue;
            float e[3] = {c[0], c[1], c[2]}, tx, ty;
            e[k] += 0.01f;
            snow_box_face_texel(h, 0, f, e, &tx, &ty, &sx, &sy);
            U[k] = tx > tx0 + 1e-4f ? 1.0f : tx < tx0 - 1e-4f ? -1.0f : 0.0f;
            V[k] = ty > ty0 + 1e-4f ? 1.0f : ty < ty0 - 1e-4f ? -1.0f : 0.0f;
        }
        const float x[3] = {U[1] * V[2] - U[2] * V[1], U[2] * V[0] - U[0] * V[2],
                            U[0] * V[1] - U[1] * V[0]};
        CHECK(x[0] == n[0] && x[1] == n[1] && x[2] == n[2]); /* seen from outside */
        if (ax != 2) CHECK(V[2] == 1.0f);                    /* sides upright */
        /* a crossing at fractions (a, b) of the face along U and V */
        const double a = 0.3, b = 0.8;
        double X[3];
        for (int k = 0; k < 3; ++k) {
            X[k] = c[k];
            if (U[k] != 0.0f) X[k] = U[k] > 0 ? lo[k] + a * (hi[k] - lo[k]) : hi[k] - a * (hi[k] - lo[k]);
            if (V[k] != 0.0f) X[k] = V[k] > 0 ? lo[k] + b * (hi[k] - lo[k]) : hi[k] - b * (hi[k] - lo[k]);
        }
        float Q[3], P[3], d[3];
        for (int k = 0; k < 3; ++k) {
            const double tang = 0.013 * (U[k] + 0.5 * V[k]);
            Q[k] = (float)(X[k] + 0.05 * n[k] + tang);
            P[k] = (float)(X[k] - 0.07 * n[k] - 1.4 * tang);
            d[k] = P[k] - Q[k];
        }
        float t;
        int32_t box, face;
        CHECK(snow_box_hit(&h->mesh, Q, d, &t, &box, &face));
        CHECK(box == 0 && face == f);
        /* the paper's parameter from the other end: R = P - s (P - Q) */
        double D1 = 0, D2 = 0, D = 0;
        for (int k = 0; k < 3; ++k) { D1 += P[k] * n[k]; D2 += Q[k] * n[k]; D += X[k] * n[k]; }
        const double s = (D - D1) / (D2 - D1);
        CHECK_NEAR(1.0 - t, s, 1e-5);
        float R[3];
        for (int k = 0; k < 3; ++k) {
            R[k] = Q[k] + t * d[k];
            CHECK_NEAR(R[k], P[k] - s * (P[k] - Q[k]), 1e-5);
            CHECK_NEAR(R[k], X[k], 1e-5);
        }
        float tx, ty;
        snow_box_face_texel(h, 0, f, R, &tx, &ty, &sx, &sy);
        const double col = ax * 20.0, row = (f & 1) ? 0.0 : 20.0;
        CHECK_NEAR(tx, col + a * 20.0, 1e-3);
        CHECK_NEAR(ty, row + b * 20.0, 1e-3);
        /* the stamp cell: the flake's diameter in texels of this face */
        double ext_u = 0.0;
        for (int k = 0; k < 3; ++k) if (U[k] != 0.0f) ext_u = hi[k] - lo[k];
        CHECK_NEAR(sx, 2.0 * p.flake_radius * 20.0 / ext_u, 1e-6);
        /* leaving from inside the box (a flake already in, Q not outside): no contact */
        const float mid[3] = {0.5f * (lo[0] + hi[0]), 0.5f * (lo[1] + hi[1]), 0.5f * (lo[2] + hi[2])};
        float dout[3];
        for (int k = 0; k < 3; ++k) dout[k] = 2.0f * ((float)X[k] - mid[k]);
        CHECK(!snow_box_hit(&h->mesh, mid, dout, &t, &box, &face));
    }
    CHECK_OK(hbk_snow_step(h, 100, NULL));
    int32_t w, ht;
    float *cov = get_cov(h, &w, &ht);
    CHECK(cov && w == 60 && ht == 40);
    const double mx = sum_region(cov, w, 0, 0, 20, 20), px = sum_region(cov, w, 0, 20, 20, 40);
    const double mz = sum_region(cov, w, 40, 0, 60, 20), pz = sum_region(cov, w, 40, 20, 60, 40);
    CHECK(mx > 1000.0 && pz > 1000.0);
    CHECK(px == 0.0 && mz == 0.0);
    free(cov);
    free(m);
    hbk_snow_destroy(h);
}
