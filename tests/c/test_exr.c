/* EXR writer and reader: round trips, orientation, strides, atomic replace, argument checks,
 * damaged files. Where a check must not trust our own reader, the test reads or writes the file
 * with OpenEXRCore directly. */
#include "test.h"
#include <omp.h>
#include <OpenEXR/openexr.h>
#include <dirent.h>
#include <dlfcn.h>
#include <errno.h>
#include <signal.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

/* ---- helpers ---------------------------------------------------------------------------- */

/* OpenEXRCore, reached through the library's own dependency: tests/c/CMakeLists.txt links the
 * runner against libhydrobake only, so the test looks the functions up at run time rather than
 * linking OpenEXRCore a second time. The prototypes still come from <openexr.h>. */
typedef struct {
    __typeof__(exr_start_read) *start_read;
    __typeof__(exr_start_write) *start_write;
    __typeof__(exr_finish) *finish;
    __typeof__(exr_get_data_window) *get_data_window;
    __typeof__(exr_get_lineorder) *get_lineorder;
    __typeof__(exr_get_chunk_count) *get_chunk_count;
    __typeof__(exr_get_scanlines_per_chunk) *get_scanlines_per_chunk;
    __typeof__(exr_get_compression) *get_compression;
    __typeof__(exr_read_scanline_chunk_info) *read_scanline_chunk_info;
    __typeof__(exr_decoding_initialize) *decoding_initialize;
    __typeof__(exr_decoding_choose_default_routines) *decoding_choose_default_routines;
    __typeof__(exr_decoding_run) *decoding_run;
    __typeof__(exr_decoding_destroy) *decoding_destroy;
    __typeof__(exr_add_part) *add_part;
    __typeof__(exr_initialize_required_attr) *initialize_required_attr;
    __typeof__(exr_initialize_required_attr_simple) *initialize_required_attr_simple;
    __typeof__(exr_add_channel) *add_channel;
    __typeof__(exr_set_tile_descriptor) *set_tile_descriptor;
    __typeof__(exr_write_header) *write_header;
    __typeof__(exr_write_scanline_chunk_info) *write_scanline_chunk_info;
    __typeof__(exr_write_tile_chunk_info) *write_tile_chunk_info;
    __typeof__(exr_encoding_initialize) *encoding_initialize;
    __typeof__(exr_encoding_choose_default_routines) *encoding_choose_default_routines;
    __typeof__(exr_encoding_update) *encoding_update;
    __typeof__(exr_encoding_run) *encoding_run;
    __typeof__(exr_encoding_destroy) *encoding_destroy;
} exr_api_t;

static int load_exr_api(exr_api_t *a)
{
    int ok = 1;
#define LOAD(f)                                                  \
    do {                                                         \
        void *p_ = dlsym(RTLD_DEFAULT, "exr_" #f);               \
        if (!p_) ok = 0;                                         \
        memcpy(&a->f, &p_, sizeof p_);                           \
    } while (0)
    LOAD(start_read); LOAD(start_write); LOAD(finish); LOAD(get_data_window);
    LOAD(get_lineorder); LOAD(get_chunk_count); LOAD(get_scanlines_per_chunk);
    LOAD(get_compression); LOAD(read_scanline_chunk_info); LOAD(decoding_initialize);
    LOAD(decoding_choose_default_routines); LOAD(decoding_run); LOAD(decoding_destroy);
    LOAD(add_part); LOAD(initialize_required_attr); LOAD(initialize_required_attr_simple);
    LOAD(add_channel); LOAD(set_tile_descriptor); LOAD(write_header);
    LOAD(write_scanline_chunk_info); LOAD(write_tile_chunk_info); LOAD(encoding_initialize);
    LOAD(encoding_choose_default_routines); LOAD(encoding_update); LOAD(encoding_run);
    LOAD(encoding_destroy);
#undef LOAD
    return ok;
}

/* Keeps OpenEXRCore quiet (its default handler prints to stderr) during the test's own calls. */
static void quiet_handler(exr_const_context_t c, exr_result_t code, const char *m)
{
    (void)c; (void)code; (void)m;
}
static exr_context_initializer_t quiet_init(void)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet_handler;
    return init;
}

static void tmp_path(char *out, size_t cap, const char *name)
{
    snprintf(out, cap, "%s/%s", hbk_test_tmpdir(), name);
}

static uint64_t rng_next(uint64_t *s)
{
    *s ^= *s >> 12; *s ^= *s << 25; *s ^= *s >> 27;
    return *s * 0x2545F4914F6CDD1DULL;
}

static uint32_t f_bits(float f) { uint32_t u; memcpy(&u, &f, 4); return u; }
static float bits_f(uint32_t u) { float f; memcpy(&f, &u, 4); return f; }

static float half_to_float_ref(uint16_t h)
{
    int s = h >> 15, e = (h >> 10) & 31, m = h & 1023;
    double v;
    if (e == 31) return m ? NAN : (s ? -INFINITY : INFINITY);
    v = e ? ldexp(1024 + m, e - 25) : ldexp(m, -24);
    return (float)(s ? -v : v);
}

/* Independent float -> half, round to nearest even, in double arithmetic (exact here). */
static uint16_t float_to_half_ref(float f)
{
    uint16_t sign = (f_bits(f) >> 16) & 0x8000;
    double a = fabs((double)f);
    if (isnan(f)) return 0x7e00;
    if (a >= 65520.0) return sign | 0x7c00; /* includes inf */
    if (a < ldexp(1, -14)) /* denormal; rounding up to 1024 gives the smallest normal */
        return sign | (uint16_t)nearbyint(a * ldexp(1, 24));
    int e;
    frexp(a, &e); /* a = m * 2^e, m in [0.5, 1) */
    int E = e - 1;
    double q = nearbyint(ldexp(a, 10 - E));
    if (q >= 2048) { q = 1024; ++E; }
    if (E + 15 >= 31) return sign | 0x7c00;
    return sign | (uint16_t)((E + 15) << 10) | (uint16_t)(q - 1024);
}

