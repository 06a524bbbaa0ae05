/* Caustics: the analytic flat map, focusing by a lens, energy, the photon tracer, shorelines,
 * tiling, determinism, view refraction and refusals. */
#include "test.h"
#include "caustics_photons.h"
#include <stdlib.h>

static void grid_fill(grid_t *g, float v)
{
    for (size_t i = 0; i < (size_t)g->img.width * g->img.height * g->img.channels; ++i) g->v[i] = v;
}

/* A periodic wavy surface around `level`: three waves with whole numbers of periods. */
static grid_t waves(int32_t w, int32_t h, float level, double amp, double shift_i, double shift_j)
{
    grid_t g = grid_new(w, h, 1);
    for (int32_t j = 0; j < h; ++j)
        for (int32_t i = 0; i < w; ++i) {
            const double x = (i + 0.5 + shift_i) / w, y = (j + 0.5 + shift_j) / h;
            g.v[j * w + i] = (float)(level + amp * (sin(2 * M_PI * (3 * x + y)) +
                                                    0.7 * sin(2 * M_PI * (-2 * x + 5 * y) + 1.0) +
                                                    0.4 * cos(2 * M_PI * (7 * x + 4 * y))));
        }
    return g;
}

static double channel_sum(const grid_t *m, int c)
{
    double s = 0.0;
    for (size_t i = 0; i < (size_t)m->img.width * m->img.height; ++i) s += m->v[i * m->img.channels + c];
    return s;
}

static hbk_caustics_params_t sun(double x, double y)
{
    hbk_caustics_params_t p;
    hbk_caustics_params_default(&p);
    p.light_direction[0] = (float)x;
    p.light_direction[1] = (float)y;
    p.light_direction[2] = 1.0f;
    return p;
}

