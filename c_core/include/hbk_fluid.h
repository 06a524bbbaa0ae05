/* Solid fluid texturing (Holzer, Owada, Harada, Butz; SPH after Harada et al. 2007).
 *
 * One handle holds a fluid and the texturing volumes over its box:
 *  - the fluid: an SPH particle simulation (source SIMULATE), or particles the caller sets every
 *    frame (source PARTICLES, e.g. a Blender particle system), or a velocity grid the caller
 *    sets every frame (source VELOCITY_GRID, e.g. a Mantaflow cache);
 *  - V_m (motion), density, the surface field and the features, at grid vertices;
 *  - V_c: two uvw fields A and B, advected by V_m, reset to the rest mapping at staggered times
 *    and cross-faded (hbk_fluid_uvw_weight), so no texture lives long enough to stretch;
 *  - V_b: blend weights, `textures` per vertex, summing to one: feature paint (a table of
 *    feature ranges per texture) over a base that flows, plus local paint that flows and fades;
 *  - V_r: per-axis wrap flags at voxel centres (the dual grid), paper Fig. 4;
 *  - the surface: metaballs from the particles, extracted every hbk_fluid_update_surface call as a
 *    closed triangle mesh with smooth normals and per-vertex uvw, blend weights and features.
 *
 * Grid layout. The box [box_min, box_max] is split into resolution[0] x [1] x [2] voxels.
 * Vertex fields have (resolution[a] + 1) values per axis, vertex (i, j, k) at
 * box_min + (i, j, k) * cell where cell[a] = (box_max[a] - box_min[a]) / resolution[a]; voxel
 * fields (V_r) have resolution[a] values per axis, voxel (i, j, k) centred at
 * box_min + (i + 0.5, j + 0.5, k + 0.5) * cell. Index = i + nx * (j + ny * k) (x fastest),
 * channels interleaved. Axes are Blender's: z up. uvw are in [0, 1): one tile of a sample texture.
 *
 * Determinism: every result is the same bytes for any `threads` (neighbour lists in a fixed
 * order, per-particle and per-vertex gathers, no floating-point atomics). The only random numbers
 * (the jitter of hbk_fluid_fill_box, the noise textures) come from the counter-based RNG keyed by
 * `seed`.
 *
 * Threads: one handle must not be used from two threads at once; different handles are
 * independent. The handle owns everything it allocates; setters copy the caller's buffers and
 * getters write into buffers the caller sized (counts from the handle's queries). */
