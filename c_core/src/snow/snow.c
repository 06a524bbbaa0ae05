/* The snow handle: create, materials, mesh, step, outputs. */
#include "internal_snow.h"
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define MAX_SLOTS 65536
#define MAX_TRIANGLES (1 << 26)
#define MAX_VERTICES (1 << 28)

hbk_result_t snow_textures_alloc(hbk_snow_t *h, int32_t blocks)
{
    const size_t n = (size_t)h->tex_w * (size_t)h->tex_h * (size_t)blocks;
    float *c = calloc(n, sizeof *c), *d = calloc(n, sizeof *d);
    if (!c || !d) {
        free(c);
        free(d);
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "out of memory for %zu texels", n);
    }
    free(h->coverage);
    free(h->depth);
    h->coverage = c;
    h->depth = d;
    h->blocks = blocks;
    return HBK_OK;
}

static void mesh_free(snow_mesh_t *m)
{
    snow_bvh_free(&m->bvh);
    snow_grid_free(&m->grid);
    free(m->info);
    free(m->boxes);
    memset(m, 0, sizeof *m);
}

void hbk_snow_destroy(hbk_snow_t *h)
{
    if (!h) return;
    free(h->flakes);
    free(h->scratch);
    free(h->ids);
    free(h->ids_spare);
    mesh_free(&h->mesh);
    free(h->materials);
    free(h->chance);
    free(h->coverage);
    free(h->depth);
    for (int i = 0; i < h->tev_count; ++i) free(h->tev[i].e);
    free(h->tev);
    free(h->all.e);
    free(h);
}

const char *hbk_snow_message(const hbk_snow_t *h) { return h ? h->msg.text : ""; }

/* Copies the slots and their sticking chances, all or nothing. */
static hbk_result_t store_materials(hbk_snow_t *h, const hbk_snow_material_t *m, int32_t count)
{
    hbk_snow_material_t *mm = malloc(sizeof *mm * (size_t)count);
    float *ch = malloc(sizeof *ch * (size_t)count);
    if (!mm || !ch) {
        free(mm);
        free(ch);
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "out of memory for %d materials", count);
    }
    memcpy(mm, m, sizeof *mm * (size_t)count);
    for (int32_t i = 0; i < count; ++i)
        ch[i] = hbk_snow_hit_chance(&h->p, h->p.temperature, m[i].catch_chance);
    free(h->materials);
    free(h->chance);
    h->materials = mm;
    h->chance = ch;
    h->material_count = count;
    return HBK_OK;
}

hbk_result_t hbk_snow_create(hbk_snow_t **out, const hbk_snow_params_t *p, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (!out) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out: must not be NULL");
    *out = NULL;
    hbk_result_t r = snow_params_check(p, msg);
    if (r) return r;
    if (p->contact_mode == HBK_SNOW_CONTACT_BOX && (p->texture_width < 3 || p->texture_height < 2))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "texture_width x texture_height = %d x %d: must be at least 3 x 2 in "
                        "BOX mode (six tiles per box)", p->texture_width, p->texture_height);
    hbk_snow_t *h = calloc(1, sizeof *h);
    if (!h) return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "out of memory");
    h->p = *p;
    h->tex_w = p->texture_width;
    h->tex_h = p->texture_height;
    const size_t n = (size_t)p->flake_count;
    h->flakes = malloc(sizeof *h->flakes * n);
    h->scratch = malloc(sizeof *h->scratch * n);
    h->ids = malloc(sizeof *h->ids * n);
    h->ids_spare = malloc(sizeof *h->ids_spare * n);
    const hbk_snow_material_t def = {0.0f, 0, 0};
    if (!h->flakes || !h->scratch || !h->ids || !h->ids_spare || store_materials(h, &def, 1) ||
        snow_textures_alloc(h, 1)) {
        hbk_snow_destroy(h);
        return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "out of memory for %zu flakes and %d x %d "
                        "texels", n, p->texture_width, p->texture_height);
    }
    snow_flakes_init(h);
    *out = h;
    return HBK_OK;
}

