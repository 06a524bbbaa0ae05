/* Checkpoints of the fluid handle: a header, then fixed sections in a fixed order. */
#include "internal_fluid.h"
#include <stdlib.h>
#include <string.h>

static const char k_magic[8] = {'H', 'B', 'K', 'F', 'L', 'U', 'I', 'D'};
/* Version 2 added the obstacles' rotation (turned boxes), version 3 the meshes' distance
 * fields: after the sections, each obstacle's field dims (int32 x 3, zeros but for a mesh),
 * then the meshes' fields in obstacle order. Versions 1 and 2 still load (no meshes then;
 * version 1's obstacles in the 28-byte records of then: type, centre, extent). */
enum { STATE_VERSION = 3, STATE_HEADER = 64, OBSTACLE_V1_BYTES = 28 };
#define FIELD_DIMS_BYTES (sizeof(int32_t) * 3 * HBK_FLUID_MAX_OBSTACLES)

typedef struct header {
    char magic[8];
    uint32_t version;
    int32_t res[3], textures, max_particles, count, n_obs;
    int32_t have_fields, paint_active, has_in_vel, has_in_surface;
    uint64_t frame;
} header_t;
_Static_assert(sizeof(header_t) <= STATE_HEADER, "header fits");

/* What a section's bytes must be for the state to load (see check_section): FINITE values
 * also lie within lim, the setter's range for an input, else room beyond what a run reaches
 * (DERIVED: far from overflowing the arithmetic that reads them). */
enum { ANY, FINITE, NOT_NAN, OBSTACLES, OBSTACLES_V1, OBSTACLES_V2 };
#define DERIVED 1e18f
typedef struct section {
    void *p;
    size_t bytes;
    int check;
    const char *name;
    float lim;
} section_t;

/* The sections of a handle, given its particle count, input flags and the state's version. */
static int sections(hbk_fluid_t *h, int32_t count, int has_vel, int has_surf, uint32_t version,
                    section_t *s)
{
    const size_t nv = h->n_vert, nvox = h->n_vox, K = (size_t)h->K, F = HBK_FLUID_FEATURE_COUNT;
    int n = 0;
    s[n++] = (section_t){h->pos, 3 * (size_t)count * sizeof(float), FINITE, "particles", 1e5f};
    s[n++] = (section_t){h->vel, 3 * (size_t)count * sizeof(float), FINITE, "particles", 1e6f};
    if (version == 1)
        s[n++] = (section_t){h->obs, HBK_FLUID_MAX_OBSTACLES * OBSTACLE_V1_BYTES, OBSTACLES_V1,
                             "obstacles", 0};
    else
        s[n++] = (section_t){h->obs, sizeof h->obs, version == 2 ? OBSTACLES_V2 : OBSTACLES,
                             "obstacles", 0};
    s[n++] = (section_t){h->in_vel, has_vel ? 3 * nv * sizeof(float) : 0, FINITE,
                         "input velocity", 1e4f};
    s[n++] = (section_t){h->in_surface, has_surf ? nv * sizeof(float) : 0, FINITE,
                         "input surface", 1e9f};
    s[n++] = (section_t){h->v.uvw[0], 3 * nv * sizeof(float), FINITE, "uvw", DERIVED};
    s[n++] = (section_t){h->v.uvw[1], 3 * nv * sizeof(float), FINITE, "uvw", DERIVED};
    s[n++] = (section_t){h->v.wrap[0], nvox, ANY, "wrap flags", 0};
    s[n++] = (section_t){h->v.wrap[1], nvox, ANY, "wrap flags", 0};
    s[n++] = (section_t){h->v.base, K * nv * sizeof(float), FINITE, "blend", DERIVED};
    s[n++] = (section_t){h->v.paint, K * nv * sizeof(float), FINITE, "paint", DERIVED};
    s[n++] = (section_t){h->v.life, nv * sizeof(float), FINITE, "paint life", DERIVED};
    s[n++] = (section_t){h->motion, 3 * nv * sizeof(float), FINITE, "motion", DERIVED};
    s[n++] = (section_t){h->density, nv * sizeof(float), FINITE, "density", DERIVED};
    s[n++] = (section_t){h->surface, nv * sizeof(float), FINITE, "surface", DERIVED};
    s[n++] = (section_t){h->features, F * nv * sizeof(float), FINITE, "features", DERIVED};
    s[n++] = (section_t){h->rule_on, sizeof h->rule_on, ANY, "rules", 0};
    /* A bound may be infinite: -FLT_MAX .. FLT_MAX, or beyond, for "any". */
    s[n++] = (section_t){h->rule_lo, sizeof h->rule_lo, NOT_NAN, "rules", 0};
    s[n++] = (section_t){h->rule_hi, sizeof h->rule_hi, NOT_NAN, "rules", 0};
    return n;
}
#define MAX_SECTIONS 24