#ifndef HBK_FLUID_H
#define HBK_FLUID_H
#include "hbk_base.h"
#ifdef __cplusplus
extern "C" {
#endif

#define HBK_FLUID_MAX_TEXTURES 8
#define HBK_FLUID_MAX_OBSTACLES 64

typedef enum hbk_fluid_source {
    HBK_FLUID_SIMULATE = 0,      /* the built-in SPH moves the particles */
    HBK_FLUID_PARTICLES = 1,     /* the caller sets positions and velocities every frame */
    HBK_FLUID_VELOCITY_GRID = 2  /* the caller sets V_m (and a surface field) every frame */
} hbk_fluid_source_t;

/* Features per vertex (paper §3.2), in this channel order. */
typedef enum hbk_fluid_feature {
    HBK_FLUID_FEATURE_DENSITY = 0,      /* kg/m^3, SPH density (a grid source: its surface field) */
    HBK_FLUID_FEATURE_DENSITY_RATE = 1, /* kg/m^3/s, d density / dt between frames; 0 on frame 1 */
    HBK_FLUID_FEATURE_FLOW_ANGLE = 2,   /* rad in [0, pi]: angle between the flow and the outward
                                         * surface normal (-grad density); pi/2 where either is 0 */
    HBK_FLUID_FEATURE_ACCELERATION = 3, /* m/s^2, |dV_m/dt| between frames; 0 on frame 1 */
    HBK_FLUID_FEATURE_DIVERGENCE = 4,   /* 1/s, div V_m by central differences */
    HBK_FLUID_FEATURE_CURVATURE = 5,    /* 1/m, mean curvature of the density's level sets,
                                         * div(n) / 2 with n the outward normal: 1/R on a sphere
                                         * of radius R, > 0 where convex; 0 where the density is
                                         * flat (inside the fluid, in the air) */
    HBK_FLUID_FEATURE_COUNT = 6
} hbk_fluid_feature_t;

typedef struct hbk_fluid_params {
    uint32_t size;              /* sizeof(hbk_fluid_params_t), set by hbk_fluid_params_default */
    int32_t source;             /* hbk_fluid_source_t */
    int32_t resolution[3];      /* voxels per axis, 4..256 (paper: 32) */
    float box_min[3];           /* m, the simulation box; particles never leave it */
    float box_max[3];           /* m */
    float dt;                   /* s advanced by one hbk_fluid_step (one frame), e.g. 1/24 */
    int32_t substeps;           /* least SPH steps per frame, 1..1000; a frame takes more
                                 * when stability needs them (hbk_fluid_step) */
    int32_t max_particles;      /* particle capacity, 0..4,000,000 */
    float particle_spacing;     /* m, rest lattice spacing; the mass is set so that a lattice
                                 * of this spacing has exactly rest_density */
    float smoothing_length;     /* m, SPH kernel radius h, 1.5..3 x particle_spacing */
    float rest_density;         /* kg/m^3, 1000 for water */
    float stiffness;            /* m^2/s^2, k of p = k (rho - rho0), p >= 0; the sound speed is
                                 * sqrt(k): 10x the fastest flow keeps compression near 1% */
    float viscosity;            /* Pa s (Mueller et al. 2003 viscosity term), 0..100; 0.5..5 */
    float damping;              /* 1/s, velocity decay, 0..100; 0 for real fluid */
    float gravity[3];           /* m/s^2, (0, 0, -9.81) */
    float metaball_radius;      /* m, radius of one particle's metaball, 1..4 x spacing */
    float surface_threshold;    /* iso value of the metaball sum (1 at a lone particle's centre),
                                 * 0.01..10; 0.5 typical */
    float max_flow;             /* voxels per frame: faster V_m is clamped to this speed */
    int32_t textures;           /* sample textures, 1..8 */
    int32_t default_texture;    /* texture of the base blend at creation, 0..textures-1 */
    float uvw_tile;             /* m, world size of one texture tile at a uvw reset */
    float reset_period;         /* s between resets of one uvw field (B is half a period later);
                                 * 0 = never reset (only field A, weight 1) */
    float stretch_fade;         /* 0 = the cross-fade follows the reset schedule alone; > 0:
                                 * where a field is stretched, it fades out early in favour of
                                 * the other (weight x exp(-stretch / stretch_fade), stretch =
                                 * mean squared stretch - 1, 0 for a rigid motion); 0..100 */
    float paint_duration;       /* s a local paint stroke lasts at full strength */
    float paint_fade;           /* s over which it then fades out */
    float texture_scale[HBK_FLUID_MAX_TEXTURES]; /* per texture: tiles per uvw unit (for the
                                                 * shader; the core only stores it) */
    int32_t texture_feature[HBK_FLUID_MAX_TEXTURES]; /* per texture: the feature that
                                                 * hbk_fluid_capture_feature_rule reads, or
                                                 * HBK_FLUID_FEATURE_COUNT for all features */
    uint64_t seed;              /* random seed (fill jitter) */
    int32_t threads;            /* OpenMP threads, 0 = all; results never depend on it */
} hbk_fluid_params_t;

/* Fills every field with the defaults (a 1 m box at 32^3, 2 cm particles). Never fails. */
HBK_EXPORT void hbk_fluid_params_default(hbk_fluid_params_t *p);
/* The parameter table (every field but `size`); *count receives its length. Never fails. */
HBK_EXPORT const hbk_param_info_t *hbk_fluid_params_info(size_t *count);
/* Table ranges plus cross-field rules (box_max > box_min, smoothing_length and metaball_radius
 * within 1..4 spacings, default_texture < textures, texture_feature). HBK_ERR_INVALID_ARGUMENT
 * naming the field, HBK_ERR_VERSION. */
HBK_EXPORT hbk_result_t hbk_fluid_params_check(const hbk_fluid_params_t *p, hbk_message_t *msg);

typedef struct hbk_fluid hbk_fluid_t;

/* A new handle: no particles, uvw at the rest mapping, blend = default_texture, no paint.
 * HBK_ERR_INVALID_ARGUMENT, HBK_ERR_VERSION, HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_fluid_create(hbk_fluid_t **out, const hbk_fluid_params_t *p,
                                         hbk_message_t *msg);
HBK_EXPORT void hbk_fluid_destroy(hbk_fluid_t *h); /* NULL is allowed */
/* Detail of the handle's last failure ("" after a success); never NULL. */
HBK_EXPORT const char *hbk_fluid_message(const hbk_fluid_t *h);

/* Setters: HBK_ERR_INVALID_ARGUMENT (NULL, out of range, non-finite; the message names it) and
 * the handle is then unchanged. */

/* Replaces all particles: pos and vel are count x 3 floats (m, m/s); vel may be NULL (rest).
 * Positions must lie in the box. The external-particles path calls this every frame; with the
 * simulation it seeds the fluid. count <= max_particles. */
HBK_EXPORT hbk_result_t hbk_fluid_set_particles(hbk_fluid_t *h, const float *pos,
                                                const float *vel, int32_t count);
/* Adds particles at rest on a lattice of particle_spacing filling [lo, hi] (clipped to the box,
 * half a spacing from its walls), each moved by up to `jitter` spacings (0..0.5) with the RNG
 * keyed by seed, leaving out those inside an obstacle set before (within half a spacing, as
 * the step keeps them out). HBK_ERR_INVALID_ARGUMENT also when they would exceed
 * max_particles. */
HBK_EXPORT hbk_result_t hbk_fluid_fill_box(hbk_fluid_t *h, const float lo[3], const float hi[3],
                                           float jitter);
HBK_EXPORT int32_t hbk_fluid_particle_count(const hbk_fluid_t *h); /* 0 for NULL */
/* Copies positions and/or velocities (either may be NULL), particle_count x 3 floats each. */
HBK_EXPORT hbk_result_t hbk_fluid_get_particles(hbk_fluid_t *h, float *pos, float *vel,
                                                int32_t capacity);

/* Obstacles the particles cannot enter (SIMULATE only). */
typedef struct hbk_fluid_obstacle {
    int32_t type;       /* 0 = sphere, 1 = axis-aligned box, 2 = turned box, 3 = mesh (a signed
                         * distance field over a turned box: hbk_fluid_set_obstacle_field) */
    float center[3];    /* m */
    float extent[3];    /* m: sphere radius in [0]; box half-sizes along its own axes (a
                         * mesh's: of its field's box, each > 0) */
    float rotation[4];  /* types 2, 3: unit quaternion (w, x, y, z) turning the box's axes into
                         * the world's (length within 1e-3 of 1); the others ignore it */
} hbk_fluid_obstacle_t;
#define HBK_FLUID_FIELD_MAX_DIM 128
/* As fill_box over the box of `shape` (an obstacle record, checked as set_obstacles checks
 * one, "shape." before the name), keeping the lattice points inside it: a sphere, a box, a
 * turned box, or a mesh (type 3) whose signed distances (negative inside) dims and distance
 * give as set_obstacle_field takes them (NULL for the other types). The shape is not kept:
 * water poured in that shape, not an obstacle. */
HBK_EXPORT hbk_result_t hbk_fluid_fill_shape(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                             const int32_t dims[3], const float *distance,
                                             float jitter);
/* An inflow (SIMULATE): water poured in from `shape` (an obstacle record and a mesh's field,
 * checked as fill_shape takes them) at `velocity` (m/s, each component in [-1000, 1000]),
 * from the next step on. Its points: a lattice of particle_spacing inside the shape (and the
 * box, half a spacing from its walls) laid along the flow (the shape's own axes turned the
 * least way that puts one along `velocity`; fill_box's lattice over the shape's bounds for
 * no velocity or one along an axis of an unturned shape), so that a stream leaves in whole
 * columns at rest density whichever way it pours. At the start of every SPH substep each
 * point, jittered by up to `jitter` spacings (0..0.5, keyed by seed,
 * frame, substep and point), outside the obstacles and with no particle nearer than
 * particle_spacing, gains a particle moving at `velocity`, until max_particles: started as
 * far along the flow as it would be had it left when the point cleared (at most a substep's
 * travel), so a stream's particles follow a spacing apart and the inflow pours velocity x
 * cross-section. The stable step counts its speed. The shape is not an obstacle. NULL shape
 * stops the inflow. Not part of the saved state (set it again after load_state, as the
 * obstacles). HBK_ERR_INVALID_ARGUMENT also for another source or a shape holding more
 * lattice points than max_particles; HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_fluid_set_inflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                             const int32_t dims[3], const float *distance,
                                             const float velocity[3], float jitter);
/* set_inflow with a speed `normal` (m/s, in [0, 1000]) added along the shape's outward normal,
 * as Blender's fluids' Normal initial velocity: a sprinkler. With normal > 0 the points lie
 * on the shape's surface instead of filling it: half a spacing in (where a filled shape's
 * outer particles sit), at least particle_spacing apart, spread in the order of a half-spacing
 * lattice over the shape's bounds; each pours at `velocity` + normal x its outward normal
 * (a box's nearest face's, a mesh's field gradient), and those whose velocity does not leave
 * the shape are left out (they would pour into it). normal = 0 is set_inflow. */
HBK_EXPORT hbk_result_t hbk_fluid_set_inflow_normal(hbk_fluid_t *h,
                                                    const hbk_fluid_obstacle_t *shape,
                                                    const int32_t dims[3], const float *distance,
                                                    const float velocity[3], float normal,
                                                    float jitter);
/* A further inflow beside those set (two taps, a fountain's jets): `shape` pours at `velocity`
 * plus `normal` along its surface normal, exactly as set_inflow_normal would pour it alone,
 * with the jitter of the last set_inflow (0 after set_inflow(NULL)). The points of all pour
 * each at their own velocity; the rate is the sum of theirs. set_inflow replaces them all.
 * HBK_ERR_INVALID_ARGUMENT as set_inflow_normal (a NULL shape too, and the shapes holding
 * more points together than max_particles), the inflows left as they were;
 * HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_fluid_add_inflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                             const int32_t dims[3], const float *distance,
                                             const float velocity[3], float normal);
/* The lattice points the inflow pours from (0 without one, or for a shape no point of the
 * lattice lies in: it pours nothing). 0 for NULL. */
HBK_EXPORT int32_t hbk_fluid_inflow_points(const hbk_fluid_t *h);
/* Particles a second the inflow pours while the water before clears it (nothing backing up
 * to it, no max_particles): the lattice columns its points make along its velocity (the
 * shape's cross-section across the flow in spacing squares), each pouring once the particle
 * before has gone a spacing: every s / speed seconds (k^2 v / s for a k x k tap across an
 * axis), or with gravity g along the flow the t of speed t + g t^2 / 2 = s (a sprinkler's
 * points: each a column at its own velocity; inflows added: the sum). 0 without one,
 * at zero velocity, for a jet too slow to rise a spacing against gravity, or for NULL. A
 * bake's forecast of when max_particles stops the inflow. */
HBK_EXPORT double hbk_fluid_inflow_rate(const hbk_fluid_t *h);
/* Particles the inflow added in the last step; *capped receives 1 if a point ready to pour
 * found the fluid at max_particles (capped may be NULL). 0 for NULL. */
HBK_EXPORT int32_t hbk_fluid_inflow_added(const hbk_fluid_t *h, int32_t *capped);
/* An outflow (SIMULATE): a drain. After every SPH substep the particles inside `shape` (an
 * obstacle record and a mesh's field, checked as fill_shape takes them; the field is copied)
 * are removed, the others keeping their order. The shape is not an obstacle: the water flows
 * into it. NULL shape stops the outflow. Not part of the saved state (set it again after
 * load_state, as the obstacles). HBK_ERR_INVALID_ARGUMENT also for another source;
 * HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_fluid_set_outflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                              const int32_t dims[3], const float *distance);
/* A further drain beside those set (a pool's two drains): after every SPH substep the
 * particles inside `shape` go too, as set_outflow takes it (the field is copied). set_outflow
 * replaces them all. HBK_ERR_INVALID_ARGUMENT as set_outflow (a NULL shape too), the drains
 * left as they were; HBK_ERR_OUT_OF_MEMORY. */
HBK_EXPORT hbk_result_t hbk_fluid_add_outflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                              const int32_t dims[3], const float *distance);
/* Particles the outflow removed in the last step. 0 for NULL. */
HBK_EXPORT int32_t hbk_fluid_outflow_removed(const hbk_fluid_t *h);
/* Replaces the obstacle list (count 0..64; NULL with 0 clears), still where they are, and
 * drops a move not stepped yet. */