static unsigned char *read_bytes(const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc(n > 0 ? (size_t)n : 1);
    if (b && fread(b, 1, (size_t)n, f) != (size_t)n) { free(b); b = NULL; }
    fclose(f);
    *size = (size_t)n;
    return b;
}

static int write_bytes(const char *path, const unsigned char *b, size_t n)
{
    FILE *f = fopen(path, "wb");
    if (!f) return 0;
    size_t w = fwrite(b, 1, n, f);
    return (fclose(f) == 0) && w == n;
}

/* Number of entries in `dir` other than . and .. (-1 if it cannot be listed). */
static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    int n = 0;
    if (!d) return -1;
    for (struct dirent *e; (e = readdir(d));)
        n += strcmp(e->d_name, ".") && strcmp(e->d_name, "..");
    closedir(d);
    return n;
}

static int any_temp_left(const char *dir)
{
    DIR *d = opendir(dir);
    int found = 0;
    if (!d) return 0;
    for (struct dirent *e; (e = readdir(d));)
        if (e->d_name[0] == '.' && strstr(e->d_name, ".tmp-")) found = 1;
    closedir(d);
    return found;
}

/* ---- round trip --------------------------------------------------------------------------- */

#define LONG_NAME "displacement.height_in_metres_after_bake" /* 40 bytes: needs long names */

static void roundtrip_case(int32_t w, int32_t h, int32_t comp, uint64_t seed)
{
    const size_t n = (size_t)w * (size_t)h;
    float *zf = malloc(n * 4), *he = malloc(n * 4), *hr = malloc(n * 4), *ln = malloc(n * 4);
    float *back = malloc(n * 4);
    CHECK(zf && he && hr && ln && back);
    for (size_t i = 0; i < n; ++i) {
        uint64_t r = rng_next(&seed);
        zf[i] = bits_f((uint32_t)r); /* any bit pattern, NaN payloads and denormals included */
        uint16_t hb = (uint16_t)(r >> 32);
        if (i % 11 == 0) hb = (uint16_t)(i % 1024);       /* half denormals */
        he[i] = half_to_float_ref(hb);                      /* exactly representable */
        switch (i % 7) {
        case 0: { /* exact tie between two halves: must round to the even one */
            uint16_t lo = (uint16_t)((r >> 40) % 0x7bff);
            double a = half_to_float_ref(lo), b = half_to_float_ref((uint16_t)(lo + 1));
            hr[i] = (float)((a + b) / 2);
            break;
        }
        case 1: /* any magnitude from 2^-30 to 2^17 */
            hr[i] = (float)ldexp((double)(r >> 40) / 16777216.0, (int)((r >> 20) % 48) - 30);
            break;
        case 2: hr[i] = (i & 8) ? 70000.0f : -1e30f; break;            /* overflow to inf */
        case 3: hr[i] = (float)ldexp(1, -26) * ((i & 16) ? 1 : -1); break; /* underflow */
        default: hr[i] = (float)(((double)(r >> 11) / 9007199254740992.0 - 0.5) * 200.0);
        }
        ln[i] = (float)(i % (size_t)w) + 1000.0f * (float)(i / (size_t)w);
    }
    hbk_exr_channel_t ch[4] = {
        {LONG_NAME, ln, 1, (size_t)w, 0},
        {"Zf", zf, 1, (size_t)w, 0},
        {"Hr", hr, 1, (size_t)w, 1},
        {"He", he, 1, (size_t)w, 1},
    };
    char path[512];
    tmp_path(path, sizeof path, "hbk_exr_roundtrip.exr");
    hbk_message_t msg;
    hbk_result_t wr = hbk_exr_write(path, w, h, ch, 4, comp, &msg);
    if (wr) fprintf(stderr, "hbk_exr_write: %s\n", msg.text);
    CHECK_OK(wr);
    CHECK(msg.text[0] == '\0');

    hbk_exr_reader_t *r = NULL;
    CHECK_OK(hbk_exr_open(&r, path, &msg));
    int32_t rw = 0, rh = 0;
    hbk_exr_size(r, &rw, &rh);
    CHECK(rw == w && rh == h);
    CHECK(hbk_exr_channel_count(r) == 4);
    /* Stored sorted by name (byte order): upper case before lower case. */
    CHECK(!strcmp(hbk_exr_channel_name(r, 0), "He") && hbk_exr_channel_is_half(r, 0) == 1);
    CHECK(!strcmp(hbk_exr_channel_name(r, 1), "Hr") && hbk_exr_channel_is_half(r, 1) == 1);
    CHECK(!strcmp(hbk_exr_channel_name(r, 2), "Zf") && hbk_exr_channel_is_half(r, 2) == 0);
    CHECK(!strcmp(hbk_exr_channel_name(r, 3), LONG_NAME) && hbk_exr_channel_is_half(r, 3) == 0);
    CHECK(hbk_exr_channel_name(r, 4) == NULL && hbk_exr_channel_name(r, -1) == NULL);
    CHECK(hbk_exr_channel_is_half(r, 4) == -1);

    CHECK_OK(hbk_exr_read_channel(r, "Zf", back, 1, (size_t)w));
    CHECK(memcmp(back, zf, n * 4) == 0); /* float: bit exact */
    CHECK_OK(hbk_exr_read_channel(r, LONG_NAME, back, 1, (size_t)w));
    CHECK(memcmp(back, ln, n * 4) == 0);
    CHECK_OK(hbk_exr_read_channel(r, "He", back, 1, (size_t)w));
    for (size_t i = 0; i < n; ++i) {
        if (isnan(he[i])) CHECK(isnan(back[i]));
        else CHECK(f_bits(back[i]) == f_bits(he[i])); /* representable: exact, -0 kept */
    }
    CHECK_OK(hbk_exr_read_channel(r, "Hr", back, 1, (size_t)w));
    for (size_t i = 0; i < n; ++i) {
        float v = hr[i], got = back[i];
        /* bit-exact against an independent round-to-nearest-even conversion ... */
        CHECK(f_bits(got) == f_bits(half_to_float_ref(float_to_half_ref(v))));
        /* ... which is within half a half-ulp (2^-11 relative, 2^-25 absolute for denormals) */
        if (fabsf(v) < 65520.0f)
            CHECK(fabs((double)got - v) <= fmax(fabs((double)v) * ldexp(1, -11), ldexp(1, -25)));
        else
            CHECK(isinf(got) && (got > 0) == (v > 0));
    }
    CHECK(hbk_exr_message(r)[0] == '\0');
    hbk_exr_close(r);
    remove(path);
    free(zf); free(he); free(hr); free(ln); free(back);
}

