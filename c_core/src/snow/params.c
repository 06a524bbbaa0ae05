/* Snow params: defaults (the paper's figures), the table, and the checks between fields. */
#include "internal_snow.h"
#include <string.h>

/* The binding mirrors the struct with natural alignment; no padding keeps both simple. */
_Static_assert(offsetof(hbk_snow_params_t, seed) % 8 == 0, "seed must be 8-aligned");
_Static_assert(sizeof(hbk_snow_params_t) == offsetof(hbk_snow_params_t, seed) + 8,
               "no trailing padding");

static const hbk_snow_params_t k_paper = {
    .size = sizeof(hbk_snow_params_t),
    .temperature = -1.0f,
    .flake_count = 200000,
    .flake_radius = 0.0025f,
    .fall_speed = 1.0f,
    .flutter_amplitude = 0.3f,
    .flutter_frequency = 0.5f,
    .wind = {1.0f, 0.0f, 0.0f},
    .volume_min = {-2.0f, -2.0f, 0.0f},
    .volume_max = {2.0f, 2.0f, 4.0f},
    .time_step = 0.04f,
    .texture_width = 1024,
    .texture_height = 1024,
    .depth_per_flake = 0.001f,
    .contact_mode = HBK_SNOW_CONTACT_TRIANGLES,
    .threads = 0,
    .wet_temperature = -2.0f,
    .water_temperature = {-2.0f, 3.0f},
    .water_content = {5.0f, 25.0f},
    .tension_water = {5.0f, 15.0f, 25.0f},
    .tension_chance = {7.0f, 25.0f, 7.0f},
    .sinter_temperature = {-10.0f, -2.0f},
    .sinter_chance = {2.0f, 10.0f},
    .bleed_water = {5.0f, 25.0f},
    .bleed = {0.1f, 1.0f},
    .wet_stamp = {110.0f, 25.0f, -48.0f, 25.0f, 10.0f, 12.0f, 10.0f, 5.0f, 9.0f},
    .dry_stamp = {90.0f, 90.0f, 10.0f, 15.0f, 5.0f, 10.0f},
    .seed = 1,
};

const hbk_snow_params_t *snow_params_paper(void) { return &k_paper; }

void hbk_snow_params_default(hbk_snow_params_t *p)
{
    if (p) *p = k_paper;
}

