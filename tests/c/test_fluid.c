/* Solid fluid texturing: exact advection of uvw (also across the wrap), still fluid unchanged,
 * short-way interpolation, normalised blends, SPH density and rest, a closed surface and a
 * sphere's area and volume, cross-fade weights, determinism, checkpoints, cancel, refusals. */
#include "test.h"
#include "fluid/internal_fluid.h"
#include <float.h>
#include <stdint.h>
#include <stdlib.h>

static hbk_fluid_params_t params(int32_t res, int32_t source)
{
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    for (int a = 0; a < 3; ++a) p.resolution[a] = res;
    p.source = source;
    p.threads = 1;
    return p;
}

/* Circular distance of two uvw values. */
static double cdist(double a, double b)
{
    double d = fabs(a - b);
    d -= floor(d);
    return d < 1.0 - d ? d : 1.0 - d;
}

static float *volume(hbk_fluid_t *h, int which)
{
    size_t n = hbk_fluid_volume_size(h, which);
    float *v = malloc(n * sizeof *v);
    if (v && hbk_fluid_get_volume(h, which, v, n) != HBK_OK) { free(v); return NULL; }
    return v;
}

static void uniform_grid(hbk_fluid_t *h, const float vel[3])
{
    size_t nv = hbk_fluid_grid_vertices(h, NULL);
    float *v = malloc(3 * nv * sizeof *v);
    for (size_t i = 0; i < nv; ++i) for (int a = 0; a < 3; ++a) v[3 * i + a] = vel[a];
    hbk_fluid_set_velocity_grid(h, v, NULL);
    free(v);
}

void test_fluid_params_rejects(void)
{
    size_t n = 0;
    const hbk_param_info_t *info = hbk_fluid_params_info(&n);
    CHECK(n > 20);
    hbk_message_t m;
    hbk_fluid_params_t p;
    hbk_fluid_params_default(&p);
    CHECK_OK(hbk_fluid_params_check(&p, &m));
    for (size_t i = 0; i < n; ++i) {
        /* Above the maximum (or NaN for floats) must be refused, naming the field. */
        hbk_fluid_params_default(&p);
        unsigned char *at = (unsigned char *)&p + info[i].offset;
        if (info[i].type == HBK_PARAM_F32) { float f = NAN; memcpy(at, &f, 4); }
        else if (info[i].type == HBK_PARAM_U64) continue; /* every seed is valid */
        else { int32_t v = (int32_t)info[i].max + 1; memcpy(at, &v, 4); }
        hbk_fluid_t *h = NULL;
        CHECK(hbk_fluid_create(&h, &p, &m) == HBK_ERR_INVALID_ARGUMENT);
        CHECK(h == NULL);
        if (!strstr(m.text, info[i].name)) fprintf(stderr, "message '%s' lacks '%s'\n", m.text, info[i].name);
        CHECK(strstr(m.text, info[i].name) != NULL);
    }
    hbk_fluid_params_default(&p);
    p.box_max[1] = p.box_min[1];
    CHECK(hbk_fluid_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT && strstr(m.text, "box_max"));
    hbk_fluid_params_default(&p);
    p.smoothing_length = 5.0f * p.particle_spacing;
    CHECK(hbk_fluid_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT && strstr(m.text, "smoothing_length"));
    /* The dense particle grid: 256^3 cells of h is the most allowed, 257^3 is refused, and so
     * is 4000^3 (a 0.4 m box with h = 1e-4 m, under the per-axis limit of 4096). */
    hbk_fluid_params_default(&p);
    for (int a = 0; a < 3; ++a) p.box_min[a] = 0.0f, p.box_max[a] = 1.0f;
    p.smoothing_length = p.metaball_radius = 1.0f / 256.0f;
    p.particle_spacing = 0.5f / 256.0f;
    CHECK_OK(hbk_fluid_params_check(&p, &m));
    p.smoothing_length = nextafterf(1.0f / 256.0f, 0.0f);
    CHECK(hbk_fluid_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "smoothing_length = 0.00390625: the box holds 16974593 cells", 59));
    CHECK(strstr(m.text, "at most 16777216 are allowed"));
    p.source = HBK_FLUID_VELOCITY_GRID; /* no particles, no particle grid */
    CHECK_OK(hbk_fluid_params_check(&p, &m));
    for (int a = 0; a < 3; ++a) p.box_max[a] = 200.0f; /* a large Mantaflow domain */
    CHECK_OK(hbk_fluid_params_check(&p, &m));
    for (int a = 0; a < 3; ++a) p.box_max[a] = 1.0f;
    p.source = HBK_FLUID_PARTICLES; /* particles given each frame: cells of max(h, R) */
    CHECK_OK(hbk_fluid_params_check(&p, &m)); /* R = 1/256 */
    p.metaball_radius = p.smoothing_length;
    CHECK(hbk_fluid_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT && strstr(m.text, "smoothing_length"));
    p.smoothing_length = p.particle_spacing;
    CHECK(hbk_fluid_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "metaball_radius = 0.00390625: the box holds 16974593 cells", 58));
    p.source = HBK_FLUID_SIMULATE;
    for (int a = 0; a < 3; ++a) p.box_max[a] = 0.4f;
    p.particle_spacing = p.smoothing_length = p.metaball_radius = 1e-4f;
    CHECK(hbk_fluid_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT && strstr(m.text, "smoothing_length"));
    hbk_fluid_params_default(&p);
    p.metaball_radius = 0.5f * p.particle_spacing;
    CHECK(hbk_fluid_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT && strstr(m.text, "metaball_radius"));
    hbk_fluid_params_default(&p);
    p.default_texture = p.textures;
    CHECK(hbk_fluid_params_check(&p, &m) == HBK_ERR_INVALID_ARGUMENT && strstr(m.text, "default_texture"));
    hbk_fluid_params_default(&p);
    p.size = 4;
    CHECK(hbk_fluid_params_check(&p, &m) == HBK_ERR_VERSION);
    /* Setters and calls refuse by name and change nothing. */
    p = params(8, HBK_FLUID_SIMULATE);
    p.max_particles = 10;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float out_of_box[3] = {0.5f, 2.0f, 0.5f};
    CHECK(hbk_fluid_set_particles(h, out_of_box, NULL, 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "pos[0][1]") && hbk_fluid_particle_count(h) == 0);
    CHECK(hbk_fluid_set_particles(h, out_of_box, NULL, 11) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "count"));
    const float c[3] = {0.5f, 0.5f, 0.5f};
    CHECK(hbk_fluid_paint_sphere(h, 3, c, 0.1f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "texture"));
    CHECK(hbk_fluid_paint_sphere(h, 0, c, -1.0f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "radius"));
    float lo[HBK_FLUID_FEATURE_COUNT] = {0, 0, 0, 0, 0, 0};
    float hi[HBK_FLUID_FEATURE_COUNT] = {1, 1, 1, 1, -1, 1};
    CHECK(hbk_fluid_set_feature_rule(h, 0, lo, hi) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "hi[4]"));
    const float lo3[3] = {0, 0, 0}, hi3[3] = {1, 1, 1};
    CHECK(hbk_fluid_fill_box(h, lo3, hi3, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "max_particles") && hbk_fluid_particle_count(h) == 0);
    hbk_fluid_obstacle_t ob = {4, {0, 0, 0}, {1, 1, 1}, {1, 0, 0, 0}};
    CHECK(hbk_fluid_set_obstacles(h, &ob, 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "obs[0].type"));
    ob.type = 2; /* a turned box needs a unit quaternion */
    ob.rotation[0] = 0.99f;
    CHECK(hbk_fluid_set_obstacles(h, &ob, 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "obs[0].rotation: length 0.99"));
    ob.rotation[0] = 0.9995f;
    CHECK(hbk_fluid_set_obstacles(h, &ob, 1) == HBK_OK);
    float one = 0.0f;
    CHECK(hbk_fluid_get_volume(h, HBK_FLUID_VOL_UVW_A, &one, 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "count"));
    CHECK(hbk_noise3d_tileable(&one, 4, 5, 1, 0.5f, 0, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "period"));
    hbk_fluid_destroy(h);
}

/* Uniform flow along x shifts u by v dt / cell voxels per frame, across the wrap too; v and w
 * stay bitwise. The rest mapping is u = frac(i cell / tile): with tile = 4 cells it wraps every
 * 4 vertices. */
void test_fluid_uniform_flow_shift(void)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_VELOCITY_GRID);
    p.reset_period = 0.0f;
    p.uvw_tile = 4.0f / 16.0f;
    p.dt = 0.1f;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const double d = 0.3; /* voxels per frame */
    const float vel[3] = {(float)(d / 16.0 / 0.1), 0.0f, 0.0f};
    uniform_grid(h, vel);
    float *u0 = volume(h, HBK_FLUID_VOL_UVW_A);
    for (int f = 1; f <= 3; ++f) {
        CHECK_OK(hbk_fluid_step(h, NULL));
        float *u = volume(h, HBK_FLUID_VOL_UVW_A);
        double worst = 0.0;
        int wrapped = 0;
        for (int k = 0; k <= 16; ++k)
            for (int j = 0; j <= 16; ++j)
                for (int i = 0; i <= 16; ++i) {
                    size_t vi = (size_t)i + 17u * ((size_t)j + 17u * (size_t)k);
                    CHECK(u[3 * vi + 1] == u0[3 * vi + 1] && u[3 * vi + 2] == u0[3 * vi + 2]);
                    const double src = i - f * d;
                    if (i < 2 * f) continue; /* the inflow border reaches one vertex per frame */
                    const double want = src / 4.0 - floor(src / 4.0);
                    const double e = cdist(u[3 * vi], want);
                    worst = e > worst ? e : worst;
                    wrapped |= floor(src / 4.0) != floor(i / 4.0);
                }
        free(u);
        CHECK(wrapped);
        if (worst > 2e-6) fprintf(stderr, "frame %d worst %g\n", f, worst);
        CHECK(worst <= 2e-6);
    }
    free(u0);
    hbk_fluid_destroy(h);
}

/* Still fluid: nothing moves, bit for bit, also with paint and particles at rest. */
void test_fluid_zero_flow_bitwise(void)
{
    hbk_fluid_params_t p = params(12, HBK_FLUID_PARTICLES);
    p.reset_period = 0.0f;
    p.paint_duration = 100.0f;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float lo[3] = {0.2f, 0.2f, 0.0f}, hi[3] = {0.8f, 0.8f, 0.4f}, c[3] = {0.5f, 0.5f, 0.2f};
    CHECK_OK(hbk_fluid_fill_box(h, lo, hi, 0.3f));
    CHECK_OK(hbk_fluid_paint_sphere(h, 1, c, 0.2f, 0.1f));
    int vols[4] = {HBK_FLUID_VOL_UVW_A, HBK_FLUID_VOL_UVW_B, HBK_FLUID_VOL_BLEND, HBK_FLUID_VOL_WRAP};
    float *before[4];
    for (int q = 0; q < 4; ++q) before[q] = volume(h, vols[q]);
    for (int f = 0; f < 5; ++f) CHECK_OK(hbk_fluid_step(h, NULL));
    for (int q = 0; q < 4; ++q) {
        float *after = volume(h, vols[q]);
        CHECK(!memcmp(before[q], after, hbk_fluid_volume_size(h, vols[q]) * sizeof(float)));
        free(after);
        free(before[q]);
    }
    hbk_fluid_destroy(h);
}

/* Fig. 4: 0.9 next to 0.1 interpolates through 0/1, 0.1 next to 0.3 directly. */
void test_fluid_wrap_short_way(void)
{
    hbk_fluid_params_t p = params(4, HBK_FLUID_VELOCITY_GRID);
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const size_t nv = h->n_vert;
    for (size_t i = 0; i < nv; ++i) {
        const int x = (int)(i % 5);
        h->v.uvw[0][3 * i] = x == 0 ? 0.9f : x == 1 ? 0.1f : x == 2 ? 0.3f : x == 3 ? 0.8f : 0.2f;
        h->v.uvw[0][3 * i + 1] = 0.5f;
        h->v.uvw[0][3 * i + 2] = 0.5f;
    }
    memset(h->v.wrap[0], 0, h->n_vox);
    const float still[3] = {0, 0, 0};
    uniform_grid(h, still); /* a still frame re-derives the flags from the corners */
    CHECK_OK(hbk_fluid_step(h, NULL));
    float w[3 * 64];
    CHECK_OK(hbk_fluid_get_volume(h, HBK_FLUID_VOL_WRAP, w, 3 * 64));
    CHECK(w[0] == 1.0f && w[3] == 0.0f && w[6] == 0.0f && w[9] == 1.0f); /* 0.8 -> 0.2 wraps */
    CHECK(w[1] == 0.0f && w[2] == 0.0f);
    float uvw[3];
    const float mid01[3] = {0.5f / 4.0f, 0.3f, 0.6f}, mid12[3] = {1.5f / 4.0f, 0.3f, 0.6f},
                q34[3] = {3.25f / 4.0f, 0.1f, 0.1f};
    CHECK_OK(hbk_fluid_sample_uvw(h, 0, mid01, uvw));
    CHECK(cdist(uvw[0], 0.0) < 1e-6 && uvw[0] >= 0.0f && uvw[0] < 1.0f);
    CHECK_NEAR(uvw[1], 0.5, 0.0);
    CHECK_OK(hbk_fluid_sample_uvw(h, 0, mid12, uvw));
    CHECK_NEAR(uvw[0], 0.2, 1e-6);
    CHECK_OK(hbk_fluid_sample_uvw(h, 0, q34, uvw)); /* 0.8 + 0.25 * 0.4 = 0.9 */
    CHECK_NEAR(uvw[0], 0.9, 1e-6);
    hbk_fluid_destroy(h);
}

/* V_r advects with the flow (paper: "offset V_c, V_b and V_r by V_m"): on a torn uvw field
 * (every voxel's corners spread over a third of the tile both ways, so no repair applies) each
 * voxel takes the flags of the voxel its centre came from. Uniform flow of one voxel per frame
 * along x, and a shear vx ~ z, whose back-trace at a centre is the mean of its corners' (the
 * centre of layer k moves (k + 1/2 - 8) / 2 voxels). Third case, uniform flow with only v
 * torn: u and w are constant, so the repair clears their bits, and v's bit alone travels. */