HBK_EXPORT hbk_result_t hbk_fluid_set_obstacles(hbk_fluid_t *h, const hbk_fluid_obstacle_t *obs,
                                                int32_t count);
/* The shape of mesh obstacle `index` (type 3; set after set_obstacles, which drops the fields):
 * signed distances (m, negative inside, finite, within +-1e6) at dims[0] x dims[1] x dims[2]
 * points (x fastest, 2..HBK_FLUID_FIELD_MAX_DIM each) spanning its box [-extent, extent] in
 * its own axes, corners included. Copied. The field moves, turns and stretches with the
 * obstacle's box; a point outside the box is outside the mesh. A step or fill with a mesh
 * obstacle whose field is not set is refused by name. Part of the saved state. */
HBK_EXPORT hbk_result_t hbk_fluid_set_obstacle_field(hbk_fluid_t *h, int32_t index,
                                                     const int32_t dims[3],
                                                     const float *distance);
/* A mesh whose shape changes (an armature, a wave): the shape of mesh obstacle `index` at the
 * end of the next step, checked as set_obstacle_field checks it. With the dims of the field
 * it has, the step changes one into the other at a constant rate (each point's distance from
 * the old to the new), and the fluid meets the surface moving: a particle it reaches leaves
 * no slower along the normal than the surface moves there, its change of shape added to the
 * obstacle's motion. A field of other dims, or a mesh without one yet, takes it at once, as
 * set_obstacle_field. A completed step makes it the field; a cancelled one keeps it pending;
 * set_obstacles, set_obstacle_field and load_state drop it. Not part of the saved state. */
