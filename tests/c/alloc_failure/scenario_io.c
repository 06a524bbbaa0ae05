/* IO: a small four-channel EXR (three half channels interleaved, one float channel) written,
 * written again over itself with other data, and read back; after every failed write the
 * folder must hold no temporary file and the target must be absent (first write) or exactly the
 * earlier file (second write). Then the normal map of the read heights and a tileable noise
 * volume (neither allocates today; they are here so they are covered if they come to), and a
 * UV layout's overlap. */
#include "alloc_failure.h"
#include <dirent.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

enum { W = 13, H = 21 };

typedef struct {
    hbk_exr_reader_t *reader;
    char dir[400], path[480];
} io_state_t;

/* Removes every file in the scenario's folder; returns how many there were. */
static int clear_dir(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d) return 0;
    int n = 0;
    char p[800];
    for (struct dirent *e; (e = readdir(d));) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        unlink(p);
        ++n;
    }
    closedir(d);
    return n;
}

/* The file's bytes in a scenario buffer (NULL if it cannot be read). */
static unsigned char *file_bytes(af_ctx_t *c, const char *path, size_t *size)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    const long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = af_buffer(c, n > 0 ? (size_t)n : 1);
    *size = n > 0 && fread(b, 1, (size_t)n, f) == (size_t)n ? (size_t)n : 0;
    fclose(f);
    return b;
}

/* The folder holds nothing but the target (no temporary file). */
static void check_no_temp(af_ctx_t *c, const io_state_t *s)
{
    DIR *d = opendir(s->dir);
    if (!d) {
        af_fail(c, __LINE__, "cannot list %s", s->dir);
        return;
    }
    for (struct dirent *e; (e = readdir(d));)
        if (strcmp(e->d_name, ".") && strcmp(e->d_name, "..") && strcmp(e->d_name, "bake.exr"))
            af_fail(c, __LINE__, "a write left \"%s\" behind", e->d_name);
    closedir(d);
}

/* After a failed write: no temporary file, and the target is `before` (NULL: absent). */
static void check_after_failure(af_ctx_t *c, const io_state_t *s, const unsigned char *before,
                                size_t before_size)
{
    check_no_temp(c, s);
    size_t size = 0;
    struct stat st;
    if (!before) {
        if (stat(s->path, &st) == 0) af_fail(c, __LINE__, "a failed first write left the target");
        return;
    }
    const unsigned char *now = file_bytes(c, s->path, &size);
    if (!now || size != before_size || memcmp(now, before, size))
        af_fail(c, __LINE__, "a failed write changed the earlier file (%zu bytes, was %zu)",
                now ? size : 0, before_size);
}

/* hbk_exr_write, with the folder checked whenever it fails. */
static hbk_result_t write_checked(af_ctx_t *c, const io_state_t *s, const hbk_exr_channel_t *ch,
                                  int32_t compression, const unsigned char *before,
                                  size_t before_size, hbk_message_t *m)
{
    m->text[0] = '\0';
    const hbk_result_t r = hbk_exr_write(s->path, W, H, ch, 4, compression, m);
    if (r != HBK_OK) check_after_failure(c, s, before, before_size);
    return r;
}

