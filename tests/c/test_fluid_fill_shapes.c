/* Water poured in a shape (hbk_fluid_fill_shape): refused by name; a sphere, a turned box and
 * a mesh (a sphere's field, a torus's) hold as many particles as their volume holds lattice
 * cells, every one inside; a box is fill_box to the byte; obstacles are still left out. */
#include "test.h"
#include "fluid/internal_fluid.h"
#include <math.h>
#include <stdlib.h>

static const double PI = 3.14159265358979323846;

/* The particles' positions (malloc'd, count in *n). */
static float *positions(hbk_fluid_t *h, int32_t *n)
{
    *n = hbk_fluid_particle_count(h);
    float *p = malloc(3 * (size_t)(*n > 0 ? *n : 1) * sizeof *p);
    if (p && hbk_fluid_get_particles(h, p, NULL, *n) != HBK_OK) {
        free(p);
        return NULL;
    }
    return p;
}

/* Particles times a lattice cell's volume, over `volume`. */
static double filled(hbk_fluid_t *h, double volume)
{
    const double s = 0.02; /* the default particle_spacing */
    return hbk_fluid_particle_count(h) * s * s * s / volume;
}

void test_fluid_fill_shape_refused(void)
{
    hbk_fluid_t *h = fluid_lone(0.0f, 100, 0);
    CHECK(h);
    CHECK(hbk_fluid_fill_shape(h, NULL, NULL, NULL, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "shape: must not be NULL"));
    hbk_fluid_obstacle_t ob = {5, {0.5f, 0.5f, 0.5f}, {0.1f, 0, 0}, {1, 0, 0, 0}};
    CHECK(hbk_fluid_fill_shape(h, &ob, NULL, NULL, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "shape.type = 5: must be 0 (sphere)"));
    ob.type = 2, ob.rotation[0] = 2.0f;
    CHECK(hbk_fluid_fill_shape(h, &ob, NULL, NULL, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "shape.rotation: length 2, must be a unit quaternion"));
    ob.type = 3, ob.rotation[0] = 1.0f, ob.extent[1] = ob.extent[2] = 0.1f;
    CHECK(hbk_fluid_fill_shape(h, &ob, NULL, NULL, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "dims: must not be NULL"));
    float f[8] = {-1, -1, -1, -1, -1, -1, -1, NAN};
    const int32_t dims[3] = {2, 2, 2};
    CHECK(hbk_fluid_fill_shape(h, &ob, dims, f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "distance[7] = nan: must be a finite number"));
    f[7] = -1.0f;
    CHECK(hbk_fluid_fill_shape(h, &ob, dims, f, 0.7f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "jitter = 0.7: must be in [0, 0.5]"));
    /* (a 0.2 m cube: 1000 lattice points, more than max_particles = 100) */
    CHECK(hbk_fluid_fill_shape(h, &ob, dims, f, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h),
                 "fill_shape: 1000 particles plus the 0 present exceed max_particles = 100"));
    CHECK(hbk_fluid_particle_count(h) == 0);
    hbk_fluid_destroy(h);
}