void test_exr_roundtrip_float_half(void)
{
    static const int32_t sizes[][2] = {{37, 23}, {1, 1}, {16, 33}, {300, 5}};
    for (int32_t comp = HBK_EXR_NONE; comp <= HBK_EXR_ZIPS; ++comp)
        for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; ++s) {
            int before = hbk_test_failed;
            uint64_t seed = 0x9E3779B97F4A7C15ULL + s * 7 + (uint64_t)comp;
            roundtrip_case(sizes[s][0], sizes[s][1], comp, seed);
            if (hbk_test_failed && !before) {
                fprintf(stderr, "  in case %dx%d, compression %d\n", sizes[s][0], sizes[s][1],
                        comp);
                return;
            }
        }
}

/* Smooth rows with a share of random values, from none to all: somewhere deflate saves
 * exactly its own overhead and the zlib stream is as long as the raw chunk. OpenEXRCore 3.1.5
 * stored that stream, which readers take for raw pixels (openexr#2306). Every chunk must read
 * back bit for bit. */
void test_exr_partly_compressible_chunks(void)
{
    uint64_t seed = 0x5EEDC0DEULL;
    float *img = malloc(64 * 40 * sizeof(float)), *back = malloc(64 * 40 * sizeof(float));
    CHECK(img && back);
    char path[512];
    tmp_path(path, sizeof path, "hbk_exr_partly.exr");
    for (int k = 0; k < 400 && !hbk_test_failed; ++k) {
        const int32_t w = 1 + (int32_t)(rng_next(&seed) % 64);
        const int32_t h = 1 + (int32_t)(rng_next(&seed) % 40);
        const uint64_t share = rng_next(&seed) % 1024; /* of 1024 values are random */
        const int half = k & 1;
        float v = 0.5f;
        for (int32_t i = 0; i < w * h; ++i) {
            const uint64_t r = rng_next(&seed);
            v += (float)((int64_t)(r % 201) - 100) * 1e-6f;
            img[i] = (r >> 20) % 1024 < share ? (float)((r >> 32) % 100000) * 1e-5f : v;
            if (half) img[i] = half_to_float_ref(float_to_half_ref(img[i]));
        }
        hbk_exr_channel_t ch = {"Y", img, 1, (size_t)w, half};
        const int32_t comp = k % 3 ? HBK_EXR_ZIP : HBK_EXR_ZIPS;
        hbk_message_t msg;
        CHECK_OK(hbk_exr_write(path, w, h, &ch, 1, comp, &msg));
        hbk_exr_reader_t *r = NULL;
        CHECK_OK(hbk_exr_open(&r, path, &msg));
        if (!r) break;
        CHECK_OK(hbk_exr_read_channel(r, "Y", back, 1, (size_t)w));
        hbk_exr_close(r);
        if (memcmp(back, img, (size_t)w * (size_t)h * sizeof(float))) {
            fprintf(stderr, "  image %d (%dx%d, %s, compression %d) read back differently\n", k,
                    w, h, half ? "half" : "float", comp);
            CHECK(0);
        }
    }
    remove(path);
    free(img);
    free(back);
}

/* The chunks are compressed on all cores and written in order: the file's bytes are the same
 * whatever the thread count, for every compression, with more chunks than one batch of them
 * (ZIPS: a chunk a row), and the image reads back as written. */
void test_exr_same_bytes_any_threads(void)
{
    enum { W = 300, H = 257 };
    uint64_t seed = 0xC0FFEEULL;
    float *a = malloc(sizeof(float) * W * H), *b = malloc(sizeof(float) * 2 * W * H);
    float *back = malloc(sizeof(float) * W * H);
    CHECK(a && b && back);
    float v = 0.25f;
    for (int32_t i = 0; i < W * H; ++i) { /* smooth with a share of noise: chunks differ */
        const uint64_t r = rng_next(&seed);
        v += (float)((int64_t)(r % 201) - 100) * 1e-5f;
        a[i] = r % 5 ? v : (float)(r >> 40) * 1e-7f;
        b[2 * i] = a[i] * 3.0f;
        b[2 * i + 1] = half_to_float_ref(float_to_half_ref(a[i]));
    }
    const hbk_exr_channel_t ch[3] = {{"A", a, 1, W, 0}, {"B", b, 2, 2 * W, 0},
                                     {"H", b + 1, 2, 2 * W, 1}};
    char path[512];
    tmp_path(path, sizeof path, "hbk_exr_threads.exr");
    const int max = omp_get_max_threads();
    for (int32_t comp = HBK_EXR_NONE; comp <= HBK_EXR_ZIPS; ++comp) {
        unsigned char *first = NULL;
        size_t first_n = 0;
        static const int teams[] = {1, 2, 5};
        for (size_t t = 0; t < sizeof teams / sizeof teams[0]; ++t) {
            omp_set_num_threads(teams[t]);
            hbk_message_t msg;
            CHECK_OK(hbk_exr_write(path, W, H, ch, 3, comp, &msg));
            size_t n = 0;
            unsigned char *bytes = read_bytes(path, &n);
            CHECK(bytes && n > 0);
            if (!first) {
                first = bytes;
                first_n = n;
                continue;
            }
            if (n != first_n || memcmp(bytes, first, n)) {
                fprintf(stderr, "  compression %d: %d threads wrote other bytes\n", comp, teams[t]);
                CHECK(0);
            }
            free(bytes);
        }
        free(first);
        hbk_exr_reader_t *r = NULL;
        hbk_message_t msg;
        CHECK_OK(hbk_exr_open(&r, path, &msg));
        if (!r) break;
        CHECK_OK(hbk_exr_read_channel(r, "A", back, 1, W));
        CHECK(!memcmp(back, a, sizeof(float) * W * H));
        hbk_exr_close(r);
    }
    omp_set_num_threads(max);
    remove(path);
    free(a);
    free(b);
    free(back);
}