static void run(af_ctx_t *c, void *state)
{
    io_state_t *s = state;
    snprintf(s->dir, sizeof s->dir, "%s/hbk_af_io_%ld", af_tmpdir(), (long)getpid());
    snprintf(s->path, sizeof s->path, "%s/bake.exr", s->dir);
    mkdir(s->dir, 0755);
    clear_dir(s->dir);
    hbk_message_t m;
    float *rgb = af_buffer(c, (size_t)W * H * 3 * sizeof *rgb);
    float *height = af_buffer(c, (size_t)W * H * sizeof *height);
    hbk_exr_channel_t ch[4] = {{"R", rgb, 3, 3 * W, 1}, {"G", rgb + 1, 3, 3 * W, 1},
                               {"B", rgb + 2, 3, 3 * W, 1}, {"height", height, 1, W, 0}};
    for (int pass = 0; pass < 2; ++pass) {
        for (size_t i = 0; i < (size_t)W * H * 3; ++i)
            rgb[i] = (float)((i * 7 + pass) % 11) / 8.0f;
        for (size_t i = 0; i < (size_t)W * H; ++i)
            height[i] = 0.01f * (float)(i % W) * (float)(1 + pass) + 0.003f * (float)(i / W);
        size_t old_size = 0;
        const unsigned char *old = pass ? file_bytes(c, s->path, &old_size) : NULL;
        if (pass && !af_skipped(c) && (!old || !old_size)) {
            af_fail(c, __LINE__, "the first write left no readable file");
            return;
        }
        if (!old_size) old = NULL; /* the first write failed and was skipped: no file yet */
        AF_CALL(c, write_checked(c, s, ch, pass ? HBK_EXR_ZIPS : HBK_EXR_ZIP, old, old_size, &m),
                m.text);
        check_no_temp(c, s);
        if (af_failed(c)) return; /* a check failed, though the write succeeded on retry */
    }

    AF_CREATE(c, hbk_exr_open(&s->reader, s->path, &m), s->reader, m);
    int32_t w = 0, h = 0;
    hbk_exr_size(s->reader, &w, &h);
    const int32_t n = hbk_exr_channel_count(s->reader);
    if (w != W || h != H || n != 4) {
        af_fail(c, __LINE__, "read back %d x %d with %d channels", w, h, n);
        return;
    }
    float *back = af_buffer(c, (size_t)W * H * 4 * sizeof *back);
    for (int32_t k = 0; k < n; ++k) {
        const char *name = hbk_exr_channel_name(s->reader, k);
        const int32_t half = hbk_exr_channel_is_half(s->reader, k);
        af_hash(c, name, strlen(name));
        af_hash(c, &half, sizeof half);
        AF_CALL(c, hbk_exr_read_channel(s->reader, name, back + k, 4, 4 * W),
                hbk_exr_message(s->reader));
    }
    af_hash(c, back, (size_t)W * H * 4 * sizeof *back);

    /* "height" sorts last: channel 3 of `back`, made planar for the normal map. */
    const hbk_image_t hi = {af_buffer(c, (size_t)W * H * sizeof(float)), W, H, 1, W};
    for (size_t i = 0; i < (size_t)W * H; ++i) hi.data[i] = back[4 * i + 3];
    hbk_image_t nm = {af_buffer(c, (size_t)W * H * 4 * sizeof(float)), W, H, 4, 4 * W};
    m.text[0] = '\0';
    AF_CALL(c, hbk_normal_map(&hi, 0.01f, 0.01f, 1.0f, HBK_EDGE_WRAP, 1, &nm, &m), m.text);
    af_hash(c, nm.data, (size_t)W * H * 4 * sizeof(float));
    float *noise = af_buffer(c, 8 * 8 * 8 * sizeof *noise);
    m.text[0] = '\0';
    AF_CALL(c, hbk_noise3d_tileable(noise, 8, 2, 2, 0.5f, 5, &m), m.text);
    af_hash(c, noise, 8 * 8 * 8 * sizeof *noise);
    /* Two overlapping triangles' share of a UV layout (its coverage grid is allocated). */
    const float uvs[12] = {0, 0, 1, 0, 0, 1, 0.2f, 0.2f, 0.9f, 0.2f, 0.2f, 0.9f};
    float overlap = -1.0f;
    m.text[0] = '\0';
    AF_CALL(c, hbk_uv_overlap(uvs, 2, 32, &overlap, &m), m.text);
    af_hash(c, &overlap, sizeof overlap);
}

static void done(void *state)
{
    io_state_t *s = state;
    hbk_exr_close(s->reader);
    if (s->dir[0]) {
        clear_dir(s->dir);
        rmdir(s->dir);
    }
}

const af_scenario_t af_scenario_io = {"io", sizeof(io_state_t), run, done};