void test_caustics_params_rejects(void)
{
    size_t count = 0;
    const hbk_param_info_t *info = hbk_caustics_params_info(&count);
    CHECK(count == 13);
    hbk_caustics_params_t p0;
    hbk_caustics_params_default(&p0);
    hbk_message_t m;
    CHECK_OK(hbk_caustics_params_check(&p0, &m));
    size_t covered = sizeof(uint32_t);
    for (size_t i = 0; i < count; ++i) covered += info[i].count * 4u;
    CHECK(covered == sizeof p0);
    grid_t w = grid_new(8, 8, 1), g = grid_new(8, 8, 1), out = grid_new(16, 16, 3);
    grid_fill(&w, 1.0f);
    for (size_t i = 0; i < count; ++i) {
        CHECK(info[i].description && strlen(info[i].description) > 10 && info[i].unit);
        for (int side = 0; side < 3; ++side) {
            hbk_caustics_params_t p = p0;
            if (!hbk_test_break_param(&p, &info[i], side)) continue;
            /* Every entry point refuses it and names the field. */
            CHECK(hbk_caustics_render(&p, &w.img, &g.img, 0.1f, &out.img, NULL, NULL, &m) ==
                  HBK_ERR_INVALID_ARGUMENT);
            CHECK(!strncmp(m.text, info[i].name, strlen(info[i].name)));
            const float cam[3] = {0.4f, 0.4f, 5.0f};
            grid_t uv = grid_new(8, 8, 2);
            CHECK(hbk_caustics_view(&p, &w.img, &g.img, 0.1f, cam, &uv.img, NULL, &m) ==
                  HBK_ERR_INVALID_ARGUMENT);
            CHECK(!strncmp(m.text, info[i].name, strlen(info[i].name)));
            free(uv.v);
        }
    }
    /* Cross-field rules. */
    hbk_caustics_params_t p = p0;
    p.size = 4;
    CHECK(hbk_caustics_render(&p, &w.img, &g.img, 0.1f, &out.img, NULL, NULL, &m) == HBK_ERR_VERSION);
    p = sun(1.0, 0.0);
    p.light_direction[2] = -0.5f;
    CHECK(hbk_caustics_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "light_direction", 15));
    p = p0;
    p.auto_extent = 0;
    p.extent[0] = 1.0f;
    p.extent[2] = 0.5f;
    p.extent[3] = 1.0f;
    CHECK(hbk_caustics_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "extent", 6));
    p.extent[2] = 2.0f;
    CHECK_OK(hbk_caustics_params_check(&p, &m));
    p.periodic = 1;
    CHECK(hbk_caustics_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "auto_extent", 11));
    p = p0;
    p.periodic = 1;
    p.light_type = HBK_LIGHT_POINT;
    CHECK(hbk_caustics_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "light_type", 10));
    /* Inputs. */
    p = p0;
    grid_t small = grid_new(7, 8, 1), two = grid_new(8, 8, 2), o2 = grid_new(16, 16, 2);
    CHECK(hbk_caustics_render(&p, &w.img, &small.img, 0.1f, &out.img, NULL, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "ground_height size = 7 x 8", 26));
    CHECK(hbk_caustics_render(&p, &two.img, &g.img, 0.1f, &out.img, NULL, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "water_height.channels = 2", 25));
    CHECK(hbk_caustics_render(&p, &w.img, &g.img, 0.0f, &out.img, NULL, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "cell_size = 0", 13));
    CHECK(hbk_caustics_render(&p, &w.img, &g.img, 0.1f, &o2.img, NULL, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "out.channels = 2", 16));
    CHECK(hbk_caustics_render(&p, &w.img, &g.img, 0.1f, NULL, NULL, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    w.v[9] = NAN;
    CHECK(hbk_caustics_render(&p, &w.img, &g.img, 0.1f, &out.img, NULL, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "water_height at pixel (1, 1) = nan", 34));
    w.v[9] = 1.0f;
    p.light_type = HBK_LIGHT_POINT;
    p.light_position[2] = 0.5f;
    CHECK(hbk_caustics_render(&p, &w.img, &g.img, 0.1f, &out.img, NULL, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "light_position[2] = 0.5", 23));
    p = p0;
    const float low[3] = {0.4f, 0.4f, 0.5f};
    grid_t uv = grid_new(8, 8, 2), uv5 = grid_new(8, 8, 5);
    CHECK(hbk_caustics_view(&p, &w.img, &g.img, 0.1f, low, &uv.img, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "camera[2] = 0.5", 15));
    CHECK(hbk_caustics_view(&p, &w.img, &g.img, 0.1f, NULL, &uv.img, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    const float cam[3] = {0.4f, 0.4f, 5.0f};
    CHECK(hbk_caustics_view(&p, &w.img, &g.img, 0.1f, cam, &uv5.img, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(hbk_caustics_view(&p, &w.img, &g.img, 0.1f, cam, &uv.img, &uv.img, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "out_reflect", 11));
    CHECK(hbk_caustics_lit_ground(&out.img, &out.img, 7, &out.img, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "edge = 7", 8));
    CHECK(hbk_caustics_lit_ground(&o2.img, &out.img, 0, &out.img, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "texture.channels = 2", 20));
    free(w.v); free(g.v); free(out.v); free(small.v); free(two.v); free(o2.v); free(uv.v); free(uv5.v);
}

/* Transmitted flat-water irradiance: E cos(theta) T exp(-a D / cos(theta_r)). */
static double flat_value(double E, double tan_theta, double n, double depth, double absorb,
                         int fresnel)
{
    const double ci = 1.0 / sqrt(1.0 + tan_theta * tan_theta), si = tan_theta * ci;
    const double st = si / n, ct = sqrt(1.0 - st * st);
    double T = 1.0;
    if (fresnel) {
        const double rs = (ci - n * ct) / (ci + n * ct), rp = (n * ci - ct) / (n * ci + ct);
        T = 1.0 - 0.5 * (rs * rs + rp * rp);
    }
    return E * ci * T * exp(-absorb * depth / ct);
}

void test_caustics_flat_uniform(void)
{
    /* Flat water 0.8 m deep over flat ground, an oblique sun (35 deg), a periodic tile at a map
     * size unrelated to the grid: every pixel equals the analytic transmitted irradiance, per
     * channel, with dispersion, absorption and the Fresnel term each on or off. */
    const int32_t W = 40, H = 30;
    grid_t w = grid_new(W, H, 1), g = grid_new(W, H, 1), out = grid_new(97, 61, 4);
    grid_fill(&w, 0.3f);
    grid_fill(&g, -0.5f);
    const double tan_t = tan(35.0 * M_PI / 180.0);
    for (int variant = 0; variant < 4; ++variant) {
        hbk_caustics_params_t p = sun(tan_t * 0.6, tan_t * 0.8);
        p.periodic = 1;
        p.irradiance[0] = 2.0f;
        p.irradiance[1] = 1.0f;
        p.irradiance[2] = 0.5f;
        if (variant >= 1) { p.ior[0] = 1.331f; p.ior[2] = 1.337f; }
        if (variant >= 2) { p.absorption[0] = 0.35f; p.absorption[1] = 0.06f; p.absorption[2] = 0.01f; }
        if (variant == 3) p.fresnel = 1;
        hbk_caustics_stats_t st;
        hbk_message_t m;
        CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, 0.05f, &out.img, &st, NULL, &m));
        for (int c = 0; c < 3; ++c) {
            const double want = flat_value(p.irradiance[c], tan_t, p.ior[c], 0.8, p.absorption[c],
                                           p.fresnel);
            float lo = INFINITY, hi = -INFINITY;
            for (int i = 0; i < 97 * 61; ++i) {
                lo = fminf(lo, out.v[4 * i + c]);
                hi = fmaxf(hi, out.v[4 * i + c]);
            }
            CHECK_NEAR(lo, want, 1e-5 * want);
            CHECK_NEAR(hi, want, 1e-5 * want);
            /* Entered: E cos(theta) T over the tile. */
            const double area = W * H * 0.05 * 0.05;
            CHECK_NEAR(st.entered[c], flat_value(p.irradiance[c], tan_t, p.ior[c], 0, 0, p.fresnel) * area,
                       1e-6 * st.entered[c]);
            CHECK_NEAR(st.ground[c], want * area, 1e-5 * st.ground[c]);
        }
        for (int i = 0; i < 97 * 61; ++i) CHECK(out.v[4 * i + 3] == 1.0f);
    }
    /* Not periodic, overhead sun: the mesh reaches the borders, so the map is uniform too. */
    hbk_caustics_params_t p = sun(0, 0);
    CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, 0.05f, &out.img, NULL, NULL, NULL));
    for (int i = 0; i < 97 * 61; ++i) CHECK_NEAR(out.v[4 * i], 1.0, 1e-6);
    free(w.v);
    free(g.v);
    free(out.v);
}

void test_caustics_energy_conserved(void)
{
    /* A rough periodic sea, oblique sun: the map holds exactly the light that entered, less
     * what was absorbed: sum(map) x pixel area = stats.ground (flat ground), and without
     * Fresnel, entered = irradiance x cos(theta) x area (the tile's shadow on the ground). */
    const int32_t W = 64, H = 48;
    const float dx = 0.04f;
    grid_t w = waves(W, H, 0.0f, 0.02, 0, 0), g = grid_new(W, H, 1), out = grid_new(211, 150, 3);
    grid_fill(&g, -1.2f);
    for (int variant = 0; variant < 3; ++variant) {
        hbk_caustics_params_t p = sun(0.4, -0.3);
        p.periodic = 1;
        if (variant >= 1) { p.ior[0] = 1.32f; p.ior[2] = 1.36f; p.absorption[0] = 0.3f; }
        if (variant == 2) p.fresnel = 1;
        hbk_caustics_stats_t st;
        CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, dx, &out.img, &st, NULL, NULL));
        const double pa = (W * dx / 211.0) * (H * dx / 150.0), area = W * H * (double)dx * dx;
        const double lx = 0.4f, ly = -0.3f; /* as the float params hold them */
        const double cos_t = 1.0 / sqrt(1.0 + lx * lx + ly * ly);
        for (int c = 0; c < 3; ++c) {
            if (!p.fresnel) CHECK_NEAR(st.entered[c], cos_t * area, 1e-9 * area);
            CHECK(st.absorbed[c] >= 0.0 && st.dry[c] == 0.0);
            CHECK_NEAR(channel_sum(&out, c) * pa, st.ground[c], 1e-6 * st.ground[c]);
        }
        /* Something interesting happened: caustics at least 3x the mean. */
        float hi = 0.0f;
        for (int i = 0; i < 211 * 150; ++i) hi = fmaxf(hi, out.v[3 * i]);
        CHECK(hi > 3.0 * cos_t);
    }
    free(w.v);
    free(g.v);
    free(out.v);
}

/* Peak of the map at the centre for a spherical-cap lens of radius of curvature R, aperture a,
 * over ground at depth D below the apex. */