void test_fluid_wrap_flags_advect(void)
{
    const int32_t R = 16;
    for (int run = 0; run < 3; ++run) {
        const int shear = run == 1, only_v = run == 2;
        hbk_fluid_params_t p = params(R, HBK_FLUID_VELOCITY_GRID);
        p.reset_period = 0.0f;
        p.max_flow = 8.0f;
        p.dt = 0.1f;
        hbk_fluid_t *h = fluid_make(&p);
        CHECK(h);
        const int32_t n = R + 1;
        for (int32_t k = 0; k < n; ++k)
            for (int32_t j = 0; j < n; ++j)
                for (int32_t i = 0; i < n; ++i) {
                    float *u = h->v.uvw[0] + 3 * ((size_t)i + (size_t)n * ((size_t)j + (size_t)n * (size_t)k));
                    for (int a = 0; a < 3; ++a)
                        u[a] = only_v && a != 1 ? 0.25f : (float)((i + j + k + a) % 3) / 3.0f;
                }
        for (size_t v = 0; v < h->n_vox; ++v) h->v.wrap[0][v] = (uint8_t)((v * 2654435761u) >> 13 & 7u);
        uint8_t *before = malloc(h->n_vox);
        memcpy(before, h->v.wrap[0], h->n_vox);
        /* source - vertex = -dt vx / cell voxels along x */
        float *vel = calloc(3 * h->n_vert, sizeof *vel);
        for (size_t v = 0; v < h->n_vert; ++v) {
            const double k = (double)(v / ((size_t)n * (size_t)n));
            const double disp = shear ? 0.5 * (k - 8.0) : 1.0; /* voxels per frame, downstream */
            vel[3 * v] = (float)(disp / R / p.dt);
        }
        hbk_fluid_set_velocity_grid(h, vel, NULL);
        free(vel);
        CHECK_OK(hbk_fluid_step(h, NULL));
        int bad = 0, checked = 0;
        for (int32_t k = 0; k < R; ++k)
            for (int32_t j = 0; j < R; ++j)
                for (int32_t i = 0; i < R; ++i) {
                    const double from = i + 0.5 - (shear ? 0.5 * (k + 0.5 - 8.0) : 1.0);
                    if (from < 0.0 || from >= R) continue; /* inflow border */
                    const int32_t fi = (int32_t)floor(from);
                    const size_t vox = (size_t)i + (size_t)R * ((size_t)j + (size_t)R * (size_t)k);
                    const uint8_t src = before[(size_t)fi + (size_t)R * ((size_t)j + (size_t)R * (size_t)k)];
                    bad += h->v.wrap[0][vox] != (only_v ? (src & 2u) : src);
                    ++checked;
                }
        if (bad) fprintf(stderr, "flags advect (%s): %d of %d voxels wrong\n", shear ? "shear" : only_v ? "v only" : "uniform", bad, checked);
        CHECK(checked > R * R * R / 2 && bad == 0);
        free(before);
        hbk_fluid_destroy(h);
    }
}

/* Blend weights sum to one after advection by a swirl, paint strokes, fading and feature
 * rules, on the grid and on the surface. */
void test_fluid_blend_normalised(void)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_VELOCITY_GRID);
    p.textures = 4;
    p.paint_duration = 0.1f;
    p.paint_fade = 0.2f;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    size_t nv = hbk_fluid_grid_vertices(h, NULL);
    float *vel = malloc(3 * nv * sizeof *vel), *surf = malloc(nv * sizeof *surf);
    for (size_t i = 0; i < nv; ++i) {
        const float x = (float)(i % 17) / 16.0f - 0.5f, y = (float)(i / 17 % 17) / 16.0f - 0.5f,
                    z = (float)(i / 289) / 16.0f - 0.5f;
        vel[3 * i] = -y * 3.0f; vel[3 * i + 1] = x * 3.0f; vel[3 * i + 2] = 0.2f * x;
        surf[i] = 1.0f - sqrtf(x * x + y * y + z * z) / 0.4f;
    }
    CHECK_OK(hbk_fluid_set_velocity_grid(h, vel, surf));
    const float c1[3] = {0.3f, 0.5f, 0.5f}, c2[3] = {0.6f, 0.4f, 0.5f};
    CHECK_OK(hbk_fluid_paint_sphere(h, 1, c1, 0.1f, 0.1f));
    const float lo[HBK_FLUID_FEATURE_COUNT] = {0.5f, -FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX, -FLT_MAX};
    const float hi[HBK_FLUID_FEATURE_COUNT] = {FLT_MAX, FLT_MAX, FLT_MAX, FLT_MAX, FLT_MAX, FLT_MAX};
    CHECK_OK(hbk_fluid_set_feature_rule(h, 3, lo, hi));
    for (int f = 0; f < 12; ++f) {
        if (f == 3) CHECK_OK(hbk_fluid_paint_sphere(h, 2, c2, 0.15f, 0.05f));
        CHECK_OK(hbk_fluid_step(h, NULL));
        float *b = volume(h, HBK_FLUID_VOL_BLEND);
        for (size_t i = 0; i < nv; ++i) {
            double s = 0.0;
            for (int t = 0; t < 4; ++t) { CHECK(b[4 * i + t] >= 0.0f && b[4 * i + t] <= 1.0f + 1e-6f); s += b[4 * i + t]; }
            CHECK_NEAR(s, 1.0, 1e-5);
        }
        free(b);
    }
    /* The rule's texture owns the dense core; the surface carries normalised blends too. */
    CHECK_OK(hbk_fluid_update_surface(h, NULL));
    int32_t mv = 0, mt = 0;
    CHECK_OK(hbk_fluid_mesh_counts(h, &mv, &mt));
    CHECK(mv > 100);
    float *mb = malloc((size_t)mv * 4 * sizeof *mb);
    CHECK_OK(hbk_fluid_get_mesh(h, NULL, NULL, NULL, NULL, NULL, mb, NULL));
    for (int32_t i = 0; i < mv; ++i) CHECK_NEAR(mb[4 * i] + mb[4 * i + 1] + mb[4 * i + 2] + mb[4 * i + 3], 1.0, 1e-5);
    free(mb);
    float *b = volume(h, HBK_FLUID_VOL_BLEND);
    const size_t centre = 8 + 17 * (8 + 17 * 8);
    CHECK(b[4 * centre + 3] == 1.0f);
    free(b);
    free(vel);
    free(surf);
    hbk_fluid_destroy(h);
}

/* Feature paint (paper 3.1): after each step every vertex whose features all lie in a rule's
 * ranges (bounds included) holds that texture alone, the later texture where several match;
 * the constant features of the rows far from the fluid (matched once per row) match like any
 * others, and a range of the curvature (the features' second pass) counts like the others.
 * Rules changed between steps apply from the next step. On the plain and the widest paths. */
static void rules_exact(void)
{
    enum { T = 4 };
    hbk_fluid_params_t p = params(16, HBK_FLUID_VELOCITY_GRID);
    p.textures = T;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    if (!h) return;
    const size_t nv = hbk_fluid_grid_vertices(h, NULL);
    float *vel = calloc(3 * nv, sizeof *vel), *surf = calloc(nv, sizeof *surf);
    for (size_t i = 0; i < nv; ++i) { /* a swirling ball; still and empty around it */
        const float x = (float)(i % 17) / 16.0f - 0.4f, y = (float)(i / 17 % 17) / 16.0f - 0.4f,
                    z = (float)(i / 289) / 16.0f - 0.4f, r = sqrtf(x * x + y * y + z * z);
        if (r >= 0.3f) continue;
        vel[3 * i] = -y * 3.0f; vel[3 * i + 1] = x * 3.0f; vel[3 * i + 2] = 0.5f * x;
        surf[i] = 1.0f - r / 0.3f;
    }
    CHECK_OK(hbk_fluid_set_velocity_grid(h, vel, surf));
    const int F = HBK_FLUID_FEATURE_COUNT;
    float lo[T][HBK_FLUID_FEATURE_COUNT], hi[T][HBK_FLUID_FEATURE_COUNT];
    for (int t = 0; t < T; ++t)
        for (int c = 0; c < F; ++c) lo[t][c] = -FLT_MAX, hi[t][c] = FLT_MAX;
    const float angle = (float)(0.5 * M_PI); /* the flow angle where there is no flow */
    /* 0: a shell of the ball; 1: its core; 2: the part of the shell curved more than 4.35 (most
     * of it), over 0; 3: wherever nothing flows, the dry rows included */
    lo[0][HBK_FLUID_FEATURE_DENSITY] = lo[2][HBK_FLUID_FEATURE_DENSITY] = 0.2f;
    hi[0][HBK_FLUID_FEATURE_DENSITY] = hi[2][HBK_FLUID_FEATURE_DENSITY] = 0.6f;
    lo[1][HBK_FLUID_FEATURE_DENSITY] = 0.5f;
    lo[2][HBK_FLUID_FEATURE_CURVATURE] = 4.35f;
    lo[3][HBK_FLUID_FEATURE_FLOW_ANGLE] = hi[3][HBK_FLUID_FEATURE_FLOW_ANGLE] = angle;
    for (int t = 0; t < T; ++t) CHECK_OK(hbk_fluid_set_feature_rule(h, t, lo[t], hi[t]));
    for (int f = 0; f < 4; ++f) {
        if (f == 2) { /* texture 2's curvature narrowed: from this step on */
            lo[2][HBK_FLUID_FEATURE_CURVATURE] = 5.0f;
            CHECK_OK(hbk_fluid_set_feature_rule(h, 2, lo[2], hi[2]));
        }
        CHECK_OK(hbk_fluid_step(h, NULL));
        float *ft = volume(h, HBK_FLUID_VOL_FEATURES), *b = volume(h, HBK_FLUID_VOL_BLEND);
        int count[T] = {0}, bad = 0;
        for (size_t i = 0; i < nv; ++i) {
            int want = -1;
            const float *fi = ft + (size_t)F * i;
            for (int t = 0; t < T; ++t) {
                int in = 1;
                for (int c = 0; c < F; ++c) in &= fi[c] >= lo[t][c] && fi[c] <= hi[t][c];
                if (in) want = t;
            }
            if (want < 0) continue;
            ++count[want];
            for (int t = 0; t < T; ++t)
                bad += b[(size_t)T * i + (size_t)t] != (t == want ? 1.0f : 0.0f);
        }
        size_t quiet = 0;
        for (size_t r = 0; r < h->n_rows; ++r) quiet += h->quiet[r];
        if (bad) fprintf(stderr, "rules, frame %d: %d weights wrong\n", f, bad);
        CHECK(bad == 0 && quiet > 0);
        for (int t = 0; t < T; ++t) CHECK(count[t] > 0);
        free(ft);
        free(b);
    }
    free(vel);
    free(surf);
    hbk_fluid_destroy(h);
}

void test_fluid_rules_exact(void)
{
    setenv("HBK_PATHS", "scalar", 1); /* the features of the plain pass too */
    rules_exact();
    unsetenv("HBK_PATHS");
    rules_exact();
}

/* A rule is left unapplied to a row only while the row's base is known one-hot at its texture
 * in both buffers (rows_hot): a row that moved in between is matched again. Rows far above a
 * ball are made one-hot by a rule of no density, rate or acceleration; one frame of upward flow
 * carries the ball's texture 0 into them (the rule fails on moving rows), the next stops
 * everything (it fails on the acceleration), and once all is quiet the rule must hold again
 * everywhere. */
void test_fluid_rules_after_flow(void)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_VELOCITY_GRID);
    p.textures = 2;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    if (!h) return;
    const size_t nv = hbk_fluid_grid_vertices(h, NULL);
    float *zero = calloc(3 * nv, sizeof(float)), *up = calloc(3 * nv, sizeof(float)),
          *ball = calloc(nv, sizeof(float));
    for (size_t i = 0; i < nv; ++i) {
        const float x = (float)(i % 17) / 16.0f - 0.5f, y = (float)(i / 17 % 17) / 16.0f - 0.3f,
                    z = (float)(i / 289) / 16.0f - 0.5f, r = sqrtf(x * x + y * y + z * z);
        ball[i] = r < 0.2f ? 1.0f - r / 0.2f : 0.0f;
        up[3 * i + 1] = 4.0f / 16.0f * 24.0f; /* four cells a frame */
    }
    float lo[HBK_FLUID_FEATURE_COUNT], hi[HBK_FLUID_FEATURE_COUNT];
    for (int c = 0; c < HBK_FLUID_FEATURE_COUNT; ++c) lo[c] = -FLT_MAX, hi[c] = FLT_MAX;
    lo[HBK_FLUID_FEATURE_DENSITY] = hi[HBK_FLUID_FEATURE_DENSITY] = 0.0f;
    lo[HBK_FLUID_FEATURE_DENSITY_RATE] = hi[HBK_FLUID_FEATURE_DENSITY_RATE] = 0.0f;
    lo[HBK_FLUID_FEATURE_ACCELERATION] = hi[HBK_FLUID_FEATURE_ACCELERATION] = 0.0f;
    CHECK_OK(hbk_fluid_set_feature_rule(h, 1, lo, hi));
    for (int f = 0; f < 8; ++f) {
        CHECK_OK(hbk_fluid_set_velocity_grid(h, f < 3 ? zero : f == 3 ? up : zero,
                                             f <= 3 ? ball : zero));
        CHECK_OK(hbk_fluid_step(h, NULL));
        float *b = volume(h, HBK_FLUID_VOL_BLEND);
        size_t off = 0; /* vertices not one-hot at texture 1 */
        for (size_t i = 0; i < nv; ++i) off += b[2 * i] != 0.0f || b[2 * i + 1] != 1.0f;
        if (f == 4) CHECK(off > 0); /* the flow brought texture 0 up, and the rule failed */
        if (f == 7) {
            if (off) fprintf(stderr, "rules after flow: %zu vertices not one-hot\n", off);
            CHECK(off == 0);
        }
        free(b);
    }
    free(zero);
    free(up);
    free(ball);
    hbk_fluid_destroy(h);
}

/* Poly6 kernel sum in double, the analytic reference. */
static double lattice_kernel_sum(double s, double H, double ox, double oy, double oz)
{
    double sum = 0.0;
    for (int k = -6; k <= 6; ++k)
        for (int j = -6; j <= 6; ++j)
            for (int i = -6; i <= 6; ++i) {
                const double x = i * s + ox, y = j * s + oy, z = k * s + oz, r2 = x * x + y * y + z * z;
                if (r2 < H * H) sum += 315.0 / (64.0 * M_PI * pow(H, 9)) * pow(H * H - r2, 3);
            }
    return sum;
}

/* Particles on a lattice: the density at interior vertices equals m sum W (and rest density
 * where the vertices sit on particles); at rest its rate and the acceleration are zero. */
