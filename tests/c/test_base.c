#include "test.h"
#include "base/internal_base.h"
#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>

void test_base_result_strings(void)
{
    CHECK(!strcmp(hbk_result_string(HBK_OK), "success"));
    for (int i = 0; i < HBK_RESULT_COUNT; ++i) CHECK(strlen(hbk_result_string(i)) > 0);
    CHECK(!strcmp(hbk_result_string(-1), "unknown result code"));
    CHECK(!strcmp(hbk_result_string(HBK_RESULT_COUNT), "unknown result code"));
    CHECK(!strcmp(hbk_version_string(), "0.1.0"));
}

typedef struct {
    uint32_t size;
    float speed;
    int32_t count;
    float dir[3];
    uint64_t seed;
    int32_t mode;
} demo_params_t;

static const hbk_param_info_t k_demo[] = {
    {"speed", HBK_PARAM_F32, offsetof(demo_params_t, speed), 1, 0, 50, "m/s", NULL, "speed"},
    {"count", HBK_PARAM_I32, offsetof(demo_params_t, count), 1, 1, 100, "1", NULL, "count"},
    {"dir", HBK_PARAM_F32, offsetof(demo_params_t, dir), 3, -1, 1, "1", NULL, "direction"},
    {"seed", HBK_PARAM_U64, offsetof(demo_params_t, seed), 1, 0, 1.8e19, "1", NULL, "seed"},
    {"mode", HBK_PARAM_ENUM, offsetof(demo_params_t, mode), 1, 0, 2, "1", "A|B|C", "mode"},
};