HBK_EXPORT hbk_result_t hbk_fluid_move_obstacle_field(hbk_fluid_t *h, int32_t index,
                                                      const int32_t dims[3],
                                                      const float *distance);
/* Moving obstacles: where each obstacle is at the end of the next step (one per obstacle, in
 * order, of the same type). The step carries each there in a straight line over its dt
 * (centre and extent at a constant rate; a turned box also turns at a constant rate about
 * one axis, the shorter way), and the fluid meets the moving surface: a particle
 * it reaches is pushed out and leaves no slower along the normal than the surface moves
 * (free slip along it). A completed step makes them the obstacles; a cancelled one keeps
 * them where they were, the move still pending. Not part of the saved state. */
HBK_EXPORT hbk_result_t hbk_fluid_move_obstacles(hbk_fluid_t *h, const hbk_fluid_obstacle_t *to,
                                                 int32_t count);

/* VELOCITY_GRID source: V_m at the vertices (vertex_count x 3 floats, m/s) and optionally a
 * surface field (vertex_count floats, e.g. a density or liquid fraction; the surface is where
 * it equals surface_threshold; it also stands in for the density feature). NULL surface: none. */
HBK_EXPORT hbk_result_t hbk_fluid_set_velocity_grid(hbk_fluid_t *h, const float *velocity,
                                                    const float *surface);

