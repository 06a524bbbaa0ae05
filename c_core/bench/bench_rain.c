/* Windshield rain: per frame, the simulation step and the maps (height map with its
 * compression, then normals by hbk_normal_map), for a 1 m x 1 m glass simulated and mapped at
 * 1024^2 and 2048^2 cells, carrying 5,000 and 20,000 drops, at 1 and 2 threads, in light rain
 * (300 / m^2 s). Drop masses: 98 % raindrop-sized (1.2..4.8 mg), 2 % heavy enough to run
 * (15..30 mg); the drop count printed is at the start (runners soon add trail drops). Two
 * scenes: no wipers (the drop model alone), and two pivot wipers sweeping through all that
 * water (a stress case: one sweep gathers 15..60 g into particles).
 * Steps are timed over 24 frames (1 s at 24 fps) replayed from a checkpoint, maps as the best
 * of 5; each is the minimum of 3 runs, as other work on the machine only ever adds time.
 * Bytes/s count what a pass reads and writes once (height map: 4 B per texel written;
 * normals: 4 B read + 12 B written), against memcpy of a 16 B-per-texel buffer in the same run
 * (read + write). Usage: bench_rain [frames]. Prints a markdown table. */
#include "bench_args.h"
#include "hydrobake.h"
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static double now(void) { return omp_get_wtime(); }

int main(int argc, char **argv)
{
    const char *usage = "bench_rain [frames: 1-10000, default 24]";
    bench_check_args(argc, argv, 1, usage);
    const int frames = bench_int_arg(argc, argv, 1, "frames", 24, 1, 10000, usage);
    const int sizes[2] = {1024, 2048}, counts[2] = {5000, 20000};
    printf("Windshield rain: 1 m x 1 m glass, %d frames of 1/24 s, rain 300 / m^2 s, %d cores "
           "available\n\n", frames, omp_get_num_procs());
    printf("| glass | drops | wipers | threads | step (ms) | height map (ms) | normals (ms) | "
           "frame (ms) | particles | height map GB/s | normals GB/s | memcpy GB/s |\n");
    printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (int wipers = 0; wipers <= 2; wipers += 2)
    for (int si = 0; si < 2; ++si)
        for (int ci = 0; ci < 2; ++ci)
            for (int threads = 1; threads <= 2; ++threads) {
                const int N = sizes[si];
                hbk_rain_params_t p;
                hbk_rain_params_default(&p);
                p.width = p.height = p.map_width = p.map_height = N;
                p.cell_size = 1.0f / (float)N;
                p.threads = threads;
                p.seed = 1;
                p.wiper_count = wipers;
                p.wiper_pivot[0] = 0.2f;
                p.wiper_pivot[1] = -0.03f;
                p.wiper_pivot[2] = 0.65f;
                p.wiper_pivot[3] = -0.03f;
                p.blade_length = 0.5f;
                omp_set_num_threads(threads); /* hbk_normal_map uses the default team */
                hbk_rain_t *h;
                hbk_message_t msg;
                if (hbk_rain_create(&h, &p, &msg)) {
                    fprintf(stderr, "create: %s\n", msg.text);
                    return 1;
                }
                /* Drops that land on others merge: add until the count is reached. */
                for (int i = 0; hbk_rain_drop_count(h) < counts[ci] && i < 10 * counts[ci]; ++i) {
                    uint32_t r[4];
                    hbk_rng_u32x4(99, 7, (uint64_t)i, r);
                    const float u = (float)(r[2] >> 8) / 16777216.0f;
                    hbk_rain_add_drop(h, (float)(r[0] >> 8) / 16777216.0f,
                                      (float)(r[1] >> 8) / 16777216.0f,
                                      (r[3] % 50) ? 1.2f + 3.6f * u : 15.0f + 15.0f * u);
                }
                const int64_t drops = hbk_rain_drop_count(h);
                for (int s = 0; s < 6; ++s) hbk_rain_step(h, 1.0f / 24.0f, NULL); /* warm up */
                const size_t ssize = hbk_rain_state_size(h);
                void *state = malloc(ssize);
                const size_t texels = (size_t)N * (size_t)N;
                float *height = malloc(texels * sizeof(float));
                float *normals = malloc(3 * texels * sizeof(float));
                unsigned char *a = malloc(16 * texels), *b = malloc(16 * texels);
                if (!state || !height || !normals || !a || !b) return 1;
                memset(a, 1, 16 * texels);
                memset(b, 2, 16 * texels);
                hbk_rain_save_state(h, state, ssize);
                double step = 1e30, hm = 1e30, nm = 1e30, cp = 1e30;
                int64_t most = 0; /* particles at the end of the frames */
                hbk_image_t hi = {height, N, N, 1, (size_t)N};
                hbk_image_t ni = {normals, N, N, 3, 3 * (size_t)N};
                const float texel = 1.0f / (float)N;
                for (int run = 0; run < 3; ++run) {
                    hbk_rain_load_state(h, state, ssize);
                    double t0 = now();
                    for (int s = 0; s < frames; ++s) hbk_rain_step(h, 1.0f / 24.0f, NULL);
                    const double t = (now() - t0) / frames;
                    step = t < step ? t : step;
                    hbk_rain_water_t w;
                    hbk_rain_water(h, &w);
                    most = w.particles;
                    for (int k = 0; k < 5; ++k) {
                        t0 = now();
                        hbk_rain_heightmap(h, &hi);
                        const double t1 = now();
                        hbk_normal_map(&hi, texel, texel, 1.0f, HBK_EDGE_CLAMP, 1, &ni, &msg);
                        const double t2 = now();
                        memcpy(k & 1 ? a : b, k & 1 ? b : a, 16 * texels);
                        const double t3 = now();
                        hm = t1 - t0 < hm ? t1 - t0 : hm;
                        nm = t2 - t1 < nm ? t2 - t1 : nm;
                        cp = t3 - t2 < cp ? t3 - t2 : cp;
                    }
                }
                const double gb = 1e-9;
                printf("| %d^2 | %lld | %d | %d | %.2f | %.2f | %.2f | %.2f | %lld | %.2f | %.2f | "
                       "%.2f |\n", N, (long long)drops, wipers, threads, step * 1e3, hm * 1e3,
                       nm * 1e3, (step + hm + nm) * 1e3, (long long)most,
                       4.0 * texels / hm * gb, 16.0 * texels / nm * gb, 32.0 * texels / cp * gb);
                fflush(stdout);
                hbk_rain_destroy(h);
                free(state);
                free(height);
                free(normals);
                free(a);
                free(b);
            }
    return 0;
}