void test_fluid_density_lattice(void)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_PARTICLES);
    p.particle_spacing = 1.0f / 16.0f;
    p.smoothing_length = 2.0f / 16.0f;
    p.metaball_radius = 2.0f / 16.0f;
    p.max_particles = 17 * 17 * 17;
    const double s = 1.0 / 16.0, H = 2.0 / 16.0;
    const double mass = 1000.0 / lattice_kernel_sum(s, H, 0, 0, 0);
    for (int shifted = 0; shifted < 2; ++shifted) {
        hbk_fluid_t *h = fluid_make(&p);
        CHECK(h);
        const int n = shifted ? 16 : 17;
        float *pos = malloc(3 * (size_t)n * n * n * sizeof *pos);
        int q = 0;
        for (int k = 0; k < n; ++k)
            for (int j = 0; j < n; ++j)
                for (int i = 0; i < n; ++i, ++q) {
                    pos[3 * q] = (float)((i + 0.5 * shifted) * s);
                    pos[3 * q + 1] = (float)((j + 0.5 * shifted) * s);
                    pos[3 * q + 2] = (float)((k + 0.5 * shifted) * s);
                }
        CHECK_OK(hbk_fluid_set_particles(h, pos, NULL, q));
        CHECK_OK(hbk_fluid_update_fields(h));
        CHECK_OK(hbk_fluid_step(h, NULL));
        CHECK_OK(hbk_fluid_step(h, NULL));
        float *d = volume(h, HBK_FLUID_VOL_DENSITY), *f = volume(h, HBK_FLUID_VOL_FEATURES);
        const double want = mass * lattice_kernel_sum(s, H, 0.5 * s * shifted, 0.5 * s * shifted,
                                                      0.5 * s * shifted);
        if (!shifted) CHECK_NEAR(want, 1000.0, 1e-9);
        for (int k = 3; k <= 13; ++k)
            for (int j = 3; j <= 13; ++j)
                for (int i = 3; i <= 13; ++i) {
                    const size_t vi = (size_t)i + 17u * ((size_t)j + 17u * (size_t)k);
                    CHECK_NEAR(d[vi], want, 1e-4 * want);
                    CHECK(f[HBK_FLUID_FEATURE_COUNT * vi + HBK_FLUID_FEATURE_DENSITY_RATE] == 0.0f);
                    CHECK(f[HBK_FLUID_FEATURE_COUNT * vi + HBK_FLUID_FEATURE_ACCELERATION] == 0.0f);
                    CHECK(f[HBK_FLUID_FEATURE_COUNT * vi + HBK_FLUID_FEATURE_DIVERGENCE] == 0.0f);
                    /* uniform density: no surface, no curvature */
                    CHECK(f[HBK_FLUID_FEATURE_COUNT * vi + HBK_FLUID_FEATURE_CURVATURE] == 0.0f);
                }
        free(d);
        free(f);
        free(pos);
        hbk_fluid_destroy(h);
    }
}

/* The fastest particle's speed; *rms (if given) the root mean square speed. */
static double max_speed(hbk_fluid_t *h, float *vel, double *rms)
{
    const int32_t n = hbk_fluid_particle_count(h);
    hbk_fluid_get_particles(h, NULL, vel, n);
    double m = 0.0, s2 = 0.0;
    for (int32_t i = 0; i < n; ++i) {
        const double v2 = vel[3 * i] * vel[3 * i] + vel[3 * i + 1] * vel[3 * i + 1] + vel[3 * i + 2] * vel[3 * i + 2];
        m = sqrt(v2) > m ? sqrt(v2) : m;
        s2 += v2;
    }
    if (rms) *rms = n ? sqrt(s2 / n) : 0.0;
    return m;
}

/* Two and three particles closer than the rest spacing, far from the walls: the pressure pushes
 * them apart, pairwise equal and opposite (zero total momentum). With h = one spacing a lone
 * particle is exactly at rest density, so any closer neighbour raises the pressure. */
static void sph_push_apart(int n)
{
    hbk_fluid_params_t p = params(8, HBK_FLUID_SIMULATE);
    p.particle_spacing = p.smoothing_length = 0.02f;
    p.metaball_radius = 0.02f;
    p.gravity[2] = 0.0f;
    p.viscosity = 0.0f;
    p.substeps = 1;
    p.dt = 1e-4f;
    p.max_particles = 3;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float pos[9] = {0.5f, 0.5f, 0.5f, 0.512f, 0.5f, 0.5f, 0.506f, 0.51f, 0.503f};
    CHECK_OK(hbk_fluid_set_particles(h, pos, NULL, n));
    CHECK_OK(hbk_fluid_step(h, NULL));
    float v[9];
    CHECK_OK(hbk_fluid_get_particles(h, NULL, v, n));
    double c[3] = {0, 0, 0}, sum[3] = {0, 0, 0}, vmax = 0.0;
    for (int i = 0; i < n; ++i)
        for (int a = 0; a < 3; ++a) {
            c[a] += pos[3 * i + a] / n;
            sum[a] += v[3 * i + a];
            vmax = fmax(vmax, fabs(v[3 * i + a]));
        }
    CHECK(vmax > 1e-4);
    for (int a = 0; a < 3; ++a) CHECK(fabs(sum[a]) <= 1e-5 * vmax);
    for (int i = 0; i < n; ++i) {
        double out = 0.0;
        for (int a = 0; a < 3; ++a) out += (pos[3 * i + a] - c[a]) * v[3 * i + a];
        CHECK(out > 0.0);
    }
    hbk_fluid_destroy(h);
}

/* A column settled under gravity stays still, and no particle leaves the box. */
void test_fluid_sph_rest(void)
{
    sph_push_apart(2);
    sph_push_apart(3);

    hbk_fluid_params_t p = params(8, HBK_FLUID_SIMULATE);
    p.box_max[0] = p.box_max[1] = 0.2f;
    p.box_max[2] = 0.4f;
    p.max_particles = 2000;
    p.damping = 5.0f;
    hbk_fluid_t *settle = fluid_make(&p);
    CHECK(settle);
    const float lo[3] = {0, 0, 0}, hi[3] = {0.2f, 0.2f, 0.2f};
    CHECK_OK(hbk_fluid_fill_box(settle, lo, hi, 0.0f));
    const int32_t n = hbk_fluid_particle_count(settle);
    CHECK(n == 1000);
    for (int f = 0; f < 48; ++f) CHECK_OK(hbk_fluid_step(settle, NULL));
    size_t sz = hbk_fluid_state_size(settle);
    void *buf = malloc(sz);
    CHECK_OK(hbk_fluid_save_state(settle, buf, sz));
    p.damping = 0.0f; /* now real fluid: it must stay at rest by itself */
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    CHECK_OK(hbk_fluid_load_state(h, buf, sz));
    float *pos0 = malloc(3 * (size_t)n * sizeof *pos0), *pos = malloc(3 * (size_t)n * sizeof *pos),
          *vel = malloc(3 * (size_t)n * sizeof *vel);
    CHECK_OK(hbk_fluid_get_particles(h, pos0, NULL, n));
    double worst_v = 0.0, worst_rms = 0.0, rms = 0.0, rms0 = 0.0;
    for (int f = 0; f < 48; ++f) {
        CHECK_OK(hbk_fluid_step(h, NULL));
        const double v = max_speed(h, vel, &rms);
        worst_v = v > worst_v ? v : worst_v;
        worst_rms = rms > worst_rms ? rms : worst_rms;
        if (f == 0) rms0 = rms;
        CHECK_OK(hbk_fluid_get_particles(h, pos, NULL, n));
        for (int32_t i = 0; i < n; ++i)
            for (int a = 0; a < 3; ++a)
                CHECK(pos[3 * i + a] >= p.box_min[a] && pos[3 * i + a] <= p.box_max[a]);
    }
    double worst_d = 0.0;
    for (int32_t i = 0; i < 3 * n; ++i) worst_d = fmax(worst_d, fabs(pos[i] - pos0[i]));
    fprintf(stderr, "sph_rest: max speed %.4g m/s, rms %.4g m/s (first frame %.4g, last %.4g), "
            "max drift %.4g m over 2 s\n", worst_v, worst_rms, rms0, rms, worst_d);
    /* At rest: the kinetic energy stays small and does not grow (rms about 0.005 m/s, falling
     * to 0.002). The fastest single particle is a noisy measure: the rounding of the sums
     * alone (the lane order) moved it between 0.037 and 0.075 m/s. */
    CHECK(worst_rms < 0.01);
    CHECK(rms <= rms0);
    CHECK(worst_v < 0.1);
    /* Not 0.25 spacing: a free surface has no shear stiffness, so its particles creep into the
     * hollows of the settled lattice at the speeds allowed above (~0.8 spacing in 2 s). */
    CHECK(worst_d < 1.0 * p.particle_spacing);
    free(pos0); free(pos); free(vel); free(buf);
    hbk_fluid_destroy(settle);
    hbk_fluid_destroy(h);
}

/* Mechanical energy per kg: kinetic plus potential above z = 0 (gravity along -z). */
static double energy(hbk_fluid_t *h, float *pos, float *vel)
{
    const int32_t n = hbk_fluid_particle_count(h);
    hbk_fluid_get_particles(h, pos, vel, n);
    double e = 0.0;
    for (int32_t i = 0; i < n; ++i)
        e += 0.5 * (vel[3 * i] * vel[3 * i] + vel[3 * i + 1] * vel[3 * i + 1] +
                    vel[3 * i + 2] * vel[3 * i + 2]) + 9.81 * pos[3 * i + 2];
    return n ? e / n : 0.0;
}

/* A dam break asked for one SPH step per 1/24 s frame (a 40x too long step: it would explode)
 * takes the steps stability needs, at least dt (sqrt(k) + v_max) / (0.4 h); its energy only
 * falls (viscosity, walls; the lattice starts at rest density, so with no stored pressure). Fewer asked-for steps than that give the same bytes; more are
 * taken exactly. */
void test_fluid_sph_stable_steps(void)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_SIMULATE);
    p.max_particles = 2000;
    p.box_max[2] = 0.5f;
    const float lo[3] = {0, 0, 0}, hi[3] = {0.2f, 0.2f, 0.3f};
    hbk_fluid_t *h[3];
    const int32_t asked[3] = {1, 8, 120};
    for (int c = 0; c < 3; ++c) {
        p.substeps = asked[c];
        CHECK(h[c] = fluid_make(&p));
        if (!h[c]) return;
        CHECK_OK(hbk_fluid_fill_box(h[c], lo, hi, 0.0f));
    }
    const int32_t n = hbk_fluid_particle_count(h[0]);
    CHECK(n == 1500);
    CHECK(hbk_fluid_substeps_taken(h[0]) == 0);
    float *pos = malloc(6 * (size_t)n * sizeof *pos), *vel = malloc(6 * (size_t)n * sizeof *vel);
    const double e0 = energy(h[0], pos, vel), c = sqrt((double)p.stiffness);
    double e_prev = e0;
    for (int f = 0; f < 12; ++f) {
        const double vmax = max_speed(h[0], vel, NULL);
        for (int k = 0; k < 3; ++k) CHECK_OK(hbk_fluid_step(h[k], NULL));
        const int32_t taken = hbk_fluid_substeps_taken(h[0]);
        CHECK(taken >= (int32_t)ceil(p.dt * (c + vmax) / (0.4 * p.smoothing_length) - 1e-6));
        CHECK(taken <= 2 * (int32_t)ceil(p.dt * (c + 10.0) / (0.4 * p.smoothing_length)));
        CHECK(hbk_fluid_substeps_taken(h[1]) == taken);
        CHECK(hbk_fluid_substeps_taken(h[2]) == 120);
        hbk_fluid_get_particles(h[1], pos + 3 * (size_t)n, vel + 3 * (size_t)n, n);
        const double e = energy(h[0], pos, vel);
        CHECK(!memcmp(pos, pos + 3 * (size_t)n, 3 * (size_t)n * sizeof *pos));
        CHECK(!memcmp(vel, vel + 3 * (size_t)n, 3 * (size_t)n * sizeof *vel));
        CHECK(e <= e_prev * 1.001);
        e_prev = e;
        if (f == 0) fprintf(stderr, "sph_stable_steps: %d steps in frame 1\n", taken);
    }
    CHECK(e_prev < 0.9 * e0); /* it fell and spread (0.82 e0 after 0.5 s) */
    CHECK(energy(h[2], pos, vel) < e0);
    free(pos); free(vel);
    for (int k = 0; k < 3; ++k) hbk_fluid_destroy(h[k]);
}

static int cmp(const void *x, const void *y)
{
    const uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return a < b ? -1 : a > b;
}

/* Every edge in exactly two triangles, once in each direction (consistent winding). */
static int watertight(const int32_t *tri, int32_t nt, int32_t nv)
{
    /* Sort directed edges as 64-bit keys. */
    size_t ne = 3 * (size_t)nt;
    uint64_t *e = malloc(ne * sizeof *e);
    for (int32_t t = 0; t < nt; ++t)
        for (int k = 0; k < 3; ++k) {
            uint32_t a = (uint32_t)tri[3 * t + k], b = (uint32_t)tri[3 * t + (k + 1) % 3];
            if (a >= (uint32_t)nv || b >= (uint32_t)nv || a == b) { free(e); return 0; }
            e[3 * (size_t)t + k] = (uint64_t)a << 32 | b;
        }
    qsort(e, ne, sizeof *e, cmp);
    int ok = 1;
    for (size_t i = 0; i < ne && ok; ++i) {
        if (i + 1 < ne && e[i] == e[i + 1]) ok = 0; /* same direction twice */
        const uint64_t rev = (e[i] & 0xffffffffu) << 32 | e[i] >> 32;
        if (!bsearch(&rev, e, ne, sizeof *e, cmp)) ok = 0;
    }
    free(e);
    return ok;
}

/* A closed blob of random particles, one touching the box floor: closed surfaces. */
void test_fluid_mc_closed(void)
{
    hbk_fluid_params_t p = params(24, HBK_FLUID_PARTICLES);
    p.max_particles = 600;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    float pos[3 * 600];
    for (int i = 0; i < 600; ++i) {
        float r[3];
        hbk_rng_fill_uniform(7, 1, (uint64_t)i, r, 3);
        const int wall = i >= 400;
        pos[3 * i] = wall ? 0.2f + 0.2f * r[0] : 0.35f + 0.3f * r[0];
        pos[3 * i + 1] = wall ? 0.2f + 0.2f * r[1] : 0.4f + 0.25f * r[1];
        pos[3 * i + 2] = wall ? 0.01f + 0.1f * r[2] : 0.45f + 0.3f * r[2];
    }
    CHECK_OK(hbk_fluid_set_particles(h, pos, NULL, 600));
    CHECK_OK(hbk_fluid_update_fields(h));
    CHECK_OK(hbk_fluid_update_surface(h, NULL));
    int32_t nv = 0, nt = 0;
    CHECK_OK(hbk_fluid_mesh_counts(h, &nv, &nt));
    CHECK(nt > 200);
    int32_t *tri = malloc(3 * (size_t)nt * sizeof *tri);
    float *mp = malloc(3 * (size_t)nv * sizeof *mp);
    CHECK_OK(hbk_fluid_get_mesh(h, mp, NULL, tri, NULL, NULL, NULL, NULL));
    CHECK(watertight(tri, nt, nv));
    float zmin = 1.0f;
    for (int32_t i = 0; i < nv; ++i) zmin = mp[3 * i + 2] < zmin ? mp[3 * i + 2] : zmin;
    CHECK(zmin == 0.0f); /* capped on the floor */
    free(tri);
    free(mp);
    hbk_fluid_destroy(h);
}

/* White noise, inside or outside at random per vertex: every cube configuration, and many
 * faces that plain marching cubes finds ambiguous, and still a closed, consistently wound
 * surface. */
