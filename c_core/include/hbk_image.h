/* Float image buffers and the image kernels the effects share.
 *
 * Layout of every image buffer: row-major float32, `channels` interleaved values per pixel,
 * `row_stride` floats from one row to the next (>= width * channels). Row 0 is v = 0, the
 * BOTTOM of the image as Blender and UV space have it; x grows with u. The EXR writer flips
 * rows so files open the right way up everywhere. Buffers are owned by the caller. */
#ifndef HBK_IMAGE_H
#define HBK_IMAGE_H
#include "hbk_base.h"
#ifdef __cplusplus
extern "C" {
#endif

typedef struct hbk_image {
    float *data;
    int32_t width, height, channels;
    size_t row_stride; /* in floats */
} hbk_image_t;

typedef enum hbk_edge {
    HBK_EDGE_CLAMP = 0,  /* repeat the border texel */
    HBK_EDGE_WRAP = 1,   /* periodic: tileable maps */
    HBK_EDGE_MIRROR = 2  /* reflect at the border (the rain paper's refraction lookup) */
} hbk_edge_t;

/* Checks the view (non-NULL data, positive sizes, stride large enough). `name` is used in the
 * message, e.g. "height.row_stride = 3: must be >= width * channels = 512". */
HBK_EXPORT hbk_result_t hbk_image_check(const hbk_image_t *img, const char *name,
                                        hbk_message_t *msg);

/* Bilinear sample of channel `c` at pixel coordinates (x, y), pixel centres at integers.
 * Never fails (the view must be valid). */
HBK_EXPORT float hbk_image_sample(const hbk_image_t *img, float x, float y, int32_t c,
                                  int32_t edge);

/* Normals of a height field by central differences.
 * height: 1 channel, values in world units; texel_size: world size of one texel (x and y);
 * strength scales the slopes (1 = true geometry).
 * out: 3 or 4 channels, same width/height: tangent-space unit normal (x along u, y along v,
 * z out of the surface). With `encode` set, written as n * 0.5 + 0.5, as Blender's Normal Map
 * node expects; alpha (if 4 channels) is set to 1. Edges follow `edge`.
 * HBK_ERR_INVALID_ARGUMENT also when strength / (2 texel_size) is past float's range. */
HBK_EXPORT hbk_result_t hbk_normal_map(const hbk_image_t *height, float texel_size_x,
                                       float texel_size_y, float strength, int32_t edge,
                                       int32_t encode, hbk_image_t *out, hbk_message_t *msg);

/* The share of a UV layout's texels that two or more triangles cover, at resolution x
 * resolution texels (texel centres sampled; an edge two triangles share counts once; mirrored
 * triangles count like the others; degenerate ones cover nothing; UVs outside 0..1 cover only
 * what lies inside). uvs: triangles x 3 corners x (u, v). *overlap = 0 when nothing is covered.
 * Snow and rain bake into the object's UVs: what overlaps shows on both faces. */
HBK_EXPORT hbk_result_t hbk_uv_overlap(const float *uvs, int32_t triangles, int32_t resolution,
                                       float *overlap, hbk_message_t *msg);

#ifdef __cplusplus
}
#endif
#endif
