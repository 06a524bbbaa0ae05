/* Private: the fluid handle and the entry points shared by the fluid sources. */
#ifndef HBK_INTERNAL_FLUID_H
#define HBK_INTERNAL_FLUID_H
#include "hbk_fluid.h"
#include <string.h>
#include "../base/internal_base.h"
#include <math.h>

#define HBK_FLUID_STREAM_JITTER 0xf1a1u
#define HBK_FLUID_STREAM_NOISE 0xf1a2u

/* Uniform grid of particles: cells of `size` m, counting-sorted so every query visits particles
 * in the same order whatever the thread count. */
typedef struct hbk_fluid_cells {
    float origin[3], size, inv_size;
    int32_t dims[3];
    size_t ncells;
    int32_t *start;    /* ncells + 1 offsets into `order` */
    int32_t *order;    /* particle ids sorted by cell, ascending id within a cell */
    int32_t *cell_of;  /* cell of each particle */
    size_t cap_cells, cap_particles;
} hbk_fluid_cells_t;

/* The texturing volumes that advect (double buffered by the step for cancellation). */
typedef struct hbk_fluid_vols {
    float *uvw[2];     /* nv x 3 */
    uint8_t *wrap[2];  /* nvox: bit a = component a wraps in this voxel */
    float *base;       /* nv x K: base blend (feature paint acts on it) */
    float *paint;      /* nv x K: paint weights, sum = coverage in [0, 1] */
    float *life;       /* nv: seconds of paint left (duration + fade when painted) */
    uint8_t *unpainted; /* per vertex row: 1 if its paint and life are all +0, 0 if not or not
                         * known (kept by the advection while paint is active; 2 within it:
                         * clean, known by the sixteen-lane row) */
} hbk_fluid_vols_t;

/* One drain of the outflow (outflow.c): its shape, a mesh's field (a copy), its axes and
 * box. */
typedef struct hbk_fluid_drain {
    hbk_fluid_obstacle_t shape;
    int32_t dims[3];
    float *field;
    float ax[9], lo[3], hi[3];
} hbk_fluid_drain_t;

