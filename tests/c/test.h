/* Minimal test harness: one runner, a table of named tests, a name filter (libsoundio style). */
#ifndef HBK_TEST_H
#define HBK_TEST_H
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "hydrobake.h"

extern int hbk_test_failed;

#define CHECK(cond)                                                                  \
    do {                                                                             \
        if (!(cond)) {                                                               \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
            hbk_test_failed = 1;                                                     \
            return;                                                                  \
        }                                                                            \
    } while (0)

#define CHECK_NEAR(a, b, tol)                                                          \
    do {                                                                               \
        double a_ = (double)(a), b_ = (double)(b);                                     \
        if (!(fabs(a_ - b_) <= (tol))) {                                               \
            fprintf(stderr, "%s:%d: CHECK_NEAR failed: %s = %.9g, %s = %.9g, tol %g\n", \
                    __FILE__, __LINE__, #a, a_, #b, b_, (double)(tol));                \
            hbk_test_failed = 1;                                                       \
            return;                                                                    \
        }                                                                              \
    } while (0)

#define CHECK_OK(expr)                                                                     \
    do {                                                                                   \
        hbk_result_t r_ = (expr);                                                          \
        if (r_ != HBK_OK) {                                                                \
            fprintf(stderr, "%s:%d: %s returned %d (%s)\n", __FILE__, __LINE__, #expr, r_, \
                    hbk_result_string(r_));                                                \
            hbk_test_failed = 1;                                                           \
            return;                                                                        \
        }                                                                                  \
    } while (0)

/* A scratch folder for files, made by the runner: HBK_TEST_TMP or /tmp. */
const char *hbk_test_tmpdir(void);

/* A zeroed float buffer with its image view (free(g.v) when done). */
typedef struct {
    float *v;
    hbk_image_t img;
} grid_t;
grid_t grid_new(int32_t w, int32_t h, int32_t channels);

/* Puts parameter `p` of the params struct at `params` out of its range (the last element of
 * an array): side 0 below the minimum, 1 above the maximum, 2 NaN. Returns 0 where that side
 * does not apply (NaN for an integer, any side for a u64 seed, which takes every value). */
int hbk_test_break_param(void *params, const hbk_param_info_t *p, int side);
/* A fluid in the default 1 m box at 16^3 with gravity (0, 0, gz) (the obstacle tests' lone
 * particles; threads 0: the default), and a malloc'd copy of a handle's saved state (NULL on failure). */
hbk_fluid_t *fluid_lone(float gz, int32_t max_particles, int32_t threads);
/* A handle of these parameters, or NULL with the reason on stderr. */
hbk_fluid_t *fluid_make(const hbk_fluid_params_t *p);
unsigned char *fluid_state_of(hbk_fluid_t *h, size_t *size);
/* The default 1 m box at 16^3 (spacing 2 cm, h 4 cm), no gravity, little viscosity, one
 * thread (the inflow and outflow tests' box). */
hbk_fluid_params_t fluid_still_box(int32_t max_particles);
/* hbk_fluid_step(h) with a second thread cancelling it as soon as its progress passes 0 (a
 * substep done); *midway receives whether the step was cancelled that far in. */
hbk_result_t fluid_step_cancelled(hbk_fluid_t *h, int *midway);
/* Whether two handles' saved states are the same bytes. */
int fluid_same_state(hbk_fluid_t *a, hbk_fluid_t *b);
/* Mesh obstacles' fields: the signed distance at p (own axes) to a sphere of radius a, a box
 * of half-sizes (a, b, c) or a torus about z of radii a (ring) and b (tube); and a malloc'd
 * field of one over the box of half-sizes e at n points a side (x fastest). */
enum { SDF_SPHERE, SDF_BOX, SDF_TORUS };
float fluid_sdf(int shape, const double p[3], double a, double b, double c);
float *fluid_sdf_field(int shape, const float e[3], int n, double a, double b, double c);

/* Every test, one line each as X-macro entries of group and name; the runner and CMake
 * (tests/c/CMakeLists.txt) both read this list. */
#define HBK_TEST_LIST(X)                 \
    X(base, result_strings)              \
    X(base, params_validate)             \
    X(base, params_float_bounds)         \
    X(base, grid_to_xyz)                 \
    X(rng, philox_known_answer)          \
    X(rng, uniform_statistics)           \
    X(rng, counter_independence)         \
    X(image, sample_edges)               \
    X(image, normal_map_plane)           \
    X(image, normal_map_sphere)          \
    X(image, normal_map_rejects)         \
    X(image, normal_map_tiny_texel)      \
    X(image, normal_map_non_finite_height) \
    X(image, uv_overlap_known_layouts)   \
    X(image, uv_overlap_fan_shares_edges_once) \
    X(image, uv_overlap_rejects)         \
    X(exr, roundtrip_float_half)         \
    X(exr, partly_compressible_chunks)   \
    X(exr, same_bytes_any_threads)       \
    X(exr, orientation_and_strides)      \
    X(exr, atomic_failure_keeps_old)     \
    X(exr, rejects_bad_input)            \
    X(exr, read_missing_and_corrupt)     \
    X(water, params_rejects)             \
    X(water, volume_conserved)           \
    X(water, stable_large_dt)            \
    X(water, wet_dry)                    \
    X(water, wave_speed)                 \
    X(water, flat_stays_flat)            \
    X(water, periodic_seamless)          \
    X(water, threads_identical)          \
    X(water, state_roundtrip)            \
    X(water, sources)                    \
    X(water, footprint_displaces)        \
    X(water, cancel)                     \
    X(water, cancel_during_rain)         \
    X(water, many_threads_under_a_memory_limit) \
    X(water, kass_miller_matrix)         \
    X(water, wave_speed_kass_miller)     \
    X(caustics, params_rejects)          \
    X(caustics, flat_uniform)            \
    X(caustics, energy_conserved)        \
    X(caustics, lens_focus)              \
    X(caustics, photon_reference)        \
    X(caustics, threads_identical)       \
    X(caustics, periodic_seamless)       \
    X(caustics, shoreline)               \
    X(caustics, point_light)             \
    X(caustics, view_uv)                 \
    X(caustics, lit_ground)              \
    X(caustics, tiny_extent)             \
    X(caustics, huge_extent_dispersive)  \
    X(caustics, cancel)                  \
    X(caustics, workspace_reuse)         \
    X(caustics, paths_same_bytes)        \
    X(caustics, snell_flat)              \
    X(caustics, snell_tilted_surface)    \
    X(caustics, energy_sloped_ground)    \
    X(snow, formulas)                    \
    X(snow, params)                      \
    X(snow, sticking_statistics)         \
    X(snow, stamp_formulas)              \
    X(snow, stamp_scaling)               \
    X(snow, melts_and_sheds)             \
    X(snow, roof_shelter)                \
    X(snow, depth_grows)                 \
    X(snow, wind_windward)               \
    X(snow, moving_mesh)                 \
    X(snow, determinism_threads)         \
    X(snow, slots_by_place)              \
    X(snow, state_roundtrip)             \
    X(snow, cancel)                      \
    X(snow, mesh_rejects)                \
    X(snow, mesh_rejects_far_vertices)   \
    X(snow, box_mode)                    \
    X(snow, box_slots_fit_the_image)     \
    X(snow, bvh_brute_force)             \
    X(snow, flake_motion)                \
    X(snow, box_faces)                   \
    X(rain, params_rejects)              \
    X(rain, kernel_formula)              \
    X(rain, water_conserved)             \
    X(rain, flows_along_gravity)         \
    X(rain, tangent_field)               \
    X(rain, merge)                       \
    X(rain, mask_after_merge)            \
    X(rain, trails_fade)                 \
    X(rain, wiper_sweep)                 \
    X(rain, holdback)                    \
    X(rain, car_motion)                  \
    X(rain, threads_identical)           \
    X(rain, state_roundtrip)             \
    X(rain, state_refuses_absurd_motion) \
    X(rain, cancel)                      \
    X(rain, refraction)                  \
    X(rain, refraction_rejects_bad_normals) \
    X(rain, paths_same_bytes)            \
    X(rain, friction_threshold)          \
    X(rain, terminal_speed)              \
    X(rain, meander_unbiased)            \
    X(rain, particles_split)             \
    X(rain, holdback_rule)               \
    X(fluid, params_rejects)             \
    X(fluid, uniform_flow_shift)         \
    X(fluid, zero_flow_bitwise)          \
    X(fluid, wrap_short_way)             \
    X(fluid, wrap_flags_advect)          \
    X(fluid, blend_normalised)           \
    X(fluid, rules_exact)                \
    X(fluid, rules_after_flow)           \
    X(fluid, density_lattice)            \
    X(fluid, sph_rest)                   \
    X(fluid, sph_stable_steps)           \
    X(fluid, mc_closed)                  \
    X(fluid, mc_closed_noise)            \
    X(fluid, mc_sphere)                  \
    X(fluid, mesh_uvw_unwrapped)         \
    X(fluid, crossfade)                  \
    X(fluid, stretch_fade)               \
    X(fluid, threads_identical)          \
    X(fluid, paths_same_bytes)           \
    X(fluid, state_roundtrip)            \
    X(fluid, reload_every_frame)         \
    X(fluid, state_no_stale_paint)       \
    X(fluid, paint_from_still_rows)      \
    X(fluid, paint_cleared_any_textures) \
    X(fluid, paint_points)               \
    X(fluid, cancel)                     \
    X(fluid, noise_tileable)             \
    X(fluid, sums_staggered)           \
    X(fluid, kernels_normalised)       \
    X(fluid, sph_pair_exact)           \
    X(fluid, sph_momentum)             \
    X(fluid, sph_lattice_rest_density) \
    X(fluid, features_known_fields)    \
    X(fluid, crossfade_schedule)       \
    X(fluid, blend_advect_shift) \
    X(fluid, obstacles_move_refused)    \
    X(fluid, obstacles_moving_wall)     \
    X(fluid, obstacles_growing_sphere)  \
    X(fluid, obstacles_move_deterministic) \
    X(fluid, obstacles_move_cancel_resume) \
    X(fluid, obstacles_fill_around)     \
    X(fluid, turned_box_quarter)        \
    X(fluid, turned_box_ramp)           \
    X(fluid, turned_box_paddle)         \
    X(fluid, turned_box_stirred)        \
    X(fluid, turned_box_state_v1)       \
    X(fluid, mesh_refused)              \
    X(fluid, mesh_sphere_field)         \
    X(fluid, mesh_ramp)                 \
    X(fluid, mesh_torus_hole)           \
    X(fluid, mesh_moving_state)         \
    X(fluid, deforming_refused)         \
    X(fluid, deforming_growing_ball)    \
    X(fluid, deforming_pending)         \
    X(fluid, deforming_same_bytes)      \
    X(fluid, fill_shape_refused)        \
    X(fluid, fill_shape_volumes)        \
    X(fluid, fill_shape_box_and_obstacles) \
    X(fluid, inflow_refused)            \
    X(fluid, inflow_rate)               \
    X(fluid, inflow_forecast_rate)      \
    X(fluid, inflow_starts_in_the_shape) \
    X(fluid, inflow_clear_of_water)     \
    X(fluid, inflow_obstacles)          \
    X(fluid, inflow_capacity)           \
    X(fluid, inflow_cancel)             \
    X(fluid, inflow_deterministic)      \
    X(fluid, sprinkler_points)          \
    X(fluid, sprinkler_pours_its_rate)  \
    X(fluid, sprinkler_refused)         \
    X(fluid, inflows_added)             \
    X(fluid, inflows_replaced_and_refused) \
    X(fluid, outflow_drains_its_inside) \
    X(fluid, outflow_frame_by_frame)    \
    X(fluid, outflow_refused)           \
    X(fluid, outflow_tap_and_drain)     \
    X(fluid, outflow_cancel)            \
    X(fluid, outflows_added)            \
    X(fluid, outflows_replaced_and_refused)

#define HBK_DECLARE(g, n) void test_##g##_##n(void);
HBK_TEST_LIST(HBK_DECLARE)
#undef HBK_DECLARE
#endif