static size_t total(const section_t *s, int n)
{
    size_t t = STATE_HEADER;
    for (int i = 0; i < n; ++i) t += s[i].bytes;
    return t;
}

/* Bytes of one mesh's field, and of all of them, given the field dims. */
static size_t field_size(const int32_t d[3])
{
    return (size_t)d[0] * (size_t)d[1] * (size_t)d[2] * sizeof(float);
}

static size_t field_bytes(const int32_t dims[][3])
{
    size_t t = 0;
    for (int i = 0; i < HBK_FLUID_MAX_OBSTACLES; ++i) t += field_size(dims[i]);
    return t;
}

size_t hbk_fluid_state_size(const hbk_fluid_t *h)
{
    if (!h) return 0;
    section_t s[MAX_SECTIONS];
    const int n = sections((hbk_fluid_t *)h, h->count, h->in_vel != NULL, h->in_surface != NULL,
                           STATE_VERSION, s);
    return total(s, n) + FIELD_DIMS_BYTES + field_bytes(h->obs_dims);
}

hbk_result_t hbk_fluid_save_state(hbk_fluid_t *h, void *buffer, size_t size)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    if (!buffer) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "buffer: must not be NULL");
    section_t s[MAX_SECTIONS];
    const int n = sections(h, h->count, h->in_vel != NULL, h->in_surface != NULL, STATE_VERSION,
                           s);
    const size_t need = total(s, n) + FIELD_DIMS_BYTES + field_bytes(h->obs_dims);
    if (size < need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "size = %zu: must be >= hbk_fluid_state_size() = %zu", size, need);
    header_t hd;
    memset(&hd, 0, sizeof hd);
    memcpy(hd.magic, k_magic, 8);
    hd.version = STATE_VERSION;
    for (int a = 0; a < 3; ++a) hd.res[a] = h->p.resolution[a];
    hd.textures = h->K;
    hd.max_particles = h->p.max_particles;
    hd.count = h->count;
    hd.n_obs = h->n_obs;
    hd.have_fields = h->have_fields;
    hd.paint_active = h->paint_active;
    hd.has_in_vel = h->in_vel != NULL;
    hd.has_in_surface = h->in_surface != NULL;
    hd.frame = h->frame;
    unsigned char *at = buffer;
    memset(at, 0, STATE_HEADER);
    memcpy(at, &hd, sizeof hd);
    at += STATE_HEADER;
    for (int i = 0; i < n; ++i) {
        if (s[i].bytes) memcpy(at, s[i].p, s[i].bytes);
        at += s[i].bytes;
    }
    memcpy(at, h->obs_dims, FIELD_DIMS_BYTES);
    at += FIELD_DIMS_BYTES;
    for (int i = 0; i < HBK_FLUID_MAX_OBSTACLES; ++i) {
        const size_t b = field_size(h->obs_dims[i]);
        if (b) memcpy(at, h->obs_field[i], b);
        at += b;
    }
    return HBK_OK;
}

/* A version 1 record (type, centre, extent) as an obstacle; 0 if its type is not one of then. */
static int obstacle_v1(const unsigned char *p, hbk_fluid_obstacle_t *o)
{
    memset(o, 0, sizeof *o);
    memcpy(&o->type, p, 4);
    memcpy(o->center, p + 4, 12);
    memcpy(o->extent, p + 16, 12);
    o->rotation[0] = 1.0f;
    return o->type == 0 || o->type == 1;
}

/* Whether a section's bytes (at p, perhaps unaligned) are what a run can hold: a NaN or an
 * infinity would spread through the simulation, an obstacle set_obstacles refuses would too. */