struct hbk_fluid {
    hbk_fluid_params_t p;
    hbk_message_t msg;
    int32_t nv[3];              /* vertices per axis */
    size_t n_vert, n_vox;
    int K;                      /* textures */
    float cell[3], inv_cell[3];
    double mass;                /* kg per particle: a lattice is at rest density under poly6 */
    double sph_mass;            /* the same under the spiky kernel, for the SPH step */
    /* State. */
    int32_t count;
    float *pos, *vel;           /* max_particles x 3 */
    int32_t n_obs;
    hbk_fluid_obstacle_t obs[HBK_FLUID_MAX_OBSTACLES]; /* where they are after the last step */
    /* Not state: a move_obstacles not stepped yet (where the next step takes them), and the
     * obstacles as the substep under way meets them (obstacles.c). */
    int32_t obs_moving;
    hbk_fluid_obstacle_t obs_to[HBK_FLUID_MAX_OBSTACLES];
    hbk_fluid_obstacle_t obs_now[HBK_FLUID_MAX_OBSTACLES];
    float obs_rate[HBK_FLUID_MAX_OBSTACLES][9]; /* centre, extent (m/s), turning (rad/s) */
    float obs_axes[HBK_FLUID_MAX_OBSTACLES][9]; /* obs_now's axes in the world: x, y, z */
    /* State: the distance fields of mesh obstacles (NULL, dims 0 for the others). */
    float *obs_field[HBK_FLUID_MAX_OBSTACLES];
    int32_t obs_dims[HBK_FLUID_MAX_OBSTACLES][3];
    /* Not state: a mesh's shape at the end of the next step (move_obstacle_field; its dims
     * are obs_dims), the fastest its surface moves by the change (m/s), and how far into the
     * step the substep under way meets it (0..1). */
    float *obs_field_to[HBK_FLUID_MAX_OBSTACLES];
    float obs_shape_speed[HBK_FLUID_MAX_OBSTACLES];
    float obs_t;
    float obs_speed;            /* m/s: the fastest any obstacle's surface moves (stable dt) */
    float *in_vel, *in_surface; /* VELOCITY_GRID inputs (nv x 3, nv), or NULL */
    hbk_fluid_vols_t v;
    float *motion;              /* nv x 3, V_m */
    float *density;             /* nv */
    float *surface;             /* nv, metaball sum */
    float *features;            /* nv x F */
    int32_t have_fields;        /* density/motion hold a frame (the rates can use them) */
    int32_t rule_on[HBK_FLUID_MAX_TEXTURES];
    float rule_lo[HBK_FLUID_MAX_TEXTURES][HBK_FLUID_FEATURE_COUNT];
    float rule_hi[HBK_FLUID_MAX_TEXTURES][HBK_FLUID_FEATURE_COUNT];
    int32_t paint_active;
    uint64_t frame;
    /* Scratch, not state. */
    hbk_fluid_vols_t scratch;   /* advection targets */
    float *pos0, *vel0;         /* particles at the start of a step (cancellation) */
    float *sorted;              /* SPH and splat scratch: particles in cell order, 8 floats
                                 * each (x, v, then the SPH's density and pressure) */
    float *soa;                 /* the same as 8 arrays of max_particles + 8 (sph_lanes.c) */
    int32_t *nbr, *nbr_n;       /* SPH scratch, one block made by the first AVX2 step: each
                                 * particle's (neighbour, image) pairs in reach, from the
                                 * density for the forces (HBK_FLUID_NBR_CAP each), and their
                                 * count (-1: more) */
    float *g_motion, *g_density, *g_surface, *g_features; /* fields under construction */
    float *g_normal;             /* vertices x 3: outward unit normal of the density (features) */
    float *g_wsum;              /* Shepard weight sums of the velocity gather */
    float *g_mp[3];             /* nv each, a plane per axis: the splat's velocity sums, then V_m */
    float *g_sums;              /* the block g_wsum and g_mp are in (hbk_fluid_sums_alloc) */
    int32_t *splat_ylo, *splat_yhi; /* per vertex layer: the rows of g_wsum and g_mp that
                                 * may be non-zero (metaballs.c clears only those) */
    uint8_t *moving;            /* nv: V_m is not zero there (advection) */
    uint8_t *rule_tex;          /* nv: the texture this step's feature rules set (0xff: none),
                                 * matched by the features pass outside quiet rows */
    int rules_matched;          /* rule_tex holds this step's matches (some rule is on) */
    /* Per vertex row, for the fields of the handle (h->density ...) and those under
     * construction (g_density ...), swapped with them: */
    uint8_t *blank, *g_blank;   /* density, V_m and surface all written +0 as a row no particle
                                 * reaches (metaballs.c: such a row is not written again) */
    uint8_t *fz, *g_fz;         /* density and V_m all +0, bit for bit (features.c; the advection
                                 * copies such rows whole) */
    uint8_t *fq, *g_fq;         /* the features hold the constants of a quiet row */
    uint8_t *quiet;             /* rows (features.c): all zero now, last frame and around */
    uint8_t *same_rows;         /* the vertex row of v and scratch holds the same uvw, base and
                                 * (if the paint was active since) paint: a still row need not
                                 * be copied again (advection) */
    uint8_t *row_flags;         /* the block the flags above live in, n_rows each */
    size_t n_rows;              /* vertex rows, ny x nz */
    uint8_t *rows_hot;          /* the texture a rule made the row's whole base one-hot at
                                 * in both buffers (0xff: none); forgotten when the row is
                                 * copied, as it stops being the same (advect.c) */
    uint8_t *same_vox;          /* ry x rz: same_rows for a voxel row of the flags */
    float *disp;                /* nv x 3: a moving vertex's back-trace, source - vertex, in
                                 * voxels (advection, for V_r); g_normal's buffer */
    int32_t wrap_checked;       /* the flags were repaired from the uvw as they are (advection
                                 * then repairs only where something moved); 0 after create or
                                 * load_state, so the first frame checks every voxel */
    hbk_fluid_cells_t cells;
    /* Mesh. */
    int32_t mesh_nv, mesh_nt;
    float *mesh_pos, *mesh_nrm;
    int32_t *mesh_tri;
    size_t mesh_cap_v, mesh_cap_t; /* vertices and triangles the mesh buffers hold */
    /* Marching scratch, kept between frames (fresh buffers of this size each frame cost a
     * fifth of the frame in page faults): the next mesh, built while the current one stays
     * whole for a cancel, and the per-cell tables. */
    float *next_pos, *next_nrm;
    int32_t *next_tri;
    size_t next_cap_v, next_cap_t;
    uint8_t *mc_mask, *mc_in, *mc_row_in, *mc_cfg;
    int32_t *mc_first;
    int64_t *mc_row_v, *mc_row_t;
    struct mc_table *mc_table;  /* triangles per cube configuration (marching_cubes.c) */
    double ms[4];
    int32_t substeps_taken;     /* by the last step */
    /* Not state: the inflow (inflow.c): its lattice points inside the shape and the box, the
     * velocity and jitter they start with, and a grid of cells over their reach (each of
     * inflow_cell m, at least a spacing) listing the particles near them. */
    float *inflow_pts;
    float *inflow_pvel; /* a sprinkler's: each point's velocity (3 n), else NULL */
    int32_t inflow_n;
    float inflow_vel[3], inflow_jitter, inflow_cell, inflow_lo[3];
    float inflow_top2; /* the fastest point's speed squared (the stable step's) */
    int32_t inflow_dims[3];
    double inflow_rate; /* particles a second (hbk_fluid_inflow_rate) */
    int32_t *inflow_head, *inflow_next; /* cells + 1, max_particles */
    int32_t inflow_added, inflow_capped; /* by the last step */
    /* Not state: the outflow (outflow.c): its drains, and a byte per particle (inside one). */
    hbk_fluid_drain_t *drains;
    int32_t drain_n;
    uint8_t *outflow_gone;
    int32_t outflow_removed; /* by the last step */
};

#define HBK_OMP_THREADS(h) hbk_threads((h)->p.threads)
/* An entry point's start: a NULL handle refused, the last call's message cleared. */
#define HBK_FLUID_ENTER(h)                         \
    do {                                           \
        if (!(h)) return HBK_ERR_INVALID_ARGUMENT; \
        hbk_message_clear(&(h)->msg);              \
    } while (0)

