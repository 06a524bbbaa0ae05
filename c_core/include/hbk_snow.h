/* Snow attachment (Ise 2004, "リアルタイム3DCGコンテンツにおける雪の付着表現に関する研究"):
 * falling flakes that stick to a mesh by temperature, water content and material, baked into
 * a coverage texture (white snow over transparent) and a depth map.
 *
 * The model, as implemented:
 *  - Flakes fall through a box (`volume_min`..`volume_max`, world space, Z up) with their own
 *    fall speed (fall_speed ±20 %), a helical flutter (a horizontal velocity of
 *    `flutter_amplitude` turning at about `flutter_frequency`) and the `wind`. A flake's
 *    velocity follows that air velocity with the relaxation time of a flake falling at
 *    terminal speed, tau = fall_speed / 9.81 s, so a bounced flake is carried off again.
 *    The box wraps around on its four sides; a flake that falls out of the bottom (or rises
 *    above the top), sticks, melts or is shed starts again at a random place at the top.
 *    Flakes start spread through the whole volume. After each hbk_snow_set_mesh, the next
 *    step first moves to the top every flake that the new mesh shelters, i.e. with geometry
 *    on its way back to the top along the mean air velocity (under a roof, in the lee, or
 *    inside an object that has moved onto it): such a flake could not have got there.
 *  - Contact: each step moves a flake from Q to P = Q + v dt and tests the segment Q->P.
 *    TRIANGLES (default): against the mesh's triangles (the mesh's bounds, an occupancy grid,
 *    then a BVH, so flakes away from the surfaces cost little); the first triangle hit wins,
 *    so sheltered places (under a roof, the leeward side) get no snow. Both sides of a
 *    triangle take snow. The stamp goes into the mesh's own UV space.
 *    BOX (the paper's §3.2.1): against one bounding box per material slot ("part"); the entry
 *    face follows from Q and P, the hit point R from the segment and that face's plane.
 *  - Sticking, per contact, with the figures of the paper's §4.1 as defaults (all exposed):
 *      water content  W(T) = linear from water_content[0] at water_temperature[0] to
 *                     water_content[1] at water_temperature[1] (5 % at -2 degC, 25 % at 3 degC),
 *                     0 below wet_temperature (dry snow);
 *      temperature chance p_T: at and above wet_temperature (-2 degC) surface tension,
 *                     piecewise linear in W through (tension_water[i], tension_chance[i]) =
 *                     (5 %, 7 %), (15 %, 25 %), (25 %, 7 %), from 0 at W = 0 below the first
 *                     point and 0 beyond the last ("almost nothing beyond 25 %");
 *                     below wet_temperature sintering, linear in T from sinter_chance[0] at
 *                     sinter_temperature[0] to [1] at [1] (2 % at -10, 10 % at -2 degC),
 *                     held constant outside;
 *      catch chance   p_C of the material (rough cloth 0.4, smooth metal 0).
 *    The mechanisms are independent chances: a flake sticks with
 *      p = 1 - (1 - p_T) (1 - p_C).
 *    One uniform number decides it. A material that `melts` or `sheds` removes every flake
 *    that touches it (counted as melted / shed) and takes no snow. Any other flake that does
 *    not stick bounces: its velocity is mirrored at the surface with restitution 0.3 and it
 *    flies on from the contact point (the rest of that step is dropped). Each contact is a
 *    new trial, so on a flat, calm face a bounced flake soon lands again and most flakes end
 *    up staying, as real snow does; the chances show most on steep faces and in wind.
 *  - Stamps (§3.3.1): a 3x3 pattern of alpha on a 0-255 scale, added to the texel and clamped
 *    at 255. Wet look (T >= wet_temperature): alpha = u + vR + wD with R uniform in [0, 1) per
 *    stuck flake and D = bleed(W) (0.1 at 5 %, 1 at 25 % water content, linear, held outside);
 *    dry look: alpha = m + nR. Negative values count as 0.
 *    Beyond the paper: each stamp cell is the flake's footprint (2 * flake_radius) measured in
 *    texels of the hit triangle's UV mapping (separately along u and v, from the triangle's
 *    UV-to-surface Jacobian), so snow per area does not depend on the resolution. A cell
 *    smaller than a texel covers one texel and its alpha is scaled by its area (e.g. a
 *    0.5 x 0.5 texel flake adds a quarter of the alpha); at exactly one texel the stamp is
 *    the paper's 3x3 texels around the texel hit. Stamps are clipped to the texture (box
 *    mode: to the face's tile), never wrapped.
 *    Depth (m) grows by depth_per_flake * alpha / 255 per texel and stamp (alpha before the
 *    clamp), so it keeps growing when coverage has saturated at 255.
 *  - Determinism: every random number comes from the counter-based RNG keyed by (seed,
 *    flake id, substep, purpose); stuck flakes are stamped in (substep, flake id) order after
 *    the motion. The same seed, params, mesh and calls give the same bytes for any thread
 *    count, and step(h, 2) equals step(h, 1) twice.
 *
 * Texture layout (hbk_image.h: row 0 = bottom = v 0, x grows with u):
 *  TRIANGLES: texture_width x texture_height over UV [0, 1]^2; texels outside get nothing.
 *  BOX: one block of texture_width x texture_height per material slot b, stacked upwards
 *    (rows b*texture_height ..), so the image is texture_width x (texture_height * slots),
 *    at most 65536 texels high (hbk_snow_set_materials refuses more slots).
 *    A block holds six tiles of floor(width / 3) x floor(height / 2) texels:
 *      bottom row: -X, -Y, -Z   top row: +X, +Y, +Z   (columns x, y, z)
 *    Each face is seen from outside with (u, v) axes: +X (+Y, +Z), -X (-Y, +Z), +Y (-X, +Z),
 *    -Y (+X, +Z), +Z (+X, +Y), -Z (+X, -Y), spanning the box (so sides stand upright).
 *    Projecting the tiles back onto the model (§3.3.2) is the caller's (shader's) job.
 *
 * Threads: a handle may be used by one thread at a time; different handles are independent.
 * hbk_snow_step uses `threads` OpenMP threads (0 = all).
 */