/* ---- orientation and strides ------------------------------------------------------------ */

/* Reads channel `name` of the chunk that starts at the top of the data window, with
 * OpenEXRCore only, into `out` (chunk height rows of `width` floats, file order). */
static int first_chunk_rows(const exr_api_t *x, const char *path, const char *name, float *out,
                            int32_t *rows, int32_t *is_first_in_file)
{
    exr_context_initializer_t init = quiet_init();
    exr_context_t c = NULL;
    if (x->start_read(&c, path, &init) != EXR_ERR_SUCCESS) return 0;
    int ok = 0;
    exr_attr_box2i_t dw;
    exr_lineorder_t lo;
    int32_t nchunks = 0, lines = 0;
    exr_chunk_info_t first, other;
    exr_decode_pipeline_t dec = EXR_DECODE_PIPELINE_INITIALIZER;
    if (x->get_data_window(c, 0, &dw) || x->get_lineorder(c, 0, &lo) ||
        lo != EXR_LINEORDER_INCREASING_Y || x->get_chunk_count(c, 0, &nchunks) ||
        x->get_scanlines_per_chunk(c, 0, &lines) ||
        x->read_scanline_chunk_info(c, 0, dw.min.y, &first) || first.start_y != dw.min.y)
        goto out;
    /* the top chunk is also the first one stored in the file */
    *is_first_in_file = 1;
    for (int32_t y = dw.min.y + lines; y <= dw.max.y; y += lines) {
        if (x->read_scanline_chunk_info(c, 0, y, &other)) goto out;
        if (other.data_offset <= first.data_offset) *is_first_in_file = 0;
    }
    if (x->decoding_initialize(c, 0, &first, &dec)) goto out;
    for (int k = 0; k < dec.channel_count; ++k) {
        exr_coding_channel_info_t *cc = &dec.channels[k];
        if (strcmp(cc->channel_name, name)) continue;
        cc->user_data_type = EXR_PIXEL_FLOAT;
        cc->user_bytes_per_element = 4;
        cc->user_pixel_stride = 4;
        cc->user_line_stride = 4 * first.width;
        cc->decode_to_ptr = (uint8_t *)out;
    }
    if (!x->decoding_choose_default_routines(c, 0, &dec) && !x->decoding_run(c, 0, &dec)) {
        *rows = first.height;
        ok = 1;
    }
    x->decoding_destroy(c, &dec);
out:
    x->finish(&c);
    return ok;
}

/* Writes a one-channel ("Y", float) file with OpenEXRCore, data window origin (ox, oy), where
 * each value is 1000 * (file row, 0 = top) + x. */
static int write_offset_window(const exr_api_t *x, const char *path, int32_t w, int32_t h,
                               int32_t ox, int32_t oy)
{
    exr_context_initializer_t init = quiet_init();
    exr_context_t c = NULL;
    if (x->start_write(&c, path, EXR_WRITE_FILE_DIRECTLY, &init)) return 0;
    int part = 0, ok = 0, have = 0;
    exr_attr_box2i_t dw = {{{{ox, oy}}}, {{{ox + w - 1, oy + h - 1}}}};
    exr_attr_v2f_t center = {{{0.0f, 0.0f}}};
    float *row = malloc((size_t)w * 4);
    exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
    if (!row || x->add_part(c, "main", EXR_STORAGE_SCANLINE, &part) ||
        x->initialize_required_attr(c, part, &dw, &dw, 1.0f, &center, 1.0f,
                                    EXR_LINEORDER_INCREASING_Y, EXR_COMPRESSION_NONE) ||
        x->add_channel(c, part, "Y", EXR_PIXEL_FLOAT, EXR_PERCEPTUALLY_LINEAR, 1, 1) ||
        x->write_header(c))
        goto out;
    for (int32_t f = 0; f < h; ++f) { /* NONE: one scanline per chunk */
        exr_chunk_info_t ci;
        for (int32_t i = 0; i < w; ++i) row[i] = 1000.0f * (float)f + (float)i;
        if (x->write_scanline_chunk_info(c, part, oy + f, &ci)) goto out;
        if (!have) {
            if (x->encoding_initialize(c, part, &ci, &enc)) goto out;
            have = 1;
            enc.channels[0].user_data_type = EXR_PIXEL_FLOAT;
            enc.channels[0].user_bytes_per_element = 4;
            enc.channels[0].user_pixel_stride = 4;
            enc.channels[0].user_line_stride = 4 * w;
            enc.channels[0].encode_from_ptr = (const uint8_t *)row;
            if (x->encoding_choose_default_routines(c, part, &enc)) goto out;
        } else if (x->encoding_update(c, part, &ci, &enc)) {
            goto out;
        }
        if (x->encoding_run(c, part, &enc)) goto out;
    }
    ok = 1;
out:
    if (have) x->encoding_destroy(c, &enc);
    free(row);
    if (x->finish(&c)) ok = 0;
    return ok;
}

