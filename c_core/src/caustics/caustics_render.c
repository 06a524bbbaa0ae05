/* hbk_caustics_render: checks, then trace vertices -> weigh triangles -> rasterise. */
#include "internal_caustics.h"
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

hbk_result_t hbk_caustics_check_inputs(const hbk_caustics_params_t *p, const hbk_image_t *water,
                                       const hbk_image_t *ground, float cell_size,
                                       hbk_message_t *msg)
{
    hbk_result_t r = hbk_caustics_params_check(p, msg);
    if (r || (r = hbk_image_check(water, "water_height", msg)) ||
        (r = hbk_image_check(ground, "ground_height", msg)))
        return r;
    if (water->channels != 1 || ground->channels != 1)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "%s.channels = %d: must be 1",
                        water->channels != 1 ? "water_height" : "ground_height",
                        water->channels != 1 ? water->channels : ground->channels);
    if (ground->width != water->width || ground->height != water->height)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "ground_height size = %d x %d: must equal water_height's, %d x %d",
                        ground->width, ground->height, water->width, water->height);
    if (water->width < 2 || water->height < 2)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "water_height size = %d x %d: must be at least 2 x 2", water->width,
                        water->height);
    if (!(cell_size >= 1e-5f && cell_size <= 1e4f))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "cell_size = %g: must be a finite number in [1e-05, 10000] m",
                        (double)cell_size);
    r = hbk_image_check_values(water, "water_height", -1e6, 1e6, "m", msg);
    return r ? r : hbk_image_check_values(ground, "ground_height", -1e6, 1e6, "m", msg);
}

void hbk_caustics_init(hbk_caustics_ctx_t *c, hbk_caustics_workspace_t *ws,
                       const hbk_caustics_params_t *p, const hbk_image_t *water,
                       const hbk_image_t *ground, float cell_size)
{
    memset(c, 0, sizeof *c);
    c->ws = ws;
    c->p = p;
    c->water = water->data;
    c->ground = ground->data;
    c->water_stride = water->row_stride;
    c->ground_stride = ground->row_stride;
    c->W = water->width;
    c->H = water->height;
    c->dx = cell_size;
    c->inv_dx = 1.0 / c->dx;
    c->wet_depth = p->wet_depth;
    c->periodic = p->periodic;
    c->threads = hbk_threads(p->threads);
    c->point = p->light_type == HBK_LIGHT_POINT;
    const double len = sqrt((double)p->light_direction[0] * p->light_direction[0] +
                            (double)p->light_direction[1] * p->light_direction[1] +
                            (double)p->light_direction[2] * p->light_direction[2]);
    for (int k = 0; k < 3; ++k) {
        c->L[k] = c->point ? 0.0 : p->light_direction[k] / len;
        c->lpos[k] = p->light_position[k];
        c->E[k] = p->irradiance[k];
    }
    /* One pass when the index is the same for all channels; else one per channel. */
    c->ng = p->ior[0] == p->ior[1] && p->ior[1] == p->ior[2] ? 1 : 3;
    c->mono = c->ng == 1 && p->absorption[0] == p->absorption[1] &&
              p->absorption[1] == p->absorption[2];
    c->nch = c->ng == 1 && !c->mono ? 3 : 1;
    c->ps = c->mono ? 1 : 3;
    for (int k = 0; k < 3; ++k) {
        c->Ew[k] = c->mono ? 1.0 : c->E[k];
        c->escale[k] = c->mono ? c->E[k] : 1.0;
    }
    for (int g = 0; g < c->ng; ++g) {
        c->ior[g] = p->ior[g];
        c->eta[g] = 1.0 / p->ior[g];
        for (int ch = 0; ch < c->nch; ++ch) {
            c->sigma[g][ch] = p->absorption[c->ng == 1 && !c->mono ? ch : g];
            c->absorb |= c->sigma[g][ch] > 0.0;
        }
    }
    if (p->auto_extent) {
        c->ex0 = c->ey0 = 0.0;
        c->sx = 1.0 / c->dx; /* scaled by the map size in render */
        c->sy = 1.0 / c->dx;
    }
}

hbk_result_t hbk_caustics_render(const hbk_caustics_params_t *p, const hbk_image_t *water_height,
                                 const hbk_image_t *ground_height, float cell_size,
                                 hbk_image_t *out, hbk_caustics_stats_t *stats,
                                 hbk_progress_t *progress, hbk_message_t *msg)
{
    hbk_caustics_workspace_t ws = {0};
    const hbk_result_t r = hbk_caustics_render_with(&ws, p, water_height, ground_height, cell_size,
                                                    out, stats, progress, msg);
    hbk_cs_release(&ws);
    return r;
}

