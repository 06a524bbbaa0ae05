/* Uniform-grid neighbour search: a counting sort of the particles by cell. Particles keep
 * ascending id within a cell, so every gather visits neighbours in one fixed order. */
#include "internal_fluid.h"
#include <omp.h>
#include <stdlib.h>
#include <string.h>

void hbk_fluid_cells_free(hbk_fluid_cells_t *c)
{
    free(c->start);
    free(c->order);
    free(c->cell_of);
    memset(c, 0, sizeof *c);
}

hbk_result_t hbk_fluid_cells_build(hbk_fluid_cells_t *c, const float *pos, int32_t count,
                                   const float lo[3], const float hi[3], float size, int threads)
{
    size_t ncells = 1;
    for (int a = 0; a < 3; ++a) {
        c->origin[a] = lo[a];
        int32_t d = (int32_t)ceilf((hi[a] - lo[a]) / size);
        c->dims[a] = d < 1 ? 1 : d;
        ncells *= (size_t)c->dims[a];
    }
    c->size = size;
    c->inv_size = 1.0f / size;
    if (ncells > c->cap_cells) {
        free(c->start);
        c->start = malloc((ncells + 1) * sizeof *c->start);
        c->cap_cells = c->start ? ncells : 0;
        if (!c->cap_cells) return HBK_ERR_OUT_OF_MEMORY;
    }
    if ((size_t)count > c->cap_particles || !c->order) {
        size_t cap = count > 0 ? (size_t)count : 1;
        free(c->order);
        free(c->cell_of);
        c->order = malloc(cap * sizeof *c->order);
        c->cell_of = malloc(cap * sizeof *c->cell_of);
        c->cap_particles = c->order && c->cell_of ? cap : 0;
        if (!c->cap_particles) return HBK_ERR_OUT_OF_MEMORY;
    }
    c->ncells = ncells;
    const int32_t dx = c->dims[0], dy = c->dims[1];
#pragma omp parallel for num_threads(threads) schedule(static)
    for (int32_t i = 0; i < count; ++i) {
        const float *x = pos + 3 * (size_t)i;
        int32_t cx = hbk_fluid_cell_coord(c, x[0], 0), cy = hbk_fluid_cell_coord(c, x[1], 1),
                cz = hbk_fluid_cell_coord(c, x[2], 2);
        c->cell_of[i] = cx + dx * (cy + dy * cz);
    }
    /* Serial counting sort: a few ms at 100k particles, and trivially in id order. */
    memset(c->start, 0, (ncells + 1) * sizeof *c->start);
    for (int32_t i = 0; i < count; ++i) c->start[c->cell_of[i] + 1]++;
    for (size_t k = 0; k < ncells; ++k) c->start[k + 1] += c->start[k];
    int32_t *fill = malloc(ncells * sizeof *fill);
    if (!fill) return HBK_ERR_OUT_OF_MEMORY;
    memcpy(fill, c->start, ncells * sizeof *fill);
    for (int32_t i = 0; i < count; ++i) c->order[fill[c->cell_of[i]]++] = i;
    free(fill);
    return HBK_OK;
}