static double lens_peak(double R, double n, double D)
{
    const int32_t N = 200;
    const double dx = 0.3 / N, a = 0.08, sag = R - sqrt(R * R - a * a);
    grid_t w = grid_new(N, N, 1), g = grid_new(N, N, 1), out = grid_new(300, 300, 3);
    for (int32_t j = 0; j < N; ++j)
        for (int32_t i = 0; i < N; ++i) {
            const double x = (i + 0.5) * dx - 0.15, y = (j + 0.5) * dx - 0.15, r2 = x * x + y * y;
            w.v[j * N + i] = (float)(r2 < a * a ? sqrt(R * R - r2) - (R - sag) : 0.0);
        }
    grid_fill(&g, (float)(sag - D));
    hbk_caustics_params_t p = sun(0, 0);
    p.ior[0] = p.ior[1] = p.ior[2] = (float)n;
    double peak = -1.0;
    if (hbk_caustics_render(&p, &w.img, &g.img, (float)dx, &out.img, NULL, NULL, NULL) == HBK_OK)
        for (int32_t y = 148; y < 152; ++y)
            for (int32_t x = 148; x < 152; ++x) peak = fmax(peak, out.v[3 * (y * 300 + x)]);
    free(w.v);
    free(g.v);
    free(out.v);
    return peak;
}

void test_caustics_lens_focus(void)
{
    /* A convex spherical cap of radius R refracts sunlight to a focus at f = n R / (n - 1)
     * below its apex (thin spherical refracting surface, paraxial). Scan the ground depth: the
     * brightest centre must sit at f, for two indices. Spherical aberration pulls the best
     * focus slightly towards the surface (marginal rays of this aperture cross 1.5 % short). */
    const double R = 0.4;
    for (int k = 0; k < 2; ++k) {
        const double n = k ? 1.5 : 1.333, f = n * R / (n - 1.0);
        double best = -1.0, best_d = 0.0;
        for (double D = 0.85 * f; D <= 1.15 * f; D += 0.005 * f) {
            const double pk = lens_peak(R, n, D);
            CHECK(pk > 0.0);
            if (pk > best) { best = pk; best_d = D; }
        }
        CHECK(best > 50.0); /* a real focus: 50x the sunlight */
        CHECK(best_d <= 1.005 * f && best_d >= 0.97 * f);
        /* Far from focus the spot is spread: much dimmer. */
        CHECK(lens_peak(R, n, 0.5 * f) < 0.1 * best);
    }
}

void test_caustics_photon_reference(void)
{
    /* The mesh method against brute force: 4M photons refracted at the exact interpolated
     * surface, both binned to 24 x 16 bins. The refraction model matters: a wrong index is
     * clearly told apart. */
    const int32_t W = 96, H = 64, MW = 192, MH = 128, BX = 24, BY = 16;
    const double dx = 0.03;
    grid_t w = waves(W, H, 0.0f, 0.008, 0, 0), g = grid_new(W, H, 1), out = grid_new(MW, MH, 3);
    grid_fill(&g, -0.9f);
    const double L[3] = {0.2 / sqrt(1.05), 0.1 / sqrt(1.05), 1.0 / sqrt(1.05)};
    photon_scene_t sc = {w.v, W, H, dx, 1.333, {L[0], L[1], L[2]}, 1.0, -0.9, NULL};
    double *ref = calloc((size_t)MW * MH, sizeof *ref);
    CHECK(photon_prepare(&sc));
    photon_trace(&sc, 12345, 4000000, ref, MW, MH);
    free(sc.normals);
    double err[2];
    for (int k = 0; k < 2; ++k) {
        hbk_caustics_params_t p = sun(0.2, 0.1);
        p.periodic = 1;
        p.ior[0] = p.ior[1] = p.ior[2] = k ? 1.25f : 1.333f;
        CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, (float)dx, &out.img, NULL, NULL, NULL));
        double bins[2][24 * 16] = {{0}};
        for (int32_t y = 0; y < MH; ++y)
            for (int32_t x = 0; x < MW; ++x) {
                const int b = (y * BY / MH) * BX + x * BX / MW;
                bins[0][b] += out.v[3 * (y * MW + x)];
                bins[1][b] += ref[y * MW + x];
            }
        double num = 0.0, den = 0.0;
        for (int b = 0; b < BX * BY; ++b) {
            num += fabs(bins[0][b] - bins[1][b]);
            den += bins[1][b];
        }
        err[k] = num / den;
    }
    free(ref);
    free(w.v);
    free(g.v);
    free(out.v);
    CHECK(err[0] < 0.02);
    CHECK(err[1] > 3.0 * err[0]);
}

/* Every pixel of a map rendered twice is bit-identical for threads 1 and 2. */
static int same_for_threads(hbk_caustics_params_t p, const grid_t *w, const grid_t *g, float dx,
                            int32_t MW, int32_t MH)
{
    grid_t a = grid_new(MW, MH, 3), b = grid_new(MW, MH, 3);
    p.threads = 1;
    int ok = hbk_caustics_render(&p, &w->img, &g->img, dx, &a.img, NULL, NULL, NULL) == HBK_OK;
    p.threads = 2;
    ok &= hbk_caustics_render(&p, &w->img, &g->img, dx, &b.img, NULL, NULL, NULL) == HBK_OK;
    ok &= !memcmp(a.v, b.v, sizeof(float) * 3 * (size_t)MW * MH);
    free(a.v);
    free(b.v);
    return ok;
}

/* A beach: ground rising along x through the water level, an island, a lagoon cut off. */
static grid_t beach(int32_t W, int32_t H, double dx)
{
    grid_t g = grid_new(W, H, 1);
    for (int32_t j = 0; j < H; ++j)
        for (int32_t i = 0; i < W; ++i) {
            const double x = (i + 0.5) * dx, y = (j + 0.5) * dx;
            const double isl = 0.6 * exp(-((x - 0.6) * (x - 0.6) + (y - 0.7) * (y - 0.7)) / 0.02);
            g.v[j * W + i] = (float)(-0.4 + 0.5 * x + isl + 0.03 * sin(17 * y) * cos(11 * x));
        }
    return g;
}