#ifndef HBK_SNOW_H
#define HBK_SNOW_H
#include "hbk_base.h"
#include "hbk_image.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef enum hbk_snow_contact {
    HBK_SNOW_CONTACT_TRIANGLES = 0, /* swept segment against the mesh's triangles, UV space */
    HBK_SNOW_CONTACT_BOX = 1        /* the paper's: one bounding box per material slot */
} hbk_snow_contact_t;

typedef struct hbk_snow_params {
    uint32_t size;              /* sizeof(hbk_snow_params_t) */
    float temperature;          /* degC, -10..3: air temperature; default -1 (wet snow) */
    int32_t flake_count;        /* 1..20e6 flakes in the volume at once; default 200000 */
    float flake_radius;         /* m, 0.0001..0.05: sets the stamp size; default 0.0025 */
    float fall_speed;           /* m/s, 0.05..10: mean terminal fall speed; default 1 */
    float flutter_amplitude;    /* m/s, 0..5: sideways speed of the wobble; default 0.3 */
    float flutter_frequency;    /* Hz, 0..10: turns per second of the wobble; default 0.5 */
    float wind[3];              /* m/s, -50..50 each: wind velocity; default (1, 0, 0) */
    float volume_min[3];        /* m: lower corner of the snow volume; default (-2, -2, 0) */
    float volume_max[3];        /* m: upper corner (> min); flakes start at max z; (2, 2, 4) */
    float time_step;            /* s, 0.0001..1: length of one substep; default 0.04 */
    int32_t texture_width;      /* 1..8192 texels; default 1024 */
    int32_t texture_height;     /* 1..8192 texels; default 1024 */
    float depth_per_flake;      /* m, 0..0.1: depth a full 255 of stamped alpha adds; 0.001 */
    int32_t contact_mode;       /* hbk_snow_contact_t; default TRIANGLES */
    int32_t threads;            /* 0..1024, 0 = all cores; results never depend on it */
    /* The paper's figures (§4.1); defaults as in the comments. */
    float wet_temperature;       /* degC: at and above: surface tension and the wet look; -2 */
    float water_temperature[2];  /* degC: where the water content is water_content[i]; -2, 3 */
    float water_content[2];      /* %: water content at water_temperature[i]; 5, 25 */
    float tension_water[3];      /* %, ascending: water contents of the tension curve; 5,15,25 */
    float tension_chance[3];     /* %: sticking chance at tension_water[i]; 7, 25, 7 */
    float sinter_temperature[2]; /* degC, ascending: sintering curve; -10, -2 */
    float sinter_chance[2];      /* %: sticking chance at sinter_temperature[i]; 2, 10 */
    float bleed_water[2];        /* %, ascending: water contents of the bleed curve; 5, 25 */
    float bleed[2];              /* 1: bleed coefficient D at bleed_water[i]; 0.1, 1 */
    float wet_stamp[9];          /* (u, v, w) centre, side, corner: 110 25 -48, 25 10 12, 10 5 9 */
    float dry_stamp[6];          /* (m, n) centre, side, corner: 90 90, 10 15, 5 10 */
    uint64_t seed;               /* any value; default 1 */
} hbk_snow_params_t;

