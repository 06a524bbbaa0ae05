/* The outflow: a drain that takes away the water entering a shape (as Blender's own fluids
 * have), so that an inflow can pour for as long as the scene runs. */
#include "internal_fluid.h"
#include <stdlib.h>

void hbk_fluid_outflow_free(hbk_fluid_t *h)
{
    free(h->outflow_field);
    free(h->outflow_gone);
    h->outflow_field = NULL;
    h->outflow_gone = NULL;
    h->outflow_on = 0;
}

hbk_result_t hbk_fluid_set_outflow(hbk_fluid_t *h, const hbk_fluid_obstacle_t *shape,
                                   const int32_t dims[3], const float *distance)
{
    HBK_FLUID_ENTER(h);
    if (!shape) {
        hbk_fluid_outflow_free(h);
        return HBK_OK;
    }
    if (h->p.source != HBK_FLUID_SIMULATE)
        return hbk_fail(&h->msg, HBK_ERR_INVALID_ARGUMENT,
                        "outflow: source = %d: only the simulation (0) drains an outflow",
                        h->p.source);
    size_t n;
    hbk_result_t r = hbk_fluid_shape_check(h, shape, dims, distance, &n);
    if (r) return r;
    float *field = n ? malloc(n * sizeof *field) : NULL;
    uint8_t *gone = h->outflow_gone ? h->outflow_gone
                                    : malloc((size_t)(h->p.max_particles + 1) * sizeof *gone);
    if ((n && !field) || !gone) {
        free(field);
        if (gone != h->outflow_gone) free(gone);
        return hbk_fail(&h->msg, HBK_ERR_OUT_OF_MEMORY, "outflow: out of memory");
    }
    if (n) {
        memcpy(field, distance, n * sizeof *field);
        memcpy(h->outflow_dims, dims, sizeof h->outflow_dims);
    }
    free(h->outflow_field);
    h->outflow_field = field;
    h->outflow_gone = gone;
    h->outflow = *shape;
    hbk_fluid_shape_axes(shape, h->outflow_ax);
    hbk_fluid_shape_bounds(shape, h->outflow_lo, h->outflow_hi);
    h->outflow_on = 1;
    return HBK_OK;
}

int32_t hbk_fluid_outflow_removed(const hbk_fluid_t *h) { return h ? h->outflow_removed : 0; }

/* After each substep: which particles are inside (on threads: a box test each, the shape's
 * own only within its box), then those go and the others close up in their order, so the
 * result is the same whatever the threads. */
void hbk_fluid_outflow_drain(hbk_fluid_t *h)
{
    if (!h->outflow_on) return;
    const float *lo = h->outflow_lo, *hi = h->outflow_hi, *ax = h->outflow_ax;
    const int32_t *d = h->outflow.type == 3 ? h->outflow_dims : NULL;
    const int32_t n = h->count;
    uint8_t *gone = h->outflow_gone;
    int any = 0;
#pragma omp parallel for num_threads(HBK_OMP_THREADS(h)) schedule(static) reduction(| : any)
    for (int32_t p = 0; p < n; ++p) {
        const float *x = h->pos + 3 * (size_t)p;
        const int near = x[0] >= lo[0] && x[0] <= hi[0] && x[1] >= lo[1] && x[1] <= hi[1] &&
                         x[2] >= lo[2] && x[2] <= hi[2];
        gone[p] = (uint8_t)(near && hbk_fluid_in_shape_ax(&h->outflow, ax, d, h->outflow_field, x));
        any |= gone[p];
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