/* fill_box's lattice of particle_spacing over [lo, hi] clipped to the box, half a spacing
 * from its walls: its first point a0 and its points per axis n (0 where it is too narrow). */
static inline void hbk_fluid_lattice(const hbk_fluid_t *h, const float lo[3], const float hi[3],
                                     double a0[3], int32_t n[3])
{
    const double s = h->p.particle_spacing;
    for (int a = 0; a < 3; ++a) {
        const double l = fmax(lo[a], h->p.box_min[a]) + 0.5 * s;
        const double u = fmin(hi[a], h->p.box_max[a]) - 0.5 * s;
        a0[a] = l;
        n[a] = u >= l ? (int32_t)floor((u - l) / s + 1e-6) + 1 : 0;
    }
}

/* x moved into the box, half a spacing from its walls (as collide keeps particles). */
static inline void hbk_fluid_into_box(const hbk_fluid_t *h, float x[3])
{
    const float m = 0.5f * h->p.particle_spacing;
    for (int a = 0; a < 3; ++a) {
        x[a] = x[a] < h->p.box_min[a] + m ? h->p.box_min[a] + m : x[a];
        x[a] = x[a] > h->p.box_max[a] - m ? h->p.box_max[a] - m : x[a];
    }
}

/* SPH kernels (Mueller et al. 2003, as Harada et al. 2007 use them). */
static inline double hbk_poly6(double r2, double h)
{
    const double h2 = h * h;
    if (r2 >= h2) return 0.0;
    const double d = h2 - r2;
    return 315.0 / (64.0 * M_PI * pow(h, 9)) * d * d * d;
}

static inline double hbk_spiky(double r2, double h)
{
    if (r2 >= h * h) return 0.0;
    const double q = h - sqrt(r2);
    return 15.0 / (M_PI * pow(h, 6)) * q * q * q;
}

/* acos on [-1, 1] (the flow angle feature) from +, *, sqrt only, after Cephes' asinf: within
 * 1.3 ulp of the true value, the same bits with every C library, and several times faster than
 * acosf, which took a twentieth of a frame. */
static inline float hbk_fluid_acos(float x)
{
    const float a = fabsf(x);
    const int wide = a > 0.5f; /* acos |x| = 2 asin sqrt((1 - |x|) / 2) */
    const float z = wide ? 0.5f * (1.0f - a) : a * a, s = wide ? sqrtf(z) : a;
    const float p = ((((4.2163199048e-2f * z + 2.4181311049e-2f) * z + 4.5470025998e-2f) * z +
                      7.4953002686e-2f) * z + 1.6666752422e-1f) * z * s + s; /* asin s */
    if (wide) return x < 0.0f ? 3.14159265f - 2.0f * p : 2.0f * p;
    return x < 0.0f ? 1.57079633f + p : 1.57079633f - p;
}

/* neighbours.c */
hbk_result_t hbk_fluid_cells_build(hbk_fluid_cells_t *c, const float *pos, int32_t count,
                                   const float lo[3], const float hi[3], float size, int threads);
void hbk_fluid_cells_free(hbk_fluid_cells_t *c);
/* obstacles.c: 0 if an obstacle is one the step takes, else its problem in what (96 bytes).
 * obstacles_at: obs_now, obs_rate and obs_speed at the moment `t` (0..1) into the step (the
 * obstacles as they are, still, unless a move is pending). obstacles_moved: the step is done,
 * its move made. */
int hbk_fluid_obstacle_problem(const hbk_fluid_obstacle_t *o, char *what);
void hbk_fluid_obstacles_at(hbk_fluid_t *h, double t);
void hbk_fluid_obstacles_moved(hbk_fluid_t *h);
/* 1 if x is where the step's collision would push a particle out of an obstacle (still). */
int hbk_fluid_in_obstacle(const hbk_fluid_t *h, const float x[3]);
/* Mesh obstacle o's field at l (its own axes, m from its centre, inside its box): 1 if it is
 * nearer than m to the surface or inside, with the push out (m - distance), the outward unit
 * normal in its own axes and the speed (m/s) its surface moves along it by a change of shape
 * under way (moving 0: the field as it is, as a fill meets it); else 0. */
int hbk_fluid_field_contact(const hbk_fluid_t *h, int32_t o, const float e[3], const float l[3],
                            float m, int moving, float *push, float nl[3], float *grow);
/* HBK_OK, or the refusal by name of a field: dims (2..HBK_FLUID_FIELD_MAX_DIM each) and
 * distances (finite, within +-1e6); its point count in *n. */
hbk_result_t hbk_fluid_field_check(hbk_fluid_t *h, const int32_t dims[3], const float *distance,
                                   size_t *n);
/* HBK_OK, or the refusal by name of a shape given as an obstacle record ("shape." before the
 * record's problem) and, for a mesh (type 3), its field; the field's point count in *points
 * (0 for the other types). */
hbk_result_t hbk_fluid_shape_check(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                   const int32_t dims[3], const float *distance,
                                   size_t *points);
/* A shape given as an obstacle record (checked): its box in the world, and whether x lies
 * inside it (a mesh's: where its field, dims points over the box, is negative). */