static float grad(int32_t c, int32_t x, int32_t y) /* y = row from the bottom */
{
    switch (c) {
    case 0: return (float)x;
    case 1: return (float)y;
    case 2: return (float)(x + 100 * y);
    default: return 0.25f * (float)(y % 4); /* exact in half */
    }
}

void test_exr_orientation_and_strides(void)
{
    exr_api_t x;
    CHECK(load_exr_api(&x));
    const int32_t w = 13, h = 21; /* h > 16: ZIP files have a second, partial chunk */
    const size_t stride = (size_t)w * 4 + 3, back_stride = (size_t)w * 4 + 5;
    float *rgba = malloc((size_t)h * stride * 4), *back = malloc((size_t)h * back_stride * 4);
    float *top = malloc(16 * (size_t)w * 4);
    CHECK(rgba && back && top);
    for (size_t i = 0; i < (size_t)h * stride; ++i) rgba[i] = NAN; /* padding must not be read */
    for (int32_t y = 0; y < h; ++y)
        for (int32_t px = 0; px < w; ++px)
            for (int32_t c = 0; c < 4; ++c)
                rgba[(size_t)y * stride + (size_t)px * 4 + (size_t)c] = grad(c, px, y);
    hbk_exr_channel_t ch[4] = {
        {"R", rgba + 0, 4, stride, 0}, {"G", rgba + 1, 4, stride, 0},
        {"B", rgba + 2, 4, stride, 0}, {"A", rgba + 3, 4, stride, 1},
    };
    char path[512];
    tmp_path(path, sizeof path, "hbk_exr_orient.exr");
    static const char *const names[4] = {"R", "G", "B", "A"};
    for (int32_t comp = HBK_EXR_NONE; comp <= HBK_EXR_ZIPS; ++comp) {
        hbk_message_t msg;
        CHECK_OK(hbk_exr_write(path, w, h, ch, 4, comp, &msg));

        /* our reader, interleaved into a differently padded buffer */
        hbk_exr_reader_t *r = NULL;
        CHECK_OK(hbk_exr_open(&r, path, &msg));
        for (size_t i = 0; i < (size_t)h * back_stride; ++i) back[i] = -7.0f;
        for (int32_t c = 0; c < 4; ++c)
            CHECK_OK(hbk_exr_read_channel(r, names[c], back + c, 4, back_stride));
        hbk_exr_close(r);
        for (int32_t y = 0; y < h; ++y) {
            for (int32_t px = 0; px < w; ++px)
                for (int32_t c = 0; c < 4; ++c)
                    CHECK(back[(size_t)y * back_stride + (size_t)px * 4 + (size_t)c] ==
                          grad(c, px, y));
            for (size_t pad = (size_t)w * 4; pad < back_stride; ++pad)
                CHECK(back[(size_t)y * back_stride + pad] == -7.0f); /* padding untouched */
        }

        /* independently: the first chunk of the file holds the TOP row (y = h - 1) first */
        int32_t rows = 0, is_first = 0;
        CHECK(first_chunk_rows(&x, path, "G", top, &rows, &is_first));
        CHECK(is_first);
        CHECK(rows == (comp == HBK_EXR_ZIP ? 16 : 1));
        for (int32_t k = 0; k < rows; ++k)
            for (int32_t px = 0; px < w; ++px)
                CHECK(top[(size_t)k * (size_t)w + (size_t)px] == (float)(h - 1 - k));
    }
    remove(path);

    /* a file written by OpenEXRCore with a data window that does not start at (0, 0) */
    const int32_t ow = 9, oh = 6;
    CHECK(write_offset_window(&x, path, ow, oh, 3, -7));
    hbk_exr_reader_t *r = NULL;
    hbk_message_t msg;
    CHECK_OK(hbk_exr_open(&r, path, &msg));
    int32_t rw, rh;
    hbk_exr_size(r, &rw, &rh);
    CHECK(rw == ow && rh == oh);
    CHECK_OK(hbk_exr_read_channel(r, "Y", back, 1, (size_t)ow));
    hbk_exr_close(r);
    for (int32_t y = 0; y < oh; ++y)
        for (int32_t px = 0; px < ow; ++px)
            CHECK(back[(size_t)y * (size_t)ow + (size_t)px] ==
                  1000.0f * (float)(oh - 1 - y) + (float)px);
    remove(path);
    free(rgba); free(back); free(top);
}

/* ---- atomic replace ----------------------------------------------------------------------- */