/* Vertex and voxel counts of the grid: vertices[a] = resolution[a] + 1. Never fails for a
 * valid handle; returns the total vertex count (0 for NULL). */
HBK_EXPORT size_t hbk_fluid_grid_vertices(const hbk_fluid_t *h, int32_t vertices[3]);

/* Advances one frame: SPH substeps (SIMULATE), then density, V_m (clamped to max_flow), the
 * features, then advects V_c A/B, V_r, the base blend and the paint by V_m (semi-Lagrangian,
 * interpolation honouring V_r), resets a uvw field when its period comes round, ages the paint
 * and applies the feature rules. The SPH cuts the frame into at least `substeps` equal steps,
 * and into shorter ones while the fastest particle needs them: each at most
 * 0.4 h / (sqrt(stiffness) + v_max), 0.125 h^2 rest_density / viscosity and
 * 0.25 sqrt(h / |gravity|), at most 10,000 a frame; so a frame is stable whatever `substeps`
 * says. Polls progress->cancel between substeps and phases; on HBK_ERR_CANCELLED and
 * HBK_ERR_OUT_OF_MEMORY the handle is exactly as before. HBK_ERR_INVALID_ARGUMENT (NULL),
 * HBK_ERR_OUT_OF_MEMORY, HBK_ERR_CANCELLED. */
