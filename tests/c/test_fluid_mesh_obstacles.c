/* Mesh obstacles (signed distance fields over a turned box): refused by name when their field
 * is wrong or missing; a sphere's field meets particles where the sphere does; a box's field
 * tilted as a ramp lets a particle slide at g sin(theta); a torus keeps its hole open; the
 * field moves with its box, is part of the state, and is dropped by set_obstacles. */
#include "test.h"
#include "fluid/internal_fluid.h"
#include <stdlib.h>

static hbk_result_t set_mesh(hbk_fluid_t *h, const hbk_fluid_obstacle_t *ob, int shape, int n,
                             double a, double b, double c)
{
    hbk_result_t r = hbk_fluid_set_obstacles(h, ob, 1);
    if (r) return r;
    float *f = fluid_sdf_field(shape, ob->extent, n, a, b, c);
    const int32_t dims[3] = {n, n, n};
    r = f ? hbk_fluid_set_obstacle_field(h, 0, dims, f) : HBK_ERR_OUT_OF_MEMORY;
    free(f);
    return r;
}

void test_fluid_mesh_refused(void)
{
    hbk_fluid_t *h = fluid_lone(0.0f, 100, 0);
    CHECK(h);
    hbk_fluid_obstacle_t obs[2] = {{1, {0.5f, 0.5f, 0.5f}, {0.1f, 0.1f, 0.1f}, {0}},
                                   {3, {0.5f, 0.5f, 0.5f}, {0.1f, 0.1f, 0.1f}, {1, 0, 0, 0}}};
    CHECK_OK(hbk_fluid_set_obstacles(h, obs, 2));
    float f[8] = {1, 1, 1, 1, 1, 1, 1, 1};
    int32_t dims[3] = {2, 2, 2};
    CHECK(hbk_fluid_set_obstacle_field(h, 2, dims, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "index = 2: must be in [0, 2)"));
    CHECK(hbk_fluid_set_obstacle_field(h, 0, dims, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "index = 0: obstacle 0 is of type 1, must be 3 (mesh)"));
    dims[1] = 1;
    CHECK(hbk_fluid_set_obstacle_field(h, 1, dims, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "dims[1] = 1: must be in [2, 128]"));
    dims[1] = 2;
    f[5] = NAN;
    CHECK(hbk_fluid_set_obstacle_field(h, 1, dims, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "distance[5] = nan: must be a finite number"));
    CHECK(hbk_fluid_set_obstacle_field(h, 1, NULL, f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "dims: must not be NULL"));
    /* a step or a fill with the mesh's field missing */
    const float lo[3] = {0, 0, 0}, hi[3] = {0.1f, 0.1f, 0.1f};
    CHECK(hbk_fluid_fill_box(h, lo, hi, 0.0f) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "fill_box: obstacle 1 is a mesh without its field"));
    CHECK(hbk_fluid_step(h, NULL) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "step: obstacle 1 is a mesh without its field"));
    f[5] = 1.0f;
    CHECK_OK(hbk_fluid_set_obstacle_field(h, 1, dims, f));
    CHECK_OK(hbk_fluid_step(h, NULL));
    /* set_obstacles drops the fields */
    CHECK_OK(hbk_fluid_set_obstacles(h, obs, 2));
    CHECK(hbk_fluid_step(h, NULL) == HBK_ERR_INVALID_ARGUMENT);
    /* a mesh's box must have room */
    obs[1].extent[2] = 0.0f;
    CHECK(hbk_fluid_set_obstacles(h, obs, 2) == HBK_ERR_INVALID_ARGUMENT);
    CHECK(strstr(hbk_fluid_message(h), "obs[1].extent[2] = 0: must be in (0, 1e6] m for a mesh"));
    hbk_fluid_destroy(h);
}

/* One step of a lone particle from x0 with v0 near obstacle ob (a mesh: its shape's field). */
static void one_step(const hbk_fluid_obstacle_t *ob, int shape, double a, const float x0[3],
                     const float v0[3], float x[3], float v[3])
{
    hbk_fluid_t *h = fluid_lone(0.0f, 8, 0);
    CHECK(h);
    if (ob->type == 3) CHECK_OK(set_mesh(h, ob, shape, 64, a, a, a));
    else CHECK_OK(hbk_fluid_set_obstacles(h, ob, 1));
    CHECK_OK(hbk_fluid_set_particles(h, x0, v0, 1));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK_OK(hbk_fluid_get_particles(h, x, v, 1));
    hbk_fluid_destroy(h);
}