hbk_result_t hbk_snow_set_materials(hbk_snow_t *h, const hbk_snow_material_t *m, int32_t count)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    if (!m) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "materials: must not be NULL");
    if (count < 1 || count > MAX_SLOTS)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "count = %d: must be in [1, %d]",
                        count, MAX_SLOTS);
    for (int32_t i = 0; i < count; ++i) {
        if (!(m[i].catch_chance >= 0.0f && m[i].catch_chance <= 0.5f))
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "materials[%d].catch_chance = %g: must be in [0, 0.5]", i,
                            (double)m[i].catch_chance);
        if (m[i].melts != 0 && m[i].melts != 1)
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "materials[%d].melts = %d: must be 0 or 1", i, m[i].melts);
        if (m[i].sheds != 0 && m[i].sheds != 1)
            return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                            "materials[%d].sheds = %d: must be 0 or 1", i, m[i].sheds);
    }
    if (h->mesh.tri_count > 0 && count <= h->mesh.max_material)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "count = %d: the mesh uses material slot %d", count, h->mesh.max_material);
    if (h->p.contact_mode == HBK_SNOW_CONTACT_BOX &&
        (int64_t)count * h->p.texture_height > 65536) /* the largest image the outputs take */
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "count = %d: BOX mode stacks one %d-texel-high block per slot, and %d "
                        "of them pass 65536 texels; must be in [1, %d] at this texture_height",
                        count, h->p.texture_height, count, 65536 / h->p.texture_height);
    if (h->p.contact_mode == HBK_SNOW_CONTACT_BOX && count != h->blocks) {
        if (h->step > 0)
            return hbk_fail(&h->msg, HBK_ERR_STATE,
                            "count = %d: BOX mode holds one texture block per slot, and snow "
                            "was laid with %d; set the slots before the first step", count,
                            h->blocks);
        float *oc = h->coverage, *od = h->depth;
        const int32_t ob = h->blocks;
        h->coverage = h->depth = NULL;
        hbk_result_t r = snow_textures_alloc(h, count);
        /* The slots too before the old textures go: blocks must never differ from the slot
         * count, or a mesh using a slot past the blocks is stamped outside the textures. */
        if (!r) r = store_materials(h, m, count);
        if (r) {
            free(h->coverage);
            free(h->depth);
            h->coverage = oc; h->depth = od; h->blocks = ob;
            return r;
        }
        free(oc);
        free(od);
        return HBK_OK;
    }
    return store_materials(h, m, count);
}

/* Finite and within 1e6 m: the mesh's extent, its edges' cross products and the occupancy
 * grid's cells then all stay finite floats (a mesh spanning more than FLT_MAX made NaN cell
 * counts). The snow volume itself is at most 1e5 m from the origin. */
static int position_ok(const float *v)
{
    return fabsf(v[0]) <= 1e6f && fabsf(v[1]) <= 1e6f && fabsf(v[2]) <= 1e6f;
}

/* Texels per metre along the texture's x and y at this triangle: the rows of the Jacobian
 * from orthonormal surface coordinates to texel coordinates. */