void test_base_params_validate(void)
{
    demo_params_t p = {sizeof p, 3.0f, 10, {0, 0, 1}, 42, 1};
    hbk_message_t m;
    const size_t n = sizeof k_demo / sizeof k_demo[0];
    CHECK_OK(hbk_params_validate(&p, sizeof p, k_demo, n, &m));
    CHECK(m.text[0] == '\0');

    p.speed = -3.0f;
    CHECK(hbk_params_validate(&p, sizeof p, k_demo, n, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(m.text, "speed = -3: must be in [0, 50] m/s"));
    p.speed = NAN;
    CHECK(hbk_params_validate(&p, sizeof p, k_demo, n, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "speed = nan") && strstr(m.text, "finite"));
    p.speed = 50.0f; /* inclusive bound */
    CHECK_OK(hbk_params_validate(&p, sizeof p, k_demo, n, &m));

    p.dir[2] = 2.0f;
    CHECK(hbk_params_validate(&p, sizeof p, k_demo, n, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "dir[2] = 2:", 11));
    p.dir[2] = 1.0f;

    p.mode = 3;
    CHECK(hbk_params_validate(&p, sizeof p, k_demo, n, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "mode = 3:", 9));
    p.mode = 0;

    p.size = 8;
    CHECK(hbk_params_validate(&p, sizeof p, k_demo, n, &m) == HBK_ERR_VERSION);
    CHECK(strstr(m.text, "params.size = 8") != NULL);
    CHECK(hbk_params_validate(NULL, sizeof p, k_demo, n, NULL) == HBK_ERR_INVALID_ARGUMENT);
}

/* Bounds that are not floats: the float a caller stores for the bound (0.05f is just above
 * 0.05, 1e-4f just below 1e-4) is inside, the next float out is not. A bound past float's
 * range leaves every finite float inside. */
typedef struct {
    uint32_t size;
    float rate, big;
} fine_params_t;

static const hbk_param_info_t k_fine[] = {
    {"rate", HBK_PARAM_F32, offsetof(fine_params_t, rate), 1, 1e-4, 0.05, "m", NULL, "rate"},
    {"big", HBK_PARAM_F32, offsetof(fine_params_t, big), 1, -1e300, 1e300, "1", NULL, "big"},
};

void test_base_params_float_bounds(void)
{
    fine_params_t p = {sizeof p, 0.05f, FLT_MAX};
    hbk_message_t m;
    const size_t n = sizeof k_fine / sizeof k_fine[0];
    CHECK((double)p.rate > 0.05);
    CHECK_OK(hbk_params_validate(&p, sizeof p, k_fine, n, &m));
    p.rate = 1e-4f;
    CHECK((double)p.rate < 1e-4);
    p.big = -FLT_MAX;
    CHECK_OK(hbk_params_validate(&p, sizeof p, k_fine, n, &m));
    p.rate = nextafterf(0.05f, 1.0f);
    CHECK(hbk_params_validate(&p, sizeof p, k_fine, n, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strcmp(m.text, "rate = 0.05: must be in [0.0001, 0.05] m"));
    p.rate = nextafterf(1e-4f, 0.0f);
    CHECK(hbk_params_validate(&p, sizeof p, k_fine, n, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(!strncmp(m.text, "rate = 0.0001: must be in [0.0001, 0.05] m", 42));
    p.rate = 0.01f;
    p.big = INFINITY;
    CHECK(hbk_params_validate(&p, sizeof p, k_fine, n, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "big = inf") && strstr(m.text, "finite"));
}

void test_rng_philox_known_answer(void)
{
    /* Known-answer vectors of Random123's kat_vectors for philox4x32-10. */
    static const uint32_t ctr[3][4] = {{0, 0, 0, 0},
                                       {0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu},
                                       {0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u}};
    static const uint32_t key[3][2] = {{0, 0}, {0xffffffffu, 0xffffffffu},
                                       {0xa4093822u, 0x299f31d0u}};
    static const uint32_t want[3][4] = {{0x6627e8d5u, 0xe169c58du, 0xbc57ac4cu, 0x9b00dbd8u},
                                        {0x408f276du, 0x41c83b0eu, 0xa20bc7c6u, 0x6d5451fdu},
                                        {0xd16cfe09u, 0x94fdccebu, 0x5001e420u, 0x24126ea1u}};
    for (int i = 0; i < 3; ++i) {
        uint32_t out[4];
        hbk_philox4x32(ctr[i], key[i], out);
        for (int k = 0; k < 4; ++k) CHECK(out[k] == want[i][k]);
    }
    uint32_t a[4], b[4];
    hbk_rng_u32x4(0, 0, 0, a);
    hbk_philox4x32(ctr[0], key[0], b);
    CHECK(!memcmp(a, b, sizeof a));
}

void test_rng_uniform_statistics(void)
{
    enum { N = 1 << 20, BINS = 64 };
    static float v[N];
    hbk_rng_fill_uniform(1234, 7, 0, v, N);
    double sum = 0, sum2 = 0;
    int hist[BINS] = {0};
    for (int i = 0; i < N; ++i) {
        CHECK(v[i] >= 0.0f && v[i] < 1.0f);
        sum += v[i];
        sum2 += (double)v[i] * v[i];
        hist[(int)(v[i] * BINS)]++;
    }
    double mean = sum / N, var = sum2 / N - mean * mean;
    /* Standard error of the mean is sqrt(1/12/N) = 2.8e-4; 5 sigma. */
    CHECK_NEAR(mean, 0.5, 1.5e-3);
    CHECK_NEAR(var, 1.0 / 12.0, 1e-3);
    double chi2 = 0, e = (double)N / BINS;
    for (int b = 0; b < BINS; ++b) chi2 += (hist[b] - e) * (hist[b] - e) / e;
    /* 63 degrees of freedom: the 99.99th percentile is about 116. */
    CHECK(chi2 < 116.0);
}

void test_rng_counter_independence(void)
{
    /* A value depends only on (seed, stream, counter): filling from an offset agrees. */
    float all[64], tail[32];
    hbk_rng_fill_uniform(99, 3, 10, all, 64);
    hbk_rng_fill_uniform(99, 3, 18, tail, 32);
    CHECK(!memcmp(all + 32, tail, sizeof tail));
    CHECK(hbk_rng_uniform(99, 3, 10, 2) == all[2]);
    /* Streams and seeds differ. */
    CHECK(hbk_rng_uniform(99, 4, 10, 0) != all[0]);
    CHECK(hbk_rng_uniform(98, 3, 10, 0) != all[0]);
}

/* hbk_grid_to_xyz: every element lands at its transposed place, for sizes that are and are
 * not multiples of the tile, 1 and 3 components, 1 and 2 threads; bad arguments are named. */
void test_base_grid_to_xyz(void)
{
    const int32_t sizes[3][3] = {{1, 1, 1}, {16, 3, 32}, {37, 5, 19}};
    for (int s = 0; s < 3; ++s)
        for (int32_t comps = 1; comps <= 3; comps += 2)
            for (int32_t threads = 1; threads <= 2; ++threads) {
                const int32_t nx = sizes[s][0], ny = sizes[s][1], nz = sizes[s][2];
                const size_t n = (size_t)nx * (size_t)ny * (size_t)nz * (size_t)comps;
                float *src = malloc(n * sizeof *src), *dst = malloc(n * sizeof *dst);
                for (size_t i = 0; i < n; ++i) src[i] = (float)i;
                hbk_message_t m;
                CHECK_OK(hbk_grid_to_xyz(src, dst, nx, ny, nz, comps, threads, &m));
                int bad = 0;
                for (int32_t z = 0; z < nz; ++z)
                    for (int32_t y = 0; y < ny; ++y)
                        for (int32_t x = 0; x < nx; ++x)
                            for (int32_t c = 0; c < comps; ++c) {
                                const size_t from = (((size_t)z * ny + y) * nx + x) * comps + c;
                                const size_t to = (((size_t)x * ny + y) * nz + z) * comps + c;
                                bad += dst[to] != src[from];
                            }
                CHECK(bad == 0);
                free(src);
                free(dst);
            }
    float a[8], b[8];
    hbk_message_t m;
    CHECK(hbk_grid_to_xyz(NULL, b, 2, 2, 2, 1, 1, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "src") != NULL);
    CHECK(hbk_grid_to_xyz(a, a, 2, 2, 2, 1, 1, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(hbk_grid_to_xyz(a, b, 2, 0, 2, 1, 1, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "ny = 0") != NULL);
    CHECK(hbk_grid_to_xyz(a, b, 2, 2, 2, 17, 1, &m) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(m.text, "comps = 17") != NULL);
}