void hbk_fluid_shape_bounds(const hbk_fluid_obstacle_t *o, float lo[3], float hi[3]);
int hbk_fluid_in_shape(const hbk_fluid_obstacle_t *o, const int32_t dims[3], const float *f,
                       const float x[3]);
/* The same with the shape's axes (hbk_fluid_shape_axes) found once for many points. */
void hbk_fluid_shape_axes(const hbk_fluid_obstacle_t *o, float ax[9]);
int hbk_fluid_in_shape_ax(const hbk_fluid_obstacle_t *o, const float ax[9],
                          const int32_t dims[3], const float *f, const float x[3]);
/* The signed distance *d from x to the shape's surface (negative inside; a mesh's: its field,
 * over the gradient's length where that is under 1) and the outward normal n there (a box's
 * nearest face's, from inside); 0 where there is none (a ball's centre, a flat spot of a
 * field, outside a mesh's box). */
int hbk_fluid_shape_distance(const hbk_fluid_obstacle_t *o, const float ax[9],
                             const int32_t dims[3], const float *f, const float x[3], float *d,
                             float n[3]);
/* HBK_OK, or the refusal of a step or fill with a mesh obstacle whose field is not set. */
hbk_result_t hbk_fluid_fields_ready(hbk_fluid_t *h, const char *what);
void hbk_fluid_fields_free(hbk_fluid_t *h);
static inline int32_t hbk_fluid_cell_coord(const hbk_fluid_cells_t *c, float x, int a)
{
    /* Clamped as a float: a particle far outside the grid (a loaded state's) would overflow
     * the int32 conversion. The same cell as before for every coordinate that converted. */
    const float f = floorf((x - c->origin[a]) * c->inv_size);
    return f >= (float)c->dims[a] ? c->dims[a] - 1 : f >= 1.0f ? (int32_t)f : 0;
}

/* The rows of cells around (cx, cy, cz) (sph.c and sph_lanes.c): each a contiguous range of
 * sorted particles, [a_, e_). */
#define HBK_FLUID_FOR_ROWS(c, cx, cy, cz, a_, e_, ...)                                       \
    for (int32_t nz_ = (cz) - 1; nz_ <= (cz) + 1; ++nz_) {                                   \
        if (nz_ < 0 || nz_ >= (c)->dims[2]) continue;                                        \
        for (int32_t ny_ = (cy) - 1; ny_ <= (cy) + 1; ++ny_) {                               \
            if (ny_ < 0 || ny_ >= (c)->dims[1]) continue;                                    \
            const size_t row_ = (size_t)(c)->dims[0] * ((size_t)ny_ + (size_t)(c)->dims[1] * \
                                                        (size_t)nz_);                        \
            const int32_t x0_ = (cx) > 0 ? (cx) - 1 : 0;                                     \
            const int32_t x1_ = (cx) + 1 < (c)->dims[0] ? (cx) + 1 : (c)->dims[0] - 1;       \
            const int32_t a_ = (c)->start[row_ + (size_t)x0_];                               \
            const int32_t e_ = (c)->start[row_ + (size_t)x1_ + 1];                           \
            __VA_ARGS__                                                                      \
        }                                                                                    \
    }

/* The forces' neighbour list a particle keeps (more are found again). */
#define HBK_FLUID_NBR_CAP 64
/* SPH sums in eight lanes (sph.c and sph_lanes.c alike): the density's candidate j of a row of
 * cells that starts at sorted index a adds to lane (j - a) mod 8; the forces put the k-th
 * (neighbour, mirror image) pair in reach in lane k mod 8; the lanes are added in this tree. */
static inline int hbk_fluid_lane_of(int32_t j, int32_t a) { return (int)((j - a) & 7); }
static inline float hbk_fluid_lane_sum(const float p[8])
{
    return ((p[0] + p[1]) + (p[2] + p[3])) + ((p[4] + p[5]) + (p[6] + p[7]));
}

/* inflow.c: the inflow's particles for substep number `substep` of the step under way, `dt`
 * s long (none without an inflow or at max_particles); frees the inflow at destroy. */
void hbk_fluid_inflow_emit(hbk_fluid_t *h, int32_t substep, double dt);
/* The cell of x in a grid of cells of side `cell` from lo (dims d), c its coordinates; -1
 * outside it (the inflow's grid of particles, the sprinkler's of points). */
static inline int64_t hbk_fluid_grid_cell(const float lo[3], float cell, const int32_t d[3],
                                          const float x[3], int32_t c[3])
{
    for (int a = 0; a < 3; ++a) {
        const float t = (x[a] - lo[a]) / cell;
        if (!(t >= 0.0f && t < (float)d[a])) return -1;
        c[a] = (int32_t)t;
    }
    return c[0] + (int64_t)d[0] * (c[1] + (int64_t)d[1] * c[2]);
}
/* A sprinkler's points (inflow_surface.c): on the shape's surface, half a spacing in, at least
 * a spacing apart, and their outward normals (3 n floats each, the caller's to free). */
hbk_result_t hbk_fluid_surface_points(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                      const int32_t dims[3], const float *f, float **pts,
                                      float **nrm, size_t *n);
void hbk_fluid_inflow_free(hbk_fluid_t *h);
#define HBK_FLUID_STREAM_INFLOW 0xf1a3u
/* outflow.c: the particles inside the outflow's shape removed (after a substep); frees it at
 * destroy. */