void test_fluid_mc_closed_noise(void)
{
    hbk_fluid_params_t p = params(12, HBK_FLUID_VELOCITY_GRID);
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const size_t nvg = hbk_fluid_grid_vertices(h, NULL);
    float *vel = calloc(3 * nvg, sizeof *vel), *surf = malloc(nvg * sizeof *surf);
    int ambiguous = 0;
    for (uint64_t seed = 1; seed <= 8; ++seed) {
        for (size_t i = 0; i < nvg; ++i) {
            float r;
            hbk_rng_fill_uniform(seed, 2, (uint64_t)i, &r, 1);
            surf[i] = r < 0.5f ? 0.1f : 0.9f;
        }
        /* faces (z planes) whose two inside corners are diagonally opposite */
        for (size_t i = 0; i + 13 + 1 < nvg; ++i)
            ambiguous += (surf[i] > 0.5f) == (surf[i + 14] > 0.5f) &&
                         (surf[i + 1] > 0.5f) == (surf[i + 13] > 0.5f) &&
                         (surf[i] > 0.5f) != (surf[i + 1] > 0.5f);
        CHECK_OK(hbk_fluid_set_velocity_grid(h, vel, surf));
        CHECK_OK(hbk_fluid_update_fields(h));
        CHECK_OK(hbk_fluid_update_surface(h, NULL));
        int32_t nv = 0, nt = 0;
        CHECK_OK(hbk_fluid_mesh_counts(h, &nv, &nt));
        CHECK(nt > 1000);
        int32_t *tri = malloc(3 * (size_t)nt * sizeof *tri);
        CHECK_OK(hbk_fluid_get_mesh(h, NULL, NULL, tri, NULL, NULL, NULL, NULL));
        CHECK(watertight(tri, nt, nv));
        free(tri);
    }
    CHECK(ambiguous > 1000);
    free(vel);
    free(surf);
    hbk_fluid_destroy(h);
}

/* A surface field on a res^3 grid over the unit box: 0.5 on the sphere of radius R about the
 * centre, linear in the distance. */
static void sphere_field(float *surf, int res, double R)
{
    const size_t n = (size_t)res + 1;
    for (size_t i = 0; i < n * n * n; ++i) {
        const double x = (double)(i % n) / res - 0.5, y = (double)(i / n % n) / res - 0.5,
                     z = (double)(i / (n * n)) / res - 0.5;
        surf[i] = (float)(0.5 + 0.5 * (R - sqrt(x * x + y * y + z * z)) / R);
    }
}

/* A sphere of radius R from a smooth field: area, volume and normals near analytic. */
void test_fluid_mc_sphere(void)
{
    hbk_fluid_params_t p = params(48, HBK_FLUID_VELOCITY_GRID);
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const double R = 0.3;
    size_t nvg = hbk_fluid_grid_vertices(h, NULL);
    float *vel = calloc(3 * nvg, sizeof *vel), *surf = malloc(nvg * sizeof *surf);
    sphere_field(surf, 48, R);
    CHECK_OK(hbk_fluid_set_velocity_grid(h, vel, surf));
    CHECK_OK(hbk_fluid_update_fields(h));
    CHECK_OK(hbk_fluid_update_surface(h, NULL));
    int32_t nv = 0, nt = 0;
    CHECK_OK(hbk_fluid_mesh_counts(h, &nv, &nt));
    int32_t *tri = malloc(3 * (size_t)nt * sizeof *tri);
    float *mp = malloc(3 * (size_t)nv * sizeof *mp), *mn = malloc(3 * (size_t)nv * sizeof *mn);
    CHECK_OK(hbk_fluid_get_mesh(h, mp, mn, tri, NULL, NULL, NULL, NULL));
    CHECK(watertight(tri, nt, nv));
    double area = 0.0, vol = 0.0;
    for (int32_t t = 0; t < nt; ++t) {
        const float *a = mp + 3 * tri[3 * t], *b = mp + 3 * tri[3 * t + 1], *c = mp + 3 * tri[3 * t + 2];
        double u[3], v[3], w[3], cr[3];
        for (int k = 0; k < 3; ++k) { u[k] = b[k] - a[k]; v[k] = c[k] - a[k]; w[k] = a[k] - 0.5; }
        cr[0] = u[1] * v[2] - u[2] * v[1]; cr[1] = u[2] * v[0] - u[0] * v[2]; cr[2] = u[0] * v[1] - u[1] * v[0];
        area += 0.5 * sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
        vol += (w[0] * cr[0] + w[1] * cr[1] + w[2] * cr[2]) / 6.0;
    }
    fprintf(stderr, "mc_sphere: area %.5f (%.5f), volume %.5f (%.5f), %d triangles\n", area,
            4 * M_PI * R * R, vol, 4.0 / 3.0 * M_PI * R * R * R, nt);
    CHECK_NEAR(vol, 4.0 / 3.0 * M_PI * R * R * R, 0.01 * 4.0 / 3.0 * M_PI * R * R * R);
    CHECK_NEAR(area, 4 * M_PI * R * R, 0.03 * 4 * M_PI * R * R);
    for (int32_t i = 0; i < nv; ++i) {
        double r[3], rr = 0, dot = 0;
        for (int k = 0; k < 3; ++k) { r[k] = mp[3 * i + k] - 0.5; rr += r[k] * r[k]; }
        for (int k = 0; k < 3; ++k) dot += r[k] / sqrt(rr) * mn[3 * i + k];
        CHECK(dot > 0.995);
    }
    /* The curvature feature on the surface: 1/R, everywhere within 10 %, on average within
     * 2 %. */
    float *mf = malloc((size_t)HBK_FLUID_FEATURE_COUNT * (size_t)nv * sizeof *mf);
    CHECK_OK(hbk_fluid_get_mesh(h, NULL, NULL, NULL, NULL, NULL, NULL, mf));
    double mean = 0.0, worst = 0.0;
    for (int32_t i = 0; i < nv; ++i) {
        const double k = mf[(size_t)HBK_FLUID_FEATURE_COUNT * i + HBK_FLUID_FEATURE_CURVATURE];
        mean += k / nv;
        worst = fmax(worst, fabs(k * R - 1.0));
    }
    fprintf(stderr, "mc_sphere: curvature mean %.4f (1/R = %.4f), worst %.1f %%\n", mean, 1 / R,
            100 * worst);
    CHECK_NEAR(mean, 1.0 / R, 0.02 / R);
    CHECK(worst < 0.10);
    free(mf);
    free(tri); free(mp); free(mn); free(vel); free(surf);
    hbk_fluid_destroy(h);
}

/* The mesh's uvw, and the unwrapped volumes, are unwrapped near the rest mapping: after a
 * uniform shift of less than half a tile they are the shifted rest mapping itself, whole tiles
 * and all, so a triangle (or a renderer's trilinear) never interpolates across a 1 -> 0
 * wrap. */
void test_fluid_mesh_uvw_unwrapped(void)
{
    hbk_fluid_params_t p = params(32, HBK_FLUID_VELOCITY_GRID);
    p.reset_period = 0.0f;
    p.uvw_tile = 0.25f;
    p.dt = 0.1f;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const size_t nvg = hbk_fluid_grid_vertices(h, NULL);
    float *vel = malloc(3 * nvg * sizeof *vel), *surf = malloc(nvg * sizeof *surf);
    const double shift = 3 * 0.5 / 32.0; /* 3 frames of half a voxel: 0.047 m < tile / 2 */
    sphere_field(surf, 32, 0.3);
    for (size_t i = 0; i < nvg; ++i) {
        vel[3 * i] = (float)(0.5 / 32.0 / 0.1);
        vel[3 * i + 1] = vel[3 * i + 2] = 0.0f;
    }
    CHECK_OK(hbk_fluid_set_velocity_grid(h, vel, surf));
    for (int f = 0; f < 3; ++f) CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK_OK(hbk_fluid_update_surface(h, NULL));
    int32_t nv = 0, nt = 0;
    CHECK_OK(hbk_fluid_mesh_counts(h, &nv, &nt));
    CHECK(nv > 1000);
    float *mp = malloc(3 * (size_t)nv * sizeof *mp), *mu = malloc(3 * (size_t)nv * sizeof *mu);
    CHECK_OK(hbk_fluid_get_mesh(h, mp, NULL, NULL, mu, NULL, NULL, NULL));
    double worst = 0.0, top = 0.0;
    for (int32_t v = 0; v < nv; ++v)
        for (int c = 0; c < 3; ++c) {
            const double want = (mp[3 * v + c] - (c == 0 ? shift : 0.0)) / 0.25;
            worst = fmax(worst, fabs(mu[3 * v + c] - want));
            top = fmax(top, mu[3 * v + c]);
        }
    fprintf(stderr, "mesh_uvw_unwrapped: worst %.2e tiles, largest uvw %.2f\n", worst, top);
    CHECK(worst < 1e-4);
    CHECK(top > 3.0); /* the sphere spans 0.2 .. 0.8 m: 0.8 .. 3.2 tiles, not wrapped */
    /* The unwrapped volumes (for renderers) likewise: the shifted rest mapping wherever no
     * inflow reached (x >= 3 voxels: the border value repeats, half a voxel a frame), each
     * value the wrapped one plus whole tiles; neighbours then differ by a voxel's worth, 1/8
     * of a tile, where the wrapped field jumps by almost a whole tile. */
    float *ua = volume(h, HBK_FLUID_VOL_UVW_A), *uu = volume(h, HBK_FLUID_VOL_UVW_A_UNWRAPPED);
    CHECK(hbk_fluid_volume_size(h, HBK_FLUID_VOL_UVW_B_UNWRAPPED) == 3 * nvg);
    double vworst = 0.0, frac_err = 0.0, jump_w = 0.0, jump_u = 0.0;
    for (int k = 0; k < 33; ++k)
        for (int j = 0; j < 33; ++j)
            for (int i = 3; i < 33; ++i) {
                const size_t v = 3 * ((size_t)i + 33 * ((size_t)j + 33 * (size_t)k));
                const double want[3] = {(i / 32.0 - shift) / 0.25, j / 32.0 / 0.25,
                                        k / 32.0 / 0.25};
                for (int c = 0; c < 3; ++c) {
                    vworst = fmax(vworst, fabs(uu[v + c] - want[c]));
                    const double d = uu[v + c] - ua[v + c];
                    frac_err = fmax(frac_err, fabs(d - floor(d + 0.5)));
                }
                if (i > 3) {
                    jump_w = fmax(jump_w, fabs(ua[v] - ua[v - 3]));
                    jump_u = fmax(jump_u, fabs(uu[v] - uu[v - 3]));
                }
            }
    fprintf(stderr, "mesh_uvw_unwrapped: volume worst %.2e tiles, neighbours differ by up to "
            "%.3f (wrapped %.3f)\n", vworst, jump_u, jump_w);
    CHECK(vworst < 1e-4 && frac_err < 1e-5);
    CHECK(jump_w > 0.8 && fabs(jump_u - 0.125) < 1e-4);
    free(ua); free(uu);
    free(mp); free(mu); free(vel); free(surf);
    hbk_fluid_destroy(h);
}

/* The two uvw fields' weights sum to one; each is invisible when reset; a reset restores the
 * rest mapping. */
void test_fluid_crossfade(void)
{
    hbk_fluid_params_t p = params(8, HBK_FLUID_VELOCITY_GRID);
    p.dt = 0.1f;
    p.reset_period = 0.8f; /* 8 frames */
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float vel[3] = {0.05f, 0.02f, 0.0f};
    uniform_grid(h, vel);
    float *rest = volume(h, HBK_FLUID_VOL_UVW_A);
    for (int f = 1; f <= 16; ++f) {
        CHECK_OK(hbk_fluid_step(h, NULL));
        const float wa = hbk_fluid_uvw_weight(h), wb = 1.0f - wa;
        CHECK(wa >= 0.0f && wa <= 1.0f);
        CHECK_NEAR(wa + wb, 1.0, 0.0);
        if (f % 8 == 0 || f % 8 == 4) {
            float *u = volume(h, f % 8 == 0 ? HBK_FLUID_VOL_UVW_A : HBK_FLUID_VOL_UVW_B);
            CHECK(!memcmp(u, rest, hbk_fluid_volume_size(h, HBK_FLUID_VOL_UVW_A) * sizeof(float)));
            CHECK(f % 8 == 0 ? wa == 0.0f : wa == 1.0f);
            free(u);
        } else {
            CHECK(wa > 0.0f && wa < 1.0f);
        }
    }
    free(rest);
    hbk_fluid_destroy(h);
}

/* A full scene: SPH with obstacles, paint, rules and the surface. */
static hbk_fluid_t *scene_r(int threads, float metaball_radius)
{
    hbk_fluid_params_t p = params(24, HBK_FLUID_SIMULATE);
    p.threads = threads;
    if (metaball_radius > 0.0f) p.metaball_radius = metaball_radius;
    p.max_particles = 4000;
    p.substeps = 10;
    p.seed = 1234;
    p.reset_period = 0.25f;
    hbk_fluid_t *h = fluid_make(&p);
    if (!h) return NULL;
    const float lo[3] = {0.0f, 0.0f, 0.0f}, hi[3] = {0.3f, 0.3f, 0.3f}, c[3] = {0.15f, 0.15f, 0.2f};
    if (hbk_fluid_fill_box(h, lo, hi, 0.2f) != HBK_OK) { hbk_fluid_destroy(h); return NULL; }
    const hbk_fluid_obstacle_t obs[2] = {{0, {0.5f, 0.5f, 0.1f}, {0.1f, 0, 0}},
                                         {1, {0.7f, 0.3f, 0.1f}, {0.1f, 0.05f, 0.1f}}};
    hbk_fluid_set_obstacles(h, obs, 2);
    hbk_fluid_paint_sphere(h, 1, c, 0.1f, 0.05f);
    const float rlo[HBK_FLUID_FEATURE_COUNT] = {-FLT_MAX, -FLT_MAX, 0.0f, 1.0f, -FLT_MAX, -FLT_MAX};
    const float rhi[HBK_FLUID_FEATURE_COUNT] = {FLT_MAX, FLT_MAX, 1.0f, FLT_MAX, FLT_MAX, FLT_MAX};
    hbk_fluid_set_feature_rule(h, 2, rlo, rhi);
    return h;
}

static hbk_fluid_t *scene(int threads) { return scene_r(threads, 0.0f); }

static unsigned char *snapshot(hbk_fluid_t *h, size_t *size)
{
    *size = hbk_fluid_state_size(h);
    unsigned char *b = malloc(*size);
    if (hbk_fluid_save_state(h, b, *size) != HBK_OK) { free(b); return NULL; }
    return b;
}

