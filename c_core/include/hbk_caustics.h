/* Caustics: light refracted by a height-field water surface onto the ground (Tokuyama,
 * Yamamoto, Takai §3), as an HDR caustic map.
 *
 * Inputs are two 1-channel images of the same W x H size: the water surface height and the
 * ground height, in m, sampled at cell centres ((i + 0.5) * cell_size, (j + 0.5) * cell_size) as
 * hbk_water.h lays them out (x along i, y along j, z up; row 0 is j = 0, the bottom). A sample
 * is wet where surface - ground > wet_depth. Not periodic, the fields are extended flat over the
 * half cell between the outermost sample centres and the edges, and light leaving the extent is
 * lost; periodic, they wrap.
 *
 * Method (the paper's, made exact):
 *  - The surface mesh: two triangles per cell of sample points. Where a cell has wet and dry
 *    corners, vertices on the waterline are placed as the paper's Fig. 2 describes (where the
 *    water plane meets rising ground; a film reaching its depth down a falling slope) and the
 *    two-diagonal case is resolved by its Fig. 3 rule (crossing waterline points on the wet
 *    diagonal connect the water).
 *  - Light from the sun (or a point light) is refracted at every wet vertex by Snell's law with
 *    the vertex normal, per channel index (dispersion), and the ray is marched through the
 *    ground height field to its hit. Dry ground is lit directly.
 *  - Each surface triangle carries the power P = E (L . N_surface) S T that crosses it (S its
 *    exact area, T the Fresnel transmittance or 1) times the absorption exp(-a l) along the
 *    path l (mean of its vertices). P is spread uniformly over its image on the ground, whose
 *    exact area is S'. That is the paper's (L_r . N_ground)(S/S')(L . N_surface) with its S'
 *    taken across the refracted beam; here S' is the area on the ground itself, so the map holds
 *    irradiance on the ground surface, W/m^2 (what a ground material multiplies its colour by).
 *  - Rasterisation is exact area coverage (signed-area accumulation along scanlines, in double
 *    per band of rows): every triangle deposits exactly its power, the sum over the map is exact,
 *    folded (inverted) triangles add like the others, and with `periodic` triangles wrap across
 *    the edges so tiles meet without a seam.
 *
 * What callers may rely on:
 *  - Flat water of depth D over flat ground gives a uniform map of exactly
 *        E_map = irradiance * cos(theta) * T(theta) * exp(-absorption * D / cos(theta_r))
 *    with theta the sun's zenith angle, theta_r the refracted angle (sin theta = n sin theta_r),
 *    and T = 1 when fresnel = 0 (the default, as in the paper), else the unpolarised Fresnel
 *    transmittance.
 *  - Energy: over flat ground, sum over pixels of map x pixel area equals the light that reached
 *    the ground (stats->ground) plus the direct light on dry ground (stats->dry), less what fell
 *    outside the extent (none when periodic); with no absorption and no Fresnel term,
 *    stats->entered is the irradiance times the surface's shadow area. Over sloped ground,
 *    divide each pixel's value by the ground's cosine first (the map is per ground area).
 *  - Same inputs give the same bytes for any `threads`.
 *
 * Limits: one refraction only, as in the paper (a refracted ray is never steeper than 87 deg
 * from the vertical, so it cannot leave the water again); images of under 1e-6 pixel^2 are put
 * whole into the pixel of their centroid.
 *
 * Stateless: a call allocates its scratch (about 60 bytes per surface sample and a 1 MB band
 * accumulator per thread) and frees it before returning. A handle keeping it between frames
 * would save only the page faults (about 0.3 ms for a 256^2 surface), while stateless calls keep
 * the binding simple and let frames render in parallel from different threads. */
#ifndef HBK_CAUSTICS_H
#define HBK_CAUSTICS_H
#include "hbk_base.h"
#include "hbk_image.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef enum hbk_light_type {
    HBK_LIGHT_SUN = 0,  /* parallel light from light_direction */
    HBK_LIGHT_POINT = 1 /* from light_position, falling off as 1/r^2; maps will not tile */
} hbk_light_type_t;

typedef struct hbk_caustics_params {
    uint32_t size;            /* sizeof(hbk_caustics_params_t), set by the default function */
    int32_t light_type;       /* hbk_light_type_t */
    float light_direction[3]; /* towards the sun (any length, z > 0); (0, 0, 1) is overhead */
    float light_position[3];  /* m, point light, in the height field's frame, above the water */
    float irradiance[3];      /* RGB. Sun: W/m^2 on a plane facing it (1 = relative units).
                               * Point: W/sr, i.e. the irradiance facing it at 1 m. */
    float ior[3];             /* refractive index of water per RGB channel, 1..3. The paper:
                               * 1.333 for all; dispersive water: 1.331, 1.333, 1.337 */
    float absorption[3];      /* 1/m per RGB channel, 0..1000. The paper: none; pure water
                               * about 0.35, 0.06, 0.01 (red goes first) */
    int32_t fresnel;          /* 1: multiply by the Fresnel transmittance; 0: not (the paper) */
    int32_t lit_dry;          /* 1: dry ground gets the direct light; 0: the map is 0 there */
    float wet_depth;          /* m, a sample is wet when deeper than this; 0..1, 1e-4 */
    int32_t periodic;         /* 1: the height fields wrap and the map tiles (sun only) */
    int32_t auto_extent;      /* 1: the map covers the height field, [0, W cell] x [0, H cell] */
    float extent[4];          /* m, xmin, ymin, xmax, ymax of the map when auto_extent = 0 */
    int32_t threads;          /* OpenMP threads, 0 = all; results never depend on it */
} hbk_caustics_params_t;