void test_caustics_threads_identical(void)
{
    const int32_t W = 80, H = 60; /* big enough for the renderer to use threads */
    const double dx = 0.025;
    grid_t w = waves(W, H, 0.0f, 0.01, 0, 0), g = grid_new(W, H, 1);
    grid_fill(&g, -0.6f);
    hbk_caustics_params_t p = sun(0.3, 0.2);
    p.periodic = 1;
    CHECK(same_for_threads(p, &w, &g, (float)dx, 333, 222));
    p.ior[0] = 1.32f; p.ior[2] = 1.35f; p.absorption[1] = 0.2f; p.fresnel = 1;
    CHECK(same_for_threads(p, &w, &g, (float)dx, 333, 222));
    /* A shoreline, not periodic, a point light. */
    grid_t b = beach(W, H, dx);
    p = sun(-0.4, 0.1);
    CHECK(same_for_threads(p, &w, &b, (float)dx, 256, 160));
    p.light_type = HBK_LIGHT_POINT;
    p.light_position[0] = 0.8f; p.light_position[1] = 0.5f; p.light_position[2] = 2.0f;
    CHECK(same_for_threads(p, &w, &b, (float)dx, 256, 160));
    free(w.v);
    free(g.v);
    free(b.v);
}

void test_caustics_periodic_seamless(void)
{
    /* Tiles meet without a seam: the map of a surface shifted by half a tile is the map shifted
     * by half a map (the edges are nothing special), for an oblique sun that moves light across
     * both edges. */
    const int32_t W = 64, H = 48, MW = 256, MH = 192;
    grid_t a = waves(W, H, 0.0f, 0.015, 0, 0), b = waves(W, H, 0.0f, 0.015, W / 2, H / 2);
    grid_t g = grid_new(W, H, 1), ma = grid_new(MW, MH, 3), mb = grid_new(MW, MH, 3);
    grid_fill(&g, -1.0f);
    hbk_caustics_params_t p = sun(0.5, 0.35);
    p.periodic = 1;
    CHECK_OK(hbk_caustics_render(&p, &a.img, &g.img, 0.03f, &ma.img, NULL, NULL, NULL));
    CHECK_OK(hbk_caustics_render(&p, &b.img, &g.img, 0.03f, &mb.img, NULL, NULL, NULL));
    double worst = 0.0, peak = 0.0;
    for (int32_t y = 0; y < MH; ++y)
        for (int32_t x = 0; x < MW; ++x) {
            const float va = ma.v[3 * (y * MW + x)];
            const float vb = mb.v[3 * (((y + MH / 2) % MH) * MW + (x + MW / 2) % MW)];
            worst = fmax(worst, fabs(va - vb));
            peak = fmax(peak, va);
        }
    CHECK(peak > 2.0);
    CHECK(worst < 1e-4 * peak);
    free(a.v); free(b.v); free(g.v); free(ma.v); free(mb.v);
}

void test_caustics_shoreline(void)
{
    /* Calm water over a plane beach (slope 0.5), overhead sun: light goes straight down in the
     * water as on the dry sand, so the whole map, wet, dry and the waterline cells cut as in
     * the paper's Fig. 2, must be the irradiance on the slope, E cos(slope), with no gap and no
     * overlap. With lit_dry off the dry part goes black and the wet part stays. */
    const int32_t W = 60, H = 40;
    const double dx = 0.02f, slope = 0.5; /* dx as the float argument holds it */
    grid_t w = grid_new(W, H, 1), g = grid_new(W, H, 1), out = grid_new(150, 100, 3);
    for (int32_t j = 0; j < H; ++j)
        for (int32_t i = 0; i < W; ++i) g.v[j * W + i] = (float)(slope * ((i + 0.5) * dx - 0.6));
    grid_fill(&w, 0.0f);
    for (int k = 0; k < W * H; ++k) w.v[k] = fmaxf(w.v[k], g.v[k]); /* dry: surface = ground */
    hbk_caustics_params_t p = sun(0, 0);
    hbk_caustics_stats_t st;
    CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, (float)dx, &out.img, &st, NULL, NULL));
    /* (Beyond the outermost sample centres, half a cell, the fields are extended flat: skip
     * those 1.25-pixel strips at the left and right.) */
    const double want = 1.0 / sqrt(1.0 + slope * slope);
    for (int32_t y = 0; y < 100; ++y)
        for (int32_t x = 2; x < 148; ++x) CHECK_NEAR(out.v[3 * (y * 150 + x)], want, 1e-5);
    CHECK_NEAR(st.entered[0] + st.dry[0], W * H * dx * dx, 1e-9);
    CHECK(st.entered[0] > 0.3 * W * H * dx * dx && st.dry[0] > 0.3 * W * H * dx * dx);
    p.lit_dry = 0;
    CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, (float)dx, &out.img, &st, NULL, NULL));
    CHECK(st.dry[0] == 0.0);
    CHECK_NEAR(out.v[3 * (50 * 150 + 10)], want, 1e-5);  /* under water */
    CHECK(out.v[3 * (50 * 150 + 140)] < 1e-12f);          /* dry sand (0 up to rounding) */

    /* Rough ground with islands, lagoons and diagonal waterline cells (Fig. 3) in a periodic
     * tile, overhead sun over calm water: the wet and dry polygons tile every cell exactly, so
     * entered + dry = E x area, and the map holds it all (energy over the ground's slope). */
    const int32_t N = 48;
    grid_t rw = grid_new(N, N, 1), rg = grid_new(N, N, 1), ro = grid_new(96, 96, 3);
    int diagonal = 0;
    for (int32_t j = 0; j < N; ++j)
        for (int32_t i = 0; i < N; ++i) {
            const double x = 2 * M_PI * i / N, y = 2 * M_PI * j / N;
            rg.v[j * N + i] = (float)(0.01 * sin(5 * x) * sin(4 * y) + 0.006 * cos(3 * x - 2 * y) +
                                      (((i + j) & 1) ? 0.002 : -0.002));
            rw.v[j * N + i] = fmaxf(0.0f, rg.v[j * N + i]);
        }
    for (int32_t j = 0; j < N; ++j)
        for (int32_t i = 0; i < N; ++i) {
            const int a = rw.v[j * N + i] - rg.v[j * N + i] > 1e-4f;
            const int b = rw.v[j * N + (i + 1) % N] - rg.v[j * N + (i + 1) % N] > 1e-4f;
            const int c = rw.v[((j + 1) % N) * N + (i + 1) % N] - rg.v[((j + 1) % N) * N + (i + 1) % N] > 1e-4f;
            const int d = rw.v[((j + 1) % N) * N + i] - rg.v[((j + 1) % N) * N + i] > 1e-4f;
            diagonal += a == c && b == d && a != b;
        }
    CHECK(diagonal > 20); /* the ambiguous case is exercised */
    p = sun(0, 0);
    p.periodic = 1;
    CHECK_OK(hbk_caustics_render(&p, &rw.img, &rg.img, 0.02f, &ro.img, &st, NULL, NULL));
    const double cell = 0.02f;
    CHECK_NEAR(st.entered[0] + st.dry[0], N * N * cell * cell, 1e-9);
    /* Per ground area the light is E cos(slope): never more than E (an overlap would double
     * it), never near 0 (a gap), and the total over the map at most E x area. */
    double sum = 0.0;
    for (int i = 0; i < 96 * 96; ++i) {
        sum += ro.v[3 * i];
        CHECK(ro.v[3 * i] <= 1.0f + 1e-5f && ro.v[3 * i] > 0.6f);
    }
    const double pa = (N * cell / 96.0) * (N * cell / 96.0), total = N * N * cell * cell;
    CHECK(sum * pa <= total * (1 + 1e-6) && sum * pa > 0.8 * total);
    free(w.v); free(g.v); free(out.v); free(rw.v); free(rg.v); free(ro.v);
}

