/* Caustics parameters: defaults, the table, and the checks the table cannot express. */
#include "internal_caustics.h"
#include <math.h>
#include <stddef.h>

void hbk_caustics_params_default(hbk_caustics_params_t *p)
{
    if (!p) return;
    *p = (hbk_caustics_params_t){0};
    p->size = sizeof *p;
    p->light_type = HBK_LIGHT_SUN;
    p->light_direction[2] = 1.0f; /* overhead */
    p->light_position[2] = 10.0f;
    for (int c = 0; c < 3; ++c) {
        p->irradiance[c] = 1.0f; /* relative units: flat water maps to 1 */
        p->ior[c] = 1.333f;      /* the paper: one index for water, no dispersion */
        p->absorption[c] = 0.0f; /* the paper leaves attenuation for future work */
    }
    p->fresnel = 0;
    p->lit_dry = 1;
    p->wet_depth = 1e-4f;
    p->periodic = 0;
    p->auto_extent = 1;
    p->threads = 0;
}

#define F(name, n, lo, hi, unit, desc) \
    {#name, HBK_PARAM_F32, offsetof(hbk_caustics_params_t, name), n, lo, hi, unit, NULL, desc}
#define B(name, desc) \
    {#name, HBK_PARAM_BOOL, offsetof(hbk_caustics_params_t, name), 1, 0, 1, "1", NULL, desc}
static const hbk_param_info_t k_info[] = {
    {"light_type", HBK_PARAM_ENUM, offsetof(hbk_caustics_params_t, light_type), 1, 0, 1, "1",
     "SUN|POINT", "Sun (parallel light, tiles) or a point light (falls off as 1/r^2)."},
    F(light_direction, 3, -1e6, 1e6, "1", "Direction towards the sun, any length, pointing up; "
                                          "(0, 0, 1) is overhead."),
    F(light_position, 3, -1e6, 1e6, "m", "Point light position in the height field's frame; "
                                         "must be above the water."),
    F(irradiance, 3, 0, 1e9, "W/m^2", "RGB light: sun irradiance facing it, or a point light's "
                                      "irradiance at 1 m; 1 for relative maps."),
    F(ior, 3, 1, 3, "1", "Water's refractive index per RGB channel; 1.333, or 1.331/1.333/1.337 "
                         "for dispersion."),
    F(absorption, 3, 0, 1000, "1/m", "Absorption per metre of water per RGB channel; pure water "
                                     "0.35/0.06/0.01."),
    B(fresnel, "Multiply by the Fresnel transmittance at the surface (off in the paper)."),
    B(lit_dry, "Light dry ground directly; off leaves it black in the map."),
    F(wet_depth, 1, 0, 1, "m", "Depth above which a sample counts as water; 1e-4."),
    B(periodic, "The height fields wrap and the map tiles without a seam (sun only)."),
    B(auto_extent, "The map covers the height field exactly; off uses `extent`."),
    F(extent, 4, -1e6, 1e6, "m", "xmin, ymin, xmax, ymax of the map in the height field's frame, "
                                 "when auto_extent is off."),
    {"threads", HBK_PARAM_I32, offsetof(hbk_caustics_params_t, threads), 1, 0, 1024, "1", NULL,
     "Threads to use, 0 = all; the result never depends on it."},
};
#undef F
#undef B

const hbk_param_info_t *hbk_caustics_params_info(size_t *count)
{
    if (count) *count = sizeof k_info / sizeof k_info[0];
    return k_info;
}

hbk_result_t hbk_caustics_params_check(const hbk_caustics_params_t *p, hbk_message_t *msg)
{
    hbk_result_t r = hbk_params_validate(p, sizeof *p, k_info, sizeof k_info / sizeof k_info[0],
                                         msg);
    if (r) return r;
    const float *d = p->light_direction;
    const double len = sqrt((double)d[0] * d[0] + (double)d[1] * d[1] + (double)d[2] * d[2]);
    if (p->light_type == HBK_LIGHT_SUN && !(len > 0.0 && d[2] / len >= 0.01))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "light_direction = (%g, %g, %g): must point up, at least 0.6 deg above "
                        "the horizon (z / length >= 0.01)", (double)d[0], (double)d[1],
                        (double)d[2]);
    if (!p->auto_extent && !(p->extent[2] > p->extent[0] && p->extent[3] > p->extent[1]))
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "extent = (%g, %g, %g, %g): xmax must be > xmin and ymax > ymin",
                        (double)p->extent[0], (double)p->extent[1], (double)p->extent[2],
                        (double)p->extent[3]);
    if (p->periodic && !p->auto_extent)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "auto_extent = 0 with periodic = 1: a tiling map must cover exactly one "
                        "period; set auto_extent = 1");
    if (p->periodic && p->light_type == HBK_LIGHT_POINT)
        return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                        "light_type = 1 (POINT) with periodic = 1: a point light does not tile; "
                        "use the sun");
    return HBK_OK;
}
