/* Snow attachment: flake-steps per second against a 100,000-triangle torus, at 1 and 2
 * threads, in an open scene (the volume much larger than the mesh, as in a real shot) and a
 * tight one (the volume hugging the mesh, so most flakes need the full BVH query); the
 * substeps in one call, and one call a substep as a bake's frames step them by default.
 * Usage: bench_snow [flakes] [substeps]. Prints a markdown table. */
#include "bench_args.h"
#include "hydrobake.h"
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

#define U 250 /* segments around the ring */
#define V 200 /* segments around the tube: 2 U V = 100,000 triangles */

static void torus(float *pos, int32_t *tri, float *uv)
{
    const float R = 1.0f, r = 0.35f, cz = 1.0f;
    for (int i = 0; i < U; ++i)
        for (int j = 0; j < V; ++j) {
            const float a = 2.0f * (float)M_PI * i / U, b = 2.0f * (float)M_PI * j / V;
            float *p = pos + 3 * (i * V + j);
            p[0] = (R + r * cosf(b)) * cosf(a);
            p[1] = (R + r * cosf(b)) * sinf(a);
            p[2] = cz + r * sinf(b);
        }
    int t = 0;
    for (int i = 0; i < U; ++i)
        for (int j = 0; j < V; ++j) {
            const int i1 = (i + 1) % U, j1 = (j + 1) % V;
            const int q[4] = {i * V + j, i1 * V + j, i1 * V + j1, i * V + j1};
            const float qu[4][2] = {{(float)i / U, (float)j / V}, {(float)(i + 1) / U, (float)j / V},
                                    {(float)(i + 1) / U, (float)(j + 1) / V},
                                    {(float)i / U, (float)(j + 1) / V}};
            const int c[2][3] = {{0, 1, 2}, {0, 2, 3}};
            for (int k = 0; k < 2; ++k, ++t)
                for (int m = 0; m < 3; ++m) {
                    tri[3 * t + m] = q[c[k][m]];
                    uv[6 * t + 2 * m] = qu[c[k][m]][0];
                    uv[6 * t + 2 * m + 1] = qu[c[k][m]][1];
                }
        }
}

int main(int argc, char **argv)
{
    const char *usage = "bench_snow [flakes: 1-100000000, default 1000000] "
                        "[substeps: 1-100000, default 20]";
    bench_check_args(argc, argv, 2, usage);
    const int32_t flakes = bench_int_arg(argc, argv, 1, "flakes", 1000000, 1, 100000000, usage);
    const int32_t substeps = bench_int_arg(argc, argv, 2, "substeps", 20, 1, 100000, usage);
    float *pos = malloc(sizeof(float) * 3 * U * V), *uv = malloc(sizeof(float) * 6 * 2 * U * V);
    int32_t *tri = malloc(sizeof(int32_t) * 3 * 2 * U * V);
    if (!pos || !uv || !tri) return 1;
    torus(pos, tri, uv);
    const struct {
        const char *name;
        float lo[3], hi[3];
    } scenes[2] = {{"open 10x10x4 m", {-5, -5, 0}, {5, 5, 4}},
                   {"tight 3x3x1 m", {-1.5f, -1.5f, 0.5f}, {1.5f, 1.5f, 1.5f}}};
    printf("Snow attachment: %d flakes, %d substeps of 0.04 s, torus of %d triangles, %d cores "
           "available\n\n", flakes, substeps, 2 * U * V, omp_get_num_procs());
    printf("| scene | threads | substeps / call | BVH build (ms) | contacts / flake-step | "
           "time (s) | flake-steps / s | per thread |\n");
    printf("|---|---:|---:|---:|---:|---:|---:|---:|\n");
    for (int s = 0; s < 2; ++s)
        for (int run = 0; run < 4; ++run) {
            const int threads = 1 + run % 2, per_call = run < 2 ? substeps : 1;
            hbk_snow_params_t p;
            hbk_snow_params_default(&p);
            p.flake_count = flakes;
            p.threads = threads;
            for (int k = 0; k < 3; ++k) {
                p.volume_min[k] = scenes[s].lo[k];
                p.volume_max[k] = scenes[s].hi[k];
            }
            hbk_snow_t *h;
            hbk_message_t msg;
            if (hbk_snow_create(&h, &p, &msg)) {
                fprintf(stderr, "create: %s\n", msg.text);
                return 1;
            }
            double t0 = omp_get_wtime();
            if (hbk_snow_set_mesh(h, pos, U * V, tri, uv, NULL, 2 * U * V)) {
                fprintf(stderr, "set_mesh: %s\n", hbk_snow_message(h));
                return 1;
            }
            const double build = omp_get_wtime() - t0;
            hbk_snow_step(h, 5, NULL); /* warm up: first placement, caches, event buffers */
            hbk_snow_stats_t a, b;
            hbk_snow_stats(h, &a);
            t0 = omp_get_wtime();
            for (int32_t done = 0; done < substeps; done += per_call)
                if (hbk_snow_step(h, per_call, NULL)) {
                    fprintf(stderr, "step: %s\n", hbk_snow_message(h));
                    return 1;
                }
            const double dt = omp_get_wtime() - t0;
            hbk_snow_stats(h, &b);
            const double fs = (double)(b.flake_steps - a.flake_steps);
            printf("| %s | %d | %d | %.0f | %.4f | %.3f | %.1f M | %.1f M |\n", scenes[s].name,
                   threads, per_call, build * 1e3, (double)(b.hits - a.hits) / fs, dt,
                   fs / dt * 1e-6, fs / dt * 1e-6 / threads);
            hbk_snow_destroy(h);
        }
    free(pos);
    free(uv);
    free(tri);
    return 0;
}