void test_caustics_point_light(void)
{
    /* A point light of intensity I at height h above flat water of depth D: straight below,
     * the paraxial rays spread as from a source at h + D / n, so E = I / (h + D / n)^2. */
    const int32_t N = 200;
    const double dx = 0.01, h = 1.5, D = 0.6, n = 1.333;
    grid_t w = grid_new(N, N, 1), g = grid_new(N, N, 1), out = grid_new(200, 200, 3);
    grid_fill(&w, 0.0f);
    grid_fill(&g, (float)-D);
    hbk_caustics_params_t p = sun(0, 0);
    p.light_type = HBK_LIGHT_POINT;
    p.light_position[0] = p.light_position[1] = 1.0f;
    p.light_position[2] = (float)h;
    p.irradiance[0] = p.irradiance[1] = p.irradiance[2] = 4.0f;
    CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, (float)dx, &out.img, NULL, NULL, NULL));
    const double want = 4.0 / ((h + D / n) * (h + D / n));
    CHECK_NEAR(out.v[3 * (100 * 200 + 100)], want, 2e-3 * want);
    CHECK(out.v[3 * (5 * 200 + 5)] < 0.7 * want); /* falls off to the corner */
    free(w.v); free(g.v); free(out.v);
}

void test_caustics_view_uv(void)
{
    /* Flat water D deep: a camera straight above a sample sees the ground below it; an oblique
     * view is bent towards the normal, landing D tan(theta_r) from the entry point. Reflectance
     * at normal incidence is ((n-1)/(n+1))^2; the reflection of a flat mirror. */
    const int32_t W = 50, H = 40;
    const double dx = 0.02, D = 0.3, n = 1.333;
    grid_t w = grid_new(W, H, 1), g = grid_new(W, H, 1), uv = grid_new(W, H, 4), rf = grid_new(W, H, 3);
    grid_fill(&w, 0.1f);
    grid_fill(&g, (float)(0.1 - D));
    hbk_caustics_params_t p = sun(0, 0);
    const float cam[3] = {(float)(20.5 * dx), (float)(10.5 * dx), 2.1f};
    CHECK_OK(hbk_caustics_view(&p, &w.img, &g.img, (float)dx, cam, &uv.img, &rf.img, NULL));
    const float *o = uv.v + 4 * (10 * W + 20);
    CHECK_NEAR(o[0], 20.5 / W, 1e-6);
    CHECK_NEAR(o[1], 10.5 / H, 1e-6);
    CHECK_NEAR(o[2], D, 1e-6);
    CHECK_NEAR(o[3], ((n - 1) / (n + 1)) * ((n - 1) / (n + 1)), 1e-6);
    CHECK_NEAR(rf.v[3 * (10 * W + 20) + 2], 1.0, 1e-6);
    /* Sample (40, 30): the view comes down from the camera at (20.5, 10.5) in cells. */
    const double ex = (40.5 - 20.5) * dx, ey = (30.5 - 10.5) * dx, rh = sqrt(ex * ex + ey * ey);
    const double sin_t = rh / sqrt(rh * rh + 2.0 * 2.0) / n, tan_r = sin_t / sqrt(1 - sin_t * sin_t);
    const double hx = 40.5 * dx + ex / rh * D * tan_r, hy = 30.5 * dx + ey / rh * D * tan_r;
    o = uv.v + 4 * (30 * W + 40);
    CHECK_NEAR(o[0], hx / (W * dx), 1e-5);
    CHECK_NEAR(o[1], hy / (H * dx), 1e-5);
    CHECK_NEAR(o[2], D / sqrt(1 - sin_t * sin_t), 1e-5);
    const float *r = rf.v + 3 * (30 * W + 40);
    CHECK_NEAR(r[0], ex / sqrt(rh * rh + 4.0), 1e-5); /* mirror: goes on away, and up */
    CHECK_NEAR(r[2], 2.0 / sqrt(rh * rh + 4.0), 1e-5);
    free(w.v); free(g.v); free(uv.v); free(rf.v);
}

/* Renders, checks every value of the map is finite, and frees the three grids. */
static void renders_finite(const hbk_caustics_params_t *p, grid_t *w, grid_t *g, float spacing,
                           grid_t *out)
{
    hbk_message_t m;
    CHECK_OK(hbk_caustics_render(p, &w->img, &g->img, spacing, &out->img, NULL, NULL, &m));
    const size_t n = (size_t)out->img.width * (size_t)out->img.height * (size_t)out->img.channels;
    for (size_t i = 0; i < n; ++i) CHECK(isfinite(out->v[i]));
    free(w->v);
    free(g->v);
    free(out->v);
}

void test_caustics_tiny_extent(void)
{
    /* A map 1e-38 m wide puts the wavy surface's images some 1e38 pixels away; a degenerate
     * one among them reached the int64 conversion of the raster's floor (undefined; seen
     * with -fsanitize=float-cast-overflow). Drawn nowhere instead: a finite map. */
    grid_t w = grid_new(24, 20, 1), g = grid_new(24, 20, 1), out = grid_new(64, 64, 4);
    for (int y = 0; y < 20; ++y)
        for (int x = 0; x < 24; ++x) {
            g.v[y * 24 + x] = 0.02f * (float)x - 0.2f;
            w.v[y * 24 + x] = 0.1f + 0.01f * sinf((float)x * 0.7f) * cosf((float)y * 0.5f);
        }
    hbk_caustics_params_t p = sun(0.0, 0.0);
    p.auto_extent = 0;
    p.extent[2] = p.extent[3] = 1e-38f;
    renders_finite(&p, &w, &g, 0.05f, &out);
}