HBK_EXPORT hbk_result_t hbk_fluid_step(hbk_fluid_t *h, hbk_progress_t *progress);
/* Frames stepped since creation. 0 for NULL. */
HBK_EXPORT uint64_t hbk_fluid_frame(const hbk_fluid_t *h);
/* Recomputes density, V_m, the surface field and the features from the current particles or
 * grid without advancing time or advecting (for frame 0, or after set_particles). */
HBK_EXPORT hbk_result_t hbk_fluid_update_fields(hbk_fluid_t *h);

/* Volumes. */
typedef enum hbk_fluid_volume {
    HBK_FLUID_VOL_UVW_A = 0,    /* vertices x 3: uvw field A in [0, 1) */
    HBK_FLUID_VOL_UVW_B = 1,    /* vertices x 3: uvw field B */
    HBK_FLUID_VOL_BLEND = 2,    /* vertices x textures: V_b, sums to one */
    HBK_FLUID_VOL_MOTION = 3,   /* vertices x 3: V_m, m/s, clamped */
    HBK_FLUID_VOL_DENSITY = 4,  /* vertices x 1: kg/m^3 */
    HBK_FLUID_VOL_SURFACE = 5,  /* vertices x 1: the metaball sum (or the caller's field) */
    HBK_FLUID_VOL_FEATURES = 6, /* vertices x HBK_FLUID_FEATURE_COUNT */
    HBK_FLUID_VOL_WRAP = 7,     /* voxels x 3: V_r flags per uvw component, 0 or 1 (field A) */
    HBK_FLUID_VOL_WRAP_B = 8,   /* voxels x 3: V_r of field B */
    HBK_FLUID_VOL_UVW_WEIGHT = 9, /* vertices x 1: the cross-fade weight of field A there
                                   * (hbk_fluid_uvw_weight everywhere unless stretch_fade) */
    HBK_FLUID_VOL_UVW_A_UNWRAPPED = 10, /* vertices x 3: field A moved by whole tiles to within
                                         * half a tile of the rest mapping (x - box_min) /
                                         * uvw_tile at the vertex, as the mesh's uvw are: plain
                                         * trilinear interpolation (a renderer's) then needs no
                                         * wrap flags where the fluid moved under half a tile */
    HBK_FLUID_VOL_UVW_B_UNWRAPPED = 11, /* vertices x 3: the same of field B */
    HBK_FLUID_VOL_COUNT = 12
} hbk_fluid_volume_t;
/* Floats a volume needs (0 for NULL or an unknown volume). */
HBK_EXPORT size_t hbk_fluid_volume_size(const hbk_fluid_t *h, int32_t volume);
/* Copies a volume into out[0..count); count must equal hbk_fluid_volume_size. */
HBK_EXPORT hbk_result_t hbk_fluid_get_volume(hbk_fluid_t *h, int32_t volume, float *out,
                                             size_t count);
