/* Saving and loading the state of a bake, so that it can resume bit-identically. */
#include "internal_snow.h"
#include <math.h>
#include <string.h>

#define STATE_VERSION 1
static const char k_magic[8] = "HBKSNOW";

typedef struct state_header {
    char magic[8];
    uint32_t version;
    uint32_t header_size;
    int32_t flake_count, tex_w, tex_h, blocks, contact_mode, flake_size;
    int32_t shelter_check, reserved;
    uint64_t step;
    hbk_snow_stats_t stats;
    uint64_t payload_bytes;
    uint64_t checksum; /* of the payload */
} state_header_t;

static size_t payload_bytes(const hbk_snow_t *h)
{
    const size_t texels = (size_t)h->tex_w * (size_t)h->tex_h * (size_t)h->blocks;
    return sizeof(snow_flake_t) * (size_t)h->p.flake_count + 2 * sizeof(float) * texels;
}

size_t hbk_snow_state_size(const hbk_snow_t *h)
{
    return h ? sizeof(state_header_t) + payload_bytes(h) : 0;
}

/* FNV-1a over 64-bit words (then the tail bytes): catches truncation and corruption. */
static uint64_t hash_bytes(uint64_t x, const unsigned char *p, size_t n)
{
    const uint64_t prime = 0x100000001b3ULL;
    size_t i = 0;
    for (; i + 8 <= n; i += 8) {
        uint64_t w;
        memcpy(&w, p + i, 8);
        x = (x ^ w) * prime;
    }
    for (; i < n; ++i) x = (x ^ p[i]) * prime;
    return x;
}

hbk_result_t hbk_snow_save_state(hbk_snow_t *h, void *buffer, size_t size)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    if (!buffer) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "buffer: must not be NULL");
    const size_t need = hbk_snow_state_size(h);
    if (size < need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "size = %zu: must be >= %zu (hbk_snow_state_size)", size, need);
    state_header_t hd;
    memset(&hd, 0, sizeof hd);
    memcpy(hd.magic, k_magic, sizeof hd.magic);
    hd.version = STATE_VERSION;
    hd.header_size = sizeof hd;
    hd.flake_count = h->p.flake_count;
    hd.tex_w = h->tex_w;
    hd.tex_h = h->tex_h;
    hd.blocks = h->blocks;
    hd.contact_mode = h->p.contact_mode;
    hd.flake_size = (int32_t)sizeof(snow_flake_t);
    hd.step = h->step;
    hd.shelter_check = h->shelter_check;
    hd.stats = h->stats;
    hd.payload_bytes = payload_bytes(h);
    unsigned char *o = (unsigned char *)buffer + sizeof hd;
    const size_t texels = (size_t)h->tex_w * (size_t)h->tex_h * (size_t)h->blocks;
    const size_t fb = sizeof(snow_flake_t) * (size_t)h->p.flake_count, tb = sizeof(float) * texels;
    for (int32_t j = 0; j < h->p.flake_count; ++j) /* by id, whatever slot each is in */
        memcpy(o + sizeof(snow_flake_t) * h->ids[j], &h->flakes[j], sizeof(snow_flake_t));
    memcpy(o + fb, h->coverage, tb);
    memcpy(o + fb + tb, h->depth, tb);
    uint64_t x = 0xcbf29ce484222325ULL; /* in the three parts hbk_snow_load_state hashes */
    x = hash_bytes(x, o, fb);
    x = hash_bytes(x, o + fb, tb);
    hd.checksum = hash_bytes(x, o + fb + tb, tb);
    memcpy(buffer, &hd, sizeof hd);
    return HBK_OK;
}