void test_exr_atomic_failure_keeps_old(void)
{
    char dir[400], path[512], sub[512], inner[600], missing[512];
    snprintf(dir, sizeof dir, "%s/hbk_exr_atomic_%ld", hbk_test_tmpdir(), (long)getpid());
    mkdir(dir, 0755);
    snprintf(path, sizeof path, "%s/bake.exr", dir);
    snprintf(sub, sizeof sub, "%s/subdir", dir);
    snprintf(inner, sizeof inner, "%s/keep.txt", sub);
    snprintf(missing, sizeof missing, "%s/no_such_folder/bake.exr", dir);
    remove(inner); rmdir(sub); remove(path);
    CHECK(count_entries(dir) == 0);

    enum { W = 256, H = 256 };
    float *big = malloc((size_t)W * H * 4);
    CHECK(big);
    for (size_t i = 0; i < (size_t)W * H; ++i) big[i] = (float)i * 0.37f;
    hbk_exr_channel_t ch[4] = {{"R", big, 1, W, 0}, {"G", big, 1, W, 0},
                               {"B", big, 1, W, 0}, {"A", big, 1, W, 0}};
    hbk_message_t msg;
    CHECK_OK(hbk_exr_write(path, 8, 8, ch, 4, HBK_EXR_ZIP, &msg)); /* the "old" file */
    size_t old_size = 0, now_size = 0;
    unsigned char *old = read_bytes(path, &old_size), *now = NULL;
    CHECK(old && old_size > 0 && old_size < 16384);

    /* 1. rejected before anything is created */
    CHECK(hbk_exr_write(path, 0, 8, ch, 4, HBK_EXR_ZIP, &msg) == HBK_ERR_INVALID_ARGUMENT);

    /* 2. the disk "fills up" halfway: a 1 MB file against a 64 KB file size limit */
    struct rlimit saved, lim;
    CHECK(getrlimit(RLIMIT_FSIZE, &saved) == 0);
    lim = saved;
    lim.rlim_cur = 65536;
    void (*old_sig)(int) = signal(SIGXFSZ, SIG_IGN);
    CHECK(setrlimit(RLIMIT_FSIZE, &lim) == 0);
    hbk_result_t full = hbk_exr_write(path, W, H, ch, 4, HBK_EXR_NONE, &msg);
    setrlimit(RLIMIT_FSIZE, &saved);
    signal(SIGXFSZ, old_sig);
    CHECK(full == HBK_ERR_IO);
    CHECK(strstr(msg.text, path) != NULL);
    CHECK(strstr(msg.text, strerror(EFBIG)) != NULL);

    /* 3. the folder does not exist */
    CHECK(hbk_exr_write(missing, W, H, ch, 4, HBK_EXR_ZIP, &msg) == HBK_ERR_IO);
    CHECK(strstr(msg.text, missing) != NULL);
    CHECK(strstr(msg.text, strerror(ENOENT)) != NULL);

    /* 4. every chunk written, but the final rename fails (target is a non-empty folder) */
    CHECK(mkdir(sub, 0755) == 0);
    CHECK(write_bytes(inner, (const unsigned char *)"keep", 4));
    CHECK(hbk_exr_write(sub, W, H, ch, 4, HBK_EXR_ZIP, &msg) == HBK_ERR_IO);
    CHECK(strstr(msg.text, sub) != NULL && strstr(msg.text, "rename") != NULL);
    struct stat st;
    CHECK(stat(sub, &st) == 0 && S_ISDIR(st.st_mode));

    /* the old file is byte for byte what it was, and no temporary file is left behind */
    now = read_bytes(path, &now_size);
    CHECK(now && now_size == old_size && memcmp(now, old, old_size) == 0);
    CHECK(!any_temp_left(dir));
    CHECK(count_entries(dir) == 2); /* bake.exr and subdir */

    /* and a successful write does replace it */
    CHECK_OK(hbk_exr_write(path, 16, 4, ch, 4, HBK_EXR_ZIP, &msg));
    hbk_exr_reader_t *r = NULL;
    CHECK_OK(hbk_exr_open(&r, path, &msg));
    int32_t rw, rh;
    hbk_exr_size(r, &rw, &rh);
    hbk_exr_close(r);
    CHECK(rw == 16 && rh == 4);
    CHECK(!any_temp_left(dir));

    remove(inner); rmdir(sub); remove(path); rmdir(dir);
    free(old); free(now); free(big);
}

/* ---- argument checks ---------------------------------------------------------------------- */