void test_fluid_threads_identical(void)
{
    hbk_fluid_t *a = scene(1), *b = scene(2);
    CHECK(a && b);
    for (int f = 0; f < 4; ++f) {
        CHECK_OK(hbk_fluid_step(a, NULL));
        CHECK_OK(hbk_fluid_step(b, NULL));
    }
    size_t sa, sb;
    unsigned char *xa = snapshot(a, &sa), *xb = snapshot(b, &sb);
    CHECK(sa == sb && !memcmp(xa, xb, sa));
    CHECK_OK(hbk_fluid_update_surface(a, NULL));
    CHECK_OK(hbk_fluid_update_surface(b, NULL));
    int32_t va, ta, vb, tb;
    hbk_fluid_mesh_counts(a, &va, &ta);
    hbk_fluid_mesh_counts(b, &vb, &tb);
    CHECK(va == vb && ta == tb && ta > 0);
    float *pa = malloc((size_t)va * 16 * sizeof(float)), *pb = malloc((size_t)va * 16 * sizeof(float));
    int32_t *ia = malloc((size_t)ta * 3 * sizeof(int32_t)), *ib = malloc((size_t)ta * 3 * sizeof(int32_t));
    CHECK_OK(hbk_fluid_get_mesh(a, pa, pa + 3 * va, ia, pa + 6 * va, pa + 9 * va, pa + 12 * va, NULL));
    CHECK_OK(hbk_fluid_get_mesh(b, pb, pb + 3 * va, ib, pb + 6 * va, pb + 9 * va, pb + 12 * va, NULL));
    CHECK(!memcmp(pa, pb, (size_t)va * 15 * sizeof(float)) && !memcmp(ia, ib, (size_t)ta * 3 * sizeof(int32_t)));
    CHECK(watertight(ia, ta, va));
    free(pa); free(pb); free(ia); free(ib); free(xa); free(xb);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
}

void test_fluid_state_roundtrip(void)
{
    hbk_fluid_t *a = scene(2), *b = scene(2);
    CHECK(a && b);
    for (int f = 0; f < 2; ++f) CHECK_OK(hbk_fluid_step(a, NULL));
    size_t s0;
    unsigned char *x0 = snapshot(a, &s0);
    for (int f = 0; f < 3; ++f) CHECK_OK(hbk_fluid_step(a, NULL));
    CHECK_OK(hbk_fluid_load_state(b, x0, s0));
    for (int f = 0; f < 3; ++f) CHECK_OK(hbk_fluid_step(b, NULL));
    size_t sa, sb;
    unsigned char *xa = snapshot(a, &sa), *xb = snapshot(b, &sb);
    CHECK(sa == sb && !memcmp(xa, xb, sa));
    /* Refusals leave the handle as it was. */
    x0[0] = 'X';
    CHECK(hbk_fluid_load_state(b, x0, s0) == HBK_ERR_FORMAT);
    x0[0] = 'H';
    CHECK(hbk_fluid_load_state(b, x0, s0 - 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(b), "size"));
    float nan = NAN, keep;
    memcpy(&keep, x0 + 64, 4);
    memcpy(x0 + 64, &nan, 4);
    CHECK(hbk_fluid_load_state(b, x0, s0) == HBK_ERR_FORMAT);
    memcpy(x0 + 64, &keep, 4);
    /* Finite but past what a run holds (a particle's speed past 1e6 m/s): refused by name,
     * with the bound; within it, taken. */
    int32_t count;
    memcpy(&count, x0 + 32, 4); /* the header's particle count */
    unsigned char *vel0 = x0 + 64 + 3 * (size_t)count * sizeof(float);
    const float fast = 2e6f, fine = 9e5f;
    memcpy(vel0, &fast, 4);
    CHECK(hbk_fluid_load_state(b, x0, s0) == HBK_ERR_FORMAT);
    CHECK(strstr(hbk_fluid_message(b), "state particles: not all valid numbers (finite, within "
                                       "+-1e+06)"));
    memcpy(vel0, &fine, 4);
    hbk_fluid_t *d = scene(2);
    CHECK(d && hbk_fluid_load_state(d, x0, s0) == HBK_OK);
    hbk_fluid_destroy(d);
    unsigned char *xc = snapshot(b, &sb);
    CHECK(!memcmp(xa, xc, sa));
    free(x0); free(xa); free(xb); free(xc);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
}

/* Still rows are not copied again where both buffers already hold them. A handle reloaded
 * from its own state every frame (which forgets that) must give the same bytes, through a flow
 * that stops, then uvw resets, a new feature rule and a paint stroke over the still rows. */
static void half_flow(hbk_fluid_t *h, float speed)
{
    int32_t n[3];
    const size_t nv = hbk_fluid_grid_vertices(h, n);
    float *v = calloc(3 * nv, sizeof *v);
    for (size_t i = 0; i < nv; ++i)
        if (i / ((size_t)n[0] * (size_t)n[1]) < (size_t)n[2] / 2) {
            v[3 * i] = speed;
            v[3 * i + 1] = 0.5f * speed;
        }
    hbk_fluid_set_velocity_grid(h, v, NULL);
    free(v);
}

/* a and b hold the same state, and b reloads its own (forgetting its row flags). */
static int same_then_reload(hbk_fluid_t *a, hbk_fluid_t *b)
{
    size_t sa, sb;
    unsigned char *xa = snapshot(a, &sa), *xb = snapshot(b, &sb);
    const int same = xa && xb && sa == sb && !memcmp(xa, xb, sa) &&
                     hbk_fluid_load_state(b, xb, sb) == HBK_OK;
    free(xa);
    free(xb);
    return same;
}

void test_fluid_reload_every_frame(void)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_VELOCITY_GRID);
    p.threads = 2;
    p.reset_period = 8.0f * p.dt; /* field B resets at frame 4, A at 8 */
    hbk_fluid_t *h[2] = {fluid_make(&p), fluid_make(&p)};
    CHECK(h[0] && h[1]);
    float lo[HBK_FLUID_FEATURE_COUNT], hi[HBK_FLUID_FEATURE_COUNT];
    for (int c = 0; c < HBK_FLUID_FEATURE_COUNT; ++c) lo[c] = -FLT_MAX, hi[c] = FLT_MAX;
    /* Where the flow stops (frame 3), the vertices stand still and their acceleration matches
     * this rule once: the rule, not the advection, changes their base then, and the frame
     * after must copy it though they stood still twice. */
    float alo[HBK_FLUID_FEATURE_COUNT];
    memcpy(alo, lo, sizeof alo);
    alo[HBK_FLUID_FEATURE_ACCELERATION] = 1.0f;
    const float c[3] = {0.5f, 0.5f, 0.5f};
    int same = 1;
    for (int f = 1; f <= 10; ++f) {
        for (int k = 0; k < 2; ++k) {
            if (f == 1 || f == 3) half_flow(h[k], f == 1 ? 0.3f : 0.0f);
            if (f == 2) CHECK_OK(hbk_fluid_set_feature_rule(h[k], 2, alo, hi));
            if (f == 6) CHECK_OK(hbk_fluid_paint_sphere(h[k], 1, c, 0.3f, 0.1f));
            if (f == 7) CHECK_OK(hbk_fluid_set_feature_rule(h[k], 2, lo, hi));
            CHECK_OK(hbk_fluid_step(h[k], NULL));
        }
        same &= same_then_reload(h[0], h[1]);
    }
    CHECK(same);
    hbk_fluid_destroy(h[0]);
    hbk_fluid_destroy(h[1]);
    /* The same for a simulation: the splat's rows, blank fields and quiet features are
     * skipped where the buffers hold them already. */
    hbk_fluid_t *a = scene(2), *b = scene(2);
    CHECK(a && b);
    same = 1;
    for (int f = 0; f < 6; ++f) {
        CHECK_OK(hbk_fluid_step(a, NULL));
        CHECK_OK(hbk_fluid_step(b, NULL));
        same &= same_then_reload(a, b);
    }
    CHECK(same);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
}

/* A 16^3 velocity grid of `textures` textures: fluid (a surface field of 1) in vertex rows
 * y >= fluid, rising at four cells a frame in rows y >= rise, still elsewhere. */
static hbk_fluid_t *rising(size_t fluid, size_t rise, int32_t textures)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_VELOCITY_GRID);
    p.textures = textures;
    p.max_flow = 8.0f;
    hbk_fluid_t *h = fluid_make(&p);
    if (!h) return NULL;
    const size_t nv = hbk_fluid_grid_vertices(h, NULL);
    float *v = calloc(3 * nv, sizeof *v), *surf = calloc(nv, sizeof *surf);
    for (size_t i = 0; i < nv; ++i) {
        const size_t y = i / 17 % 17;
        if (y >= rise) v[3 * i + 1] = 4.0f / 16.0f * 24.0f;
        if (y >= fluid) surf[i] = 1.0f;
    }
    const int ok = hbk_fluid_set_velocity_grid(h, v, surf) == HBK_OK;
    free(v);
    free(surf);
    if (!ok) hbk_fluid_destroy(h);
    return ok ? h : NULL;
}

/* Fluid rising above y = 1/2 (rows 8 up), still air below it: vertex (8, 10, 8) takes its
 * paint and life from rows 6 and 7 of the air, whatever path. */
static hbk_fluid_t *updraft(void) { return rising(8, 8, 2); }

/* Fluid from row 10 up, rising from row 12: rows 10 and 11 hold fluid that stands (no vertex
 * of theirs moves, though they are not empty), and vertex (4, 14, 8) rises from (4, 10, 8). */
static hbk_fluid_t *standing_rows(void) { return rising(10, 12, 2); }

/* The weight of texture 1 at vertex (i, j, 8). */
static float painted_at(hbk_fluid_t *h, int i, int j)
{
    float *b = volume(h, HBK_FLUID_VOL_BLEND);
    const float w = b ? b[2 * ((size_t)i + 17 * ((size_t)j + 17 * 8)) + 1] : 0.0f;
    free(b);
    return w;
}

static float painted(hbk_fluid_t *h) { return painted_at(h, 8, 10); }

/* Paint on still air flows into the fluid that leaves it, and painted fluid carried off
 * leaves none behind. The sixteen-lane advection writes +0 paint for sources in rows known to
 * hold none, and nothing where the row holds +0 already (advect_lanes.c): this fails if a
 * still row is taken as unpainted without a look, if a stroke or load_state leaves rows
 * marked so, if a row written two frames ago is taken as clean, or if a row is kept clean
 * whose still vertices copy paint. */
void test_fluid_paint_from_still_rows(void)
{
    static const char *const paths[2] = {"scalar", NULL};
    const float air[3] = {0.5f, 0.3f, 0.5f}, far[3] = {0.9f, 0.1f, 0.9f}; /* both still */
    for (int k = 0; k < 2; ++k) {
        if (paths[k]) setenv("HBK_PATHS", paths[k], 1);
        /* the air painted, then three frames */
        hbk_fluid_t *a = updraft();
        CHECK(a && hbk_fluid_paint_sphere(a, 1, air, 0.25f, 0.0f) == HBK_OK);
        size_t size = 0;
        unsigned char *saved = a ? snapshot(a, &size) : NULL;
        for (int f = 0; f < 3 && a; ++f) {
            CHECK_OK(hbk_fluid_step(a, NULL));
            CHECK(painted(a) > 0.5f);
        }
        /* two frames with paint far away, then the air painted: a stroke */
        hbk_fluid_t *b = updraft();
        CHECK(b && hbk_fluid_paint_sphere(b, 0, far, 0.05f, 0.0f) == HBK_OK);
        for (int f = 0; f < 2 && b; ++f) CHECK_OK(hbk_fluid_step(b, NULL));
        CHECK(b && painted(b) == 0.0f);
        CHECK(b && hbk_fluid_paint_sphere(b, 1, air, 0.25f, 0.0f) == HBK_OK);
        if (b) CHECK_OK(hbk_fluid_step(b, NULL));
        CHECK(b && painted(b) > 0.5f);
        /* the same two frames, then the painted state loaded */
        hbk_fluid_t *c = updraft();
        CHECK(c && hbk_fluid_paint_sphere(c, 0, far, 0.05f, 0.0f) == HBK_OK);
        for (int f = 0; f < 2 && c; ++f) CHECK_OK(hbk_fluid_step(c, NULL));
        CHECK(c && saved && hbk_fluid_load_state(c, saved, size) == HBK_OK);
        if (c) CHECK_OK(hbk_fluid_step(c, NULL));
        CHECK(c && painted(c) > 0.5f);
        /* the fluid painted and carried off: (8, 10, 8) now draws from clean air, and the
         * buffer it is written to held paint two frames ago */
        hbk_fluid_t *d = updraft();
        const float lifted[3] = {0.5f, 0.65f, 0.5f};
        CHECK(d && hbk_fluid_paint_sphere(d, 1, lifted, 0.1f, 0.0f) == HBK_OK);
        CHECK(d && painted(d) == 1.0f);
        for (int f = 0; f < 3 && d; ++f) {
            CHECK_OK(hbk_fluid_step(d, NULL));
            CHECK(painted(d) == 0.0f);
        }
        /* standing fluid painted after two frames that knew its rows clean: the copy of its
         * vertices makes the out rows painted */
        hbk_fluid_t *e = standing_rows();
        const float still[3] = {0.25f, 0.625f, 0.5f};
        CHECK(e && hbk_fluid_paint_sphere(e, 0, far, 0.05f, 0.0f) == HBK_OK);
        for (int f = 0; f < 2 && e; ++f) CHECK_OK(hbk_fluid_step(e, NULL));
        CHECK(e && hbk_fluid_paint_sphere(e, 1, still, 0.07f, 0.0f) == HBK_OK);
        for (int f = 0; f < 3 && e; ++f) {
            CHECK_OK(hbk_fluid_step(e, NULL));
            CHECK(painted_at(e, 4, 10) == 1.0f && painted_at(e, 4, 14) > 0.5f);
        }
        unsetenv("HBK_PATHS");
        free(saved);
        hbk_fluid_destroy(a);
        hbk_fluid_destroy(b);
        hbk_fluid_destroy(c);
        hbk_fluid_destroy(d);
        hbk_fluid_destroy(e);
    }
}

/* The +0 written for clean sources (advect_lanes.c's zero_records) at every texture count:
 * painted fluid carried off, with the plain path's bytes. */
void test_fluid_paint_cleared_any_textures(void)
{
    const float lifted[3] = {0.5f, 0.65f, 0.5f};
    for (int32_t K = 1; K <= HBK_FLUID_MAX_TEXTURES; ++K) {
        unsigned char *x[2] = {NULL, NULL};
        size_t n[2] = {0, 0};
        for (int w = 0; w < 2; ++w) {
            if (!w) setenv("HBK_PATHS", "scalar", 1);
            hbk_fluid_t *h = rising(8, 8, K);
            CHECK(h && hbk_fluid_paint_sphere(h, K - 1, lifted, 0.1f, 0.0f) == HBK_OK);
            for (int f = 0; f < 3 && h; ++f) CHECK_OK(hbk_fluid_step(h, NULL));
            if (h) x[w] = snapshot(h, &n[w]);
            unsetenv("HBK_PATHS");
            hbk_fluid_destroy(h);
        }
        CHECK(x[0] && x[1] && n[0] == n[1] && !memcmp(x[0], x[1], n[0]));
        free(x[0]);
        free(x[1]);
    }
}

/* With the paint cleared, the state holds no stale paint: a step undone by load_state leaves
 * the same bytes as no step, though it swapped the buffers. */