void test_fluid_mesh_sphere_field(void)
{
    const hbk_fluid_obstacle_t ball = {0, {0.5f, 0.5f, 0.5f}, {0.15f, 0, 0}, {0}};
    hbk_fluid_obstacle_t mesh = {3, {0.5f, 0.5f, 0.5f}, {0.2f, 0.2f, 0.2f}, {1, 0, 0, 0}};
    /* turned, as any mesh may be: a sphere's field is the same whichever way it faces */
    const double t = 0.4;
    mesh.rotation[0] = (float)cos(t), mesh.rotation[1] = (float)(0.6 * sin(t));
    mesh.rotation[3] = (float)(0.8 * sin(t));
    const float starts[4][3] = {{0.5f, 0.62f, 0.5f},   /* inside */
                                {0.6f, 0.55f, 0.58f},  /* inside, off the axes */
                                {0.5f, 0.5f, 0.662f},  /* within half a spacing */
                                {0.5f, 0.5f, 0.7f}};   /* clear of it */
    const float vel[3] = {0.2f, -0.4f, -0.3f};
    for (int i = 0; i < 4; ++i) {
        float xa[3], va[3], xb[3], vb[3];
        one_step(&mesh, SDF_SPHERE, 0.15, starts[i], vel, xa, va);
        one_step(&ball, SDF_SPHERE, 0.15, starts[i], vel, xb, vb);
        for (int k = 0; k < 3; ++k) {
            CHECK_NEAR(xa[k], xb[k], 1e-3);
            CHECK_NEAR(va[k], vb[k], 2e-2);
        }
    }
}

/* A box's field tilted 30 degrees about y, a particle set on it: it slides down at g sin(theta),
 * neither sinking in nor leaving it. */
void test_fluid_mesh_ramp(void)
{
    const double th = 30.0 * M_PI / 180.0, m = 0.01;
    hbk_fluid_obstacle_t ramp = {3, {0.5f, 0.5f, 0.4f}, {0.45f, 0.35f, 0.06f}, {1, 0, 0, 0}};
    ramp.rotation[0] = (float)cos(0.5 * th), ramp.rotation[2] = (float)sin(0.5 * th);
    hbk_fluid_t *h = fluid_lone(-9.81f, 8, 0);
    CHECK(h);
    CHECK_OK(hbk_fluid_set_obstacles(h, &ramp, 1));
    const int32_t dims[3] = {91, 71, 13}; /* 1 cm apart: the board 0.8 x 0.6 x 0.02 m */
    float *g = malloc((size_t)dims[0] * dims[1] * dims[2] * sizeof *g);
    CHECK(g);
    for (int k = 0; k < dims[2]; ++k)
        for (int j = 0; j < dims[1]; ++j)
            for (int i = 0; i < dims[0]; ++i) {
                const double p[3] = {-0.45 + 0.01 * i, -0.35 + 0.01 * j, -0.06 + 0.01 * k};
                g[i + dims[0] * (j + dims[1] * k)] = fluid_sdf(SDF_BOX, p, 0.4, 0.3, 0.01);
            }
    CHECK_OK(hbk_fluid_set_obstacle_field(h, 0, dims, g));
    free(g);
    const double n[3] = {sin(th), 0.0, cos(th)}, d[3] = {cos(th), 0.0, -sin(th)};
    float x[3], v[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k) x[k] = (float)(ramp.center[k] - 0.3 * d[k] + (0.01 + m) * n[k]);
    CHECK_OK(hbk_fluid_set_particles(h, x, v, 1));
    const int frames = 6;
    for (int i = 0; i < frames; ++i) CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK_OK(hbk_fluid_get_particles(h, x, v, 1));
    double vn = 0.0, vd = 0.0, height = 0.0;
    for (int k = 0; k < 3; ++k) {
        vn += v[k] * n[k];
        vd += v[k] * d[k];
        height += (x[k] - ramp.center[k]) * n[k];
    }
    const double t = frames / 24.0;
    CHECK_NEAR(vn, 0.0, 1e-3);
    CHECK_NEAR(height, 0.01 + m, 1e-4);
    CHECK_NEAR(vd, 9.81 * sin(th) * t, 1e-2);
    hbk_fluid_destroy(h);
}

/* A torus keeps its hole open: a fill leaves out the tube but keeps the hole, and a particle
 * in the hole stays where it is. */
void test_fluid_mesh_torus_hole(void)
{
    hbk_fluid_t *h = fluid_lone(0.0f, 20000, 0);
    CHECK(h);
    const hbk_fluid_obstacle_t torus = {3, {0.5f, 0.5f, 0.2f}, {0.3f, 0.3f, 0.12f}, {1, 0, 0, 0}};
    CHECK_OK(set_mesh(h, &torus, SDF_TORUS, 64, 0.2, 0.08, 0));
    const float lo[3] = {0.2f, 0.2f, 0.1f}, hi[3] = {0.8f, 0.8f, 0.3f};
    CHECK_OK(hbk_fluid_fill_box(h, lo, hi, 0.0f));
    const int32_t n = hbk_fluid_particle_count(h);
    float *pos = malloc(3 * (size_t)n * sizeof *pos);
    CHECK(pos && hbk_fluid_get_particles(h, pos, NULL, n) == HBK_OK);
    int in_tube = 0, in_hole = 0;
    for (int32_t i = 0; i < n; ++i) {
        const double p[3] = {pos[3 * i] - 0.5, pos[3 * i + 1] - 0.5, pos[3 * i + 2] - 0.2};
        const float d = fluid_sdf(SDF_TORUS, p, 0.2, 0.08, 0);
        in_tube += d < 0.0099f;
        in_hole += sqrt(p[0] * p[0] + p[1] * p[1]) < 0.1;
    }
    free(pos);
    CHECK(in_tube == 0);
    CHECK(in_hole > 50); /* about 78 of a full lattice there, less the z rows near the tube */
    const float x0[3] = {0.5f, 0.5f, 0.2f}, v0[3] = {0, 0, 0};
    float x[3], v[3];
    CHECK_OK(hbk_fluid_set_particles(h, x0, v0, 1));
    CHECK_OK(hbk_fluid_step(h, NULL));
    CHECK_OK(hbk_fluid_get_particles(h, x, v, 1));
    CHECK(x[0] == x0[0] && x[1] == x0[1] && x[2] == x0[2]);
    hbk_fluid_destroy(h);
}