#define F(name, n, lo, hi, unit, desc) \
    {#name, HBK_PARAM_F32, offsetof(hbk_snow_params_t, name), n, lo, hi, unit, NULL, desc}
#define I(name, lo, hi, desc) \
    {#name, HBK_PARAM_I32, offsetof(hbk_snow_params_t, name), 1, lo, hi, "1", NULL, desc}

static const hbk_param_info_t k_info[] = {
    F(temperature, 1, -10, 3, "degC",
      "Air temperature: -2 and above wet snow sticking by surface tension, below dry snow by "
      "sintering; the paper shows -10, -1 and 3"),
    I(flake_count, 1, 20000000, "Flakes falling in the volume at once; the paper ran 1500"),
    F(flake_radius, 1, 0.0001, 0.05, "m",
      "Radius of a flake; sets the size of its stamp in texels (typical 0.001-0.005)"),
    F(fall_speed, 1, 0.05, 10, "m/s", "Mean terminal fall speed of the flakes (typical 0.5-1.5)"),
    F(flutter_amplitude, 1, 0, 5, "m/s",
      "Sideways speed of the flakes' helical wobble (typical 0.1-0.5)"),
    F(flutter_frequency, 1, 0, 10, "Hz", "Turns per second of the wobble (typical 0.3-1)"),
    F(wind, 3, -50, 50, "m/s", "Wind velocity; snow builds up on the windward faces"),
    F(volume_min, 3, -1e5, 1e5, "m",
      "Lower corner of the snow volume (world space); wraps around on its four sides"),
    F(volume_max, 3, -1e5, 1e5, "m", "Upper corner of the snow volume; flakes start at its top"),
    F(time_step, 1, 0.0001, 1, "s", "Length of one substep (typical 1/24-1/100)"),
    I(texture_width, 1, 8192, "Width of the snow textures in texels"),
    I(texture_height, 1, 8192, "Height of the snow textures in texels"),
    F(depth_per_flake, 1, 0, 0.1, "m",
      "Snow depth added where the stamps sum to 255 alpha; depth keeps growing after coverage "
      "is full"),
    {"contact_mode", HBK_PARAM_ENUM, offsetof(hbk_snow_params_t, contact_mode), 1, 0, 1, "1",
     "TRIANGLES|BOX",
     "TRIANGLES: flakes hit the real triangles and stamp into the UV map (sheltered places stay "
     "clear); BOX: the paper's six textures per bounding box of each material slot"},
    I(threads, 0, 1024, "Threads to use, 0 = all cores; the result never depends on it"),
    F(wet_temperature, 1, -10, 3, "degC",
      "At and above: surface tension and the wet (bleeding) look; below: sintering and the dry "
      "look (paper: -2)"),
    F(water_temperature, 2, -10, 10, "degC",
      "Temperatures where the water content is water_content[0] and [1] (paper: -2, 3)"),
    F(water_content, 2, 0, 100, "%",
      "Water content of the snow at water_temperature[0] and [1], linear between (paper: 5, 25)"),
    F(tension_water, 3, 0, 100, "%",
      "Water contents of the surface-tension curve's points, ascending (paper: 5, 15, 25)"),
    F(tension_chance, 3, 0, 100, "%",
      "Surface-tension sticking chance at those water contents (paper: 7, 25, 7)"),
    F(sinter_temperature, 2, -20, 10, "degC",
      "Temperatures of the sintering curve's ends, ascending (paper: -10, -2)"),
    F(sinter_chance, 2, 0, 100, "%",
      "Sintering sticking chance at those temperatures (paper: 2, 10)"),
    F(bleed_water, 2, 0, 100, "%",
      "Water contents of the bleed curve's ends, ascending (paper: 5, 25)"),
    F(bleed, 2, 0, 10, "1", "Bleed coefficient D of the wet stamp at those water contents "
      "(paper: 0.1, 1)"),
    F(wet_stamp, 9, -255, 255, "1",
      "Wet stamp alpha = u + vR + wD: (u, v, w) for centre, sides, corners (paper: 110 25 -48, "
      "25 10 12, 10 5 9)"),
    F(dry_stamp, 6, -255, 255, "1",
      "Dry stamp alpha = m + nR: (m, n) for centre, sides, corners (paper: 90 90, 10 15, 5 10)"),
    {"seed", HBK_PARAM_U64, offsetof(hbk_snow_params_t, seed), 1, 0, 18446744073709551615.0,
     "1", NULL, "Random seed: the same seed gives the same snow, whatever the thread count"},
};
#undef F
#undef I

const hbk_param_info_t *hbk_snow_params_info(size_t *count)
{
    if (count) *count = sizeof k_info / sizeof k_info[0];
    return k_info;
}

static hbk_result_t ascending(const float *v, int n, const char *name, hbk_message_t *msg)
{
    for (int i = 1; i < n; ++i)
        if (!(v[i] > v[i - 1]))
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                            "%s[%d] = %g: must be > %s[%d] = %g", name, i, (double)v[i], name,
                            i - 1, (double)v[i - 1]);
    return HBK_OK;
}

hbk_result_t snow_params_check(const hbk_snow_params_t *p, hbk_message_t *msg)
{
    hbk_result_t r = hbk_params_validate(p, sizeof *p, k_info, sizeof k_info / sizeof k_info[0],
                                         msg);
    if (r) return r;
    for (int i = 0; i < 3; ++i)
        if (!(p->volume_max[i] > p->volume_min[i]))
            return hbk_fail(msg, HBK_ERR_INVALID_ARGUMENT,
                            "volume_max[%d] = %g: must be > volume_min[%d] = %g", i,
                            (double)p->volume_max[i], i, (double)p->volume_min[i]);
    if ((r = ascending(p->water_temperature, 2, "water_temperature", msg))) return r;
    if ((r = ascending(p->tension_water, 3, "tension_water", msg))) return r;
    if ((r = ascending(p->sinter_temperature, 2, "sinter_temperature", msg))) return r;
    if ((r = ascending(p->bleed_water, 2, "bleed_water", msg))) return r;
    return HBK_OK;
}
