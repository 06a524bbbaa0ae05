/* The paper's contact (§3.2.1): one bounding box per part, entry face from Q and P, and the
 * hit point R on that face's plane mapped into one of six tiles per box. */
#include "internal_snow.h"
#include <math.h>

int snow_box_hit(const snow_mesh_t *m, const float q[3], const float d[3], float *t_out,
                 int32_t *box_out, int32_t *face_out)
{
    float best = INFINITY;
    int found = 0;
    float inv[3];
    for (int k = 0; k < 3; ++k) inv[k] = 1.0f / (d[k] != 0.0f ? d[k] : copysignf(1e-30f, d[k]));
    for (int32_t b = 0; b < m->box_count; ++b) {
        const snow_box_t *bx = &m->boxes[b];
        if (!bx->valid) continue;
        float tn = -INFINITY, tf = INFINITY;
        int axis = 0;
        for (int k = 0; k < 3; ++k) {
            float t0 = (bx->lo[k] - q[k]) * inv[k], t1 = (bx->hi[k] - q[k]) * inv[k];
            float a = fminf(t0, t1), c = fmaxf(t0, t1);
            if (a > tn) { tn = a; axis = k; }
            tf = fminf(tf, c);
        }
        /* Q outside (tn >= 0) and the segment enters before P: the face between Q and P. */
        if (tn >= 0.0f && tn <= tf && tn <= 1.0f && tn < best) {
            best = tn;
            *box_out = b;
            *face_out = 2 * axis + (d[axis] > 0.0f); /* moving up an axis enters its min face */
            found = 1;
        }
    }
    if (found) *t_out = best;
    return found;
}

void snow_box_normal(int32_t face, float n[3])
{
    n[0] = n[1] = n[2] = 0.0f;
    n[face / 2] = (face & 1) ? -1.0f : 1.0f;
}

static void tile_size(const hbk_snow_t *h, int32_t *tw, int32_t *th)
{
    *tw = h->tex_w / 3;
    *th = h->tex_h / 2;
}

void snow_box_tile(const hbk_snow_t *h, int32_t box, int32_t face, int32_t rect[4])
{
    int32_t tw, th;
    tile_size(h, &tw, &th);
    const int32_t col = face / 2, row = (face & 1) ? 0 : 1; /* minus faces in the bottom row */
    rect[0] = col * tw;
    rect[1] = box * h->tex_h + row * th;
    rect[2] = rect[0] + tw;
    rect[3] = rect[1] + th;
}

void snow_box_face_texel(const hbk_snow_t *h, int32_t box, int32_t face, const float x[3],
                         float *tx, float *ty, float *sx, float *sy)
{
    /* (u axis, u sign, v axis, v sign) per face: seen from outside, sides upright. */
    static const int8_t k_axes[6][4] = {
        {1, 1, 2, 1},  /* +X: +Y, +Z */
        {1, -1, 2, 1}, /* -X: -Y, +Z */
        {0, -1, 2, 1}, /* +Y: -X, +Z */
        {0, 1, 2, 1},  /* -Y: +X, +Z */
        {0, 1, 1, 1},  /* +Z: +X, +Y */
        {0, 1, 1, -1}, /* -Z: +X, -Y */
    };
    const snow_box_t *b = &h->mesh.boxes[box];
    const int8_t *a = k_axes[face];
    float uv[2], ext[2];
    for (int i = 0; i < 2; ++i) {
        const int ax = a[2 * i];
        ext[i] = fmaxf(b->hi[ax] - b->lo[ax], 1e-6f); /* a flat part has no extent */
        float f = (x[ax] - b->lo[ax]) / ext[i];
        uv[i] = a[2 * i + 1] > 0 ? f : 1.0f - f;
    }
    int32_t rect[4];
    snow_box_tile(h, box, face, rect);
    const float tw = (float)(rect[2] - rect[0]), th = (float)(rect[3] - rect[1]);
    *tx = (float)rect[0] + uv[0] * tw;
    *ty = (float)rect[1] + uv[1] * th;
    const float dia = 2.0f * h->p.flake_radius;
    *sx = fminf(dia * tw / ext[0], tw);
    *sy = fminf(dia * th / ext[1], th);
}
