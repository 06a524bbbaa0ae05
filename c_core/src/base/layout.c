/* sizeof/offsetof of the public structs, for bindings to check their mirrors against. */
#include "hydrobake.h"
#include <string.h>

typedef struct {
    const char *type, *field;
    size_t value;
} layout_entry_t;

#define SIZE(T) {#T, NULL, sizeof(T)}
#define FIELD(T, f) {#T, #f, offsetof(T, f)}

static const layout_entry_t k_layout[] = {
    SIZE(hbk_message_t), FIELD(hbk_message_t, text),
    SIZE(hbk_progress_t), FIELD(hbk_progress_t, cancel), FIELD(hbk_progress_t, fraction),
    SIZE(hbk_param_info_t), FIELD(hbk_param_info_t, name), FIELD(hbk_param_info_t, type),
    FIELD(hbk_param_info_t, offset), FIELD(hbk_param_info_t, count),
    FIELD(hbk_param_info_t, min), FIELD(hbk_param_info_t, max), FIELD(hbk_param_info_t, unit),
    FIELD(hbk_param_info_t, items), FIELD(hbk_param_info_t, description),
    SIZE(hbk_image_t), FIELD(hbk_image_t, data), FIELD(hbk_image_t, width),
    FIELD(hbk_image_t, height), FIELD(hbk_image_t, channels), FIELD(hbk_image_t, row_stride),
    SIZE(hbk_exr_channel_t), FIELD(hbk_exr_channel_t, name), FIELD(hbk_exr_channel_t, data),
    FIELD(hbk_exr_channel_t, pixel_stride), FIELD(hbk_exr_channel_t, row_stride),
    FIELD(hbk_exr_channel_t, half),
    SIZE(hbk_caustics_stats_t), FIELD(hbk_caustics_stats_t, entered),
    FIELD(hbk_caustics_stats_t, absorbed), FIELD(hbk_caustics_stats_t, ground),
    FIELD(hbk_caustics_stats_t, dry),
    SIZE(hbk_snow_material_t), FIELD(hbk_snow_material_t, catch_chance),
    FIELD(hbk_snow_material_t, melts), FIELD(hbk_snow_material_t, sheds),
    SIZE(hbk_snow_stats_t), FIELD(hbk_snow_stats_t, substeps),
    FIELD(hbk_snow_stats_t, flake_steps), FIELD(hbk_snow_stats_t, hits),
    FIELD(hbk_snow_stats_t, stuck), FIELD(hbk_snow_stats_t, bounced),
    FIELD(hbk_snow_stats_t, melted), FIELD(hbk_snow_stats_t, shed),
    FIELD(hbk_snow_stats_t, fell),
    SIZE(hbk_rain_water_t), FIELD(hbk_rain_water_t, rain_in), FIELD(hbk_rain_water_t, on_glass),
    FIELD(hbk_rain_water_t, wiped), FIELD(hbk_rain_water_t, run_off),
    FIELD(hbk_rain_water_t, in_drops), FIELD(hbk_rain_water_t, in_particles),
    FIELD(hbk_rain_water_t, in_film), FIELD(hbk_rain_water_t, drops),
    FIELD(hbk_rain_water_t, trails), FIELD(hbk_rain_water_t, particles),
    SIZE(hbk_rain_drop_t), FIELD(hbk_rain_drop_t, x), FIELD(hbk_rain_drop_t, y),
    FIELD(hbk_rain_drop_t, mass), FIELD(hbk_rain_drop_t, radius), FIELD(hbk_rain_drop_t, speed),
    FIELD(hbk_rain_drop_t, kind), FIELD(hbk_rain_drop_t, id),
    SIZE(hbk_rain_blade_t), FIELD(hbk_rain_blade_t, x0), FIELD(hbk_rain_blade_t, y0),
    FIELD(hbk_rain_blade_t, x1), FIELD(hbk_rain_blade_t, y1), FIELD(hbk_rain_blade_t, width),
    FIELD(hbk_rain_blade_t, value),
    SIZE(hbk_fluid_obstacle_t), FIELD(hbk_fluid_obstacle_t, type),
    FIELD(hbk_fluid_obstacle_t, center), FIELD(hbk_fluid_obstacle_t, extent),
    FIELD(hbk_fluid_obstacle_t, rotation),
};

hbk_result_t hbk_layout(const char *struct_name, const char *field, size_t *out)
{
    if (!struct_name || !out) return HBK_ERR_INVALID_ARGUMENT;
    for (size_t i = 0; i < sizeof k_layout / sizeof k_layout[0]; ++i) {
        const layout_entry_t *e = &k_layout[i];
        if (strcmp(e->type, struct_name)) continue;
        if (field ? (e->field && !strcmp(e->field, field)) : !e->field) {
            *out = e->value;
            return HBK_OK;
        }
    }
    return HBK_ERR_INVALID_ARGUMENT;
}