/* Fills every field with the defaults (the paper: overhead sun, one index 1.333, no
 * absorption, no Fresnel term). Never fails. */
HBK_EXPORT void hbk_caustics_params_default(hbk_caustics_params_t *p);
/* The parameter table (every field but `size`); *count receives its length. Never fails. */
HBK_EXPORT const hbk_param_info_t *hbk_caustics_params_info(size_t *count);
/* Range checks plus: light_direction z > 0 after normalising (the sun is above the horizon);
 * extent max > min when auto_extent = 0; periodic needs auto_extent and a sun.
 * HBK_ERR_INVALID_ARGUMENT / HBK_ERR_VERSION. */
HBK_EXPORT hbk_result_t hbk_caustics_params_check(const hbk_caustics_params_t *p,
                                                  hbk_message_t *msg);

/* Where the light went, per RGB channel, in W (irradiance x m^2). */
typedef struct hbk_caustics_stats {
    double entered[3];  /* crossed the water surface (after Fresnel) */
    double absorbed[3]; /* absorbed on the way down */
    double ground[3];   /* reached the ground under water (entered - absorbed) */
    double dry[3];      /* fell directly on dry ground */
} hbk_caustics_stats_t;

/* Renders the caustic map into `out` (3 or 4 channels, any size; alpha is set to 1). The map
 * covers the extent; pixel (x, y) is the mean irradiance over its square. `stats` may be NULL.
 * Polls progress->cancel; on HBK_ERR_CANCELLED `out` holds garbage.
 * Returns HBK_ERR_INVALID_ARGUMENT (params, image views, sizes, cell_size outside
 * [1e-5, 1e4] m, non-finite heights, a point light not above the water), HBK_ERR_VERSION,
 * HBK_ERR_OUT_OF_MEMORY, HBK_ERR_CANCELLED. */
HBK_EXPORT hbk_result_t hbk_caustics_render(const hbk_caustics_params_t *p,
                                            const hbk_image_t *water_height,
                                            const hbk_image_t *ground_height, float cell_size,
                                            hbk_image_t *out, hbk_caustics_stats_t *stats,
                                            hbk_progress_t *progress, hbk_message_t *msg);

/* A workspace keeps a render's scratch buffers (about 10 MB for a 256^2 surface and a 1024^2
 * map) between renders, so a sequence of frames does not pay for fresh memory every frame.
 * One workspace serves one render at a time; results are the same bytes as without it. */
typedef struct hbk_caustics_workspace hbk_caustics_workspace_t;

/* Returns HBK_ERR_INVALID_ARGUMENT (out NULL), HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_caustics_workspace_create(hbk_caustics_workspace_t **out,
                                                      hbk_message_t *msg);
HBK_EXPORT void hbk_caustics_workspace_destroy(hbk_caustics_workspace_t *ws);
/* Bytes of scratch the workspace holds now. */
HBK_EXPORT size_t hbk_caustics_workspace_bytes(const hbk_caustics_workspace_t *ws);

/* hbk_caustics_render with its scratch kept in `ws` (not NULL). Same results and errors. */
HBK_EXPORT hbk_result_t hbk_caustics_render_with(hbk_caustics_workspace_t *ws,
                                                 const hbk_caustics_params_t *p,
                                                 const hbk_image_t *water_height,
                                                 const hbk_image_t *ground_height,
                                                 float cell_size, hbk_image_t *out,
                                                 hbk_caustics_stats_t *stats,
                                                 hbk_progress_t *progress, hbk_message_t *msg);

/* View refraction (paper §3.2): for every surface sample, the ray from `camera` (m, same frame)
 * to the water surface is refracted (index ior[1]) and marched to the ground; its hit becomes
 * texture coordinates of the ground over the extent (0..1, same convention as the map).
 * out_uv: W x H, 2..4 channels: u, v, [path length in water in m], [Fresnel reflectance].
 * Dry samples get their own position, length 0, reflectance 0. out_reflect (NULL allowed):
 * W x H, 3 channels, the unit reflected view direction, for an environment lookup (the paper
 * uses its horizontal components as texture coordinates).
 * Returns HBK_ERR_INVALID_ARGUMENT (as render, and a camera below the water). */
HBK_EXPORT hbk_result_t hbk_caustics_view(const hbk_caustics_params_t *p,
                                          const hbk_image_t *water_height,
                                          const hbk_image_t *ground_height, float cell_size,
                                          const float camera[3], hbk_image_t *out_uv,
                                          hbk_image_t *out_reflect, hbk_message_t *msg);

/* The lit ground (paper §3.1): out = texture x caustic map, per channel (RGB; alpha copied from
 * the texture if both have it, else 1). `caustics` is sampled bilinearly at the texture's pixel
 * centres, so the two may differ in size; `edge` is an hbk_edge_t (WRAP for tiling maps).
 * texture and out: same size, 3 or 4 channels; caustics: 3 or 4 channels. */
HBK_EXPORT hbk_result_t hbk_caustics_lit_ground(const hbk_image_t *texture,
                                                const hbk_image_t *caustics, int32_t edge,
                                                hbk_image_t *out, hbk_message_t *msg);

#ifdef __cplusplus
}
#endif
#endif
