/* The outflow: drains that take away the water entering their shapes (as Blender's own fluids
 * have), so that an inflow can pour for as long as the scene runs. */
#include "internal_fluid.h"
#include <stdlib.h>

void hbk_fluid_outflow_free(hbk_fluid_t *h)
{
    for (int32_t i = 0; i < h->drain_n; ++i) free(h->drains[i].field);
    free(h->drains);
    free(h->outflow_gone);
    h->drains = NULL;
    h->outflow_gone = NULL;
    h->drain_n = 0;
}

/* The checks set_outflow and add_outflow share: the source and the shape (its field's size in
 * *n). */
static hbk_result_t checked(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                            const int32_t dims[3], const float *distance, size_t *n)
{
    if (h->p.source != HBK_FLUID_SIMULATE)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "outflow: source = %d: only the simulation (0) drains an outflow",
                        h->p.source);
    return hbk_fluid_shape_check(h, shape, dims, distance, n);
}

/* Appends a checked drain, its field (n distances) copied. */
static hbk_result_t add_drain(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                              const int32_t dims[3], const float *distance, size_t n)
{
    float *field = n ? malloc(n * sizeof *field) : NULL;
    uint8_t *gone = h->outflow_gone ? h->outflow_gone
                                    : malloc((size_t)(h->p.max_particles + 1) * sizeof *gone);
    hbk_fluid_drain_t *drains = realloc(h->drains, (size_t)(h->drain_n + 1) * sizeof *drains);
    if (drains) h->drains = drains; /* (grown: the drains before stay, whatever comes next) */
    if ((n && !field) || !gone || !drains) {
        free(field);
        if (gone != h->outflow_gone) free(gone);
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "outflow: out of memory");
    }
    h->outflow_gone = gone;
    hbk_fluid_drain_t *dr = &drains[h->drain_n++];
    memset(dr, 0, sizeof *dr);
    if (n) {
        memcpy(field, distance, n * sizeof *field);
        memcpy(dr->dims, dims, sizeof dr->dims);
    }
    dr->field = field;
    dr->shape = *shape;
    hbk_fluid_shape_axes(shape, dr->ax);
    hbk_fluid_shape_bounds(shape, dr->lo, dr->hi);
    return HBK_OK;
}

hbk_result_t hbk_fluid_add_outflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                   const int32_t dims[3], const float *distance)
{
    HBK_FLUID_ENTER(h);
    if (!shape) return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT, "shape: must not be NULL");
    size_t n;
    hbk_result_t r = checked(h, shape, dims, distance, &n);
    return r ? r : add_drain(h, shape, dims, distance, n);
}

hbk_result_t hbk_fluid_set_outflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                   const int32_t dims[3], const float *distance)
{
    HBK_FLUID_ENTER(h);
    size_t n = 0;
    hbk_result_t r = shape ? checked(h, shape, dims, distance, &n) : HBK_OK;
    if (r) return r; /* (checked before the drains before go: a refusal leaves them) */
    for (int32_t i = 0; i < h->drain_n; ++i) free(h->drains[i].field);
    h->drain_n = 0;
    return shape ? add_drain(h, shape, dims, distance, n) : HBK_OK;
}

int32_t hbk_fluid_outflow_removed(const hbk_fluid_t *h) { return h ? h->outflow_removed : 0; }

/* Whether x is inside a drain: a box test, then the shape's own only within its box. */
static inline int in_drain(const hbk_fluid_drain_t *dr, const float x[3])
{
    const float *lo = dr->lo, *hi = dr->hi;
    return x[0] >= lo[0] && x[0] <= hi[0] && x[1] >= lo[1] && x[1] <= hi[1] && x[2] >= lo[2] &&
           x[2] <= hi[2] &&
           hbk_fluid_in_shape_ax(&dr->shape, dr->ax, dr->shape.type == 3 ? dr->dims : NULL,
                                 dr->field, x);
}

/* After each substep: which particles are inside a drain (on threads), then those go and the
 * others close up in their order, so the result is the same whatever the threads. */
void hbk_fluid_outflow_drain(hbk_fluid_t *h)
{
    if (!h->drain_n) return;
    const int32_t n = h->count, drains = h->drain_n;
    uint8_t *gone = h->outflow_gone;
    int any = 0;
#pragma omp parallel for num_threads(HBK_OMP_THREADS(h)) schedule(static) reduction(| : any)
    for (int32_t p = 0; p < n; ++p) {
        const float *x = h->pos + 3 * (size_t)p;
        int in = 0;
        for (int32_t i = 0; i < drains && !in; ++i) in = in_drain(&h->drains[i], x);
        gone[p] = (uint8_t)in;
        any |= in;
    }
    if (!any) return;
    int32_t kept = 0;
    for (int32_t p = 0; p < n; ++p) {
        if (gone[p]) continue;
        if (kept != p) {
            memcpy(h->pos + 3 * (size_t)kept, h->pos + 3 * (size_t)p, 3 * sizeof(float));
            memcpy(h->vel + 3 * (size_t)kept, h->vel + 3 * (size_t)p, 3 * sizeof(float));
        }
        ++kept;
    }
    h->outflow_removed += n - kept;
    h->count = kept;
}