/* Per material slot (triangles' material_index). catch_chance: 0..0.5, the chance that the
 * surface's roughness catches a flake (paper: coat 0.4, trousers 0.25, shoes 0.1, car body 0).
 * melts: 1 = warm (skin), sheds: 1 = throws snow off (spinning tyres); either removes the
 * flake and takes no snow. */
typedef struct hbk_snow_material {
    float catch_chance;
    int32_t melts;
    int32_t sheds;
} hbk_snow_material_t;

/* Counters since the handle was created (or of the loaded state). */
typedef struct hbk_snow_stats {
    int64_t substeps;    /* substeps taken */
    int64_t flake_steps; /* substeps * flake_count */
    int64_t hits;        /* contacts: stuck + bounced + melted + shed */
    int64_t stuck;       /* flakes that stuck and were stamped */
    int64_t bounced;     /* contacts that did not stick */
    int64_t melted;      /* flakes removed by a `melts` material */
    int64_t shed;        /* flakes removed by a `sheds` material */
    int64_t fell;        /* flakes that left through the bottom (or the top) */
} hbk_snow_stats_t;

typedef struct hbk_snow hbk_snow_t;

/* Fills every field with the defaults above (the paper's figures). Never fails. */
HBK_EXPORT void hbk_snow_params_default(hbk_snow_params_t *p);

/* The parameter table (every field but size); never NULL, never fails. */
HBK_EXPORT const hbk_param_info_t *hbk_snow_params_info(size_t *count);

/* The model's formulas, for tests and user interfaces. `p` may be NULL for the paper's
 * figures (the defaults); its other fields are ignored. Chances are fractions in [0, 1],
 * water contents in %. None of them fails. */
HBK_EXPORT float hbk_snow_water_content(const hbk_snow_params_t *p, float temp_c);
HBK_EXPORT float hbk_snow_tension_chance(const hbk_snow_params_t *p, float water_content);
HBK_EXPORT float hbk_snow_sinter_chance(const hbk_snow_params_t *p, float temp_c);
/* p_T: tension_chance(water_content(T)) at and above wet_temperature, else sinter_chance(T). */
HBK_EXPORT float hbk_snow_stick_chance(const hbk_snow_params_t *p, float temp_c);
/* 1 - (1 - p_T)(1 - catch_chance): the chance a contact sticks (catch_chance clamped 0..1). */
HBK_EXPORT float hbk_snow_hit_chance(const hbk_snow_params_t *p, float temp_c,
                                     float catch_chance);
HBK_EXPORT float hbk_snow_bleed(const hbk_snow_params_t *p, float water_content);
/* The 3x3 stamp for random number r at temp_c: alpha[(dy + 1) * 3 + (dx + 1)], dy, dx in
 * -1..1 (dy up = +v), on the 0-255 scale, negative values as 0. Computed as u + v*r + w*D
 * (wet) or m + n*r (dry) in float, the same expression the stamps use. */
HBK_EXPORT void hbk_snow_stamp_alpha(const hbk_snow_params_t *p, float temp_c, float r,
                                     float alpha[9]);

/* Checks the params (HBK_ERR_INVALID_ARGUMENT naming the field, HBK_ERR_VERSION for a wrong
 * size) and makes a handle with flake_count flakes spread through the volume, one default
 * material (catch 0, takes snow), no mesh and empty textures. HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_snow_create(hbk_snow_t **out, const hbk_snow_params_t *p,
                                        hbk_message_t *msg);
/* NULL is allowed. */
HBK_EXPORT void hbk_snow_destroy(hbk_snow_t *h);
/* Detail of the handle's last failure ("" after a success); never NULL. */
HBK_EXPORT const char *hbk_snow_message(const hbk_snow_t *h);