void test_caustics_huge_extent_dispersive(void)
{
    /* A map 170 km wide with dispersion: some pass draws no loose triangle of a group, whose
     * rows stayed [+inf, -inf] and reached the int64 conversion (undefined; found by a fuzz
     * of parameter combinations under UBSan). Drawn nowhere: the map as before, finite. */
    grid_t w = grid_new(8, 8, 1), g = grid_new(8, 8, 1), out = grid_new(16, 16, 4);
    for (int i = 0; i < 64; ++i) {
        w.v[i] = 0.02f * sinf((float)i * 0.7f);
        g.v[i] = -1.0f;
    }
    hbk_caustics_params_t p = sun(0.0, 0.0);
    p.auto_extent = 0;
    p.extent[0] = -170795.18f;
    p.extent[1] = 0.0f;
    p.extent[2] = p.extent[3] = 0.8f;
    p.ior[0] = p.ior[2] = 1.333f;
    p.ior[1] = 3.0f;
    renders_finite(&p, &w, &g, 0.1f, &out);
}

void test_caustics_lit_ground(void)
{
    grid_t tex = grid_new(8, 6, 4), map = grid_new(4, 3, 3), out = grid_new(8, 6, 4);
    for (int i = 0; i < 8 * 6; ++i) {
        tex.v[4 * i] = 0.5f; tex.v[4 * i + 1] = 0.25f; tex.v[4 * i + 2] = 1.0f; tex.v[4 * i + 3] = 0.75f;
    }
    grid_fill(&map, 2.0f);
    CHECK_OK(hbk_caustics_lit_ground(&tex.img, &map.img, HBK_EDGE_WRAP, &out.img, NULL));
    for (int i = 0; i < 8 * 6; ++i) {
        CHECK(out.v[4 * i] == 1.0f && out.v[4 * i + 1] == 0.5f && out.v[4 * i + 2] == 2.0f);
        CHECK(out.v[4 * i + 3] == 0.75f);
    }
    /* Resampling: a map with one bright pixel lights the texture pixels over it. */
    grid_fill(&map, 0.0f);
    map.v[3 * (1 * 4 + 2)] = 4.0f;
    CHECK_OK(hbk_caustics_lit_ground(&tex.img, &map.img, HBK_EDGE_CLAMP, &out.img, NULL));
    float best = 0.0f;
    int at = -1;
    for (int i = 0; i < 8 * 6; ++i)
        if (out.v[4 * i] > best) { best = out.v[4 * i]; at = i; }
    CHECK(at / 8 >= 2 && at / 8 <= 3 && at % 8 >= 4 && at % 8 <= 5);
    /* A NaN texel, or an infinite one in the map, came out as such: refused by pixel. */
    hbk_message_t m;
    tex.v[4 * (2 * 8 + 3) + 1] = NAN;
    CHECK(hbk_caustics_lit_ground(&tex.img, &map.img, 0, &out.img, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "texture at pixel (3, 2) = nan: must be a finite number", 54));
    tex.v[4 * (2 * 8 + 3) + 1] = 0.25f;
    map.v[3 * (2 * 4 + 1) + 2] = INFINITY;
    CHECK(hbk_caustics_lit_ground(&tex.img, &map.img, 0, &out.img, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "caustics at pixel (1, 2) = inf", 30));
    free(tex.v); free(map.v); free(out.v);
}

void test_caustics_cancel(void)
{
    grid_t w = waves(64, 64, 0.0f, 0.01, 0, 0), g = grid_new(64, 64, 1), out = grid_new(128, 128, 3);
    grid_fill(&g, -1.0f);
    hbk_caustics_params_t p = sun(0.1, 0.0);
    hbk_progress_t pr = {1, 0.0f};
    hbk_message_t m;
    CHECK(hbk_caustics_render(&p, &w.img, &g.img, 0.02f, &out.img, NULL, &pr, &m) == HBK_ERR_CANCELLED);
    CHECK(strstr(m.text, "cancelled"));
    pr.cancel = 0;
    CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, 0.02f, &out.img, NULL, &pr, &m));
    CHECK(pr.fraction == 1.0f);
    free(w.v); free(g.v); free(out.v);
}

/* One workspace through a sequence of different renders (sizes up and down, mono and
 * dispersive, periodic and shoreline, one cancelled) gives the stateless render's bytes. */