hbk_result_t hbk_caustics_render_with(hbk_caustics_workspace_t *ws, const hbk_caustics_params_t *p,
                                      const hbk_image_t *water_height,
                                      const hbk_image_t *ground_height, float cell_size,
                                      hbk_image_t *out, hbk_caustics_stats_t *stats,
                                      hbk_progress_t *progress, hbk_message_t *msg)
{
    hbk_message_clear(msg);
    if (stats) memset(stats, 0, sizeof *stats);
    if (!ws) return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "workspace: must not be NULL");
    hbk_result_t r = hbk_caustics_check_inputs(p, water_height, ground_height, cell_size, msg);
    if (r || (r = hbk_image_check(out, "out", msg))) return r;
    if (out->channels < 3)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT, "out.channels = %d: must be 3 or 4",
                        out->channels);
    if (p->light_type == HBK_LIGHT_POINT) {
        float top = -INFINITY;
        for (int32_t y = 0; y < water_height->height; ++y)
            for (int32_t x = 0; x < water_height->width; ++x)
                top = fmaxf(top, water_height->data[(size_t)y * water_height->row_stride + (size_t)x]);
        if (!(p->light_position[2] > top))
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                            "light_position[2] = %g: the point light must be above the water "
                            "(highest surface %g m)", (double)p->light_position[2], (double)top);
    }
    hbk_caustics_ctx_t c;
    hbk_caustics_init(&c, ws, p, water_height, ground_height, cell_size);
    c.progress = progress;
    c.MW = out->width;
    c.MH = out->height;
    if ((size_t)c.W * (size_t)c.H < 4096 && (size_t)c.MW * (size_t)c.MH < 65536)
        c.threads = 1; /* too small to be worth waking threads; the bytes are the same */
    c.inv_mw = 1.0 / c.MW;
    double ex1, ey1;
    if (p->auto_extent) {
        ex1 = c.W * c.dx;
        ey1 = c.H * c.dx;
    } else {
        c.ex0 = p->extent[0];
        c.ey0 = p->extent[1];
        ex1 = p->extent[2];
        ey1 = p->extent[3];
    }
    c.sx = c.MW / (ex1 - c.ex0);
    c.sy = c.MH / (ey1 - c.ey0);
    c.inv_sx = 1.0 / c.sx;
    c.inv_sy = 1.0 / c.sy;
    c.pixel_area = (ex1 - c.ex0) / c.MW * ((ey1 - c.ey0) / c.MH);
    hbk_report(progress, 0.0f);
    if ((r = hbk_caustics_setup_ground(&c)) || (r = hbk_caustics_setup_mesh(&c))) goto fail;
    if (hbk_cancelled(progress)) { r = HBK_ERR_CANCELLED; goto fail; }
    hbk_caustics_trace_vertices(&c);
    hbk_report(progress, 0.3f);
    if (hbk_cancelled(progress)) { r = HBK_ERR_CANCELLED; goto fail; }
    if ((r = hbk_caustics_build_triangles(&c))) goto fail;
    hbk_report(progress, 0.5f);
    /* (A cancel during the triangle pass leaves its rows uncounted: caught here.) */
    if (hbk_cancelled(progress)) { r = HBK_ERR_CANCELLED; goto fail; }
    if ((r = hbk_caustics_rasterise(&c, out, progress))) goto fail;
    if (stats) {
        for (int32_t j = 0; j < c.ncy; ++j)
            for (int k = 0; k < 3; ++k) {
                const int from = c.mono ? 0 : k; /* mono: computed once for irradiance 1 */
                stats->entered[k] += c.row_stats[9 * (size_t)j + (size_t)from];
                stats->absorbed[k] += c.row_stats[9 * (size_t)j + 3 + (size_t)from];
                stats->dry[k] += c.row_stats[9 * (size_t)j + 6 + (size_t)from];
            }
        for (int k = 0; k < 3; ++k) {
            stats->entered[k] *= c.escale[k];
            stats->absorbed[k] *= c.escale[k];
            stats->dry[k] *= c.escale[k];
            stats->ground[k] = stats->entered[k] - stats->absorbed[k];
        }
    }
    hbk_report(progress, 1.0f);
    return HBK_OK;
fail:;
    const int32_t W = c.W, H = c.H, MW = c.MW, MH = c.MH;
    if (stats) memset(stats, 0, sizeof *stats);
    if (r == HBK_ERR_CANCELLED) return hbk_fail(msg, r, "render cancelled; out is incomplete");
    return hbk_fail(msg, r, "caustics scratch for a %d x %d surface and a %d x %d map: out of "
                    "memory", W, H, MW, MH);
}