/* Material slots 0..count-1 (count 1..65536), copied. HBK_ERR_INVALID_ARGUMENT (NULL, a
 * value out of range, fewer slots than the current mesh uses); HBK_ERR_STATE in BOX mode if
 * the slot count changes after snow was laid (the atlas has one block per slot);
 * HBK_ERR_OUT_OF_MEMORY. On failure the slots (and in BOX mode the textures) stay. */
HBK_EXPORT hbk_result_t hbk_snow_set_materials(hbk_snow_t *h, const hbk_snow_material_t *m,
                                               int32_t count);

/* The collision mesh, world space, copied (call again each frame for moving objects; the
 * snow already laid stays in the textures). positions: xyz per vertex; triangles: 3 vertex
 * indices per triangle; uvs: 2 per triangle corner (u, v of corner k of triangle t at
 * uvs[6t + 2k]), required in TRIANGLES mode, may be NULL in BOX mode; material_index: a slot
 * per triangle, NULL = all 0. triangle_count 0 removes the mesh.
 * HBK_ERR_INVALID_ARGUMENT (NULL, an index out of range, a non-finite value, a position
 * beyond 1e6 m, counts out of range), HBK_ERR_OUT_OF_MEMORY. On failure the previous mesh
 * stays. */
HBK_EXPORT hbk_result_t hbk_snow_set_mesh(hbk_snow_t *h, const float *positions,
                                          int32_t vertex_count, const int32_t *triangles,
                                          const float *uvs, const int32_t *material_index,
                                          int32_t triangle_count);

/* Advances substeps (1..1e6) steps of time_step. HBK_ERR_CANCELLED (progress->cancel) and
 * HBK_ERR_OUT_OF_MEMORY leave the handle as before the call; HBK_ERR_INVALID_ARGUMENT.
 * progress may be NULL. */
HBK_EXPORT hbk_result_t hbk_snow_step(hbk_snow_t *h, int32_t substeps, hbk_progress_t *progress);

/* Size of the coverage and depth images (see the layout above). Never fails. */
HBK_EXPORT void hbk_snow_texture_size(const hbk_snow_t *h, int32_t *width, int32_t *height);

/* Writes the coverage as RGBA: RGB = 1 (white), A = coverage / 255 in [0, 1].
 * rgba: 4 channels, the size of hbk_snow_texture_size. HBK_ERR_INVALID_ARGUMENT. */
HBK_EXPORT hbk_result_t hbk_snow_coverage(hbk_snow_t *h, hbk_image_t *rgba);
/* Writes the snow depth in m (1 channel, same size). HBK_ERR_INVALID_ARGUMENT. */
HBK_EXPORT hbk_result_t hbk_snow_depth(hbk_snow_t *h, hbk_image_t *depth);
/* Positions of the falling flakes (xyz, world space, flake id order): writes
 * min(capacity, flake_count) of them and sets *count = flake_count. xyz may be NULL when
 * capacity is 0. HBK_ERR_INVALID_ARGUMENT. */
HBK_EXPORT hbk_result_t hbk_snow_flakes(hbk_snow_t *h, float *xyz, int32_t capacity,
                                        int32_t *count);
/* Never fails. */
HBK_EXPORT void hbk_snow_stats(const hbk_snow_t *h, hbk_snow_stats_t *out);

/* State for resuming a bake: flakes, step counter, statistics, coverage and depth (not the
 * params, mesh or materials, which the caller sets again). Native byte order, with a
 * checksum. Loading needs a handle with the same flake_count, texture size, contact_mode
 * and (BOX) slot count; the other params may differ, and with the same ones the bake
 * continues bit-identically. */
HBK_EXPORT size_t hbk_snow_state_size(const hbk_snow_t *h);
/* HBK_ERR_INVALID_ARGUMENT (NULL buffer, size < hbk_snow_state_size). */
HBK_EXPORT hbk_result_t hbk_snow_save_state(hbk_snow_t *h, void *buffer, size_t size);
/* HBK_ERR_INVALID_ARGUMENT (NULL), HBK_ERR_FORMAT (not a snow state, wrong version or
 * size, bad checksum, a flake or counter no run holds), HBK_ERR_STATE (saved by a handle of another shape). On failure the
 * handle is unchanged. The state includes whether a mesh was set since the last step, so
 * call set_mesh before load_state (or in the same order as the run that saved it). */
HBK_EXPORT hbk_result_t hbk_snow_load_state(hbk_snow_t *h, const void *buffer, size_t size);

#ifdef __cplusplus
}
#endif
#endif