static void texel_density(const float *p0, const float *p1, const float *p2, const float *uv,
                          float dens[2], float n[3])
{
    float e1[3], e2[3], c[3];
    for (int k = 0; k < 3; ++k) { e1[k] = p1[k] - p0[k]; e2[k] = p2[k] - p0[k]; }
    c[0] = e1[1] * e2[2] - e1[2] * e2[1];
    c[1] = e1[2] * e2[0] - e1[0] * e2[2];
    c[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const float cl = sqrtf(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
    const float a = sqrtf(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
    dens[0] = dens[1] = 0.0f;
    n[0] = n[1] = 0.0f;
    n[2] = 1.0f;
    if (!(cl > 0.0f) || !(a > 0.0f)) return; /* degenerate: never hit */
    for (int k = 0; k < 3; ++k) n[k] = c[k] / cl;
    float t[3], b[3];
    for (int k = 0; k < 3; ++k) t[k] = e1[k] / a;
    b[0] = n[1] * t[2] - n[2] * t[1];
    b[1] = n[2] * t[0] - n[0] * t[2];
    b[2] = n[0] * t[1] - n[1] * t[0];
    const float e2t = e2[0] * t[0] + e2[1] * t[1] + e2[2] * t[2];
    const float e2b = e2[0] * b[0] + e2[1] * b[1] + e2[2] * b[2];
    const float det = a * e2b;
    if (!(fabsf(det) > 0.0f)) return;
    for (int r = 0; r < 2; ++r) {
        const float d1 = uv[2 + r] - uv[r], d2 = uv[4 + r] - uv[r];
        const float j0 = d1 * e2b / det, j1 = (d2 * a - d1 * e2t) / det;
        dens[r] = sqrtf(j0 * j0 + j1 * j1);
    }
}

hbk_result_t hbk_snow_set_mesh(hbk_snow_t *h, const float *positions, int32_t vertex_count,
                               const int32_t *triangles, const float *uvs,
                               const int32_t *material_index, int32_t triangle_count)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    hbk_message_t *msg = &h->msg;
    const int box = h->p.contact_mode == HBK_SNOW_CONTACT_BOX;
    if (triangle_count < 0 || triangle_count > MAX_TRIANGLES)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "triangle_count = %d: must be in [0, %d]",
                        triangle_count, MAX_TRIANGLES);
    if (triangle_count == 0) {
        mesh_free(&h->mesh);
        h->shelter_check = 0;
        return HBK_OK;
    }
    if (vertex_count < 1 || vertex_count > MAX_VERTICES)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "vertex_count = %d: must be in [1, %d]",
                        vertex_count, MAX_VERTICES);
    if (!positions) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "positions: must not be NULL");
    if (!triangles) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "triangles: must not be NULL");
    if (!uvs && !box)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "uvs: must not be NULL in TRIANGLES mode (snow goes into the UV map)");
    for (int32_t i = 0; i < vertex_count; ++i)
        if (!position_ok(positions + 3 * (size_t)i))
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                            "positions[%d] = (%g, %g, %g): must be finite, |x|, |y|, |z| "
                            "<= 1e6 m", i,
                            (double)positions[3 * (size_t)i], (double)positions[3 * (size_t)i + 1],
                            (double)positions[3 * (size_t)i + 2]);
    int32_t max_mat = 0;
    for (int32_t t = 0; t < triangle_count; ++t) {
        for (int k = 0; k < 3; ++k) {
            const int32_t v = triangles[3 * (size_t)t + k];
            if (v < 0 || v >= vertex_count)
                return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                                "triangles[%zu] = %d: must be in [0, %d) (vertex_count)",
                                3 * (size_t)t + k, v, vertex_count);
        }
        if (uvs)
            for (int k = 0; k < 6; ++k) {
                const float u = uvs[6 * (size_t)t + k];
                if (!isfinite(u) || fabsf(u) > 1e6f)
                    return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                                    "uvs[%zu] = %g: must be finite, |uv| <= 1e6",
                                    6 * (size_t)t + k, (double)u);
            }
        if (material_index) {
            const int32_t mi = material_index[t];
            if (mi < 0 || mi >= h->material_count)
                return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                                "material_index[%d] = %d: must be in [0, %d) (the material slots "
                                "set)", t, mi, h->material_count);
            if (mi > max_mat) max_mat = mi;
        }
    }

    snow_mesh_t m = {0};
    m.tri_count = triangle_count;
    m.max_material = max_mat;
    m.info = malloc(sizeof *m.info * (size_t)triangle_count);
    if (!m.info) goto oom;
    for (int32_t t = 0; t < triangle_count; ++t) {
        snow_tri_info_t *ti = &m.info[t];
        const int32_t *tv = triangles + 3 * (size_t)t;
        for (int k = 0; k < 3; ++k) {
            ti->uv[2 * k] = uvs ? uvs[6 * (size_t)t + 2 * k] * (float)h->tex_w : 0.0f;
            ti->uv[2 * k + 1] = uvs ? uvs[6 * (size_t)t + 2 * k + 1] * (float)h->tex_h : 0.0f;
        }
        texel_density(positions + 3 * (size_t)tv[0], positions + 3 * (size_t)tv[1],
                      positions + 3 * (size_t)tv[2], ti->uv, ti->dens, ti->n);
        ti->material = material_index ? material_index[t] : 0;
    }
    if (box) {
        /* One box per slot in use: the paper's part. */
        m.box_count = max_mat + 1;
        m.boxes = calloc((size_t)m.box_count, sizeof *m.boxes);
        if (!m.boxes) goto oom;
        for (int32_t t = 0; t < triangle_count; ++t) {
            snow_box_t *b = &m.boxes[m.info[t].material];
            for (int c = 0; c < 3; ++c) {
                const float *v = positions + 3 * (size_t)triangles[3 * (size_t)t + c];
                for (int k = 0; k < 3; ++k) {
                    b->lo[k] = b->valid ? fminf(b->lo[k], v[k]) : v[k];
                    b->hi[k] = b->valid ? fmaxf(b->hi[k], v[k]) : v[k];
                }
                b->valid = 1;
            }
        }
    } else if (snow_bvh_build(&m.bvh, positions, triangles, triangle_count) ||
               snow_grid_build(&m.grid, positions, triangles, triangle_count, m.bvh.nodes[0].lo,
                               m.bvh.nodes[0].hi)) {
        goto oom;
    }
    mesh_free(&h->mesh);
    h->mesh = m;
    h->shelter_check = 1;
    return HBK_OK;
