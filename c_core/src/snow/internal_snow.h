/* Private to the snow kernel: handle, BVH, flakes, events. */
#ifndef HBK_INTERNAL_SNOW_H
#define HBK_INTERNAL_SNOW_H
#include "hbk_snow.h"
#include "../base/internal_base.h"

/* ---- Random numbers: (seed, stream = flake id, counter = substep | purpose << 56). ---- */
enum {
    SNOW_RNG_CONTACT = 1, /* lane 0: stick decision, lane 1: stamp R */
    SNOW_RNG_SPAWN_A = 2, /* lanes: x, y, z jitter, flutter phase */
    SNOW_RNG_SPAWN_B = 3, /* lanes: fall speed jitter, flutter class */
    SNOW_RNG_INIT_A = 4,  /* the first placement, as SPAWN_A but z anywhere in the volume */
    SNOW_RNG_INIT_B = 5,
    SNOW_RNG_SHELTER_A = 6, /* a flake under (or inside) a newly set mesh, moved to the top */
    SNOW_RNG_SHELTER_B = 7
};
static inline uint64_t snow_rng_counter(uint64_t substep, uint32_t purpose)
{
    return (substep & ((UINT64_C(1) << 56) - 1)) | ((uint64_t)purpose << 56);
}

/* min/max as single instructions: fminf/fmaxf are libm calls when NaN rules must hold,
 * and no NaN reaches these (positions are checked finite, zero directions replaced). */
static inline float snow_min(float a, float b) { return a < b ? a : b; }
static inline float snow_max(float a, float b) { return a > b ? a : b; }

/* A step whose flakes hit the mesh at least once in this many flake-steps leaves them in
 * slots by place (sort_by_place in flakes.c); one whose flakes hit it more seldom keeps its
 * slots. */
#define SNOW_SORT_HITS 512

/* Restitution of a bounce: how much of the normal speed a flake keeps. */
#define SNOW_RESTITUTION 0.3f
/* Flutter frequency classes: a flake's own frequency is f * (0.7 + 0.6 k / (N - 1)),
 * turning either way; a table per call keeps trigonometry out of the inner loop. */
#define SNOW_FLUTTER_CLASSES 16

/* One flake; saved as is in the state. */
typedef struct snow_flake {
    float p[3];  /* position, m */
    float v[3];  /* velocity, m/s */
    float fc, fs;/* flutter direction (cos, sin), turned every substep */
    float fall;  /* own terminal fall speed, m/s */
    uint32_t cls;/* flutter class: bits 0-3 frequency, bit 4 turns clockwise */
} snow_flake_t;

/* ---- BVH over triangles ---- */
typedef struct bvh_node {
    float lo[3], hi[3];
    int32_t first; /* leaf: first triangle; inner: index of the left child (right = +1) */
    int32_t count; /* leaf: triangle count (> 0); inner: 0 */
} bvh_node_t;

typedef struct bvh_tri {
    float v0[3], e1[3], e2[3];
    int32_t id; /* index in the caller's triangle list */
} bvh_tri_t;

/* The tree the queries walk: the binary one collapsed to up to four children a node, their
 * boxes lane by lane, so that one set of four-lane operations tests all of them. */
typedef struct bvh_wide {
    float lo[3][4], hi[3][4];
    int32_t first[4]; /* leaf: first triangle; inner: index in bvh.wide */
    int32_t count[4]; /* leaf: triangle count (> 0); inner: 0; no child: -1 */
} bvh_wide_t;

typedef struct bvh {
    bvh_node_t *nodes; /* the binary tree as built (nodes[0]: the root's box) */
    bvh_wide_t *wide;
    bvh_tri_t *tris;
    int32_t node_count, wide_count, tri_count;
    int32_t plain; /* the walk tests the four boxes without vector lanes (HBK_PATHS=scalar) */
} bvh_t;

typedef struct bvh_hit {
    float t, b1, b2; /* segment parameter in [0, 1], barycentrics of corners 1 and 2 */
    int32_t tri;     /* index into bvh.tris (leaf order) */
} bvh_hit_t;

/* Builds over `tri_count` triangles (binned SAH). HBK_ERR_OUT_OF_MEMORY; *out untouched
 * then. */
hbk_result_t snow_bvh_build(bvh_t *out, const float *positions, const int32_t *triangles,
                            int32_t tri_count);
void snow_bvh_free(bvh_t *b);
/* First hit of the segment o + t d, t in [0, 1] (of equally near triangles the first in leaf
 * order). Returns 1 and fills *hit, else 0. */
int snow_bvh_hit(const bvh_t *b, const float o[3], const float d[3], bvh_hit_t *hit);

/* Möller-Trumbore, both sides: where the segment o + t d (t in [0, 1]) meets triangle tr, as t
 * and barycentrics (u, v) for (v1, v2); 0 if it does not. */