void test_caustics_workspace_reuse(void)
{
    const double dx = 0.025;
    grid_t w = waves(80, 60, 0.0f, 0.01, 0, 0), g = grid_new(80, 60, 1), b = beach(80, 60, dx);
    grid_t ws_small = waves(24, 20, 0.0f, 0.01, 0, 0), g_small = grid_new(24, 20, 1);
    grid_fill(&g, -0.6f);
    grid_fill(&g_small, -0.4f);
    hbk_caustics_params_t mono = sun(0.3, 0.2), disp = sun(-0.4, 0.1);
    mono.periodic = 1;
    disp.ior[0] = 1.32f; disp.ior[2] = 1.35f; disp.absorption[1] = 0.2f; disp.fresnel = 1;
    struct { const hbk_caustics_params_t *p; grid_t *w, *g; int32_t mw, mh; int cancel; } runs[] = {
        {&mono, &w, &g, 333, 222, 0}, {&disp, &w, &b, 256, 160, 0}, {&mono, &ws_small, &g_small, 64, 50, 0},
        {&disp, &w, &b, 256, 160, 1}, {&mono, &w, &g, 400, 300, 0}, {&disp, &w, &b, 128, 96, 0},
    };
    hbk_caustics_workspace_t *ws = NULL;
    hbk_message_t m;
    CHECK(hbk_caustics_workspace_create(NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK_OK(hbk_caustics_workspace_create(&ws, &m));
    CHECK(hbk_caustics_workspace_bytes(ws) == 0);
    for (size_t k = 0; k < sizeof runs / sizeof runs[0]; ++k) {
        grid_t a = grid_new(runs[k].mw, runs[k].mh, 3), c = grid_new(runs[k].mw, runs[k].mh, 3);
        hbk_caustics_stats_t sa, sc;
        hbk_progress_t pr = {runs[k].cancel, 0.0f};
        const hbk_result_t r = hbk_caustics_render_with(ws, runs[k].p, &runs[k].w->img,
                                                        &runs[k].g->img, (float)dx, &c.img, &sc,
                                                        &pr, &m);
        if (runs[k].cancel) {
            CHECK(r == HBK_ERR_CANCELLED);
        } else {
            CHECK_OK(r);
            CHECK_OK(hbk_caustics_render(runs[k].p, &runs[k].w->img, &runs[k].g->img, (float)dx,
                                         &a.img, &sa, NULL, &m));
            CHECK(!memcmp(a.v, c.v, sizeof(float) * 3 * (size_t)runs[k].mw * (size_t)runs[k].mh));
            CHECK(!memcmp(&sa, &sc, sizeof sa));
            CHECK(hbk_caustics_workspace_bytes(ws) > 0);
        }
        free(a.v);
        free(c.v);
    }
    grid_t out = grid_new(16, 16, 3);
    CHECK(hbk_caustics_render_with(NULL, &mono, &w.img, &g.img, (float)dx, &out.img, NULL, NULL,
                                   &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "workspace"));
    hbk_caustics_workspace_destroy(ws);
    hbk_caustics_workspace_destroy(NULL);
    free(w.v); free(g.v); free(b.v); free(ws_small.v); free(g_small.v); free(out.v);
}

/* The vector paths (lanes of 4 doubles, their AVX2 kernels) give the bytes of the general
 * path: HBK_PATHS switches them, as a user could (see c_core/src/base/paths.c). Periodic
 * waves under an oblique sun (edges shifted by a period), a shoreline, and colour. */
void test_caustics_paths_same_bytes(void)
{
    const int32_t W = 80, H = 60, MW = 333, MH = 222;
    const double dx = 0.025;
    grid_t w = waves(W, H, 0.0f, 0.01, 0, 0), g = grid_new(W, H, 1), b = beach(W, H, dx);
    grid_fill(&g, -0.6f);
    const char *paths[3] = {"scalar", "sse", NULL};
    for (int scene = 0; scene < 3; ++scene) {
        hbk_caustics_params_t p = sun(0.3, 0.2);
        p.periodic = scene == 0;
        if (scene == 2) { p.ior[0] = 1.32f; p.ior[2] = 1.35f; }
        const grid_t *ground = scene == 1 ? &b : &g;
        grid_t m[3];
        for (int k = 0; k < 3; ++k) {
            m[k] = grid_new(MW, MH, 4);
            if (paths[k]) setenv("HBK_PATHS", paths[k], 1);
            else unsetenv("HBK_PATHS");
            const hbk_result_t r = hbk_caustics_render(&p, &w.img, &ground->img, (float)dx,
                                                       &m[k].img, NULL, NULL, NULL);
            unsetenv("HBK_PATHS");
            CHECK_OK(r);
        }
        double sum = 0.0;
        for (int32_t i = 0; i < MW * MH; ++i) sum += m[2].v[4 * i];
        CHECK(sum > 0.0); /* light on the ground */
        for (int k = 0; k < 2; ++k)
            CHECK(!memcmp(m[k].v, m[2].v, sizeof(float) * 4 * (size_t)MW * MH));
        for (int k = 0; k < 3; ++k) free(m[k].v);
    }
    free(w.v);
    free(g.v);
    free(b.v);
}

/* ---- Snell's law and the area ratio, exactly ------------------------------------------ */

void test_caustics_snell_flat(void)
{
    /* Flat water D = 1 m deep, a sun 60 deg from the zenith along +x, not periodic: every ray
     * is bent by Snell's law (sin theta = n sin theta_r) and lands D tan(theta_r) towards -x
     * of where it entered. The light of the whole field [0, Lx] lands on [-s, Lx - s]: the map
     * is E cos(theta) up to Lx - s and dark beyond, column by column (exact area coverage).
     * Dispersive indices give each channel its own edge: red, bent least, shifted most. */
    const int32_t W = 80, H = 8, MW = 400, MH = 4;
    const double dx = 0.025f, D = 1.0, Lx = W * dx, pw = Lx / MW;
    grid_t w = grid_new(W, H, 1), g = grid_new(W, H, 1), out = grid_new(MW, MH, 3);
    grid_fill(&w, 0.0f);
    grid_fill(&g, (float)-D);
    hbk_caustics_params_t p = sun(tan(60.0 * M_PI / 180.0), 0.0);
    p.ior[0] = 1.331f;
    p.ior[1] = 1.333f;
    p.ior[2] = 1.337f;
    hbk_caustics_stats_t st;
    CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, (float)dx, &out.img, &st, NULL, NULL));
    const double lx = p.light_direction[0], lz = p.light_direction[2];
    const double sin_t = lx / hypot(lx, lz), cos_t = lz / hypot(lx, lz);
    double edge[3];
    for (int c = 0; c < 3; ++c) {
        const double sr = sin_t / p.ior[c], s = D * sr / sqrt(1.0 - sr * sr);
        edge[c] = Lx - s;
        for (int32_t y = 0; y < MH; ++y)
            for (int32_t x = 0; x < MW; ++x) {
                const double x0 = x * pw, lit = fmin(1.0, fmax(0.0, (edge[c] - x0) / pw));
                CHECK_NEAR(out.v[3 * (y * MW + x) + c], cos_t * lit, 1e-5);
            }
        /* The light that left the extent is the strip s wide. */
        CHECK_NEAR(channel_sum(&out, c) * pw * (H * dx / MH), st.ground[c] * edge[c] / Lx,
                   1e-6 * st.ground[c]);
    }
    CHECK(edge[0] < edge[1] && edge[1] < edge[2]);
    CHECK((int)(edge[0] / pw) != (int)(edge[2] / pw)); /* the edges fall in different pixels */
    free(w.v);
    free(g.v);
    free(out.v);
}