void hbk_fluid_outflow_drain(hbk_fluid_t *h);
void hbk_fluid_outflow_free(hbk_fluid_t *h);

/* sph.c: one substep on h->pos / h->vel. */
#define HBK_FLUID_MAX_SUBSTEPS 10000 /* per frame, however fast the fluid */
#define HBK_FLUID_MAX_CELLS (1 << 24) /* in the particle grid (see hbk_fluid_params_check) */
hbk_result_t hbk_fluid_sph_substep(hbk_fluid_t *h, float dt, int threads);
/* The longest stable SPH step for the particles' current speeds (s). */
double hbk_fluid_sph_stable_dt(const hbk_fluid_t *h, int threads);
/* sph_lanes.c: the gathers of a particle (with its nim wall images) in AVX2 lanes, with the
 * scalar code's bytes; away from walls 16 at a time with AVX-512. hbk_fluid_sph_lanes(): 0
 * (plain code), 8 or 16, what the CPU and HBK_PATHS allow; `lanes` takes it. */
int hbk_fluid_sph_lanes(void);
float hbk_fluid_density_lanes(int lanes, const hbk_fluid_cells_t *c, const float *soa,
                              const float *rec8,
                              size_t stride, int32_t cx, int32_t cy, int32_t cz, int32_t i,
                              const float xi[3],
                              float H, int nim, const float (*sgn)[3], const float (*off)[3],
                              int32_t *list, int32_t *nlist);
void hbk_fluid_forces_lanes(int lanes, const hbk_fluid_cells_t *c, const float *soa,
                            const float *rec8,
                            const int32_t *list, int32_t nlist, size_t stride,
                            int32_t cx, int32_t cy, int32_t cz, int32_t i, const float xi[8],
                            float H, float m, float spiky, float visc, int nim,
                            const float (*sgn)[3], const float (*off)[3], float ap[3],
                            float fv[3]);
/* Paper: "too fast flow is clamped" - here to max_flow voxels per frame (m/s). */
static inline float hbk_fluid_vmax(const hbk_fluid_t *h)
{
    float cmin = h->cell[0] < h->cell[1] ? h->cell[0] : h->cell[1];
    cmin = cmin < h->cell[2] ? cmin : h->cell[2];
    return h->p.max_flow * cmin / h->p.dt;
}
/* V_m at vertex i from the flow v, clamped to vmax: into g_motion, and into the planes
 * g_mp that the features read. */
static inline void hbk_fluid_put_motion(hbk_fluid_t *h, size_t i, float v[3], float vmax)
{
    const float s2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    if (s2 > vmax * vmax) {
        const float f = vmax / sqrtf(s2);
        v[0] *= f; v[1] *= f; v[2] *= f;
    }
    for (int a = 0; a < 3; ++a) {
        h->g_motion[3 * i + (size_t)a] = v[a];
        h->g_mp[a][i] = v[a];
    }
}

/* Marks every row of g_wsum and g_mp as holding data (all = 1: after create, or after
 * something else wrote them) or none (all = 0: they were just zeroed). */
static inline void hbk_fluid_splat_rows(hbk_fluid_t *h, int all)
{
    for (int32_t k = 0; k < h->nv[2]; ++k) {
        h->splat_ylo[k] = all ? 0 : INT32_MAX;
        h->splat_yhi[k] = all ? h->nv[1] - 1 : -1;
    }
}

/* metaballs.c: density, V_m (clamped, hbk_fluid_put_motion) and the metaball sum at the
 * vertices into g_* from the particles. */
hbk_result_t hbk_fluid_particles_to_grid(hbk_fluid_t *h, int threads);

/* features.c: g_features from g_density, g_motion and the previous frame. */
void hbk_fluid_features(hbk_fluid_t *h, int threads);

/* wrap.c */
/* uvw at voxel coordinates (x, y, z) (vertex (i,j,k) at integers), honouring the flags. */
void hbk_fluid_sample_wrapped(const hbk_fluid_t *h, const float *uvw, const uint8_t *wrap,
                              const float x[3], float out[3]);
/* Interpolation weights and base index at voxel coordinates (clamped to the grid). */
typedef struct hbk_fluid_lerp {
    size_t base;   /* vertex (i, j, k) */
    size_t voxel;  /* voxel (i, j, k) */
    float t[3];
} hbk_fluid_lerp_t;

/* Inline: the advection samples several fields per vertex, millions of times a frame. */
static inline void hbk_fluid_lerp_at(const hbk_fluid_t *h, const float x[3],
                                     hbk_fluid_lerp_t *l)
{
    int32_t i[3];
    for (int a = 0; a < 3; ++a) {
        const int32_t last = h->p.resolution[a] - 1;
        float xa = x[a];
        if (!(xa >= 0.0f)) xa = 0.0f; /* also NaN */
        if (xa > (float)(last + 1)) xa = (float)(last + 1);
        int32_t k = (int32_t)xa;
        if (k > last) k = last;
        i[a] = k;
        l->t[a] = xa - (float)k;
    }
    l->base = (size_t)i[0] + (size_t)h->nv[0] * ((size_t)i[1] + (size_t)h->nv[1] * (size_t)i[2]);
    l->voxel = (size_t)i[0] + (size_t)h->p.resolution[0] *
                                  ((size_t)i[1] + (size_t)h->p.resolution[1] * (size_t)i[2]);
}