oom:
    mesh_free(&m);
    return hbk_fail(msg, HBK_ERR_OUT_OF_MEMORY, "out of memory for %d triangles", triangle_count);
}

hbk_result_t hbk_snow_step(hbk_snow_t *h, int32_t substeps, hbk_progress_t *progress)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    if (substeps < 1 || substeps > 1000000)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "substeps = %d: must be in [1, 1000000]",
                        substeps);
    return snow_flakes_step(h, substeps, progress);
}

void hbk_snow_texture_size(const hbk_snow_t *h, int32_t *width, int32_t *height)
{
    if (width) *width = h ? h->tex_w : 0;
    if (height) *height = h ? h->tex_h * h->blocks : 0;
}

static hbk_result_t check_out_image(hbk_snow_t *h, const hbk_image_t *img, const char *name,
                                    int32_t channels)
{
    hbk_result_t r = hbk_image_check(img, name, &h->msg);
    if (r) return r;
    if (img->channels != channels)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "%s.channels = %d: must be %d", name,
                        img->channels, channels);
    int32_t w, ht;
    hbk_snow_texture_size(h, &w, &ht);
    if (img->width != w || img->height != ht)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "%s size = %dx%d: must be %dx%d (hbk_snow_texture_size)", name,
                        img->width, img->height, w, ht);
    return HBK_OK;
}

hbk_result_t hbk_snow_coverage(hbk_snow_t *h, hbk_image_t *rgba)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    hbk_result_t r = check_out_image(h, rgba, "rgba", 4);
    if (r) return r;
    const int32_t w = rgba->width, ht = rgba->height;
    for (int32_t y = 0; y < ht; ++y) {
        float *row = rgba->data + (size_t)y * rgba->row_stride;
        const float *c = h->coverage + (size_t)y * (size_t)w;
        for (int32_t x = 0; x < w; ++x) {
            row[4 * x] = row[4 * x + 1] = row[4 * x + 2] = 1.0f;
            row[4 * x + 3] = c[x] * (1.0f / 255.0f);
        }
    }
    return HBK_OK;
}

hbk_result_t hbk_snow_depth(hbk_snow_t *h, hbk_image_t *depth)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    hbk_result_t r = check_out_image(h, depth, "depth", 1);
    if (r) return r;
    for (int32_t y = 0; y < depth->height; ++y)
        memcpy(depth->data + (size_t)y * depth->row_stride,
               h->depth + (size_t)y * (size_t)depth->width, sizeof(float) * (size_t)depth->width);
    return HBK_OK;
}

hbk_result_t hbk_snow_flakes(hbk_snow_t *h, float *xyz, int32_t capacity, int32_t *count)
{
    if (!h) return HBK_ERR_INVALID_ARGUMENT;
    hbk_message_clear(&h->msg);
    if (!count) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "count: must not be NULL");
    if (capacity < 0)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "capacity = %d: must be >= 0", capacity);
    if (capacity > 0 && !xyz)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "xyz: must not be NULL when capacity = %d", capacity);
    const int32_t n = capacity < h->p.flake_count ? capacity : h->p.flake_count;
    for (int32_t j = 0; j < h->p.flake_count; ++j) /* from its slot to its id's place */
        if (h->ids[j] < (uint32_t)n)
            memcpy(xyz + 3 * (size_t)h->ids[j], h->flakes[j].p, 3 * sizeof(float));
    *count = h->p.flake_count;
    return HBK_OK;
}

void hbk_snow_stats(const hbk_snow_t *h, hbk_snow_stats_t *out)
{
    if (!out) return;
    if (!h) { memset(out, 0, sizeof *out); return; }
    *out = h->stats;
}
