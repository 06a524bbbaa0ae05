/* hbk_uv_overlap: layouts whose overlap is known exactly. */
#include "test.h"
#include <math.h>
#include <stdlib.h>

/* Quad [u0, u1] x [v0, v1] as two triangles along its diagonal (counter-clockwise, or
 * mirrored). */
static void quad(float *t, float u0, float v0, float u1, float v1, int mirrored)
{
    const float a[6] = {u0, v0, u1, v0, u1, v1}, b[6] = {u0, v0, u1, v1, u0, v1};
    for (int k = 0; k < 6; ++k) t[k] = a[k], t[6 + k] = b[k];
    if (mirrored)
        for (int k = 0; k < 12; k += 2) t[k] = u0 + u1 - t[k];
}

/* The overlap, or -1 (which every check below fails on) when the call fails. */
static float overlap_of(const float *uvs, int32_t n, int32_t res)
{
    float o = -1.0f;
    hbk_message_t m;
    if (hbk_uv_overlap(uvs, n, res, &o, &m) != HBK_OK) {
        fprintf(stderr, "hbk_uv_overlap: %s\n", m.text);
        return -1.0f;
    }
    return o;
}

void test_image_uv_overlap_known_layouts(void)
{
    float t[4 * 6];
    /* The unit square: its diagonal passes through texel centres, counted once. */
    quad(t, 0, 0, 1, 1, 0);
    for (int32_t res = 1; res <= 300; res += 37) CHECK(overlap_of(t, 2, res) == 0.0f);
    /* The same square twice (a mirrored copy, as a mirror modifier's UVs are): all of it. */
    quad(t + 12, 0, 0, 1, 1, 1);
    CHECK(overlap_of(t, 4, 64) == 1.0f);
    /* Columns [0, 0.5) and [0.25, 0.75): a third of what is covered is covered twice. */
    quad(t, 0, 0, 0.5f, 1, 0);
    quad(t + 12, 0.25f, 0, 0.75f, 1, 1);
    CHECK_NEAR(overlap_of(t, 4, 64), 1.0 / 3.0, 1e-7);
    /* Side by side, touching: none. */
    quad(t + 12, 0.5f, 0, 1, 1, 0);
    CHECK(overlap_of(t, 4, 64) == 0.0f);
    /* Nothing covered, or only outside 0..1, or degenerate: 0. */
    CHECK(overlap_of(t, 0, 64) == 0.0f);
    quad(t, 1.5f, 1.5f, 2.0f, 2.0f, 0);
    CHECK(overlap_of(t, 2, 64) == 0.0f);
    const float line[6] = {0.1f, 0.1f, 0.5f, 0.5f, 0.9f, 0.9f};
    CHECK(overlap_of(line, 1, 64) == 0.0f);
}

void test_image_uv_overlap_fan_shares_edges_once(void)
{
    /* Triangles around a centre at many slopes, in both windings, their corners on texel
     * centres of a 64-texel map (odd multiples of 1/128), so that at 64 texels and finer the
     * edges run through texel centres: every shared edge, and the centre all of them share, is
     * counted by exactly one triangle (top-left rule on exact integers). */
    enum { N = 23 };
    float t[N * 6], ring[N][2];
    const float cu = 31.0f / 64 + 1.0f / 128, cv = 33.0f / 64 + 1.0f / 128;
    for (int k = 0; k < N; ++k) {
        const double a = 2 * M_PI * k / N + 0.1;
        for (int c = 0; c < 2; ++c) {
            const double x = (c ? cv : cu) + 0.45 * (c ? sin(a) : cos(a));
            ring[k][c] = (float)((2 * floor(x * 64) + 1) / 128); /* a texel centre */
        }
    }
    for (int k = 0; k < N; ++k) {
        const float *a = ring[k], *b = ring[(k + 1) % N];
        if (k % 2) { /* clockwise */
            const float *s = a;
            a = b, b = s;
        }
        const float tri[6] = {cu, cv, a[0], a[1], b[0], b[1]};
        memcpy(t + 6 * k, tri, sizeof tri);
    }
    for (int32_t res = 64; res <= 1024; res *= 2) CHECK(overlap_of(t, N, res) == 0.0f);
    /* Twice the fan: everything twice. */
    float twice[2 * N * 6];
    memcpy(twice, t, sizeof t);
    memcpy(twice + N * 6, t, sizeof t);
    CHECK(overlap_of(twice, 2 * N, 128) == 1.0f);
}

void test_image_uv_overlap_rejects(void)
{
    float t[6] = {0, 0, 1, 0, 0, 1}, o = 0;
    hbk_message_t m;
    CHECK(hbk_uv_overlap(t, -1, 64, &o, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(m.text, "triangles = -1: must be >= 0"));
    CHECK(hbk_uv_overlap(t, 1, 0, &o, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(m.text, "resolution = 0: must be in [1, 4096]"));
    CHECK(hbk_uv_overlap(t, 1, 4097, &o, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(hbk_uv_overlap(NULL, 1, 64, &o, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(m.text, "uvs: must not be NULL"));
    CHECK(hbk_uv_overlap(t, 1, 64, NULL, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(m.text, "overlap: must not be NULL"));
    /* Not finite or far outside: no crash, a number. */
    float wild[6] = {NAN, 0, INFINITY, 1e30f, -1e30f, 0.5f};
    CHECK_OK(hbk_uv_overlap(wild, 1, 64, &o, &m));
    CHECK(o >= 0.0f && o <= 1.0f);
}