/* Voxel coordinates (vertex (i, j, k) at integers) of the world point pos. */
static inline void hbk_fluid_grid_coords(const hbk_fluid_t *h, const float pos[3], float x[3])
{
    for (int a = 0; a < 3; ++a) x[a] = (pos[a] - h->p.box_min[a]) * h->inv_cell[a];
}

/* The trilinear sample of mesh vertex v's position. */
static inline void hbk_fluid_lerp_at_mesh(const hbk_fluid_t *h, int32_t v, hbk_fluid_lerp_t *l)
{
    float g[3];
    hbk_fluid_grid_coords(h, h->mesh_pos + 3 * (size_t)v, g);
    hbk_fluid_lerp_at(h, g, l);
}

/* Offsets of the 8 corners of a voxel, in the order of the trilinear weights below. */
static inline void hbk_fluid_corners(const hbk_fluid_t *h, size_t off[8])
{
    const size_t sx = 1, sy = (size_t)h->nv[0], sz = (size_t)h->nv[0] * (size_t)h->nv[1];
    off[0] = 0; off[1] = sx; off[2] = sy; off[3] = sx + sy;
    off[4] = sz; off[5] = sz + sx; off[6] = sz + sy; off[7] = sz + sx + sy;
}

/* Nested lerps rather than the 8 weights: a uniform field stays bitwise uniform, and a
 * linear ramp is reproduced to rounding. */
static inline float hbk_fluid_tri(const float c[8], const float t[3])
{
    const float a = c[0] + t[0] * (c[1] - c[0]), b = c[2] + t[0] * (c[3] - c[2]);
    const float d = c[4] + t[0] * (c[5] - c[4]), e = c[6] + t[0] * (c[7] - c[6]);
    const float f = a + t[1] * (b - a), g = d + t[1] * (e - d);
    return f + t[2] * (g - f);
}

/* The corner loops fully unrolled: -O2 keeps them as loops, re-deriving each corner's address. */
#define HBK_UNROLL8 _Pragma("GCC unroll 8")

/* Trilinear samples of a 3-vector field, the three components side by side in one 4-float
 * vector (the field has 4 floats of padding): the same operations per component, so the same
 * bytes as hbk_fluid_sample_field. The wrapped one honours V_r: a flagged component's corner
 * values below 0.5 count as value + 1, and the result is taken modulo 1. The _o samplers take
 * the corner offsets (hbk_fluid_corners) from the caller, once for many samples. */
typedef float hbk_v4f __attribute__((vector_size(16)));
typedef int32_t hbk_v4i __attribute__((vector_size(16)));

static inline hbk_v4f hbk_fluid_tri4(const hbk_v4f c[8], const float t[3])
{
    const hbk_v4f a = c[0] + t[0] * (c[1] - c[0]), b = c[2] + t[0] * (c[3] - c[2]);
    const hbk_v4f d = c[4] + t[0] * (c[5] - c[4]), e = c[6] + t[0] * (c[7] - c[6]);
    const hbk_v4f f = a + t[1] * (b - a), g = d + t[1] * (e - d);
    return f + t[2] * (g - f);
}

static inline void hbk_fluid_sample3_o(const float *f, const size_t off[8],
                                       const hbk_fluid_lerp_t *l, float out[3])
{
    hbk_v4f c[8];
    HBK_UNROLL8 for (int k = 0; k < 8; ++k) memcpy(&c[k], f + 3 * (l->base + off[k]), sizeof c[k]);
    const hbk_v4f r = hbk_fluid_tri4(c, l->t);
    out[0] = r[0];
    out[1] = r[1];
    out[2] = r[2];
}

static inline void hbk_fluid_sample_wrapped3_o(const float *uvw, const uint8_t *wrap,
                                               const size_t off[8], const hbk_fluid_lerp_t *l,
                                               float out[3])
{
    const uint8_t fl = wrap[l->voxel];
    const hbk_v4i m = {-(fl & 1), -(fl >> 1 & 1), -(fl >> 2 & 1), 0};
    const hbk_v4f zero = {0.0f, 0.0f, 0.0f, 0.0f}, half = zero + 0.5f, one = zero + 1.0f;
    hbk_v4f c[8];
    HBK_UNROLL8 for (int k = 0; k < 8; ++k) {
        hbk_v4f v;
        memcpy(&v, uvw + 3 * (l->base + off[k]), sizeof v);
        const hbk_v4i up = m & (v < half); /* a wrapped component below 0.5 counts + 1 */
        c[k] = (hbk_v4f)(((hbk_v4i)(v + one) & up) | ((hbk_v4i)v & ~up));
    }
    hbk_v4f r = hbk_fluid_tri4(c, l->t);
    const hbk_v4i over = m & (r >= one);
    r = (hbk_v4f)(((hbk_v4i)(r - one) & over) | ((hbk_v4i)r & ~over));
    const hbk_v4i bad = m & ~((r >= zero) & (r < one)); /* rounding or NaN: 0 */
    r = (hbk_v4f)((hbk_v4i)r & ~bad);
    out[0] = r[0];
    out[1] = r[1];
    out[2] = r[2];
}