void test_fluid_state_no_stale_paint(void)
{
    hbk_fluid_t *a = scene(2), *b = scene(2);
    CHECK(a && b);
    for (int f = 0; f < 2; ++f) {
        CHECK_OK(hbk_fluid_step(a, NULL));
        CHECK_OK(hbk_fluid_step(b, NULL));
    }
    CHECK_OK(hbk_fluid_clear_paint(a));
    CHECK_OK(hbk_fluid_clear_paint(b));
    size_t s0, sa, sb;
    unsigned char *x0 = snapshot(b, &s0);
    CHECK_OK(hbk_fluid_step(b, NULL));
    CHECK_OK(hbk_fluid_load_state(b, x0, s0));
    for (int f = 0; f < 3; ++f) {
        CHECK_OK(hbk_fluid_step(a, NULL));
        CHECK_OK(hbk_fluid_step(b, NULL));
    }
    unsigned char *xa = snapshot(a, &sa), *xb = snapshot(b, &sb);
    CHECK(sa == sb && !memcmp(xa, xb, sa));
    free(x0); free(xa); free(xb);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
}

void test_fluid_cancel(void)
{
    hbk_fluid_t *h = scene(2);
    CHECK(h);
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK_OK(hbk_fluid_update_surface(h, NULL));
    int32_t v0, t0, v1, t1;
    hbk_fluid_mesh_counts(h, &v0, &t0);
    size_t s0, s1;
    unsigned char *x0 = snapshot(h, &s0);
    hbk_progress_t pr = {1, 0.0f};
    CHECK(hbk_fluid_step(h, &pr) == HBK_ERR_CANCELLED);
    CHECK(strstr(hbk_fluid_message(h), "cancel"));
    CHECK(hbk_fluid_update_surface(h, &pr) == HBK_ERR_CANCELLED);
    hbk_fluid_mesh_counts(h, &v1, &t1);
    CHECK(v0 == v1 && t0 == t1);
    unsigned char *x1 = snapshot(h, &s1);
    CHECK(s0 == s1 && !memcmp(x0, x1, s0));
    CHECK(hbk_fluid_frame(h) == 1);
    free(x0); free(x1);
    hbk_fluid_destroy(h);
}

/* The noise repeats with period 1 exactly, fills [0, 1], and depends only on the seed. */
void test_fluid_noise_tileable(void)
{
    const float pts[4][3] = {{0.1f, 0.2f, 0.3f}, {0.7f, 0.05f, 0.9f}, {0.5f, 0.5f, 0.5f}, {0.0f, 0.99f, 0.25f}};
    for (int i = 0; i < 4; ++i) {
        const float a = hbk_noise3d_sample(pts[i][0], pts[i][1], pts[i][2], 4, 3, 0.5f, 9);
        const float b = hbk_noise3d_sample(pts[i][0] + 1.0f, pts[i][1] - 2.0f, pts[i][2] + 3.0f, 4, 3, 0.5f, 9);
        CHECK_NEAR(a, b, 1e-6);
    }
    const int S = 16;
    float *t = malloc((size_t)S * S * S * sizeof *t), *u = malloc((size_t)S * S * S * sizeof *u);
    hbk_message_t m;
    CHECK_OK(hbk_noise3d_tileable(t, S, 4, 3, 0.5f, 9, &m));
    CHECK_OK(hbk_noise3d_tileable(u, S, 4, 3, 0.5f, 10, &m));
    double mean = 0.0, lo = 1.0, hi = 0.0, seam = 0.0, inner = 0.0;
    int differ = 0;
    for (int i = 0; i < S * S * S; ++i) {
        mean += t[i]; lo = fmin(lo, t[i]); hi = fmax(hi, t[i]);
        differ |= t[i] != u[i];
    }
    mean /= S * S * S;
    /* Across the tile border (x = S-1 -> 0) the noise changes no more than inside. */
    for (int k = 0; k < S; ++k)
        for (int j = 0; j < S; ++j) {
            seam += fabs(t[(j + S * k) * S] - t[(j + S * k) * S + S - 1]);
            inner += fabs(t[(j + S * k) * S + 8] - t[(j + S * k) * S + 7]);
        }
    CHECK(differ && lo >= 0.0 && hi <= 1.0 && hi - lo > 0.3 && fabs(mean - 0.5) < 0.1);
    CHECK(seam < 2.0 * inner);
    free(t);
    free(u);
}

/* Particles filling [0, top] of a box [0, hi] on a res^3 grid, spacing sp, h = metaball
 * radius = H, two threads. */
static hbk_fluid_t *box_scene(int32_t res, const float hi[3], const float top[3], float sp,
                              float H, int32_t max_particles)
{
    hbk_fluid_params_t p = params(res, HBK_FLUID_SIMULATE);
    const float lo[3] = {0.0f, 0.0f, 0.0f};
    memcpy(p.box_max, hi, 3 * sizeof *hi);
    p.particle_spacing = sp;
    p.smoothing_length = p.metaball_radius = H;
    p.max_particles = max_particles;
    p.threads = 2;
    hbk_fluid_t *h = fluid_make(&p);
    if (h && hbk_fluid_fill_box(h, lo, top, 0.2f) != HBK_OK) { hbk_fluid_destroy(h); return NULL; }
    return h;
}

/* A column in a box narrower than two smoothing lengths: particles see both walls of x and
 * of y, up to 17 mirror images besides themselves. */
static hbk_fluid_t *narrow_column(void)
{
    const float hi[3] = {0.05f, 0.05f, 0.4f}, top[3] = {0.05f, 0.05f, 0.25f};
    return box_scene(8, hi, top, 0.0125f, 0.03f, 1000);
}

/* Particles on a fine grid: a reach of about 10 vertices at res 48 (two eight-lane blocks a
 * row in the vector splat) and about 19 at res 96 (over sixteen: the plain splat takes it). */
static hbk_fluid_t *wide_reach(int32_t res)
{
    const float hi[3] = {0.2f, 0.2f, 0.2f}, top[3] = {0.2f, 0.1f, 0.1f};
    return box_scene(res, hi, top, 0.01f, 0.02f, 2000);
}

/* A flow that converges along x and shears along y (a velocity grid), with five textures and
 * paint: the sources of sixteen neighbouring vertices spread over more than twenty vertices
 * and over several rows, so the AVX-512 advection takes several passes a group and its plain
 * samplers where a window would be too wide (advect_lanes.c). */
static hbk_fluid_t *converging_grid(void)
{
    hbk_fluid_params_t p = params(64, HBK_FLUID_VELOCITY_GRID);
    p.resolution[1] = p.resolution[2] = 16; /* long rows of small cells along x */
    p.dt = 1.0f / 24.0f;
    p.max_flow = 40.0f;
    p.textures = 5;
    p.threads = 2;
    hbk_fluid_t *h = fluid_make(&p);
    if (!h) return NULL;
    int32_t n[3];
    const size_t nv = hbk_fluid_grid_vertices(h, n);
    float *v = calloc(3 * nv, sizeof *v), *surf = malloc(nv * sizeof *surf);
    for (size_t i = 0; i < nv; ++i) {
        const double x = (double)(i % (size_t)n[0]) / (n[0] - 1);
        v[3 * i] = (float)(-20.0 * (x - 0.5));
        v[3 * i + 1] = (float)(4.0 * (x - 0.5));
        surf[i] = 1.0f;
    }
    const float ctr[3] = {0.5f, 0.5f, 0.5f};
    const int ok = hbk_fluid_set_velocity_grid(h, v, surf) == HBK_OK &&
                   hbk_fluid_paint_sphere(h, 3, ctr, 0.3f, 0.05f) == HBK_OK;
    free(v);
    free(surf);
    if (!ok) {
        hbk_fluid_destroy(h);
        return NULL;
    }
    return h;
}

/* The SPH lanes, the vectorised splat and the vectorised advection (AVX2, and with AVX-512
 * the SPH's 16 lanes, the advection's 16 vertices and the flags' 16 voxels) give the bytes of
 * the plain code: HBK_PATHS switches them (see c_core/src/base/paths.c; "avx2" holds AVX-512
 * back). Walls, obstacles, paint and resets included; the metaball sum derived (radius =
 * smoothing length, the default) and splatted on its own; a box so narrow that a particle has
 * more mirror images than one vector holds; a converging flow whose sources are too spread
 * for the advection's windows; and particles whose reach spans two of the splat's eight-lane
 * blocks, or more than it takes. */
void test_fluid_paths_same_bytes(void)
{
    static const char *const paths[3] = {"scalar", "avx2", NULL}; /* NULL: the widest */
    for (int own = 0; own < 6; ++own) {
        unsigned char *x[3] = {NULL, NULL, NULL};
        size_t s[3] = {0, 0, 0};
        for (int k = 0; k < 3; ++k) {
            if (paths[k]) setenv("HBK_PATHS", paths[k], 1);
            hbk_fluid_t *h = own >= 4   ? wide_reach(own == 4 ? 48 : 96)
                             : own == 3 ? converging_grid()
                             : own == 2 ? narrow_column()
                                        : scene_r(2, own ? 0.05f : 0.0f);
            int ok = h != NULL;
            for (int f = 0; f < 4 && ok; ++f) ok = hbk_fluid_step(h, NULL) == HBK_OK;
            ok = ok && hbk_fluid_update_surface(h, NULL) == HBK_OK;
            unsetenv("HBK_PATHS");
            CHECK(ok);
            x[k] = snapshot(h, &s[k]);
            hbk_fluid_destroy(h);
        }
        for (int k = 1; k < 3; ++k) CHECK(s[0] == s[k] && !memcmp(x[0], x[k], s[0]));
        for (int k = 0; k < 3; ++k) free(x[k]);
    }
}

/* Shear flow vx = s (z - 1/2): field A (reset at frame 0, every 24 frames) and B (reset at
 * frame 12) stretch as M = I - s t e_x e_z^T, so stretch = (s t)^2 / 3 for a field of age t.
 * The adapted weight is w fA / (w fA + (1 - w) fB), f = exp(-stretch / stretch_fade); 0 and 1
 * at the resets; the schedule's w without stretch_fade or under a rigid (uniform) flow. */
static void shear_grid(hbk_fluid_t *h, float s)
{
    int32_t n[3];
    const size_t nv = hbk_fluid_grid_vertices(h, n);
    float *v = calloc(3 * nv, sizeof *v), *surf = malloc(nv * sizeof *surf);
    for (size_t i = 0; i < nv; ++i) {
        const double z = (double)(i / ((size_t)n[0] * (size_t)n[1])) / (n[2] - 1);
        v[3 * i] = (float)(s * (z - 0.5));
        surf[i] = 1.0f; /* fluid everywhere */
    }
    hbk_fluid_set_velocity_grid(h, v, surf);
    free(v);
    free(surf);
}

void test_fluid_stretch_fade(void)
{
    const int32_t R = 32;
    const float s = 2.0f, fade = 0.5f;
    for (int mode = 0; mode < 3; ++mode) { /* shear adapted, shear plain, uniform adapted */
        hbk_fluid_params_t p = params(R, HBK_FLUID_VELOCITY_GRID);
        p.dt = 1.0f / 24.0f;
        p.reset_period = 1.0f; /* 24 frames: A at 0, 24; B at 12 */
        p.max_flow = 8.0f;
        p.stretch_fade = mode == 1 ? 0.0f : fade;
        hbk_fluid_t *h = fluid_make(&p);
        CHECK(h);
        if (mode == 2) {
            const float u[3] = {0.4f, 0.2f, 0.0f};
            uniform_grid(h, u);
        } else {
            shear_grid(h, s);
        }
        const size_t nv = hbk_fluid_grid_vertices(h, NULL);
        float *w = malloc(nv * sizeof *w);
        for (int f = 1; f <= 24; ++f) {
            CHECK_OK(hbk_fluid_step(h, NULL));
            CHECK_OK(hbk_fluid_get_volume(h, HBK_FLUID_VOL_UVW_WEIGHT, w, nv));
            const float wg = hbk_fluid_uvw_weight(h);
            double worst = 0.0, mean = 0.0;
            int n = 0;
            /* Where the flow came from inside the box (the box repeats its border values into
             * inflow): |z - 1/2| <= 0.16 moves at most 0.24 m in 0.75 s. */
            for (int32_t k = 11; k <= 21; ++k)
                for (int32_t j = 2; j < R - 1; ++j)
                    for (int32_t i = 10; i <= 22; ++i) {
                        const float x = w[(size_t)i + (R + 1) * ((size_t)j + (R + 1) * (size_t)k)];
                        CHECK(x >= 0.0f && x <= 1.0f);
                        mean += x;
                        ++n;
                        if (mode != 0) worst = fmax(worst, fabs(x - wg));
                    }
            mean /= n;
            if (f == 12 || f == 24) { /* a reset: the reset field is never seen */
                for (size_t v = 0; v < nv; ++v) CHECK(w[v] == (f == 12 ? 1.0f : 0.0f));
                continue;
            }
            if (mode == 1) CHECK(worst == 0.0); /* off: the schedule alone */
            if (mode == 2) CHECK(worst < 1e-4); /* rigid motion: nothing stretched */
            if (mode == 0) {
                const double ta = f / 24.0, tb = f < 12 ? ta : (f - 12) / 24.0;
                const double fa = exp(-(s * ta) * (s * ta) / 3.0 / fade);
                const double fb = exp(-(s * tb) * (s * tb) / 3.0 / fade);
                const double want = wg * fa / (wg * fa + (1.0 - wg) * fb);
                CHECK_NEAR(mean, want, 5e-3); /* uvw are floats */
                if (f == 18) CHECK(mean < 0.5 * wg); /* A, older, fades out early */
            }
        }
        /* At a surface (a ball of fluid now): the weights sampled at its vertices. */
        float *vel = calloc(3 * nv, sizeof *vel), *ball = malloc(nv * sizeof *ball);
        for (size_t v = 0; v < nv; ++v) {
            const double x = (double)(v % (R + 1)) / R - 0.5,
                         y = (double)(v / (R + 1) % (R + 1)) / R - 0.5,
                         z = (double)(v / ((R + 1) * (R + 1))) / R - 0.5;
            ball[v] = x * x + y * y + z * z < 0.09 ? 1.0f : 0.0f;
        }
        hbk_fluid_set_velocity_grid(h, vel, ball);
        CHECK_OK(hbk_fluid_step(h, NULL)); /* frame 25 */
        CHECK_OK(hbk_fluid_update_surface(h, NULL));
        int32_t mv, mt;
        CHECK_OK(hbk_fluid_mesh_counts(h, &mv, &mt));
        CHECK(mv > 0);
        float *mw = malloc((size_t)mv * sizeof *mw);
        CHECK_OK(hbk_fluid_get_mesh_weight(h, mw));
        const float wg = hbk_fluid_uvw_weight(h);
        for (int32_t v = 0; v < mv; ++v) {
            CHECK(mw[v] >= 0.0f && mw[v] <= 1.0f);
            if (mode == 1) CHECK(mw[v] == wg); /* off: the schedule alone */
        }
        CHECK(hbk_fluid_get_mesh_weight(h, NULL) == HBK_ERR_INVALID_ARGUMENT);
        free(mw);
        free(vel);
        free(ball);
        free(w);
        hbk_fluid_destroy(h);
    }
}

