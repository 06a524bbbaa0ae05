#include "test.h"
#include <stdlib.h>

void test_image_sample_edges(void)
{
    float d[4 * 2] = {0, 1, 2, 3, 10, 11, 12, 13};
    hbk_image_t img = {d, 4, 2, 1, 4};
    CHECK(hbk_image_check(&img, "img", NULL) == HBK_OK);
    CHECK_NEAR(hbk_image_sample(&img, 1.5f, 0.0f, 0, HBK_EDGE_CLAMP), 1.5, 1e-6);
    CHECK_NEAR(hbk_image_sample(&img, 1.0f, 0.5f, 0, HBK_EDGE_CLAMP), 6.0, 1e-6);
    CHECK_NEAR(hbk_image_sample(&img, -1.0f, 0.0f, 0, HBK_EDGE_CLAMP), 0.0, 1e-6);
    CHECK_NEAR(hbk_image_sample(&img, -1.0f, 0.0f, 0, HBK_EDGE_WRAP), 3.0, 1e-6);
    CHECK_NEAR(hbk_image_sample(&img, 4.0f, 0.0f, 0, HBK_EDGE_WRAP), 0.0, 1e-6);
    CHECK_NEAR(hbk_image_sample(&img, 3.5f, 0.0f, 0, HBK_EDGE_WRAP), 1.5, 1e-6);
    CHECK_NEAR(hbk_image_sample(&img, -1.0f, 0.0f, 0, HBK_EDGE_MIRROR), 0.0, 1e-6);
    CHECK_NEAR(hbk_image_sample(&img, -2.0f, 0.0f, 0, HBK_EDGE_MIRROR), 1.0, 1e-6);
    CHECK_NEAR(hbk_image_sample(&img, 5.0f, 0.0f, 0, HBK_EDGE_MIRROR), 2.0, 1e-6);
    hbk_message_t m;
    hbk_image_t bad = {d, 4, 2, 1, 3};
    CHECK(hbk_image_check(&bad, "height", &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(m.text, "height.row_stride = 3: must be >= width * channels = 4"));
}

void test_image_normal_map_plane(void)
{
    /* A plane z = a x + b y has the normal (-a, -b, 1)/|.| everywhere (wrap off: clamp edges
     * halve the slope at the border, so check the interior). */
    enum { W = 16, H = 12 };
    float hgt[W * H], out[W * H * 4];
    const float a = 0.25f, b = -0.5f, tx = 0.1f, ty = 0.2f;
    for (int y = 0; y < H; ++y)
        for (int x = 0; x < W; ++x) hgt[y * W + x] = a * x * tx + b * y * ty;
    hbk_image_t hi = {hgt, W, H, 1, W}, oi = {out, W, H, 4, W * 4};
    CHECK_OK(hbk_normal_map(&hi, tx, ty, 1.0f, HBK_EDGE_CLAMP, 0, &oi, NULL));
    const double len = sqrt(a * a + b * b + 1.0);
    for (int y = 1; y < H - 1; ++y)
        for (int x = 1; x < W - 1; ++x) {
            const float *p = out + (y * W + x) * 4;
            CHECK_NEAR(p[0], -a / len, 1e-5);
            CHECK_NEAR(p[1], -b / len, 1e-5);
            CHECK_NEAR(p[2], 1.0 / len, 1e-5);
            CHECK(p[3] == 1.0f);
        }
    /* Encoded: n * 0.5 + 0.5; a flat field encodes to (0.5, 0.5, 1). */
    for (int i = 0; i < W * H; ++i) hgt[i] = 3.0f;
    CHECK_OK(hbk_normal_map(&hi, tx, ty, 1.0f, HBK_EDGE_WRAP, 1, &oi, NULL));
    for (int i = 0; i < W * H; ++i) {
        CHECK(out[i * 4 + 0] == 0.5f && out[i * 4 + 1] == 0.5f && out[i * 4 + 2] == 1.0f);
    }
}

void test_image_normal_map_sphere(void)
{
    /* A spherical cap of radius R: the normal at (x, y) is (x, y, z) / R. Central differences
     * are second-order accurate, so error shrinks with the texel size. */
    enum { N = 129 };
    static float hgt[N * N], out[N * N * 3];
    const float R = 1.0f, t = 1.0f / 128.0f;
    for (int y = 0; y < N; ++y)
        for (int x = 0; x < N; ++x) {
            float X = (x - 64) * t, Y = (y - 64) * t;
            hgt[y * N + x] = sqrtf(R * R - X * X - Y * Y);
        }
    hbk_image_t hi = {hgt, N, N, 1, N}, oi = {out, N, N, 3, N * 3};
    CHECK_OK(hbk_normal_map(&hi, t, t, 1.0f, HBK_EDGE_CLAMP, 0, &oi, NULL));
    double worst = 0;
    for (int y = 8; y < N - 8; ++y)
        for (int x = 8; x < N - 8; ++x) {
            float X = (x - 64) * t, Y = (y - 64) * t, Z = sqrtf(R * R - X * X - Y * Y);
            const float *p = out + (y * N + x) * 3;
            double e = fabs(p[0] - X / R) + fabs(p[1] - Y / R) + fabs(p[2] - Z / R);
            if (e > worst) worst = e;
        }
    CHECK(worst < 2e-4);
}

void test_image_normal_map_tiny_texel(void)
{
    /* A texel so small that strength / (2 texel_size) overflows made every normal of a flat
     * field 0 * inf = NaN: refused by name. */
    float h[16] = {0}, o[48];
    hbk_image_t hi = {h, 4, 4, 1, 4}, oi = {o, 4, 4, 3, 12};
    hbk_message_t m;
    CHECK(hbk_normal_map(&hi, 1e-38f, 1.0f, 1000.0f, 0, 0, &oi, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "texel_size = (1e-38, 1): too small for strength = 1000", 54));
    CHECK_OK(hbk_normal_map(&hi, 1e-30f, 1.0f, 1000.0f, 0, 0, &oi, &m));
    for (int i = 0; i < 48; ++i) CHECK(isfinite(o[i]));
}

void test_image_normal_map_non_finite_height(void)
{
    /* An infinite height gave NaN normals around it: refused, naming the pixel. */
    float h[16] = {0}, o[48];
    hbk_image_t hi = {h, 4, 4, 1, 4}, oi = {o, 4, 4, 3, 12};
    hbk_message_t m;
    const float bad[] = {INFINITY, NAN, 2e6f};
    for (int k = 0; k < 3; ++k) {
        h[3 * 4 + 2] = bad[k];
        CHECK(hbk_normal_map(&hi, 1.0f, 1.0f, 1.0f, 0, 0, &oi, &m) == HBK_ERR_INVALID_ARGUMENT);
        CHECK(!strncmp(m.text, "height at pixel (2, 3) = ", 25));
        CHECK(strstr(m.text, "must be a finite number in [-1e+06, 1e+06]"));
    }
    h[3 * 4 + 2] = 1e6f;
    CHECK_OK(hbk_normal_map(&hi, 1.0f, 1.0f, 1.0f, 0, 0, &oi, &m));
    for (int i = 0; i < 48; ++i) CHECK(isfinite(o[i]));
}

void test_image_normal_map_rejects(void)
{
    float h[4] = {0}, o[12];
    hbk_image_t hi = {h, 2, 2, 1, 2}, oi = {o, 2, 2, 3, 6};
    hbk_message_t m;
    CHECK(hbk_normal_map(&hi, 0.0f, 1.0f, 1.0f, 0, 0, &oi, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "texel_size") != NULL);
    CHECK(hbk_normal_map(&hi, 1.0f, 1.0f, -1.0f, 0, 0, &oi, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "strength = -1") != NULL);
    CHECK(hbk_normal_map(&hi, 1.0f, 1.0f, 1.0f, 7, 0, &oi, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "edge = 7") != NULL);
    hbk_image_t small = {o, 1, 2, 3, 6};
    CHECK(hbk_normal_map(&hi, 1.0f, 1.0f, 1.0f, 0, 0, &small, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "out size") != NULL);
    hbk_image_t nodata = {NULL, 2, 2, 1, 2};
    CHECK(hbk_normal_map(&nodata, 1.0f, 1.0f, 1.0f, 0, 0, &oi, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(m.text, "height.data: must not be NULL"));
}
