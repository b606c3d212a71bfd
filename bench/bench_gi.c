/* bench_gi — exploratory: one scene file, one camera, one bake setting;
 * the lookup frame against a cached converged reference at pixel centres,
 * with figures on the object (pixels whose primary ray hits model 0).
 *
 * Prints: CPU seconds of the world build, the bake and the frame; energy
 * ratio and relMSE over all covered pixels and over the object; p99; the
 * share of object pixels within 3 standard errors of the reference; min and
 * max of the frame's luminance on the object (furnace scenes).
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bake/bake.h"
#include "core/cli.h"
#include "io/image.h"
#include "io/scene_file.h"
#include "metrics/image_metrics.h"
#include "ref/pathtrace.h"
#include "render/camera.h"
#include "render/world.h"
#include "verify/refcache.h"
#include "envmap/irradiance_table.h"

static double cpu_seconds(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double lum(const float *p) { return 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]; }

static int die(const sg_error *e)
{
    fprintf(stderr, "bench_gi: %s\n", e->message);
    return 1;
}

int main(int argc, char **argv)
{
    const char *scene = NULL, *camname = NULL, *cache = "out/exp/cache", *out = NULL;
    int size = 128, spp = 1024, threads = 0;
    uint64_t seed2 = 0;
    sg_bake_desc bd = {0};
    for (int i = 1; i < argc; ++i) {
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : "";
        if (!strcmp(a, "--camera")) camname = v, ++i;
        else if (!strcmp(a, "--size")) size = atoi(v), ++i;
        else if (!strcmp(a, "--ref-spp")) spp = atoi(v), ++i;
        else if (!strcmp(a, "--cache")) cache = v, ++i;
        else if (!strcmp(a, "--out")) out = v, ++i;
        else if (!strcmp(a, "--threads")) threads = atoi(v), ++i;
        else if (!strcmp(a, "--photons")) bd.photons.count = (size_t)atof(v), ++i;
        else if (!strcmp(a, "--k")) bd.gather.k = (unsigned)atoi(v), ++i;
        else if (!strcmp(a, "--direct")) bd.direct_samples = atoi(v), ++i;
        else if (!strcmp(a, "--spacing")) bd.sample_spacing = (float)atof(v), ++i;
        else if (!strcmp(a, "--seed")) bd.photons.seed = (uint64_t)atoll(v), ++i;
        else if (!strcmp(a, "--seed2")) seed2 = (uint64_t)atoll(v), ++i;
        else if (!strcmp(a, "--gather-rays")) bd.gather_rays = atoi(v), ++i;
        else if (!strcmp(a, "--refine")) bd.refine_levels = atoi(v), ++i;
        else if (!strcmp(a, "--indirect")) bd.indirect = !strcmp(v, "photons") ? SG_BAKE_INDIRECT_PHOTONS : SG_BAKE_INDIRECT_TRANSPORT, ++i;
        else if (a[0] != '-') scene = a;
        else {
            fprintf(stderr, "bench_gi: unknown option %s\n", a);
            return 2;
        }
    }
    if (!scene) {
        fprintf(stderr, "usage: bench_gi SCENE.json [--camera N] [--size N] [--ref-spp N] [bake options]\n");
        return 2;
    }
    if (threads > 0)
        omp_set_num_threads(threads);
    sg_error err = {0};
    sg_scene_file sf = {0};
    if (sg_scene_file_load(scene, &sf, &err) != SG_OK)
        return die(&err);
    const sg_scene_camera *sc = camname ? sg_scene_file_find_camera(&sf, camname) : sf.cameras;
    if (!sc) {
        fprintf(stderr, "bench_gi: no camera\n");
        return 2;
    }
    sg_camera cam;
    if (sg_camera_look_at(sc->eye, sc->look, sc->up, sc->fov_deg, 1.0f, &cam, &err) != SG_OK)
        return die(&err);
    double c0 = cpu_seconds(), w0 = omp_get_wtime();
    sg_world *w = NULL;
    if (sg_world_create(&sf, &w, &err) != SG_OK)
        return die(&err);
    double world_cpu = cpu_seconds() - c0, world_wall = omp_get_wtime() - w0;

    sg_verify_ref_desc rd = {.camera = cam, .width = size, .height = size, .spp = spp,
                             .max_depth = sf.render.max_depth, .seed = 1, .cache_dir = cache,
                             .scene_key = sg_verify_scene_key(&sf)};
    sg_ref_result ref = {0};
    int cached = 0;
    if (sg_verify_reference(w, &rd, &ref, &cached, NULL, 0, &err) != SG_OK)
        return die(&err);

    c0 = cpu_seconds();
    w0 = omp_get_wtime();
    sg_bake *b = NULL;
    if (sg_bake_create(w, &bd, &b, &err) != SG_OK)
        return die(&err);
    double bake_cpu = cpu_seconds() - c0, bake_wall = omp_get_wtime() - w0;
    sg_bake_stats bs;
    sg_bake_get_stats(b, &bs);
    sg_image frame = {0};
    sg_bake_frame_desc fd = {.camera = cam, .width = size, .height = size};
    c0 = cpu_seconds();
    if (sg_bake_render(b, w, &fd, &frame, NULL, &err) != SG_OK)
        return die(&err);
    double frame_cpu = cpu_seconds() - c0;

    sg_image_metrics m;
    sg_image diff = {0};
    if (sg_image_compare(&frame, &ref.mean, &m, &diff, &err) != SG_OK)
        return die(&err);
    double noise = 0;
    sg_image_noise_rel_mse(&ref.mean, &ref.std_error, 0.0, &noise, &err);
    /* Object figures: pixels whose centre ray hits model 0. */
    double sa = 0, sb = 0, rel = 0, lo = INFINITY, hi = -INFINITY;
    size_t nobj = 0, in3 = 0, nback = 0;
    double fa = 0, fb = 0; /* front-facing object pixels only */
    int lox = -1, loy = -1;
    double eps = 1e-2 * (m.mean_b[0] + m.mean_b[1] + m.mean_b[2]) / 3.0;
    eps *= eps;
    for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
            sg_ray r = sg_camera_ray(&cam, (float)x + 0.5f, (float)y + 0.5f, size, size);
            sg_world_hit h;
            if (!sg_world_intersect(w, &r, &h, NULL) || h.model != 0)
                continue;
            size_t i = 3 * ((size_t)y * (size_t)size + (size_t)x);
            const float *a = frame.data + i, *bb = ref.mean.data + i, *se = ref.std_error.data + i;
            double la = lum(a), lb = lum(bb), ls = lum(se);
            sa += la;
            sb += lb;
            if (sg_v3_dot(r.dir, h.hit.n) < 0.0f) {
                fa += la;
                fb += lb;
            }
            for (int c = 0; c < 3; ++c)
                rel += (a[c] - bb[c]) * (a[c] - bb[c]) / (bb[c] * bb[c] + eps) / 3.0;
            in3 += fabs(la - lb) <= 3.0 * ls;
            if (la < lo)
                lox = x, loy = y;
            lo = la < lo ? la : lo;
            nback += sg_v3_dot(r.dir, h.hit.n) > 0.0f;
            if (getenv("BENCH_GI_EXTREME") && fabs(la / (getenv("BENCH_GI_TRUTH") ? atof(getenv("BENCH_GI_TRUTH")) : lb) - 1.0) > atof(getenv("BENCH_GI_EXTREME")))
                printf("  pixel (%d, %d): bake %.4f ref %.4f +- %.4f %s splat %u\n", x, y, la, lb, ls,
                       sg_v3_dot(r.dir, h.hit.n) > 0.0f ? "BACK" : "front", h.hit.splat);
            hi = la > hi ? la : hi;
            ++nobj;
        }
    printf("%s cam=%s size=%d ref_spp=%d%s %s photons=%zu k=%u direct=%d gather=%d spacing=%g refine=%d\n", scene,
           sc->name, size, spp, cached ? " (cached)" : "", bd.indirect ? "PHOTONS" : "transport", bd.photons.count,
           bd.gather.k, bd.direct_samples, bd.gather_rays, (double)bd.sample_spacing, bd.refine_levels);
    printf("  world cpu %.2f s (wall %.2f)  bake cpu %.2f s (wall %.2f, trace %.2f gather %.2f direct %.2f)  "
           "frame cpu %.3f s  samples %zu hits %zu iters %d\n",
           world_cpu, world_wall, bake_cpu, bake_wall, bs.trace_seconds, bs.gather_seconds, bs.direct_seconds,
           frame_cpu, bs.sample_points, bs.site_hits, bs.transport_iterations);
    printf("  all: relMSE %.5f energy %.4f p99 %.4f | object (%zu px): relMSE %.5f energy %.4f within3sd %.3f "
           "lum [%.4f, %.4f] ref-lum %.5f\n",
           m.rel_mse, m.energy_ratio_lum, m.p99_rel_error, nobj, nobj ? rel / (double)nobj : 0.0,
           sb > 0 ? sa / sb : 0.0, nobj ? (double)in3 / (double)nobj : 0.0, lo, hi, nobj ? sb / (double)nobj : 0.0);
    {
        size_t ns;
        sg_bake_light_data(b, 0, &ns);
        double ef = 0, eb = 0;
        size_t lit_back = 0;
        for (size_t i = 0; i < ns; ++i) {
            sg_vec3 f = sg_bake_splat_irradiance(b, w, 0, i, 0), k = sg_bake_splat_irradiance(b, w, 0, i, 1);
            float fv[3] = {f.x, f.y, f.z}, kv[3] = {k.x, k.y, k.z};
            ef += lum(fv);
            eb += lum(kv);
            lit_back += lum(kv) > 0.1 * lum(fv);
        }
        printf("  model 0: mean E front %.4f back %.4f; splats with back > 10%% of front: %zu of %zu\n", ef / (double)ns,
               eb / (double)ns, lit_back, ns);
    }
    if (getenv("BENCH_GI_MAP")) {
        /* block-average relative error on the object, 16 x 16 blocks */
        int B = size / 16;
        for (int by = 0; by < 16; ++by) {
            printf("   ");
            for (int bx = 0; bx < 16; ++bx) {
                double a = 0, r = 0;
                for (int y = by * B; y < (by + 1) * B; ++y)
                    for (int x = bx * B; x < (bx + 1) * B; ++x) {
                        sg_ray ray = sg_camera_ray(&cam, (float)x + 0.5f, (float)y + 0.5f, size, size);
                        sg_world_hit h;
                        if (!sg_world_intersect(w, &ray, &h, NULL) || h.model != 0)
                            continue;
                        size_t i = 3 * ((size_t)y * (size_t)size + (size_t)x);
                        a += lum(frame.data + i);
                        r += lum(ref.mean.data + i);
                    }
                if (r > 0)
                    printf(" %+5.1f", 100.0 * (a / r - 1.0));
                else
                    printf("     .");
            }
            printf("\n");
        }
    }
    if (getenv("BENCH_GI_NORMALS")) {
        sg_irradiance_table *tab = NULL;
        sg_irradiance_table_create(sg_world_envmap(w), NULL, &tab, &err);
        double sum_avg = 0, sum_hit = 0, len = 0;
        size_t cnt = 0;
        const sg_pointset *ps = sg_scene_points(sg_world_scene(w, 0));
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                sg_ray ray = sg_camera_ray(&cam, (float)x + 0.5f, (float)y + 0.5f, size, size);
                sg_world_hit h;
                if (!sg_world_intersect(w, &ray, &h, NULL) || h.model != 0)
                    continue;
                uint32_t ids[32];
                float wts[32];
                int n = sg_scene_hit_weights(sg_world_scene(w, 0), &h.hit, ids, wts, 32);
                sg_vec3 avg = {0, 0, 0}, nsum = {0, 0, 0};
                for (int j = 0; j < n; ++j) {
                    sg_vec3 nj = sg_pointset_normal(ps, ids[j]);
                    avg = sg_v3_add(avg, sg_v3_scale(sg_irradiance_table_eval(tab, nj), wts[j]));
                    nsum = sg_v3_add(nsum, sg_v3_scale(nj, wts[j]));
                }
                sum_avg += 0.2126 * avg.x + 0.7152 * avg.y + 0.0722 * avg.z;
                sg_vec3 eh = sg_irradiance_table_eval(tab, h.hit.n);
                sum_hit += 0.2126 * eh.x + 0.7152 * eh.y + 0.0722 * eh.z;
                len += sqrt(sg_v3_dot(nsum, nsum));
                ++cnt;
            }
        printf("  normals: mean |sum w n| %.4f; sum w E0(n_i) / E0(n_hit) = %.4f\n", len / (double)cnt,
               sum_avg / sum_hit);
        sg_irradiance_table_destroy(tab);
    }
    if (seed2) {
        /* the noise: a second bake with another seed, frame against frame */
        sg_bake_desc b2 = bd;
        b2.photons.seed = seed2;
        sg_bake *bk2 = NULL;
        sg_image f2 = {0};
        if (sg_bake_create(w, &b2, &bk2, &err) != SG_OK || sg_bake_render(bk2, w, &fd, &f2, NULL, &err) != SG_OK)
            return die(&err);
        double n2 = 0, e2 = 0;
        size_t cnt = 0;
        for (int y = 0; y < size; ++y)
            for (int x = 0; x < size; ++x) {
                sg_ray ray = sg_camera_ray(&cam, (float)x + 0.5f, (float)y + 0.5f, size, size);
                sg_world_hit h;
                if (!sg_world_intersect(w, &ray, &h, NULL) || h.model != 0)
                    continue;
                size_t i = 3 * ((size_t)y * (size_t)size + (size_t)x);
                for (int c = 0; c < 3; ++c) {
                    double a = frame.data[i + c], b = f2.data[i + c], r = ref.mean.data[i + c];
                    n2 += (a - b) * (a - b) / (r * r + eps) / 3.0;
                    e2 += 0.5 * (a + b);
                }
                ++cnt;
            }
        printf("  seed %llu vs %llu on the object: relMSE %.5f, so the bake's own noise is about %.5f\n",
               (unsigned long long)bd.photons.seed, (unsigned long long)seed2, n2 / (double)cnt, 0.5 * n2 / (double)cnt);
        sg_image_free(&f2);
        sg_bake_destroy(bk2);
    }
    printf("  front-facing object pixels: energy %.4f\n", fb > 0 ? fa / fb : 0.0);
    printf("  back-facing object pixels %zu; darkest at (%d, %d); reference noise relMSE %.5f\n", nback, lox, loy,
           noise);
    if (out) {
        char p[1024];
        snprintf(p, sizeof p, "%s_bake.exr", out);
        sg_image_write_exr(&frame, p, &err);
        snprintf(p, sizeof p, "%s_ref.exr", out);
        sg_image_write_exr(&ref.mean, p, &err);
        snprintf(p, sizeof p, "%s_bake.png", out);
        sg_image_write_png(&frame, p, 1.0f, &err);
        snprintf(p, sizeof p, "%s_ref.png", out);
        sg_image_write_png(&ref.mean, p, 1.0f, &err);
        sg_image fc = {0};
        if (sg_image_false_colour(&diff, 0.1 * (m.mean_b[0] + m.mean_b[1] + m.mean_b[2]) / 3.0, &fc, &err) == SG_OK) {
            snprintf(p, sizeof p, "%s_diff.png", out);
            sg_image_write_png(&fc, p, 1.0f, &err);
            sg_image_free(&fc);
        }
    }
    sg_image_free(&frame);
    sg_image_free(&diff);
    sg_ref_result_free(&ref);
    sg_bake_destroy(b);
    sg_world_destroy(w);
    sg_scene_file_free(&sf);
    return 0;
}