static inline int snow_ray_tri(const bvh_tri_t *tr, const float o[3], const float d[3],
                               float *t, float *u, float *v)
{
    const float px = d[1] * tr->e2[2] - d[2] * tr->e2[1];
    const float py = d[2] * tr->e2[0] - d[0] * tr->e2[2];
    const float pz = d[0] * tr->e2[1] - d[1] * tr->e2[0];
    const float det = tr->e1[0] * px + tr->e1[1] * py + tr->e1[2] * pz;
    if (det == 0.0f) return 0;
    const float id = 1.0f / det;
    const float sx = o[0] - tr->v0[0], sy = o[1] - tr->v0[1], sz = o[2] - tr->v0[2];
    *u = (sx * px + sy * py + sz * pz) * id;
    if (*u < 0.0f || *u > 1.0f) return 0;
    const float qx = sy * tr->e1[2] - sz * tr->e1[1];
    const float qy = sz * tr->e1[0] - sx * tr->e1[2];
    const float qz = sx * tr->e1[1] - sy * tr->e1[0];
    *v = (d[0] * qx + d[1] * qy + d[2] * qz) * id;
    if (*v < 0.0f || *u + *v > 1.0f) return 0;
    *t = (tr->e2[0] * qx + tr->e2[1] * qy + tr->e2[2] * qz) * id;
    return *t >= 0.0f;
}

/* ---- Occupancy grid (grid.c) ---- */
typedef struct snow_grid {
    uint64_t *bits; /* one per cell, x fastest */
    int32_t n[3];
    float lo[3], inv[3]; /* cell of x along k: (x - lo[k]) * inv[k] */
} snow_grid_t;

hbk_result_t snow_grid_build(snow_grid_t *out, const float *pos, const int32_t *tri, int32_t n,
                             const float lo[3], const float hi[3]);
void snow_grid_free(snow_grid_t *g);
/* 0 if the box of segment p..e touches no occupied cell (no triangle can be hit). */
int snow_grid_maybe(const snow_grid_t *g, const float p[3], const float e[3]);

/* ---- Mesh ---- */
typedef struct snow_tri_info {
    float uv[6];       /* texel coordinates of the corners (u * width, v * height) */
    float dens[2];     /* texels per metre along x and y of the texture */
    float n[3];        /* unit geometric normal */
    int32_t material;
} snow_tri_info_t;

typedef struct snow_box {
    float lo[3], hi[3];
    int32_t valid; /* 0: the slot has no triangles */
} snow_box_t;

typedef struct snow_mesh {
    bvh_t bvh;
    snow_grid_t grid;
    snow_tri_info_t *info; /* per caller triangle */
    snow_box_t *boxes;     /* BOX mode: per material slot */
    int32_t tri_count, box_count, max_material;
} snow_mesh_t;

/* ---- Stuck flakes waiting to be stamped ---- */
typedef struct snow_event {
    uint64_t step;   /* global substep */
    uint32_t flake;
    int32_t prim;    /* TRIANGLES: caller triangle; BOX: slot * 6 + face */
    float tx, ty;    /* hit point in texel coordinates of the whole image */
    float sx, sy;    /* footprint (one stamp cell) in texels */
    float r;         /* the stamp's random number */
} snow_event_t;

typedef struct snow_events {
    snow_event_t *e;
    size_t n, cap;
} snow_events_t;

/* ---- The handle ---- */
struct hbk_snow {
    hbk_snow_params_t p;
    hbk_message_t msg;
    snow_flake_t *flakes, *scratch; /* scratch: the next state, swapped in on success */
    uint32_t *ids, *ids_spare;      /* the id of the flake in each slot (sort_by_place) */
    snow_mesh_t mesh;
    hbk_snow_material_t *materials;
    float *chance;         /* per slot: hbk_snow_hit_chance at the params' temperature */
    int32_t material_count;
    int32_t tex_w, tex_h;  /* one image (TRIANGLES) or one block per slot (BOX) */
    int32_t blocks;        /* BOX: material slots the textures hold; TRIANGLES: 1 */
    float *coverage;       /* 0..255, tex_w * tex_h * blocks */
    float *depth;          /* m */
    uint64_t step;         /* substeps taken */
    int32_t shelter_check; /* a mesh was set: the next step moves flakes it shelters */
    hbk_snow_stats_t stats;
    snow_events_t *tev;    /* per thread */
    int32_t tev_count;
    snow_events_t all;     /* merged */
};

/* sticking.c */
void snow_stamp(hbk_snow_t *h, const snow_event_t *e);
/* The alpha of a stamp cell: kind 0 centre, 1 side, 2 corner. */
float snow_cell_alpha(const hbk_snow_params_t *p, int wet, float bleed, int kind, float r);

/* params.c */
const hbk_snow_params_t *snow_params_paper(void); /* the defaults */
hbk_result_t snow_params_check(const hbk_snow_params_t *p, hbk_message_t *msg);

/* flakes.c */
void snow_flakes_init(hbk_snow_t *h);
/* The flakes back in slots by id (after a load). */
void snow_flakes_by_id(hbk_snow_t *h);
hbk_result_t snow_flakes_step(hbk_snow_t *h, int32_t substeps, hbk_progress_t *progress);

/* box.c */
int snow_box_hit(const snow_mesh_t *m, const float q[3], const float d[3], float *t_out,
                 int32_t *box_out, int32_t *face_out);
void snow_box_face_texel(const hbk_snow_t *h, int32_t box, int32_t face, const float x[3],
                         float *tx, float *ty, float *sx, float *sy);
void snow_box_tile(const hbk_snow_t *h, int32_t box, int32_t face, int32_t rect[4]);
/* Unit outward normal of a face: 0 +X, 1 -X, 2 +Y, 3 -Y, 4 +Z, 5 -Z. */
void snow_box_normal(int32_t face, float n[3]);

/* snow.c */
hbk_result_t snow_textures_alloc(hbk_snow_t *h, int32_t blocks);

#endif