/* Weight of uvw field A in the cross-fade; B's is 1 - A's. It is 0 the frame A is reset and 1
 * the frame B is. 1 when reset_period = 0. 0 for NULL. With stretch_fade, the weight varies
 * in space (HBK_FLUID_VOL_UVW_WEIGHT, hbk_fluid_get_mesh_weight) around this one, still 0 and
 * 1 at the resets. */
HBK_EXPORT float hbk_fluid_uvw_weight(const hbk_fluid_t *h);
/* uvw of field `which` (0 = A, 1 = B) at world position pos (clamped to the box), trilinear
 * with the wrap flags of the voxel. */
HBK_EXPORT hbk_result_t hbk_fluid_sample_uvw(hbk_fluid_t *h, int32_t which, const float pos[3],
                                             float uvw[3]);

/* Local paint (paper §3.1): from now on, texture `texture` covers the masked region at full
 * strength for paint_duration s, then fades over paint_fade s; it flows with the fluid.
 * mask: vertex_count floats in [0, 1] (coverage). A newer stroke replaces older paint where it
 * covers it. */
HBK_EXPORT hbk_result_t hbk_fluid_paint_mask(hbk_fluid_t *h, int32_t texture, const float *mask);
/* The same with a ball: coverage 1 inside `radius` m of `center`, a linear falloff over the last
 * `falloff` m. */
HBK_EXPORT hbk_result_t hbk_fluid_paint_sphere(hbk_fluid_t *h, int32_t texture,
                                               const float center[3], float radius,
                                               float falloff);
/* The same from points, such as the vertices of a surface painted in Blender: coverage
 * coverage[i] (NULL: 1) inside `radius` m of pos[3 i..3 i + 2], a linear falloff over the
 * last `falloff` m; where points' balls overlap the largest coverage counts. radius + falloff
 * must lie within 16 cells, so that a stroke stays cheap. count = 0 paints nothing. */
HBK_EXPORT hbk_result_t hbk_fluid_paint_points(hbk_fluid_t *h, int32_t texture, int32_t count,
                                               const float *pos, const float *coverage,
                                               float radius, float falloff);
/* Removes all local paint. */
HBK_EXPORT hbk_result_t hbk_fluid_clear_paint(hbk_fluid_t *h);

/* Feature paint (paper §3.1): every vertex whose features all lie in [lo[f], hi[f]] gets
 * `texture` in the base blend, every frame. Rules are tried in texture order; a later texture
 * wins where several match. Use -FLT_MAX / FLT_MAX for a feature that does not matter. */
HBK_EXPORT hbk_result_t hbk_fluid_set_feature_rule(hbk_fluid_t *h, int32_t texture,
                                                   const float lo[HBK_FLUID_FEATURE_COUNT],
                                                   const float hi[HBK_FLUID_FEATURE_COUNT]);
/* The selection UI: sets texture's rule to the range its texture_feature (or every feature)
 * takes over the vertices where mask >= 0.5; the other features are left open.
 * HBK_ERR_INVALID_ARGUMENT when the mask selects nothing. */
HBK_EXPORT hbk_result_t hbk_fluid_capture_feature_rule(hbk_fluid_t *h, int32_t texture,
                                                       const float *mask);
HBK_EXPORT hbk_result_t hbk_fluid_clear_feature_rule(hbk_fluid_t *h, int32_t texture);

/* Surface: marching cubes (a table that cuts an ambiguous face alike from both of its cubes)
 * over the surface field at the grid vertices; outside the box counts as empty, so every blob gives
 * closed surfaces, capped flat where the fluid meets the box walls. Normals are the normalised
 * negative gradient of the field. Triangles wind counter-clockwise seen from outside.
 * HBK_ERR_OUT_OF_MEMORY, HBK_ERR_CANCELLED (the previous mesh is kept). */