void test_exr_rejects_bad_input(void)
{
    enum { W = 8, H = 4 };
    float buf[W * H * 2] = {0};
    hbk_exr_channel_t good[2] = {{"R", buf, 1, W, 0}, {"G", buf, 2, 2 * W, 1}};
    char path[512], toolong[300];
    tmp_path(path, sizeof path, "hbk_exr_rejects.exr");
    remove(path);
    memset(toolong, 'n', 256);
    toolong[256] = '\0';

    struct { const char *what; int field; long value; const char *expect; } cases[] = {
        {"width 0", 0, 0, "width = 0"},
        {"width big", 0, 65537, "width = 65537: must be in [1, 65536]"},
        {"height 0", 1, 0, "height = 0"},
        {"height negative", 1, -3, "height = -3"},
        {"count 0", 2, 0, "count = 0"},
        {"count 65", 2, 65, "count = 65"},
        {"compression", 3, 3, "compression = 3"},
        {"compression negative", 3, -1, "compression = -1"},
        {"name NULL", 10, 0, "channels[1].name"},
        {"name empty", 11, 0, "channels[1].name = \"\""},
        {"name 256 bytes", 12, 0, "channels[1].name"},
        {"duplicate", 13, 0, "channels[1].name = \"R\": duplicate"},
        {"data NULL", 14, 0, "channels[1].data"},
        {"pixel_stride 0", 15, 0, "channels[1].pixel_stride = 0"},
        {"row_stride small", 16, 15,
         "channels[1].row_stride = 15: must be >= width * pixel_stride = 16"},
        {"half 2", 17, 2, "channels[1].half = 2"},
        {"row_stride huge", 18, 0, "channels[1].row_stride"},
        {"channels NULL", 20, 0, "channels: must not be NULL"},
        {"path NULL", 21, 0, "path: must not be NULL"},
        {"path empty", 22, 0, "path = \"\""},
        {"path folder", 23, 0, "must name a file"},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; ++i) {
        hbk_exr_channel_t ch[2] = {good[0], good[1]};
        int32_t w = W, h = H, count = 2, comp = HBK_EXR_ZIP;
        const char *p = path;
        const hbk_exr_channel_t *chp = ch;
        switch (cases[i].field) {
        case 0: w = (int32_t)cases[i].value; break;
        case 1: h = (int32_t)cases[i].value; break;
        case 2: count = (int32_t)cases[i].value; break;
        case 3: comp = (int32_t)cases[i].value; break;
        case 10: ch[1].name = NULL; break;
        case 11: ch[1].name = ""; break;
        case 12: ch[1].name = toolong; break;
        case 13: ch[1].name = "R"; break;
        case 14: ch[1].data = NULL; break;
        case 15: ch[1].pixel_stride = 0; break;
        case 16: ch[1].row_stride = (size_t)cases[i].value; break;
        case 17: ch[1].half = (int32_t)cases[i].value; break;
        case 18: ch[1].row_stride = SIZE_MAX / 2; break;
        case 20: chp = NULL; break;
        case 21: p = NULL; break;
        case 22: p = ""; break;
        case 23: p = "/tmp/"; break;
        }
        hbk_message_t msg;
        hbk_result_t res = hbk_exr_write(p, w, h, chp, count, comp, &msg);
        if (res != HBK_ERR_INVALID_ARGUMENT || !strstr(msg.text, cases[i].expect))
            fprintf(stderr, "case '%s': got %d, message \"%s\"\n", cases[i].what, res, msg.text);
        CHECK(res == HBK_ERR_INVALID_ARGUMENT);
        CHECK(strstr(msg.text, cases[i].expect) != NULL);
        CHECK(hbk_exr_write(p, w, h, chp, count, comp, NULL) == HBK_ERR_INVALID_ARGUMENT);
        CHECK(access(path, F_OK) != 0); /* nothing was created */
    }
    /* 255-byte names are fine */
    toolong[255] = '\0';
    hbk_exr_channel_t ok[2] = {good[0], good[1]};
    ok[1].name = toolong;
    hbk_message_t msg;
    CHECK_OK(hbk_exr_write(path, W, H, ok, 2, HBK_EXR_NONE, &msg));

    /* reader arguments */
    hbk_exr_reader_t *r = (hbk_exr_reader_t *)&msg; /* must be reset to NULL on failure */
    CHECK(hbk_exr_open(NULL, path, &msg) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(msg.text, "out") != NULL);
    CHECK(hbk_exr_open(&r, NULL, &msg) == HBK_ERR_INVALID_ARGUMENT && r == NULL);
    CHECK(strstr(msg.text, "path") != NULL);
    CHECK_OK(hbk_exr_open(&r, path, &msg));
    float back[W * H * 3];
    CHECK(hbk_exr_read_channel(r, "R", back, 0, W) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_exr_message(r), "pixel_stride = 0") != NULL);
    CHECK(hbk_exr_read_channel(r, "R", back, 3, 3 * W - 1) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_exr_message(r), "row_stride = 23: must be >= width * pixel_stride = 24"));
    CHECK(hbk_exr_read_channel(r, "R", NULL, 1, W) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_exr_message(r), "dst") != NULL);
    CHECK(hbk_exr_read_channel(r, NULL, back, 1, W) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_exr_message(r), "name") != NULL);
    CHECK_OK(hbk_exr_read_channel(r, "R", back, 3, 3 * W));
    CHECK(hbk_exr_message(r)[0] == '\0'); /* cleared by a successful call */
    CHECK(hbk_exr_read_channel(NULL, "R", back, 1, W) == HBK_ERR_INVALID_ARGUMENT);
    hbk_exr_close(r);
    hbk_exr_close(NULL);
    CHECK(hbk_exr_message(NULL) != NULL);
    int32_t sw = -1, sh = -1;
    hbk_exr_size(NULL, &sw, &sh);
    CHECK(sw == 0 && sh == 0 && hbk_exr_channel_count(NULL) == 0);
    remove(path);
}

/* ---- missing and damaged files ------------------------------------------------------------ */

/* Opens `path` and reads every channel. Returns the first failure (or HBK_OK) and whether the
 * open itself failed. */
static hbk_result_t open_and_read_all(const char *path, float *buf, int *open_failed)
{
    hbk_exr_reader_t *r = NULL;
    hbk_message_t msg;
    hbk_result_t res = hbk_exr_open(&r, path, &msg);
    *open_failed = res != HBK_OK;
    if (res) return res;
    int32_t w, h;
    hbk_exr_size(r, &w, &h);
    for (int32_t i = 0; i < hbk_exr_channel_count(r) && res == HBK_OK; ++i)
        res = hbk_exr_read_channel(r, hbk_exr_channel_name(r, i), buf, 1, (size_t)w);
    if (res) {
        const char *m = hbk_exr_message(r);
        if (!m[0]) res = HBK_ERR_INTERNAL; /* a failure must come with a message */
    }
    hbk_exr_close(r);
    return res;
}

/* Writes, with OpenEXRCore, a complete 32 x 32 file of `parts` parts, tiled (16 x 16 tiles) or
 * scanline, each with one half channel "R" of zeros. (exr_finish deletes files with missing
 * chunks, so header-only files are not an option.) */