static inline void hbk_fluid_sample_wrapped3(const hbk_fluid_t *h, const float *uvw,
                                             const uint8_t *wrap, const hbk_fluid_lerp_t *l,
                                             float out[3])
{
    size_t off[8];
    hbk_fluid_corners(h, off);
    hbk_fluid_sample_wrapped3_o(uvw, wrap, off, l, out);
}

/* hbk_fluid_sample_field for a field with 4 floats of padding: four channels at a time. */
static inline void hbk_fluid_sample_n_o(const float *f, int ch, const size_t off[8],
                                        const hbk_fluid_lerp_t *l, float *out)
{
    for (int a = 0; a < ch; a += 4) {
        hbk_v4f c[8];
        HBK_UNROLL8 for (int k = 0; k < 8; ++k)
            memcpy(&c[k], f + (size_t)ch * (l->base + off[k]) + (size_t)a, sizeof c[k]);
        const hbk_v4f r = hbk_fluid_tri4(c, l->t);
        for (int q = 0; q < 4 && a + q < ch; ++q) out[a + q] = r[q];
    }
}

/* Trilinear sample of an nv x ch field. */
static inline void hbk_fluid_sample_field(const hbk_fluid_t *h, const float *f, int ch,
                                          const hbk_fluid_lerp_t *l, float *out)
{
    size_t off[8];
    hbk_fluid_corners(h, off);
    for (int a = 0; a < ch; ++a) {
        float c[8];
        for (int k = 0; k < 8; ++k) c[k] = f[(size_t)ch * (l->base + off[k]) + (size_t)a];
        out[a] = hbk_fluid_tri(c, l->t);
    }
}

/* Where the short way is unambiguous for the voxel whose corner 0 is vertex b, from its
 * corners' uvw: per component (the three lanes of a 4-float vector: uvw is padded), the range
 * of the corners' values read directly and read across the wrap. Bit a of *d: component a is
 * short directly (its flag clears); of *x: not directly but across (its flag sets). Where
 * both ways are long (a texture already torn apart) the advected flag decides, as in the
 * paper: hbk_fluid_repair_apply. */
#define HBK_VSEL(m, a, b) ((hbk_v4f)(((hbk_v4i)(a) & (m)) | ((hbk_v4i)(b) & ~(m))))
static inline void hbk_fluid_repair_masks(const float *uvw, const size_t off[8], size_t b,
                                          unsigned *d, unsigned *x)
{
    const hbk_v4f half = {0.5f, 0.5f, 0.5f, 0.5f}, one = half + half;
    hbk_v4f lo = one + one, hi = -one, wlo = lo, whi = hi;
    HBK_UNROLL8 for (int c = 0; c < 8; ++c) {
        hbk_v4f v;
        memcpy(&v, uvw + 3 * (b + off[c]), sizeof v);
        /* v + 1 below 0.5, else v + 0 (the same for comparisons, even at -0) */
        const hbk_v4f w = v + (hbk_v4f)((hbk_v4i)one & (v < half));
#ifdef __SSE__ /* minps(a, b) is a < b ? a : b exactly, and maxps a > b ? a : b */
        lo = __builtin_ia32_minps(v, lo);
        hi = __builtin_ia32_maxps(v, hi);
        wlo = __builtin_ia32_minps(w, wlo);
        whi = __builtin_ia32_maxps(w, whi);
#else
        lo = HBK_VSEL(v < lo, v, lo);
        hi = HBK_VSEL(v > hi, v, hi);
        wlo = HBK_VSEL(w < wlo, w, wlo);
        whi = HBK_VSEL(w > whi, w, whi);
#endif
    }
    const hbk_v4i direct = hi - lo <= half, across = whi - wlo < half;
#ifdef __SSE__
    *d = (unsigned)__builtin_ia32_movmskps((hbk_v4f)direct) & 7u;
    *x = (unsigned)__builtin_ia32_movmskps((hbk_v4f)across) & 7u & ~*d;
#else
    *d = *x = 0;
    for (int a = 0; a < 3; ++a) {
        if (direct[a]) *d |= 1u << a;
        else if (across[a]) *x |= 1u << a;
    }
#endif
}

/* The advected flags f repaired by the masks of hbk_fluid_repair_masks. */
static inline uint8_t hbk_fluid_repair_apply(uint8_t f, unsigned d, unsigned x)
{
    return (uint8_t)((f & ~d) | x);
}

static inline uint8_t hbk_fluid_repair_voxel(const float *uvw, const size_t off[8], size_t b,
                                             uint8_t f)
{
    unsigned d, x;
    hbk_fluid_repair_masks(uvw, off, b, &d, &x);
    return hbk_fluid_repair_apply(f, d, x);
}

/* Rest uvw mapping and its wrap flags. */
void hbk_fluid_reset_uvw(const hbk_fluid_t *h, float *uvw, uint8_t *wrap, int threads);
/* Re-derives each voxel's flags from its corners where the short way is unambiguous; with
 * `moving`, only voxels with a moving corner (the others keep flags already repaired). */
void hbk_fluid_repair_wrap(const hbk_fluid_t *h, const float *uvw, uint8_t *wrap,
                           const uint8_t *moving, int threads);