void test_fluid_fill_shape_volumes(void)
{
    /* a sphere: 4/3 pi r^3, every particle inside */
    hbk_fluid_t *h = fluid_lone(0.0f, 20000, 0);
    CHECK(h);
    const hbk_fluid_obstacle_t ball = {0, {0.5f, 0.5f, 0.5f}, {0.2f, 0, 0}, {0}};
    CHECK_OK(hbk_fluid_fill_shape(h, &ball, NULL, NULL, 0.0f));
    const int32_t balls = hbk_fluid_particle_count(h);
    CHECK(fabs(filled(h, 4.0 / 3.0 * PI * 0.008) - 1.0) < 0.03);
    int32_t n = 0;
    float *p = positions(h, &n);
    CHECK(p);
    for (int32_t i = 0; p && i < n; ++i) {
        const double dx = p[3 * i] - 0.5, dy = p[3 * i + 1] - 0.5, dz = p[3 * i + 2] - 0.5;
        CHECK(dx * dx + dy * dy + dz * dz < 0.04);
    }
    free(p);
    hbk_fluid_destroy(h);
    /* the same sphere as a mesh's field: the same particles but a few at its surface */
    h = fluid_lone(0.0f, 20000, 0);
    CHECK(h);
    const hbk_fluid_obstacle_t mesh = {3, {0.5f, 0.5f, 0.5f}, {0.22f, 0.22f, 0.22f}, {1, 0, 0, 0}};
    float *f = fluid_sdf_field(SDF_SPHERE, mesh.extent, 45, 0.2, 0, 0);
    const int32_t dims[3] = {45, 45, 45};
    CHECK(f);
    CHECK_OK(hbk_fluid_fill_shape(h, &mesh, dims, f, 0.0f));
    free(f);
    CHECK(abs(hbk_fluid_particle_count(h) - balls) < balls / 100);
    hbk_fluid_destroy(h);
    /* a box turned 30 degrees about z: 0.4 x 0.2 x 0.2 m, every particle inside its own axes */
    h = fluid_lone(0.0f, 20000, 0);
    CHECK(h);
    const float c = (float)cos(PI / 12), s = (float)sin(PI / 12);
    const hbk_fluid_obstacle_t slab = {2, {0.5f, 0.5f, 0.5f}, {0.2f, 0.1f, 0.1f}, {c, 0, 0, s}};
    CHECK_OK(hbk_fluid_fill_shape(h, &slab, NULL, NULL, 0.3f));
    CHECK(fabs(filled(h, 0.016) - 1.0) < 0.03);
    p = positions(h, &n);
    CHECK(p);
    const double ux = cos(PI / 6), uy = sin(PI / 6);
    for (int32_t i = 0; p && i < n; ++i) {
        const double dx = p[3 * i] - 0.5, dy = p[3 * i + 1] - 0.5, dz = p[3 * i + 2] - 0.5;
        CHECK(fabs(dx * ux + dy * uy) < 0.2 && fabs(-dx * uy + dy * ux) < 0.1 &&
              fabs(dz) < 0.1);
    }
    free(p);
    hbk_fluid_destroy(h);
    /* a torus about z (ring 0.2, tube 0.08): 2 pi^2 R r^2, its hole empty */
    h = fluid_lone(0.0f, 20000, 0);
    CHECK(h);
    const hbk_fluid_obstacle_t ring = {3, {0.5f, 0.5f, 0.5f}, {0.3f, 0.3f, 0.1f}, {1, 0, 0, 0}};
    f = fluid_sdf_field(SDF_TORUS, ring.extent, 64, 0.2, 0.08, 0);
    const int32_t rdims[3] = {64, 64, 64};
    CHECK(f);
    CHECK_OK(hbk_fluid_fill_shape(h, &ring, rdims, f, 0.0f));
    free(f);
    CHECK(fabs(filled(h, 2.0 * PI * PI * 0.2 * 0.0064) - 1.0) < 0.05);
    p = positions(h, &n);
    CHECK(p && n > 0);
    for (int32_t i = 0; p && i < n; ++i) {
        const double dx = p[3 * i] - 0.5, dy = p[3 * i + 1] - 0.5;
        CHECK(dx * dx + dy * dy > 0.11 * 0.11);
    }
    free(p);
    hbk_fluid_destroy(h);
}

void test_fluid_fill_shape_box_and_obstacles(void)
{
    /* a box: fill_box's particles to the byte, jitter and all (its bounds exact in binary) */
    hbk_fluid_t *a = fluid_lone(0.0f, 20000, 0), *b = fluid_lone(0.0f, 20000, 0);
    CHECK(a && b);
    const float lo[3] = {0.25f, 0.3125f, 0.125f}, hi[3] = {0.5f, 0.4375f, 0.375f};
    const hbk_fluid_obstacle_t box = {1, {0.375f, 0.375f, 0.25f}, {0.125f, 0.0625f, 0.125f},
                                      {0}};
    CHECK_OK(hbk_fluid_fill_box(a, lo, hi, 0.3f));
    CHECK_OK(hbk_fluid_fill_shape(b, &box, NULL, NULL, 0.3f));
    CHECK(hbk_fluid_particle_count(a) == 12 * 6 * 12);
    CHECK(fluid_same_state(a, b));
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
    /* an obstacle inside the shape: left out, as fill_box leaves it out */
    hbk_fluid_t *h = fluid_lone(0.0f, 20000, 0);
    CHECK(h);
    const hbk_fluid_obstacle_t rock = {0, {0.5f, 0.5f, 0.5f}, {0.08f, 0, 0}, {0}};
    CHECK_OK(hbk_fluid_set_obstacles(h, &rock, 1));
    const hbk_fluid_obstacle_t ball = {0, {0.5f, 0.5f, 0.5f}, {0.2f, 0, 0}, {0}};
    CHECK_OK(hbk_fluid_fill_shape(h, &ball, NULL, NULL, 0.0f));
    CHECK(fabs(filled(h, 4.0 / 3.0 * PI * (0.008 - 0.09 * 0.09 * 0.09)) - 1.0) < 0.04);
    int32_t n = 0;
    float *p = positions(h, &n);
    CHECK(p);
    for (int32_t i = 0; p && i < n; ++i) {
        const double dx = p[3 * i] - 0.5, dy = p[3 * i + 1] - 0.5, dz = p[3 * i + 2] - 0.5;
        CHECK(dx * dx + dy * dy + dz * dz >= 0.09 * 0.09 * 0.999);
    }
    free(p);
    hbk_fluid_destroy(h);
}