static int check_section(const section_t *s, const unsigned char *p, int32_t n_obs)
{
    if (s->check == OBSTACLES || s->check == OBSTACLES_V1 || s->check == OBSTACLES_V2) {
        for (int32_t i = 0; i < n_obs; ++i) {
            hbk_fluid_obstacle_t o;
            if (s->check == OBSTACLES_V1) {
                if (!obstacle_v1(p + (size_t)i * OBSTACLE_V1_BYTES, &o)) return 0;
            } else {
                memcpy(&o, p + (size_t)i * sizeof o, sizeof o);
            }
            if (hbk_fluid_obstacle_problem(&o, NULL)) return 0;
            if (s->check == OBSTACLES_V2 && o.type == 3) return 0; /* no meshes then */
        }
        return 1;
    }
    for (size_t i = 0; s->check != ANY && i < s->bytes / 4; ++i) {
        float f;
        memcpy(&f, p + 4 * i, 4);
        if (s->check == FINITE ? !(fabsf(f) <= s->lim) : isnan(f)) return 0;
    }
    return 1;
}

/* The fields of a version 3 state, after its sections at ``at``: their dims (a mesh's each in
 * [2, max], or all 0 for one whose field was not set yet; 0 for the others, ``obs`` being the
 * state's obstacle records) and values (finite, within +-1e6), copied into fresh buffers. */
static hbk_result_t read_fields(hbk_fluid_t *h, const unsigned char *obs, int32_t n_obs,
                                const unsigned char *buffer, size_t size, size_t at,
                                int32_t dims[][3], float **fields)
{
    if (size < at + FIELD_DIMS_BYTES)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "size = %zu: this state needs %zu bytes", size, at + FIELD_DIMS_BYTES);
    memcpy(dims, buffer + at, FIELD_DIMS_BYTES);
    at += FIELD_DIMS_BYTES;
    for (int i = 0; i < HBK_FLUID_MAX_OBSTACLES; ++i) {
        int32_t type = -1;
        if (i < n_obs) memcpy(&type, obs + (size_t)i * sizeof(hbk_fluid_obstacle_t), 4);
        const int none = !dims[i][0] && !dims[i][1] && !dims[i][2];
        int ok = none;
        if (type == 3 && !none) {
            ok = 1;
            for (int a = 0; a < 3; ++a)
                ok &= dims[i][a] >= 2 && dims[i][a] <= HBK_FLUID_FIELD_MAX_DIM;
        }
        if (!ok)
            return hbk_fail(&h->msg, HBK_ERR_FORMAT,
                            "state obstacle %d field dims (%d, %d, %d): not a mesh's field", i,
                            dims[i][0], dims[i][1], dims[i][2]);
    }
    const size_t need = at + field_bytes((const int32_t(*)[3])dims);
    if (size < need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "size = %zu: this state needs %zu bytes",
                        size, need);
    for (int i = 0; i < HBK_FLUID_MAX_OBSTACLES; ++i) {
        const size_t n = field_size(dims[i]) / sizeof(float);
        if (!n) continue;
        fields[i] = malloc(n * sizeof(float));
        if (!fields[i]) {
            for (int k = 0; k < i; ++k) free(fields[k]);
            return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "state: out of memory");
        }
        memcpy(fields[i], buffer + at, n * sizeof(float));
        at += n * sizeof(float);
        for (size_t k = 0; k < n; ++k)
            if (!(fabsf(fields[i][k]) <= 1e6f)) {
                for (int j = 0; j <= i; ++j) free(fields[j]);
                return hbk_fail(&h->msg, HBK_ERR_FORMAT,
                                "state obstacle fields: not all valid numbers (finite, within "
                                "+-1e6)");
            }
    }
    return HBK_OK;
}