/* uvw component u moved by whole tiles to within half a tile of `rest`, the rest mapping
 * (x - box_min) / uvw_tile where it is sampled (the mesh's and the unwrapped volumes' uvw). */
static inline float hbk_fluid_unwrap(float u, float rest) { return u + floorf(rest - u + 0.5f); }

/* A uvw volume (vertices x 3) unwrapped at every vertex into out. */
void hbk_fluid_uvw_unwrapped(const hbk_fluid_t *h, const float *uvw, float *out, int threads);

/* Every float of f[0 .. n) is +0, bit for bit. */
static inline int hbk_fluid_all_zero(const float *f, size_t n)
{
    uint32_t any = 0;
    for (size_t i = 0; i < n; ++i) {
        uint32_t b;
        memcpy(&b, f + i, sizeof b);
        any |= b;
    }
    return any == 0;
}

/* Anything but the advection that writes h->v or h->scratch makes them differ. */
static inline void hbk_fluid_vols_differ(hbk_fluid_t *h)
{
    memset(h->same_rows, 0, h->n_rows);
    memset(h->same_vox, 0, (size_t)h->p.resolution[1] * (size_t)h->p.resolution[2]);
}

/* weight.c: the cross-fade weight of field A per vertex (nv floats), adapted to stretch. */
void hbk_fluid_weights(const hbk_fluid_t *h, float *out, int threads);

/* advect_lanes.c: whether this CPU and HBK_PATHS allow the sixteen-lane (AVX-512) kernels,
 * and the moving vertices of row (j, k) sixteen at a time. */
int hbk_fluid_lanes16_ok(void);
void hbk_fluid_advect_row16(const hbk_fluid_t *h, const hbk_fluid_vols_t *in,
                            hbk_fluid_vols_t *out, const size_t off[8], float dt, int32_t j,
                            int32_t k);
/* advect.c: the voxel whose flags a moving voxel (i, j, k), corner 0 at vertex b, takes
 * where its corners leave a component undecided. */
size_t hbk_fluid_traced_from(const hbk_fluid_t *h, const size_t off[8], size_t b, int32_t i,
                             int32_t j, int32_t k);
/* advect_flags16.c: V_r of voxel row (j, k) sixteen voxels at a time (AVX-512), given its
 * first vertex b0 and voxel v0i, and col[i]: whether vertex column i of the row's four vertex
 * rows moves. */
void hbk_fluid_flags_row16(const hbk_fluid_t *h, const hbk_fluid_vols_t *in,
                           hbk_fluid_vols_t *out, const size_t off[8], int32_t j, int32_t k,
                           size_t b0, size_t v0i, const uint8_t *col, int checked);
/* advect.c: advects h->v into h->scratch by h->motion over dt (does not swap), and sets the
 * feature rules on the advected base (by this step's features, h->g_features). */
void hbk_fluid_advect(hbk_fluid_t *h, float dt, int threads);

/* paint.c */
void hbk_fluid_paint_off(hbk_fluid_t *h);
/* The feature rules, compiled for matching: features 0-3, then 4-5 twice, four to a vector. */
typedef struct {
    int t;
    hbk_v4f lo0, hi0, lo1, hi1;
} hbk_fluid_rule4_t;
_Static_assert(HBK_FLUID_FEATURE_COUNT == 6, "hbk_fluid_rule4_t holds six features");
typedef struct {
    int n, lanes;
    hbk_fluid_rule4_t r[HBK_FLUID_MAX_TEXTURES];
    /* AVX-512: eight vertices' records of each rule's bounds; and for float q of sixteen
     * vertices' K weights, its vertex q / K and channel q % K */
    float lo8[HBK_FLUID_MAX_TEXTURES][8 * HBK_FLUID_FEATURE_COUNT];
    float hi8[HBK_FLUID_MAX_TEXTURES][8 * HBK_FLUID_FEATURE_COUNT];
    int32_t vtx16[16 * HBK_FLUID_MAX_TEXTURES], chan16[16 * HBK_FLUID_MAX_TEXTURES];
} hbk_fluid_rules_t;
void hbk_fluid_rules_compile(const hbk_fluid_t *h, hbk_fluid_rules_t *r);
/* h->rule_tex of the nx vertices from v0, whose features are at features (that row's). */
void hbk_fluid_rules_match_row(const hbk_fluid_t *h, const hbk_fluid_rules_t *rl,
                               const float *features, size_t v0);
/* Vertex row r of base becomes one-hot at the last matching rule's texture, per vertex: by
 * h->rule_tex, or in a quiet row (h->quiet) by its one set of features. */
void hbk_fluid_rules_row(hbk_fluid_t *h, const hbk_fluid_rules_t *rl, float *base,
                         const float *features, size_t r);
/* Final blend of vertex i (K floats). */
void hbk_fluid_blend_at(const hbk_fluid_t *h, const float *base, const float *paint,
                        const float *life, size_t i, float *out);

/* uvw cross-fade weight of field A at frame f. */
float hbk_fluid_weight_at(const hbk_fluid_params_t *p, uint64_t frame);
/* Frames per reset period (0 = never). */
uint64_t hbk_fluid_period_frames(const hbk_fluid_params_t *p);

#endif