/* The splat's four sum arrays start at different offsets into a 4 KB page, at least 64 bytes
 * apart (fluid.c, sums_alloc: where they all started alike, an Intel core held each row's
 * load of one sum behind the store to the one before), and do not overlap. This fails with
 * the arrays allocated apart again, or the stagger under a cache line. */
void test_fluid_sums_staggered(void)
{
    static const int32_t res[] = {8, 32, 128};
    for (size_t k = 0; k < sizeof res / sizeof res[0]; ++k) {
        hbk_fluid_params_t p = params(res[k], HBK_FLUID_PARTICLES);
        hbk_fluid_t *h = fluid_make(&p);
        CHECK(h != NULL);
        if (!h) continue;
        const float *s[4] = {h->g_wsum, h->g_mp[0], h->g_mp[1], h->g_mp[2]};
        for (int a = 0; a < 4; ++a)
            for (int b = a + 1; b < 4; ++b) {
                const uintptr_t d = ((uintptr_t)s[b] - (uintptr_t)s[a]) % 4096u;
                CHECK(d >= 64 && 4096 - d >= 64);
                CHECK(s[b] >= s[a] + h->n_vert); /* in order, apart */
            }
        hbk_fluid_destroy(h);
    }
}

/* Paint from points (a surface painted in Blender): one point is the sphere stroke, bit for
 * bit; overlapping points give the largest coverage whatever their order; nothing beyond the
 * ball changes; no coverage paints nothing; bad arguments are refused by name. */
void test_fluid_paint_points(void)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_SIMULATE);
    const float c[3] = {0.4f, 0.5f, 0.45f};
    hbk_fluid_t *h[4];
    for (int k = 0; k < 4; ++k) CHECK((h[k] = fluid_make(&p)) != NULL);
    float *before = volume(h[0], HBK_FLUID_VOL_BLEND);
    const size_t n = hbk_fluid_volume_size(h[0], HBK_FLUID_VOL_BLEND);
    const float none = 0.0f;
    CHECK_OK(hbk_fluid_paint_points(h[0], 1, 1, c, &none, 0.1f, 0.05f));
    CHECK_OK(hbk_fluid_paint_points(h[0], 1, 0, NULL, NULL, 0.1f, 0.05f));
    size_t s0, s1;
    unsigned char *a = snapshot(h[0], &s0), *b = snapshot(h[1], &s1);
    CHECK(a && b && s0 == s1 && !memcmp(a, b, s0)); /* untouched, paint still off */
    free(a);
    free(b);
    CHECK_OK(hbk_fluid_paint_sphere(h[0], 1, c, 0.1f, 0.05f));
    CHECK_OK(hbk_fluid_paint_points(h[1], 1, 1, c, NULL, 0.1f, 0.05f));
    const float two[6] = {c[0], c[1], c[2], c[0], c[1], c[2]};
    const float up[2] = {0.3f, 0.8f}, down[2] = {0.8f, 0.3f};
    CHECK_OK(hbk_fluid_paint_points(h[2], 2, 2, two, up, 0.1f, 0.05f));
    CHECK_OK(hbk_fluid_paint_points(h[3], 2, 2, two, down, 0.1f, 0.05f));
    float *v[4];
    for (int k = 0; k < 4; ++k) CHECK((v[k] = volume(h[k], HBK_FLUID_VOL_BLEND)) != NULL);
    CHECK(!memcmp(v[0], v[1], n * sizeof(float)));
    CHECK(!memcmp(v[2], v[3], n * sizeof(float)));
    const int K = p.textures, nx = p.resolution[0] + 1;
    int inside = 0, outside = 0;
    for (size_t i = 0; i < n / (size_t)K; ++i) {
        const float x[3] = {(float)(i % (size_t)nx) / 16.0f, (float)(i / (size_t)nx % (size_t)nx) / 16.0f,
                            (float)(i / ((size_t)nx * (size_t)nx)) / 16.0f};
        const float d = sqrtf((x[0] - c[0]) * (x[0] - c[0]) + (x[1] - c[1]) * (x[1] - c[1]) +
                              (x[2] - c[2]) * (x[2] - c[2]));
        if (d < 0.09f) { /* inside the radius: texture 2 at the larger coverage */
            CHECK_NEAR(v[2][K * i + 2], 0.8f + 0.2f * before[K * i + 2], 1e-6);
            ++inside;
        } else if (d > 0.16f) { /* beyond the ball: as before */
            CHECK(!memcmp(v[2] + K * i, before + K * i, (size_t)K * sizeof(float)));
            ++outside;
        }
    }
    CHECK(inside > 8 && outside > 1000);
    for (int k = 0; k < 4; ++k) free(v[k]);
    free(before);
    const float bad_cov[2] = {0.5f, 1.5f}, nan_pos[3] = {0.5f, 0.5f, NAN};
    CHECK(hbk_fluid_paint_points(h[0], 3, 1, c, NULL, 0.1f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h[0]), "texture = 3"));
    CHECK(hbk_fluid_paint_points(h[0], 1, -1, c, NULL, 0.1f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h[0]), "count = -1"));
    CHECK(hbk_fluid_paint_points(h[0], 1, 1, NULL, NULL, 0.1f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h[0]), "pos"));
    CHECK(hbk_fluid_paint_points(h[0], 1, 2, two, bad_cov, 0.1f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h[0]), "coverage[1] = 1.5"));
    CHECK(hbk_fluid_paint_points(h[0], 1, 1, nan_pos, NULL, 0.1f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h[0]), "pos[0][2]"));
    CHECK(hbk_fluid_paint_points(h[0], 1, 1, c, NULL, 1.01f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h[0]), "radius = 1.01: must be in [0, 1] m (16 cells)"));
    CHECK(hbk_fluid_paint_points(h[0], 1, 1, c, NULL, 0.5f, 0.6f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h[0]), "falloff = 0.6"));
    for (int k = 0; k < 4; ++k) hbk_fluid_destroy(h[k]);
}

/* ---- The papers' formulas, checked against their definitions (Harada et al. 2007 take
 * Mueller et al. 2003's kernels; the texturing paper's features, V_m clamp, advection and the
 * two-field cross-fade beyond it). ---- */

/* 4 pi int_0^H r^2 f(r) dr by Simpson's rule (f smooth on [0, H]: the kernels are
 * polynomials there, times r^2 also where f has a 1/r part). */
static double radial_integral(double (*f)(double r, double H), double H)
{
    enum { N = 4000 };
    const double dr = H / N;
    double s = 0.0;
    for (int i = 0; i <= N; ++i) {
        const double r = i * dr, w = i == 0 || i == N ? 1.0 : i % 2 ? 4.0 : 2.0;
        s += w * r * r * f(r, H);
    }
    return 4.0 * M_PI * s * dr / 3.0;
}

static double k_poly6(double r, double H) { return hbk_poly6(r * r, H); }
static double k_spiky(double r, double H) { return hbk_spiky(r * r, H); }
/* |grad W_spiky| as sph.c uses it: 45 / (pi H^6) (H - r)^2, times r (the first moment). */
static double k_spiky_grad(double r, double H)
{
    return r < H ? 45.0 / (M_PI * pow(H, 6)) * (H - r) * (H - r) : 0.0;
}
static double k_spiky_grad_r(double r, double H) { return r * k_spiky_grad(r, H); }
/* Mueller's viscosity kernel and the Laplacian sph.c uses, 45 / (pi H^6) (H - r). */
static double k_visc(double r, double H)
{
    if (r >= H) return 0.0;
    if (r <= 0.0) r = 1e-300;
    return 15.0 / (2.0 * M_PI * pow(H, 3)) *
           (-r * r * r / (2.0 * H * H * H) + r * r / (H * H) + H / (2.0 * r) - 1.0);
}
static double k_visc_lap(double r, double H) { return r < H ? 45.0 / (M_PI * pow(H, 6)) * (H - r) : 0.0; }
static double k_visc_lap_r2(double r, double H) { return r * r * k_visc_lap(r, H); }

/* The kernels integrate to one over their support and vanish at its edge; the spiky gradient
 * is the derivative of the spiky kernel, with first moment -int x (x) grad W = the identity
 * (int r |grad W| dV = 3), which makes the pressure term exact for a linear pressure field;
 * the viscosity Laplacian is the Laplacian of Mueller's viscosity kernel (itself normalised),
 * with second moment int r^2 lap W dV = 6, which makes the viscosity term exact (the
 * Laplacian of the velocity) for a quadratic velocity field. */
void test_fluid_kernels_normalised(void)
{
    const double Hs[3] = {0.04, 1.0, 2.5};
    for (int q = 0; q < 3; ++q) {
        const double H = Hs[q], H3 = H * H * H;
        CHECK_NEAR(radial_integral(k_poly6, H), 1.0, 1e-9);
        CHECK_NEAR(radial_integral(k_spiky, H), 1.0, 1e-9);
        CHECK_NEAR(radial_integral(k_spiky_grad_r, H), 3.0, 1e-9);
        /* W_visc has a 1/r part: r^2 W_visc is smooth (r = 0 gives 15 H / (4 pi H^3) r). */
        CHECK_NEAR(radial_integral(k_visc, H), 1.0, 1e-9);
        CHECK_NEAR(radial_integral(k_visc_lap_r2, H), 6.0, 1e-9);
        /* Vanish at (and beyond) H; positive within. */
        CHECK(hbk_poly6(H * H, H) == 0.0 && hbk_spiky(H * H, H) == 0.0);
        CHECK(hbk_poly6(1.0001 * H * H, H) == 0.0 && hbk_spiky(1.0001 * H * H, H) == 0.0);
        CHECK(k_spiky_grad(H, H) == 0.0 && k_visc_lap(H, H) == 0.0 && k_visc(H, H) == 0.0);
        CHECK(hbk_poly6(0.99 * H * H, H) > 0.0 && hbk_spiky(0.98 * H * H, H) > 0.0);
        /* The peaks: poly6 315 / (64 pi H^3), spiky 15 / (pi H^3). */
        CHECK_NEAR(hbk_poly6(0.0, H) * H3, 315.0 / (64.0 * M_PI), 1e-12);
        CHECK_NEAR(hbk_spiky(0.0, H) * H3, 15.0 / M_PI, 1e-12);
        for (int i = 1; i < 10; ++i) {
            const double r = H * i / 10.0, e = 1e-6 * H;
            /* -dW/dr of the spiky kernel, by central differences */
            const double dw = -(hbk_spiky((r + e) * (r + e), H) - hbk_spiky((r - e) * (r - e), H)) / (2 * e);
            CHECK_NEAR(dw / k_spiky_grad(r, H), 1.0, 1e-6);
            /* lap W_visc = (1/r^2) d/dr (r^2 dW/dr), by central differences */
            const double d1p = (k_visc(r + 2 * e, H) - k_visc(r, H)) / (2 * e);
            const double d1m = (k_visc(r, H) - k_visc(r - 2 * e, H)) / (2 * e);
            const double rp = r + e, rm = r - e;
            const double lap = (rp * rp * d1p - rm * rm * d1m) / (2 * e) / (r * r);
            CHECK_NEAR(lap / k_visc_lap(r, H), 1.0, 1e-3);
        }
    }
}

/* One SPH substep of a particle pair far from the walls against the formulas by hand: density
 * rho = m (W(0) + W(r)) (spiky), pressure p = k (rho - rho0), the symmetric pressure term
 * -m (p_i / rho_i^2 + p_j / rho_j^2) grad W with |grad W| = 45 / (pi H^6) (H - r)^2, viscosity
 * mu / rho_i m / rho_j (v_j - v_i) 45 / (pi H^6) (H - r), gravity; symplectic Euler. The pair
 * is along x, their velocities differ along y, gravity is along z: each axis checks one term.
 * With H one spacing the mass is rho0 / W(0) (the lattice's neighbours sit at r = H). The
 * pair's momentum changes by gravity alone: the forces are equal and opposite. */
void test_fluid_sph_pair_exact(void)
{
    hbk_fluid_params_t p = params(8, HBK_FLUID_SIMULATE);
    p.particle_spacing = p.smoothing_length = p.metaball_radius = 0.02f;
    p.viscosity = 10.0f;
    p.stiffness = 200.0f;
    p.substeps = 1;
    p.dt = 1e-4f;
    p.max_particles = 2;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const double H = p.smoothing_length, rho0 = 1000.0, k = 200.0, mu = 10.0, dt = (double)p.dt;
    const double W0 = 15.0 / (M_PI * pow(H, 3));
    CHECK_NEAR(h->sph_mass / (rho0 / W0), 1.0, 1e-12);
    const double m = h->sph_mass;
    const float pos[6] = {0.5f, 0.5f, 0.5f, 0.512f, 0.5f, 0.5f};
    const float vel[6] = {0.0f, 0.1f, 0.0f, 0.0f, -0.1f, 0.0f};
    CHECK_OK(hbk_fluid_set_particles(h, pos, vel, 2));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_substeps_taken(h) == 1);
    float v[6];
    CHECK_OK(hbk_fluid_get_particles(h, NULL, v, 2));
    const double r = (double)pos[3] - (double)pos[0], q = H - r;
    const double rho = m * (W0 + 15.0 / (M_PI * pow(H, 6)) * q * q * q);
    const double P = k * (rho - rho0);
    CHECK(P > 0.0);
    const double ax = m * 2.0 * (P / (rho * rho)) * 45.0 / (M_PI * pow(H, 6)) * q * q; /* apart */
    const double ay = mu / rho * m / rho * 45.0 / (M_PI * pow(H, 6)) * q * (-0.2); /* i: vj - vi */
    const double az = -9.81;
    /* particle 0 is pushed to -x, particle 1 to +x; viscosity pulls their y speeds together */
    CHECK_NEAR(v[0] / (-ax * dt), 1.0, 1e-4);
    CHECK_NEAR(v[3] / (ax * dt), 1.0, 1e-4);
    CHECK_NEAR((v[1] - 0.1) / (ay * dt), 1.0, 1e-3);
    CHECK_NEAR((v[4] + 0.1) / (-ay * dt), 1.0, 1e-3);
    CHECK_NEAR(v[2] / (az * dt), 1.0, 1e-5);
    CHECK_NEAR(v[5] / (az * dt), 1.0, 1e-5);
    /* equal and opposite: the momentum along x and y is unchanged */
    CHECK(fabs((double)v[0] + v[3]) <= 1e-6 * fabs(ax * dt));
    CHECK(fabs((double)v[1] + v[4]) <= 1e-6);
    /* symplectic Euler: the position moves by the new velocity */
    float x[6];
    CHECK_OK(hbk_fluid_get_particles(h, x, NULL, 2));
    for (int a = 0; a < 6; ++a) CHECK_NEAR(x[a], (double)pos[a] + (double)v[a] * dt, 1e-7);
    hbk_fluid_destroy(h);
}

