/* Private: the state of one caustics render, shared by its stages. */
#ifndef HBK_INTERNAL_CAUSTICS_H
#define HBK_INTERNAL_CAUSTICS_H
#include "hbk_caustics.h"
#include "../base/internal_base.h"

/* Rays never run flatter than this (|z| of the unit direction): a refracted ray pointing up
 * would leave the water, which the paper's one-refraction model cannot follow. */
#define HBK_CAUSTICS_MIN_DOWN 0.05
/* Ground triangles smaller than this (in map pixels^2) are splatted into one pixel instead of
 * rasterised: it only catches (near-)degenerate images, whose 1/area weight would be huge. */
#define HBK_CAUSTICS_TINY_PX2 1e-6
/* Size of a raster band's double accumulator: big bands split fewer edges, and it still fits
 * in a typical L2 cache. */
#define HBK_CAUSTICS_BAND_BYTES (1u << 20)

/* A ground triangle rasterised on its own: a small triangle of a shoreline cell, or a regular
 * triangle whose image is degenerate (then `splat`). Per pass: image in map pixels, weights. */
typedef struct {
    double px[3][3], py[3][3]; /* [pass][vertex] */
    float w[3][3];             /* [pass][channel of the pass] */
    uint8_t splat[3];          /* [pass]: deposit w (already pixel values) at the centroid */
    uint8_t used[3];           /* [pass]: has any weight */
} hbk_loose_tri_t;

/* Scratch buffers by role. A workspace keeps them between renders: a render of a 256^2 surface
 * into a 1024^2 map touches about 10 MB of scratch, and fresh pages from the system cost a
 * sixth of the render. Per-pass slots come in threes. */
enum {
    CS_BMAX, CS_SWET, CS_VXS, CS_VYS, CS_VSI, CS_VSJ, CS_VZ, CS_VB, CS_VWET,
    CS_IPX, CS_IPY = CS_IPX + 3, CS_IHZ = CS_IPY + 3, CS_IATT = CS_IHZ + 3, CS_TRIW = CS_IATT + 3,
    CS_ROW_LOOSE = CS_TRIW + 3, CS_CELL_LOOSE, CS_ROW_STATS, CS_LOOSE,
    CS_GROUPS, CS_BAND_START, CS_BAND_FILL, CS_BAND_LIST, CS_BAND_BUFS,
    CS_COUNT
};

struct hbk_caustics_workspace {
    void *p[CS_COUNT];
    size_t cap[CS_COUNT];
};

/* Slot `slot` with room for `bytes` (contents undefined; zeroed if `zero`), or NULL when out of
 * memory. The workspace keeps it; the caller never frees it. */
void *hbk_cs_get(hbk_caustics_workspace_t *ws, int slot, size_t bytes, int zero);
/* Frees every slot (the workspace itself stays usable). */
void hbk_cs_release(hbk_caustics_workspace_t *ws);