hbk_result_t hbk_snow_load_state(hbk_snow_t *h, const void *buffer, size_t size)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    if (!buffer) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "buffer: must not be NULL");
    state_header_t hd;
    if (size < sizeof hd)
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "size = %zu: too small for a snow state", size);
    memcpy(&hd, buffer, sizeof hd);
    if (memcmp(hd.magic, k_magic, sizeof hd.magic))
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "not a snow state (bad magic)");
    if (hd.version != STATE_VERSION)
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "snow state version %u: this library reads %d",
                        hd.version, STATE_VERSION);
    if (hd.header_size != sizeof hd || hd.flake_size != (int32_t)sizeof(snow_flake_t))
        return hbk_fail(&h->msg, HBK_ERR_FORMAT,
                        "snow state header size %u, flake size %d: this library's are %zu, %zu "
                        "(corrupt, or from another build)", (unsigned)hd.header_size,
                        (int)hd.flake_size, sizeof hd, sizeof(snow_flake_t));
    if (hd.flake_count != h->p.flake_count || hd.tex_w != h->tex_w || hd.tex_h != h->tex_h ||
        hd.blocks != h->blocks || hd.contact_mode != h->p.contact_mode)
        return hbk_fail(&h->msg, HBK_ERR_STATE,
                        "the state has flake_count %d, texture %dx%d x %d, contact_mode %d; this "
                        "handle %d, %dx%d x %d, %d", hd.flake_count, hd.tex_w, hd.tex_h,
                        hd.blocks, hd.contact_mode, h->p.flake_count, h->tex_w, h->tex_h,
                        h->blocks, h->p.contact_mode);
    if (hd.payload_bytes != payload_bytes(h) || size - sizeof hd < hd.payload_bytes)
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "size = %zu: the state needs %zu bytes", size,
                        sizeof hd + payload_bytes(h));
    const unsigned char *in = (const unsigned char *)buffer + sizeof hd;
    const size_t fb = sizeof(snow_flake_t) * (size_t)h->p.flake_count;
    const size_t tb = sizeof(float) * (size_t)h->tex_w * (size_t)h->tex_h * (size_t)h->blocks;
    /* The buffer may be unaligned: hash the bytes, copy with memcpy. */
    uint64_t x = 0xcbf29ce484222325ULL;
    x = hash_bytes(x, in, fb);
    x = hash_bytes(x, in + fb, tb);
    x = hash_bytes(x, in + fb + tb, tb);
    if (x != hd.checksum)
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "snow state checksum mismatch (corrupt)");
    /* The counters are outside the checksum; a run never makes one negative or near
     * INT64_MAX, where the next step's sums would overflow. */
    int64_t counters[sizeof hd.stats / sizeof(int64_t)];
    _Static_assert(sizeof counters == sizeof hd.stats, "hbk_snow_stats_t: int64_t counters only");
    memcpy(counters, &hd.stats, sizeof counters);
    for (size_t k = 0; k < sizeof counters / sizeof counters[0]; ++k)
        if (counters[k] < 0 || counters[k] > (int64_t)1 << 62)
            return hbk_fail(&h->msg, HBK_ERR_FORMAT, "snow state: statistics out of range");
    /* Into scratch first: the handle changes only if every flake is sane. */
    memcpy(h->scratch, in, fb);
    for (int32_t i = 0; i < h->p.flake_count; ++i) {
        const snow_flake_t *f = &h->scratch[i];
        if (!isfinite(f->p[0]) || !isfinite(f->p[1]) || !isfinite(f->p[2]) ||
            f->cls >= 2 * SNOW_FLUTTER_CLASSES)
            return hbk_fail(&h->msg, HBK_ERR_FORMAT, "snow state: flake %d is not valid", i);
    }
    snow_flake_t *t = h->flakes;
    h->flakes = h->scratch;
    h->scratch = t;
    snow_flakes_by_id(h);
    memcpy(h->coverage, in + fb, tb);
    memcpy(h->depth, in + fb + tb, tb);
    h->step = hd.step;
    h->shelter_check = hd.shelter_check != 0;
    h->stats = hd.stats;
    return HBK_OK;
}