HBK_EXPORT hbk_result_t hbk_fluid_update_surface(hbk_fluid_t *h, hbk_progress_t *progress);
/* Counts of the current mesh (0, 0 before the first update). */
HBK_EXPORT hbk_result_t hbk_fluid_mesh_counts(hbk_fluid_t *h, int32_t *vertices,
                                              int32_t *triangles);
/* Copies the mesh into caller buffers sized by hbk_fluid_mesh_counts; any pointer may be NULL.
 * pos, normal, uvw_a, uvw_b: vertices x 3; blend: vertices x textures; features: vertices x
 * HBK_FLUID_FEATURE_COUNT (the flow angle uses the mesh normal); tris: triangles x 3 indices.
 * The mesh's uvw are not wrapped into [0, 1): each is the volume's value plus the whole tiles
 * that bring it within half a tile of the rest mapping at the vertex, so they are continuous
 * wherever the fluid has moved less than half a tile since its field's reset. */
HBK_EXPORT hbk_result_t hbk_fluid_get_mesh(hbk_fluid_t *h, float *pos, float *normal,
                                           int32_t *tris, float *uvw_a, float *uvw_b,
                                           float *blend, float *features);
/* The cross-fade weight of field A at each mesh vertex (vertices floats, caller's buffer). */
HBK_EXPORT hbk_result_t hbk_fluid_get_mesh_weight(hbk_fluid_t *h, float *weight);

/* Milliseconds the last step / surface update spent in: [0] SPH, [1] density, V_m and
 * features, [2] advection and paint, [3] surface. For benchmarks; not deterministic, not state. */
HBK_EXPORT void hbk_fluid_timings(const hbk_fluid_t *h, double ms[4]);
/* SPH steps the last hbk_fluid_step took (0 before the first step, and without SIMULATE). */
HBK_EXPORT int32_t hbk_fluid_substeps_taken(const hbk_fluid_t *h);

/* Checkpoints: everything but the params and the mesh (particles, obstacles and the fields of
 * mesh obstacles, the external grid inputs, every volume, the paint, the rules, the frame
 * counter). Loading into a handle with the same params continues bit for bit. States of
 * versions 1 and 2 (before turned boxes and meshes) load too. save: HBK_ERR_INVALID_ARGUMENT
 * if size is too small. load: HBK_ERR_FORMAT (not a fluid state, other version, bad numbers),
 * HBK_ERR_INVALID_ARGUMENT (other grid, textures or capacity); unchanged on failure.
 * Native-endian: a checkpoint for the same machine, not an archive. */
HBK_EXPORT size_t hbk_fluid_state_size(const hbk_fluid_t *h);
HBK_EXPORT hbk_result_t hbk_fluid_save_state(hbk_fluid_t *h, void *buffer, size_t size);
HBK_EXPORT hbk_result_t hbk_fluid_load_state(hbk_fluid_t *h, const void *buffer, size_t size);

/* Tileable 3D gradient noise for sample textures: a size^3 voxel texture (x fastest) in [0, 1]
 * whose opposite faces continue each other. `period` lattice cells span the tile at the first
 * octave (1..size), each further octave doubles the frequency and multiplies the amplitude by
 * `persistence` (0..1). octaves 1..8. HBK_ERR_INVALID_ARGUMENT naming the argument. */
HBK_EXPORT hbk_result_t hbk_noise3d_tileable(float *out, int32_t size, int32_t period,
                                             int32_t octaves, float persistence, uint64_t seed,
                                             hbk_message_t *msg);
/* One value of that noise at (x, y, z) in tile units ([0, 1) is one tile; the noise repeats
 * with period 1). Never fails; invalid arguments give 0.5. */
HBK_EXPORT float hbk_noise3d_sample(float x, float y, float z, int32_t period, int32_t octaves,
                                    float persistence, uint64_t seed);

#ifdef __cplusplus
}
#endif
#endif