static int write_other_kind(const exr_api_t *x, const char *path, int tiled, int parts)
{
    exr_context_initializer_t init = quiet_init();
    exr_context_t c = NULL;
    if (x->start_write(&c, path, EXR_WRITE_FILE_DIRECTLY, &init)) return 0;
    static const uint16_t zeros[32 * 32];
    int ok = 1;
    for (int p = 0; p < parts && ok; ++p) {
        int idx = 0;
        char name[16];
        snprintf(name, sizeof name, "part%d", p);
        ok = !x->add_part(c, name, tiled ? EXR_STORAGE_TILED : EXR_STORAGE_SCANLINE, &idx) &&
             !x->initialize_required_attr_simple(c, idx, 32, 32, EXR_COMPRESSION_NONE) &&
             !x->add_channel(c, idx, "R", EXR_PIXEL_HALF, EXR_PERCEPTUALLY_LOGARITHMIC, 1, 1) &&
             (!tiled || !x->set_tile_descriptor(c, idx, 16, 16, EXR_TILE_ONE_LEVEL,
                                                 EXR_TILE_ROUND_DOWN));
    }
    if (ok) ok = !x->write_header(c);
    for (int p = 0; p < parts && ok; ++p) {
        int n = tiled ? 4 : 32; /* 2 x 2 tiles, or 32 one-line chunks (no compression) */
        for (int k = 0; k < n && ok; ++k) {
            exr_chunk_info_t ci;
            exr_encode_pipeline_t enc = EXR_ENCODE_PIPELINE_INITIALIZER;
            ok = !(tiled ? x->write_tile_chunk_info(c, p, k % 2, k / 2, 0, 0, &ci)
                         : x->write_scanline_chunk_info(c, p, k, &ci)) &&
                 !x->encoding_initialize(c, p, &ci, &enc);
            if (!ok) break;
            enc.channels[0].user_data_type = EXR_PIXEL_HALF;
            enc.channels[0].user_bytes_per_element = 2;
            enc.channels[0].user_pixel_stride = 2;
            enc.channels[0].user_line_stride = 2 * ci.width;
            enc.channels[0].encode_from_ptr = (const uint8_t *)zeros;
            ok = !x->encoding_choose_default_routines(c, p, &enc) && !x->encoding_run(c, p, &enc);
            x->encoding_destroy(c, &enc);
        }
    }
    if (x->finish(&c)) ok = 0;
    return ok && access(path, F_OK) == 0;
}

void test_exr_read_missing_and_corrupt(void)
{
    exr_api_t x;
    CHECK(load_exr_api(&x));
    char path[512], bad[512];
    tmp_path(path, sizeof path, "hbk_exr_corrupt_src.exr");
    tmp_path(bad, sizeof bad, "hbk_exr_corrupt_bad.exr");
    hbk_message_t msg;

    /* missing file */
    char missing[512];
    tmp_path(missing, sizeof missing, "hbk_exr_does_not_exist.exr");
    remove(missing);
    hbk_exr_reader_t *r = (hbk_exr_reader_t *)&msg;
    CHECK(hbk_exr_open(&r, missing, &msg) == HBK_ERR_IO);
    CHECK(r == NULL);
    CHECK(strstr(msg.text, missing) != NULL && strstr(msg.text, strerror(ENOENT)) != NULL);

    /* not an EXR at all */
    CHECK(write_bytes(bad, (const unsigned char *)"hello, I am not an image\n", 25));
    CHECK(hbk_exr_open(&r, bad, &msg) == HBK_ERR_FORMAT && r == NULL);
    CHECK(strstr(msg.text, bad) != NULL);

    /* a valid file with noisy data (so ZIP cannot shrink it much) */
    enum { W = 64, H = 48 };
    float *a = malloc((size_t)W * H * 4), *buf = malloc((size_t)W * H * 4);
    CHECK(a && buf);
    uint64_t s = 12345;
    for (size_t i = 0; i < (size_t)W * H; ++i) a[i] = (float)(rng_next(&s) >> 40) / 16777216.0f;
    hbk_exr_channel_t ch[3] = {{"R", a, 1, W, 0}, {"G", a, 1, W, 1}, {"B", a, 1, W, 0}};
    CHECK_OK(hbk_exr_write(path, W, H, ch, 3, HBK_EXR_ZIP, &msg));
    int open_failed = 0;
    CHECK_OK(open_and_read_all(path, buf, &open_failed));

    /* unknown channel: the message lists what there is */
    CHECK_OK(hbk_exr_open(&r, path, &msg));
    CHECK(hbk_exr_read_channel(r, "Z", buf, 1, W) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_exr_message(r), "\"Z\"") != NULL);
    CHECK(strstr(hbk_exr_message(r), "B, G, R") != NULL);
    hbk_exr_close(r);

    /* truncated copies: every cut must fail cleanly, at open or at read */
    size_t size = 0;
    unsigned char *bytes = read_bytes(path, &size);
    CHECK(bytes && size > 1000);
    const size_t cuts[] = {0, 3, 4, 20, 100, 200, 300, size / 3, size / 2, size - 100, size - 1};
    for (size_t k = 0; k < sizeof cuts / sizeof cuts[0]; ++k) {
        CHECK(write_bytes(bad, bytes, cuts[k]));
        hbk_result_t res = open_and_read_all(bad, buf, &open_failed);
        if (res != HBK_ERR_FORMAT && res != HBK_ERR_IO)
            fprintf(stderr, "cut at %zu of %zu: result %d\n", cuts[k], size, res);
        CHECK(res == HBK_ERR_FORMAT || res == HBK_ERR_IO);
    }

    /* flipped bytes in the pixel data: any outcome but a crash or an unlisted code */
    for (size_t k = 0; k < 8; ++k) {
        unsigned char *copy = malloc(size);
        CHECK(copy);
        memcpy(copy, bytes, size);
        size_t at = size / 2 + k * 97;
        copy[at] ^= 0x5A;
        copy[at + 1] ^= 0xFF;
        int okw = write_bytes(bad, copy, size);
        free(copy);
        CHECK(okw);
        hbk_result_t res = open_and_read_all(bad, buf, &open_failed);
        CHECK(res == HBK_OK || res == HBK_ERR_FORMAT || res == HBK_ERR_IO);
    }

    /* valid EXR files of kinds the reader does not take */
    CHECK(write_other_kind(&x, bad, 1, 1));
    CHECK(hbk_exr_open(&r, bad, &msg) == HBK_ERR_FORMAT && r == NULL);
    CHECK(strstr(msg.text, "tiled") != NULL);
    CHECK(write_other_kind(&x, bad, 0, 2));
    CHECK(hbk_exr_open(&r, bad, &msg) == HBK_ERR_FORMAT && r == NULL);
    CHECK(strstr(msg.text, "parts") != NULL);

    remove(bad);
    remove(path);
    free(bytes); free(a); free(buf);
}