/* Momentum: a random cluster of particles with random velocities, far from the walls and
 * without gravity, keeps its total momentum through a substep (pressure and viscosity are
 * pairwise equal and opposite), to the rounding of the per-particle sums. And a lone particle
 * (H two spacings: its own density is below rest, so no pressure) falls freely: v = g t. */
void test_fluid_sph_momentum(void)
{
    enum { N = 400 };
    hbk_fluid_params_t p = params(8, HBK_FLUID_SIMULATE);
    p.gravity[2] = 0.0f;
    p.viscosity = 2.0f;
    p.max_particles = N;
    p.dt = 2e-4f;
    p.substeps = 1;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    float pos[3 * N], vel[3 * N], u[6];
    for (int i = 0; i < N; ++i) {
        hbk_rng_fill_uniform(99, 7, (uint64_t)i * 2, u, 6);
        for (int a = 0; a < 3; ++a) {
            pos[3 * i + a] = 0.4f + 0.13f * u[a]; /* about 1.5 spacings apart: compressed */
            vel[3 * i + a] = u[3 + a] - 0.5f;
        }
    }
    CHECK_OK(hbk_fluid_set_particles(h, pos, vel, N));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK(hbk_fluid_substeps_taken(h) == 1);
    float v1[3 * N];
    CHECK_OK(hbk_fluid_get_particles(h, NULL, v1, N));
    for (int a = 0; a < 3; ++a) {
        double before = 0.0, after = 0.0, change = 0.0;
        for (int i = 0; i < N; ++i) {
            before += vel[3 * i + a];
            after += v1[3 * i + a];
            change += fabs((double)v1[3 * i + a] - vel[3 * i + a]);
        }
        CHECK(change > 1.0); /* the forces did act */
        if (fabs(after - before) > 1e-5 * change)
            fprintf(stderr, "axis %d: momentum %.9g -> %.9g (sum |dv| %.6g)\n", a, before, after, change);
        CHECK(fabs(after - before) <= 1e-5 * change);
    }
    hbk_fluid_destroy(h);

    p = params(8, HBK_FLUID_SIMULATE); /* H = 2 spacings, 1/24 s, gravity */
    p.max_particles = 1;
    CHECK(h = fluid_make(&p));
    const float one[3] = {0.5f, 0.5f, 0.8f};
    CHECK_OK(hbk_fluid_set_particles(h, one, NULL, 1));
    CHECK_OK(hbk_fluid_step(h, NULL));
    float vz[3];
    CHECK_OK(hbk_fluid_get_particles(h, NULL, vz, 1));
    CHECK_NEAR(vz[0], 0.0, 0.0);
    CHECK_NEAR(vz[1], 0.0, 0.0);
    CHECK_NEAR(vz[2], -9.81 * p.dt, 1e-5);
    hbk_fluid_destroy(h);
}

/* SPH density of a lattice at rest: particles at particle_spacing filling the box (first
 * layer half a spacing from the walls, as fill_box lays them) are at the rest density
 * everywhere, corners and edges included (the walls' mirror images continue the lattice),
 * for H of 1.5, 2 and 3 spacings; without gravity they stay at rest. */
void test_fluid_sph_lattice_rest_density(void)
{
    const float hs[3] = {1.5f, 2.0f, 3.0f};
    for (int c = 0; c < 3; ++c) {
        hbk_fluid_params_t p = params(8, HBK_FLUID_SIMULATE);
        for (int a = 0; a < 3; ++a) p.box_max[a] = 0.2f; /* 10 spacings */
        p.smoothing_length = hs[c] * p.particle_spacing;
        p.gravity[2] = 0.0f;
        p.max_particles = 1000;
        hbk_fluid_t *h = fluid_make(&p);
        CHECK(h);
        const float lo[3] = {0, 0, 0}, hi[3] = {0.2f, 0.2f, 0.2f};
        CHECK_OK(hbk_fluid_fill_box(h, lo, hi, 0.0f));
        CHECK(hbk_fluid_particle_count(h) == 1000);
        CHECK_OK(hbk_fluid_step(h, NULL));
        /* The last substep's densities, in cell order (sph.c: 8 floats a particle, [6]). */
        double worst = 0.0;
        for (int32_t i = 0; i < 1000; ++i) worst = fmax(worst, fabs(h->sorted[8 * (size_t)i + 6] - 1000.0));
        if (worst > 1e-2) fprintf(stderr, "H = %g spacings: density off rest by %g\n", hs[c], worst);
        CHECK(worst <= 1e-2); /* float sums of 30-250 terms: 1e-5 of rho0 */
        float vel[3000];
        CHECK(max_speed(h, vel, NULL) < 1e-4);
        hbk_fluid_destroy(h);
    }
}

/* The features (paper 3.2) on fields whose values are known, on a grid source whose surface
 * field s = 2 - 2 z is the density feature (outward normal +z): density; its rate
 * (s_now - s_before) / dt; the angle between V_m and the outward normal; the acceleration
 * |V_m now - V_m before| / dt; the divergence of a linear flow. V_m is the flow clamped to
 * max_flow voxels per frame, direction kept. On the surface (s = 0.5, the plane z = 0.75)
 * the flow angle uses the mesh normal, +z. */
void test_fluid_features_known_fields(void)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_VELOCITY_GRID);
    p.dt = 0.1f;
    p.max_flow = 8.0f; /* 8 voxels of 1/16 m per 0.1 s: 5 m/s */
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const int32_t n = 17;
    const size_t nv = hbk_fluid_grid_vertices(h, NULL), F = HBK_FLUID_FEATURE_COUNT;
    float *vel = malloc(3 * nv * sizeof *vel), *surf = malloc(nv * sizeof *surf), *feat = NULL,
          *mot = NULL;
    CHECK(vel && surf);
    const float v1[3] = {0.3f, 0.0f, 0.4f}, v2[3] = {0.0f, 1.0f, -1.0f};
    for (int frame = 1; frame <= 4; ++frame) {
        for (size_t i = 0; i < nv; ++i) {
            const double x = (double)(i % n) / 16, y = (double)(i / n % n) / 16,
                         z = (double)(i / (n * n)) / 16;
            surf[i] = (float)(2.0 - 2.0 * z + (frame >= 2 ? 0.05 : 0.0));
            const float lin[3] = {(float)(0.5 * x), (float)(-0.2 * y), (float)(0.3 * z + 0.1)};
            const float fast[3] = {6.0f, 8.0f, 0.0f}; /* 10 m/s: clamped to 5 */
            const float *w = frame == 1 ? v1 : frame == 2 ? v2 : frame == 3 ? lin : fast;
            memcpy(vel + 3 * i, w, 3 * sizeof(float));
        }
        CHECK_OK(hbk_fluid_set_velocity_grid(h, vel, surf));
        free(mot);
        mot = volume(h, HBK_FLUID_VOL_MOTION); /* last frame's V_m */
        CHECK_OK(hbk_fluid_step(h, NULL));
        free(feat);
        feat = volume(h, HBK_FLUID_VOL_FEATURES);
        float *mnow = volume(h, HBK_FLUID_VOL_MOTION);
        CHECK(feat && mnow);
        for (int32_t k = 1; k < n - 1; ++k)
            for (int32_t j = 1; j < n - 1; ++j)
                for (int32_t i = 1; i < n - 1; ++i) {
                    const size_t vi = (size_t)i + (size_t)n * ((size_t)j + (size_t)n * (size_t)k);
                    const float *o = feat + F * vi, *vm = mnow + 3 * vi, *vp = mot + 3 * vi;
                    CHECK_NEAR(o[HBK_FLUID_FEATURE_DENSITY], surf[vi], 0.0);
                    CHECK_NEAR(o[HBK_FLUID_FEATURE_DENSITY_RATE], frame == 2 ? 0.5 : 0.0, 2e-5);
                    const double sp = sqrt((double)vm[0] * vm[0] + (double)vm[1] * vm[1] + (double)vm[2] * vm[2]);
                    if (frame == 4) { /* clamped, direction kept */
                        CHECK_NEAR(vm[0], 3.0, 1e-5);
                        CHECK_NEAR(vm[1], 4.0, 1e-5);
                        CHECK_NEAR(vm[2], 0.0, 0.0);
                    } else {
                        for (int a = 0; a < 3; ++a) CHECK_NEAR(vm[a], vel[3 * vi + a], 0.0);
                    }
                    CHECK_NEAR(o[HBK_FLUID_FEATURE_FLOW_ANGLE], acos(vm[2] / sp), 1e-5);
                    double dv2 = 0.0;
                    for (int a = 0; a < 3; ++a) dv2 += ((double)vm[a] - vp[a]) * ((double)vm[a] - vp[a]);
                    CHECK_NEAR(o[HBK_FLUID_FEATURE_ACCELERATION], frame == 1 ? 0.0 : sqrt(dv2) / p.dt,
                               1e-5 * (1.0 + sqrt(dv2) / p.dt));
                    CHECK_NEAR(o[HBK_FLUID_FEATURE_DIVERGENCE], frame == 3 ? 0.6 : 0.0, 2e-5);
                    CHECK_NEAR(o[HBK_FLUID_FEATURE_CURVATURE], 0.0, 1e-4); /* planes */
                }
        free(mnow);
        if (frame == 2) { /* on the surface: angle between v2 and the mesh normal +z: 3 pi / 4 */
            CHECK_OK(hbk_fluid_update_surface(h, NULL));
            int32_t mv, mt;
            CHECK_OK(hbk_fluid_mesh_counts(h, &mv, &mt));
            CHECK(mv > 100);
            float *mp = malloc((size_t)mv * 3 * sizeof *mp), *mn = malloc((size_t)mv * 3 * sizeof *mn),
                  *mf = malloc((size_t)mv * F * sizeof *mf);
            CHECK_OK(hbk_fluid_get_mesh(h, mp, mn, NULL, NULL, NULL, NULL, mf));
            int on_plane = 0;
            for (int32_t v = 0; v < mv; ++v) {
                const float *x = mp + 3 * v;
                if (fabsf(x[2] - 0.775f) > 1e-4f || x[0] < 0.1f || x[0] > 0.9f || x[1] < 0.1f ||
                    x[1] > 0.9f)
                    continue; /* s + 0.05 = 0.5 at z = 0.775; skip the caps at the walls */
                ++on_plane;
                CHECK_NEAR(mn[3 * v + 2], 1.0, 1e-5);
                CHECK_NEAR(mf[F * v + HBK_FLUID_FEATURE_FLOW_ANGLE], 0.75 * M_PI, 1e-5);
                CHECK_NEAR(mf[F * v + HBK_FLUID_FEATURE_DENSITY], 0.5, 1e-5);
                CHECK_NEAR(mf[F * v + HBK_FLUID_FEATURE_DENSITY_RATE], 0.5, 2e-5);
            }
            CHECK(on_plane > 50);
            free(mp); free(mn); free(mf);
        }
    }
    free(feat); free(mot); free(vel); free(surf);
    hbk_fluid_destroy(h);
}

/* The two-field cross-fade on its schedule: with period P frames, A's weight is the triangle
 * wave 1 - |1 - 2 (f mod P) / P| and B's is one minus it, at every vertex (the weight volume);
 * each field holds the rest mapping exactly on the frames its weight is 0 (its reset) and on
 * no other frame of a moving fluid. */
void test_fluid_crossfade_schedule(void)
{
    hbk_fluid_params_t p = params(8, HBK_FLUID_VELOCITY_GRID);
    p.dt = 0.05f;
    p.reset_period = 0.5f; /* 10 frames: A at 0, 10, 20; B at 5, 15, 25 */
    p.uvw_tile = 0.5f;     /* four cells a tile */
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const float vel[3] = {0.03f, -0.02f, 0.01f};
    uniform_grid(h, vel);
    float *rest = volume(h, HBK_FLUID_VOL_UVW_A);
    const size_t nv = hbk_fluid_grid_vertices(h, NULL), n3 = 3 * nv;
    float *w = malloc(nv * sizeof *w);
    CHECK(hbk_fluid_uvw_weight(h) == 0.0f); /* frame 0: A was just set up, as at a reset */
    for (int f = 1; f <= 30; ++f) {
        CHECK_OK(hbk_fluid_step(h, NULL));
        const double want = 1.0 - fabs(1.0 - 2.0 * (f % 10) / 10.0);
        const float wa = hbk_fluid_uvw_weight(h);
        CHECK_NEAR(wa, want, 1e-7);
        CHECK_OK(hbk_fluid_get_volume(h, HBK_FLUID_VOL_UVW_WEIGHT, w, nv));
        for (size_t v = 0; v < nv; ++v) CHECK(w[v] == wa);
        float *a = volume(h, HBK_FLUID_VOL_UVW_A), *b = volume(h, HBK_FLUID_VOL_UVW_B);
        const int a_rest = !memcmp(a, rest, n3 * sizeof(float)),
                  b_rest = !memcmp(b, rest, n3 * sizeof(float));
        CHECK(a_rest == (wa == 0.0f));
        CHECK(b_rest == (1.0f - wa == 0.0f));
        free(a);
        free(b);
    }
    free(w);
    free(rest);
    hbk_fluid_destroy(h);
}

/* V_b flows with V_m as V_c does (paper: offset V_c, V_b and V_r by V_m): in a uniform flow
 * of exactly one voxel per frame along +x, the base blend moves one vertex downstream per
 * frame (the inflow column repeats its border value), and stays normalised. */
void test_fluid_blend_advect_shift(void)
{
    hbk_fluid_params_t p = params(16, HBK_FLUID_VELOCITY_GRID);
    p.dt = 0.125f;
    p.textures = 3;
    p.reset_period = 0.0f;
    hbk_fluid_t *h = fluid_make(&p);
    CHECK(h);
    const int32_t n = 17;
    const size_t nv = hbk_fluid_grid_vertices(h, NULL);
    /* a pattern along x: a ramp between textures 0 and 1, texture 2 in a band */
    for (size_t v = 0; v < nv; ++v) {
        const int32_t i = (int32_t)(v % n);
        float *b = h->v.base + 3 * v;
        b[2] = i >= 4 && i < 7 ? 1.0f : 0.0f;
        b[1] = b[2] ? 0.0f : (float)i / 16.0f;
        b[0] = 1.0f - b[1] - b[2];
    }
    hbk_fluid_vols_differ(h);
    const float vel[3] = {0.5f, 0.0f, 0.0f}; /* 0.5 m/s * 0.125 s = 1/16 m: one voxel */
    uniform_grid(h, vel);
    float *b0 = volume(h, HBK_FLUID_VOL_BLEND);
    for (int f = 1; f <= 3; ++f) {
        CHECK_OK(hbk_fluid_step(h, NULL));
        float *b = volume(h, HBK_FLUID_VOL_BLEND);
        for (size_t v = 0; v < nv; ++v) {
            const int32_t i = (int32_t)(v % n), src = i - f < 0 ? 0 : i - f;
            const size_t sv = v - (size_t)i + (size_t)src;
            for (int t = 0; t < 3; ++t) CHECK_NEAR(b[3 * v + t], b0[3 * sv + t], 1e-5);
        }
        free(b);
    }
    free(b0);
    hbk_fluid_destroy(h);
}