typedef struct {
    hbk_caustics_workspace_t *ws; /* where every scratch buffer below lives */
    /* Inputs. */
    const hbk_caustics_params_t *p;
    const float *water, *ground; /* samples, row stride in floats below */
    size_t water_stride, ground_stride;
    int32_t W, H;                /* samples */
    double dx, inv_dx, wet_depth;
    int periodic, threads;
    hbk_progress_t *progress;    /* polled per row of every stage; may be NULL */
    /* Light: unit vector towards the sun, or the point light position; irradiance per channel. */
    int point;
    double L[3], lpos[3], E[3];
    /* Passes: 1 (one index for all channels) or 3 (dispersion, one channel each). `mono`: one
     * pass whose channels differ only by a factor (same absorption): the map is drawn once,
     * with weights for irradiance 1, and scaled per channel by `escale` at the end. nch is the
     * number of weights per triangle (3, or 1 when mono or dispersive); `ps` the accumulator's
     * channels per pixel (1 when mono, else 3). */
    int ng, nch, mono, ps;
    double Ew[3], escale[3];   /* irradiance in the weights, and the final factor */
    double eta[3];               /* 1 / ior per pass */
    double ior[3];
    double sigma[3][3];          /* absorption [pass][channel of the pass] */
    int absorb;
    /* Ground for ray marching: max over blocks of 8 x 8 bilinear cells. */
    float *bmax;
    int32_t nbu, nbv, ncu, ncv;  /* blocks; bilinear cells along u and v */
    float gmax;
    uint8_t *swet;               /* W x H: sample is wet (depth > wet_depth) */
    int gflat;                   /* the ground is one height everywhere */
    /* Mesh: nvx x nvy vertices, ncx x ncy cells. */
    int32_t nvx, nvy, ncx, ncy;
    double *vxs, *vys;           /* world x of each vertex column, y of each vertex row */
    int32_t *vsi, *vsj;          /* the sample each vertex column / row takes its values from */
    float *vz, *vb;              /* surface (ground where dry) and ground height per vertex */
    uint8_t *vwet;
    /* Per pass: image of every vertex in map pixels, ground z, attenuation per channel. */
    double *ipx[3], *ipy[3];
    float *ihz[3], *iatt[3];
    /* Map. */
    int32_t MW, MH;
    double inv_mw;               /* 1 / MW */
    double ex0, ey0, sx, sy;     /* pixel = (world - e0) * s */
    double inv_sx, inv_sy;
    double pixel_area;           /* m^2 */
    /* Triangles: weight per [pass][triangle * nch + channel]; two triangles per cell. */
    float *triw[3];
    hbk_loose_tri_t *loose;
    size_t nloose;
    /* Statistics per row of cells, summed in order at the end. */
    double *row_stats;           /* ncy x 9: entered, absorbed, dry */
} hbk_caustics_ctx_t;

/* Height of the ground under (u, v) in sample coordinates (u = x / dx - 0.5), bilinear, with the
 * edges wrapped or clamped. */
double hbk_caustics_ground_at(const hbk_caustics_ctx_t *c, double u, double v);
/* Distance t >= 0 along the unit ray (o + t r, r[2] < 0) to the ground. */
double hbk_caustics_march(const hbk_caustics_ctx_t *c, const double o[3], const double r[3]);
/* Refracts the unit vector towards the light `l` entering water through the unit normal `n`
 * with eta = 1 / ior; the result points down at least HBK_CAUSTICS_MIN_DOWN. */
void hbk_caustics_refract(const double l[3], const double n[3], double eta, double r[3]);
/* Unpolarised Fresnel transmittance from air into water at incidence cosine cos_i. */
double hbk_caustics_fresnel_t(double cos_i, double ior);
/* Unit normal of the water surface at sample (i, j), from wet neighbours only. */
void hbk_caustics_normal(const hbk_caustics_ctx_t *c, int32_t i, int32_t j, double n[3]);
int hbk_caustics_wet(const hbk_caustics_ctx_t *c, int32_t i, int32_t j);

/* Stages of a render. */
hbk_result_t hbk_caustics_setup_ground(hbk_caustics_ctx_t *c);
hbk_result_t hbk_caustics_setup_mesh(hbk_caustics_ctx_t *c);
void hbk_caustics_trace_vertices(hbk_caustics_ctx_t *c);
hbk_result_t hbk_caustics_build_triangles(hbk_caustics_ctx_t *c);
hbk_result_t hbk_caustics_rasterise(hbk_caustics_ctx_t *c, hbk_image_t *out,
                                    hbk_progress_t *progress);

/* Shared input checks of render and view: images, sizes, cell size, finite heights. */
hbk_result_t hbk_caustics_check_inputs(const hbk_caustics_params_t *p, const hbk_image_t *water,
                                       const hbk_image_t *ground, float cell_size,
                                       hbk_message_t *msg);
/* Fills the input and light fields of *c from checked arguments; scratch comes from ws. */
void hbk_caustics_init(hbk_caustics_ctx_t *c, hbk_caustics_workspace_t *ws,
                       const hbk_caustics_params_t *p, const hbk_image_t *water,
                       const hbk_image_t *ground, float cell_size);

#endif