void test_caustics_snell_tilted_surface(void)
{
    /* A water surface tilted by slope s = 0.5 along x over a flat floor, overhead sun. The
     * incidence angle is theta_i = atan(s); Snell gives theta_r, and the refracted ray leans
     * theta_i - theta_r from the vertical towards +x. A point at x lands at
     *     x' = x + (z(x) - b) tan(theta_i - theta_r),   dx'/dx = 1 + s tan(theta_i - theta_r),
     * and the light through a strip dx (E dx: L . N S is the horizontal area for a vertical L)
     * spreads over dx': the map is E / (1 + s tan(theta_i - theta_r)) everywhere the plane's
     * light lands, for each channel's own index (the paper's S / S' area ratio, exactly). */
    const int32_t W = 128, H = 8, MW = 256, MH = 4;
    /* Dyadic cell size and heights: the plane is exact in float, so are its slopes. */
    const double dx = 1.0 / 128.0, slope = 0.5, b = -1.5, Lx = W * dx, pw = Lx / MW;
    grid_t w = grid_new(W, H, 1), g = grid_new(W, H, 1), out = grid_new(MW, MH, 3);
    for (int32_t j = 0; j < H; ++j)
        for (int32_t i = 0; i < W; ++i) w.v[j * W + i] = (float)(slope * ((i + 0.5) * dx - 0.5));
    grid_fill(&g, (float)b);
    hbk_caustics_params_t p = sun(0.0, 0.0);
    p.ior[0] = 1.32f;
    p.ior[1] = 1.333f;
    p.ior[2] = 1.36f;
    CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, (float)dx, &out.img, NULL, NULL, NULL));
    const double ti = atan(slope);
    double want_prev = 0.0;
    for (int c = 0; c < 3; ++c) {
        const double tr = asin(sin(ti) / p.ior[c]), td = tan(ti - tr);
        const double want = 1.0 / (1.0 + slope * td);
        /* The plane spans the sample centres 0.5 dx .. Lx - 0.5 dx (beyond, the field is
         * extended flat): where its light lands. */
        const double za = w.v[0], zb = w.v[W - 1];
        const double xa = 0.5 * dx + (za - b) * td, xb = Lx - 0.5 * dx + (zb - b) * td;
        int checked = 0;
        for (int32_t x = 0; x < MW; ++x) {
            if (x * pw < xa || (x + 1) * pw > xb) continue;
            for (int32_t y = 0; y < MH; ++y) CHECK_NEAR(out.v[3 * (y * MW + x) + c], want, 2e-6);
            ++checked;
        }
        CHECK(checked > 200);
        CHECK(want < 0.97 && want != want_prev); /* the index matters */
        want_prev = want;
    }
    free(w.v);
    free(g.v);
    free(out.v);
}

void test_caustics_energy_sloped_ground(void)
{
    /* A wavy surface (calm at its borders) over a ground plane sloping along x, a map extent
     * wide enough to catch every ray. The map is irradiance per ground area, so the light it
     * holds is sum(map x pixel area / cos(ground slope)): it must equal stats->ground, which
     * is entered - absorbed; with an overhead sun and no Fresnel term, entered is exactly the
     * irradiance times the horizontal area (no light created or lost by the refraction). */
    const int32_t W = 80, H = 60;
    const double dx = 0.02f, slope = 0.3, Lx = W * dx, Ly = H * dx;
    grid_t w = waves(W, H, 0.0f, 0.01, 0, 0), g = grid_new(W, H, 1);
    for (int32_t j = 0; j < H; ++j)
        for (int32_t i = 0; i < W; ++i) {
            /* Flat water within 8 cells of the borders, blended in smoothly. */
            const double fx = fmin(1.0, fmin(i, W - 1 - i) / 16.0);
            const double fy = fmin(1.0, fmin(j, H - 1 - j) / 16.0);
            const double win = fx < 0.5 || fy < 0.5 ? 0.0 : sin(M_PI * (fmin(fx, fy) - 0.5));
            w.v[j * W + i] = (float)(w.v[j * W + i] * fmax(0.0, win));
            g.v[j * W + i] = (float)(-0.8 + slope * (i + 0.5) * dx);
        }
    /* Pixels 0.01 m wide, their edges on the kinks of the ground at 0.5 dx and Lx - 0.5 dx
     * (outside them the clamped ground is flat). */
    const double pw = 0.01, mx = 20 * pw;
    const int32_t MW = (int32_t)lround((Lx - dx + 2 * mx) / pw), MH = 200;
    grid_t out = grid_new(MW, MH, 3);
    for (int variant = 0; variant < 2; ++variant) {
        /* (The oblique sun leans along y, and little enough that the rays leaving the field
         * come from its calm border: beyond the field a ray is ended on the level of the
         * ground where it left, exact only when it runs along a level line of the clamped
         * ground, as here.) */
        hbk_caustics_params_t p = variant ? sun(0.0, 0.25) : sun(0.0, 0.0);
        p.auto_extent = 0;
        p.extent[0] = (float)(0.5 * dx - mx);
        p.extent[2] = (float)(Lx - 0.5 * dx + mx);
        p.extent[1] = -0.6f;
        p.extent[3] = (float)(Ly + 0.6);
        if (variant) {
            p.ior[0] = 1.32f;
            p.ior[2] = 1.36f;
            p.absorption[0] = 0.4f;
            p.absorption[1] = 0.1f;
            p.fresnel = 1;
        }
        hbk_caustics_stats_t st;
        CHECK_OK(hbk_caustics_render(&p, &w.img, &g.img, (float)dx, &out.img, &st, NULL, NULL));
        const double ex0 = p.extent[0], ex1 = p.extent[2], ey0 = p.extent[1], ey1 = p.extent[3];
        const double pa = (ex1 - ex0) / MW * ((ey1 - ey0) / MH);
        const double cos_s = 1.0 / sqrt(1.0 + slope * slope);
        for (int c = 0; c < 3; ++c) {
            double light = 0.0;
            for (int32_t x = 0; x < MW; ++x) {
                const double xc = ex0 + (x + 0.5) * (ex1 - ex0) / MW;
                const double cs = xc > 0.5 * dx && xc < Lx - 0.5 * dx ? cos_s : 1.0;
                for (int32_t y = 0; y < MH; ++y) light += out.v[3 * (y * MW + x) + c] * pa / cs;
            }
            CHECK_NEAR(st.ground[c], st.entered[c] - st.absorbed[c], 1e-12 * st.entered[c]);
            CHECK_NEAR(light, st.ground[c], 1e-6 * st.ground[c]);
            CHECK(st.dry[c] == 0.0);
            if (!variant) CHECK_NEAR(st.entered[c], Lx * Ly, 1e-9 * Lx * Ly);
            else CHECK((st.absorbed[c] > 0.0) == (p.absorption[c] > 0.0f) &&
                       st.entered[c] < 0.98 * Lx * Ly);
        }
        /* Caustics formed: somewhere at least twice the mean. */
        float hi = 0.0f;
        for (int32_t i = 0; i < MW * MH; ++i) hi = fmaxf(hi, out.v[3 * i]);
        CHECK(hi > 2.0f * (float)cos_s);
    }
    free(w.v);
    free(g.v);
    free(out.v);
}