/* A box field carried along +x at u, as the moving wall: the particle it meets rides its face
 * at u; the state holds the field (a fresh handle given the state continues to the same
 * bytes, with no field of its own set), and bad dims in a state are refused. */
void test_fluid_mesh_moving_state(void)
{
    const float dt = 1.0f / 24.0f, u = 1.2f, m = 0.01f;
    hbk_fluid_obstacle_t wall = {3, {0.2f, 0.5f, 0.5f}, {0.12f, 0.12f, 0.12f}, {1, 0, 0, 0}};
    hbk_fluid_t *a = fluid_lone(0.0f, 8, 0), *b = fluid_lone(0.0f, 8, 0);
    CHECK(a && b);
    CHECK_OK(set_mesh(a, &wall, SDF_BOX, 49, 0.1, 0.1, 0.1));
    float x[3] = {0.45f, 0.5f, 0.5f}, v[3] = {0.0f, 0.2f, 0.0f};
    CHECK_OK(hbk_fluid_set_particles(a, x, v, 1));
    for (int f = 1; f <= 3; ++f) {
        wall.center[0] = 0.2f + u * dt * (float)f;
        CHECK_OK(hbk_fluid_move_obstacles(a, &wall, 1));
        CHECK_OK(hbk_fluid_step(a, NULL));
    }
    size_t size = hbk_fluid_state_size(a);
    unsigned char *st = malloc(size), *st2 = malloc(size);
    CHECK(st && st2);
    CHECK_OK(hbk_fluid_save_state(a, st, size));
    CHECK_OK(hbk_fluid_load_state(b, st, size));
    for (int f = 4; f <= 6; ++f) {
        wall.center[0] = 0.2f + u * dt * (float)f;
        CHECK_OK(hbk_fluid_move_obstacles(a, &wall, 1));
        CHECK_OK(hbk_fluid_move_obstacles(b, &wall, 1));
        CHECK_OK(hbk_fluid_step(a, NULL));
        CHECK_OK(hbk_fluid_step(b, NULL));
    }
    CHECK_OK(hbk_fluid_get_particles(a, x, v, 1));
    CHECK_NEAR(x[0], wall.center[0] + 0.1f + m, 2e-4);
    CHECK_NEAR(v[0], u, 1e-2);
    CHECK(v[1] == 0.2f);
    CHECK(hbk_fluid_state_size(b) == size);
    CHECK_OK(hbk_fluid_save_state(a, st, size));
    CHECK_OK(hbk_fluid_save_state(b, st2, size));
    CHECK(!memcmp(st, st2, size));
    /* the field's dims, after the sections: a mesh's out of range, another's not zero */
    const size_t dims_at = size - 49 * 49 * 49 * sizeof(float) - 12 * HBK_FLUID_MAX_OBSTACLES;
    int32_t bad = 200;
    memcpy(st2, st, size);
    memcpy(st2 + dims_at, &bad, 4);
    CHECK(hbk_fluid_load_state(b, st2, size) == HBK_ERR_FORMAT);
    CHECK(strstr(hbk_fluid_message(b), "state obstacle 0 field dims (200, 49, 49)"));
    memcpy(st2, st, size);
    bad = 2;
    memcpy(st2 + dims_at + 12, &bad, 4);
    CHECK(hbk_fluid_load_state(b, st2, size) == HBK_ERR_FORMAT);
    memcpy(st2, st, size);
    const float nan = NAN;
    memcpy(st2 + size - 4, &nan, 4);
    CHECK(hbk_fluid_load_state(b, st2, size) == HBK_ERR_FORMAT);
    CHECK(strstr(hbk_fluid_message(b), "state obstacle fields: not all valid numbers"));
    CHECK(hbk_fluid_load_state(b, st, size - 4) == HBK_ERR_INVALID_ARGUMENT);
    free(st);
    free(st2);
    hbk_fluid_destroy(a);
    hbk_fluid_destroy(b);
}
