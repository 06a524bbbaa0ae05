/* Solid fluid texturing: ms per frame for one SPH step, density/V_m/features, advection of
 * all volumes (two uvw fields, wrap flags, base blend, paint) and the surface, at the paper's
 * 32^3 / 10k particles, 64^3 / 50k and 128^3 / 100k, at 1 and 2 threads. A dam-break cube of
 * particles in a 1 m box, one stroke of paint active and examples.blend's two feature rules
 * (waves where the acceleration is above 30 m/s^2, noise where it is below 2), 1/24 s frames.
 * The SPH takes the steps stability needs (60-80 a frame here); the table gives the mean cost
 * of one of them and how many a frame took. The first frames are not timed: the column must
 * have fallen and be running across the floor, as in most of a bake, not sitting at rest.
 * Usage: bench_fluid [frames]. Prints a markdown table. */
#include "bench_args.h"
#include "hydrobake.h"
#include <float.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

int main(int argc, char **argv)
{
    const char *usage = "bench_fluid [frames: 1-1000, default 5]";
    bench_check_args(argc, argv, 1, usage);
    const int frames = bench_int_arg(argc, argv, 1, "frames", 5, 1, 1000, usage);
    const struct { int res, particles; } cases[3] = {{32, 10000}, {64, 50000}, {128, 100000}};
    const int warm = 6; /* 0.25 s: the wave has crossed half the floor */
    printf("Fluid texturing: mean of %d frames of 1/24 s after %d untimed ones, %d cores "
           "available; total = one SPH step + fields + advection + surface\n\n",
           frames, warm, omp_get_num_procs());
    printf("| volumes | particles | threads | SPH step (ms) | SPH steps / frame | "
           "fields + features (ms) | advection (ms) | surface (ms) | total (ms) | "
           "triangles |\n");
    printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (int c = 0; c < 3; ++c)
        for (int threads = 1; threads <= 2; ++threads) {
            hbk_fluid_params_t p;
            hbk_fluid_params_default(&p);
            for (int a = 0; a < 3; ++a) p.resolution[a] = cases[c].res;
            p.threads = threads;
            p.substeps = 1; /* the core takes what stability needs */
            p.dt = 1.0f / 24.0f;
            p.max_particles = cases[c].particles;
            p.particle_spacing = 0.015f;
            p.smoothing_length = 0.03f;
            p.metaball_radius = 0.03f;
            hbk_fluid_t *h;
            hbk_message_t msg;
            if (hbk_fluid_create(&h, &p, &msg)) {
                fprintf(stderr, "create: %s\n", msg.text);
                return 1;
            }
            const float side = p.particle_spacing * floorf(cbrtf((float)cases[c].particles));
            const float lo[3] = {0, 0, 0}, hi[3] = {side, side, side}, ctr[3] = {0.2f, 0.2f, 0.2f};
            if (hbk_fluid_fill_box(h, lo, hi, 0.2f) || hbk_fluid_paint_sphere(h, 1, ctr, 0.15f, 0.05f)) {
                fprintf(stderr, "setup: %s\n", hbk_fluid_message(h));
                return 1;
            }
            float rlo[HBK_FLUID_FEATURE_COUNT], rhi[HBK_FLUID_FEATURE_COUNT];
            for (int r = 0; r < 2; ++r) {
                for (int q = 0; q < HBK_FLUID_FEATURE_COUNT; ++q)
                    rlo[q] = -FLT_MAX, rhi[q] = FLT_MAX;
                rlo[HBK_FLUID_FEATURE_ACCELERATION] = r ? 30.0f : 0.0f;
                rhi[HBK_FLUID_FEATURE_ACCELERATION] = r ? FLT_MAX : 2.0f;
                if (hbk_fluid_set_feature_rule(h, r, rlo, rhi)) {
                    fprintf(stderr, "rule: %s\n", hbk_fluid_message(h));
                    return 1;
                }
            }
            double sum[4] = {0, 0, 0, 0}, steps = 0.0;
            int32_t nv = 0, nt = 0;
            for (int f = 0; f < frames + warm; ++f) {
                if (hbk_fluid_step(h, NULL) || hbk_fluid_update_surface(h, NULL)) {
                    fprintf(stderr, "frame: %s\n", hbk_fluid_message(h));
                    return 1;
                }
                double ms[4];
                hbk_fluid_timings(h, ms);
                if (f < warm) continue;
                for (int k = 0; k < 4; ++k) sum[k] += ms[k];
                steps += hbk_fluid_substeps_taken(h);
            }
            hbk_fluid_mesh_counts(h, &nv, &nt);
            sum[0] /= steps; /* one SPH step */
            for (int k = 1; k < 4; ++k) sum[k] /= frames;
            printf("| %d^3 | %d | %d | %.1f | %.0f | %.1f | %.1f | %.1f | %.1f | %d |\n",
                   cases[c].res, hbk_fluid_particle_count(h), threads, sum[0], steps / frames,
                   sum[1], sum[2], sum[3], sum[0] + sum[1] + sum[2] + sum[3], nt);
            hbk_fluid_destroy(h);
        }
    return 0;
}