hbk_result_t hbk_fluid_load_state(hbk_fluid_t *h, const void *buffer, size_t size)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    if (!buffer) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "buffer: must not be NULL");
    header_t hd;
    if (size < STATE_HEADER) return hbk_fail(&h->msg, HBK_ERR_FORMAT, "buffer: not a fluid state (too short)");
    memcpy(&hd, buffer, sizeof hd);
    if (memcmp(hd.magic, k_magic, 8))
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "buffer: not a fluid state (bad header)");
    if (hd.version < 1 || hd.version > STATE_VERSION)
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "state version = %u: this library reads 1 to %u",
                        hd.version, (unsigned)STATE_VERSION);
    for (int a = 0; a < 3; ++a)
        if (hd.res[a] != h->p.resolution[a])
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "state resolution[%d] = %d: must equal the handle's, %d", a, hd.res[a],
                            h->p.resolution[a]);
    if (hd.textures != h->K)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "state textures = %d: must equal the handle's, %d", hd.textures, h->K);
    if (hd.count < 0 || hd.count > h->p.max_particles)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "state particle count = %d: must be in [0, %d] (max_particles)", hd.count,
                        h->p.max_particles);
    if (hd.n_obs < 0 || hd.n_obs > HBK_FLUID_MAX_OBSTACLES)
        return hbk_fail(&h->msg, HBK_ERR_FORMAT, "state obstacle count = %d: invalid", hd.n_obs);
    section_t s[MAX_SECTIONS];
    const int n = sections(h, hd.count, hd.has_in_vel != 0, hd.has_in_surface != 0, hd.version, s);
    const size_t need = total(s, n);
    if (size < need)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "size = %zu: this state needs %zu bytes",
                        size, need);
    if (hd.version < STATE_VERSION && size != need) /* a later state under an old number */
        return hbk_fail(&h->msg, HBK_ERR_FORMAT,
                        "size = %zu: a version %u state of this header is exactly %zu bytes",
                        size, hd.version, need);
    /* Check before changing anything: a NaN would spread through the simulation. */
    const unsigned char *body = (const unsigned char *)buffer + STATE_HEADER, *q = body;
    for (int i = 0; i < n; q += s[i].bytes, ++i)
        if (!check_section(&s[i], q, hd.n_obs))
            return hbk_fail(&h->msg, HBK_ERR_FORMAT,
                            s[i].check == FINITE ? "state %s: not all valid numbers (finite, "
                                                   "within +-%g)"
                                                 : "state %s: not all valid numbers",
                            s[i].name, (double)s[i].lim);
    /* Version 3: the meshes' fields after the sections, made before anything changes. */
    int32_t dims[HBK_FLUID_MAX_OBSTACLES][3];
    float *fields[HBK_FLUID_MAX_OBSTACLES] = {NULL};
    memset(dims, 0, sizeof dims);
    if (hd.version >= 3) {
        const unsigned char *obs = body + s[0].bytes + s[1].bytes; /* after the particles */
        hbk_result_t r = read_fields(h, obs, hd.n_obs, (const unsigned char *)buffer, size, need,
                                     dims, fields);
        if (r) return r;
    }
    float *nv_in = NULL, *ns_in = NULL;
    if ((hd.has_in_vel && !h->in_vel && !(nv_in = malloc(s[3].bytes))) ||
        (hd.has_in_surface && !h->in_surface && !(ns_in = malloc(s[4].bytes)))) {
        free(nv_in);
        for (int i = 0; i < HBK_FLUID_MAX_OBSTACLES; ++i) free(fields[i]);
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "state: out of memory");
    }
    if (nv_in) h->in_vel = nv_in;
    if (ns_in) h->in_surface = ns_in;
    if (!hd.has_in_vel) { free(h->in_vel); h->in_vel = NULL; }
    if (!hd.has_in_surface) { free(h->in_surface); h->in_surface = NULL; }
    /* the new input buffers */
    sections(h, hd.count, hd.has_in_vel != 0, hd.has_in_surface != 0, hd.version, s);
    const unsigned char *at = body;
    for (int i = 0; i < n; ++i) {
        if (s[i].check == OBSTACLES_V1) {
            memset(h->obs, 0, sizeof h->obs);
            for (int32_t k = 0; k < hd.n_obs; ++k)
                obstacle_v1(at + (size_t)k * OBSTACLE_V1_BYTES, &h->obs[k]);
        } else if (s[i].bytes) {
            memcpy(s[i].p, at, s[i].bytes);
        }
        at += s[i].bytes;
    }
    hbk_fluid_fields_free(h);
    memcpy(h->obs_field, fields, sizeof fields);
    memcpy(h->obs_dims, dims, sizeof dims);
    h->count = hd.count;
    h->n_obs = hd.n_obs;
    h->obs_moving = 0; /* a pending move was made for the obstacles replaced */
    h->have_fields = hd.have_fields;
    h->paint_active = hd.paint_active;
    h->frame = hd.frame;
    h->wrap_checked = 0; /* the next advection repairs every voxel's flags */
    memset(h->v.unpainted, 0, h->n_rows); /* not known */
    hbk_fluid_vols_differ(h);
    memset(h->blank, 0, h->n_rows); /* the fields are new */
    memset(h->fz, 0, h->n_rows);
    memset(h->fq, 0, h->n_rows);
    if (!h->paint_active) hbk_fluid_paint_off(h);
    return HBK_OK;
}
