/* ocio.cpp — sg_display through OpenColorIO 2.x's C++ library: a
 * DisplayViewTransform from the scene_linear role, applied by OCIO's CPU
 * processor to blocks of rows on a few std::threads.
 *
 * Invariants:
 *  1. No exception crosses the extern "C" boundary: every entry point runs
 *     its body inside one try whose handlers map OCIO::ExceptionMissingFile
 *     -> SG_ERR_IO, std::bad_alloc -> SG_ERR_NOMEM and every other
 *     exception -> SG_ERR_CORRUPT, always with the config path. Worker
 *     threads catch everything themselves (an exception leaving a
 *     std::thread would terminate the process) and report through `job`.
 *  2. The handle is immutable after create except `scale`/`exposure_stops`
 *     (sg_display_set_exposure, documented not thread-safe); apply only
 *     reads it, and OCIO's CPUProcessor::apply is const and thread-safe
 *     for processors without dynamic properties, which ours never enable.
 *  3. Whatever enters OCIO is finite and in [0, SG_DISPLAY_MAX_INPUT], and
 *     whatever leaves it is clipped to [0, 1] with NaN -> 0 (header:
 *     "no input gives garbage, whatever the config does").
 *  4. The names handed out by sg_display_list/get_info point into
 *     std::strings the handle owns and never modifies after create.
 *  5. 8-bit output with gamma 1 (the viewer's frame) goes through `cpu8`,
 *     OCIO's processor optimised for half-float input and 8-bit output:
 *     OPTIMIZATION_COMP_SEPARABLE_PREFIX (in OCIO's default level) folds a
 *     view without channel crosstalk (the default config's sRGB encoding,
 *     its Filmic-like shaper and LUT) into one table over the 65536 half
 *     codes, where float input evaluates the transform per value (512x512:
 *     7.7 -> 3.0 ms on one thread, docs/bench_view.md stop 25). The input
 *     is rounded to half (relative 2^-11) after the clamp of invariant 3,
 *     here to MAX_HALF_INPUT, past which every view of the default config is
 *     saturated; OCIO's conversion to 8 bits clamps to [0, 255] and
 *     rounds. Bytes differ from the float path by at most 1 (1% of them on
 *     the dragon's frames). Float output, and gamma != 1, keep the float
 *     path.
 */
#include "display/ocio.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <sys/stat.h>
#include <system_error>
#include <thread>
#include <vector>

#include <Imath/half.h>
#include <OpenColorIO/OpenColorIO.h>
#if defined(__F16C__) && defined(__AVX__)
#include <immintrin.h>
#endif

namespace OCIO = OCIO_NAMESPACE;

#ifndef SG_OCIO_DEFAULT_CONFIG
#error "SG_OCIO_DEFAULT_CONFIG (path of display/config.ocio) must be defined by the build"
#endif

struct sg_display {
    std::string config_path;                   /* file loaded                 */
    std::string config_from;                   /* "desc", "$OCIO", "default"  */
    std::string display;                       /* display in use              */
    std::string view;                          /* view in use                 */
    std::vector<std::string> displays;         /* active displays, in order   */
    std::vector<const char *> display_ptrs;    /* c_str() of displays         */
    std::vector<std::vector<std::string>> views;     /* views per display     */
    std::vector<std::vector<const char *>> view_ptrs; /* c_str() of views    */
    OCIO::ConstCPUProcessorRcPtr cpu;          /* scene_linear -> display     */
    OCIO::ConstCPUProcessorRcPtr cpu8;         /* the same, half in, 8 bits out
                                                  (invariant 5)               */
    float exposure_stops = 0.0f;               /* current exposure            */
    float scale = 1.0f;                        /* 2^exposure_stops            */
    float gamma = 1.0f;                        /* display gamma               */
    float inv_gamma = 1.0f;                    /* 1 / gamma                   */
    int threads = 1;                           /* workers for apply, >= 1     */
};

namespace {

/* Pixels per block handed to one OCIO apply: 4096 RGB floats (48 KiB) stay
 * in L2 while the pre-pass, OCIO and the post-pass walk them. */
constexpr int64_t BLOCK_PIXELS = 4096;

/* The largest finite half: the 8-bit path's input ceiling (invariant 5). */
constexpr float MAX_HALF_INPUT = 65504.0f;

/* n values of s, scaled and clamped as invariant 3 asks (to MAX_HALF_INPUT),
 * to half floats in h (round to nearest even). */
void to_half(const float *s, float scale, int64_t n, uint16_t *h)
{
    int64_t i = 0;
#if defined(__F16C__) && defined(__AVX__)
    const __m256 k = _mm256_set1_ps(scale), zero = _mm256_setzero_ps(), top = _mm256_set1_ps(MAX_HALF_INPUT);
    for (; i + 8 <= n; i += 8) {
        __m256 v = _mm256_mul_ps(_mm256_loadu_ps(s + i), k);
        /* max(v, 0) with v first: a NaN gives the second operand, 0 */
        v = _mm256_min_ps(_mm256_max_ps(v, zero), top);
        _mm_storeu_si128(reinterpret_cast<__m128i *>(h + i), _mm256_cvtps_ph(v, _MM_FROUND_TO_NEAREST_INT));
    }
#endif
    for (; i < n; i++) {
        float v = s[i] * scale;
        v = !(v >= 0.0f) ? 0.0f : std::min(v, MAX_HALF_INPUT);
        h[i] = Imath::half(v).bits();
    }
}

std::string join(const std::vector<std::string> &names)
{
    std::string s;
    for (size_t i = 0; i < names.size(); i++)
        s += (i ? ", " : "") + names[i];
    return names.empty() ? std::string("none") : s;
}

int find(const std::vector<std::string> &names, const std::string &name)
{
    for (size_t i = 0; i < names.size(); i++)
        if (names[i] == name)
            return static_cast<int>(i);
    return -1;
}

/* Where the config came from, for messages: "path" or "path (from $OCIO)". */
std::string where(const sg_display &d)
{
    return d.config_from == "$OCIO" ? d.config_path + " (from $OCIO)" : d.config_path;
}

sg_status check_gamma_exposure(float stops, float gamma, sg_error *err)
{
    if (!std::isfinite(stops))
        return sg_error_set(err, SG_ERR_INVALID_ARG, "display: exposure %g stops is not finite",
                            static_cast<double>(stops));
    if (!std::isfinite(gamma) || gamma < 0.0f)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "display: gamma %g must be finite and > 0 (0 means 1)",
                            static_cast<double>(gamma));
    return SG_OK;
}

sg_status create(const sg_display_desc *desc, sg_display **out, sg_error *err)
{
    const sg_display_desc zero = {};
    const sg_display_desc &dd = desc ? *desc : zero;
    sg_status st = check_gamma_exposure(dd.exposure_stops, dd.gamma, err);
    if (st != SG_OK)
        return st;
    if (dd.threads < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "display: threads %d is negative", dd.threads);

    std::unique_ptr<sg_display> d(new sg_display);
    const char *env = std::getenv("OCIO");
    if (dd.config_path && dd.config_path[0]) {
        d->config_path = dd.config_path;
        d->config_from = "desc";
    } else if (env && env[0]) {
        d->config_path = env;
        d->config_from = "$OCIO";
    } else {
        d->config_path = SG_OCIO_DEFAULT_CONFIG;
        d->config_from = "default";
    }
    const std::string at = where(*d);

    /* OCIO reports an unreadable file only as a parse failure; stat first
     * gives the OS's reason and tells a missing file from a bad one. */
    struct stat sb;
    if (stat(d->config_path.c_str(), &sb) != 0)
        return sg_error_set(err, SG_ERR_IO, "%s: cannot open OCIO config: %s", at.c_str(),
                            std::strerror(errno));
    if (!S_ISREG(sb.st_mode))
        return sg_error_set(err, SG_ERR_IO, "%s: OCIO config is not a regular file", at.c_str());

    OCIO::ConstConfigRcPtr config = OCIO::Config::CreateFromFile(d->config_path.c_str());
    config->validate();
    if (!config->getColorSpace(OCIO::ROLE_SCENE_LINEAR))
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: OCIO config has no scene_linear role",
                            at.c_str());

    for (int i = 0; i < config->getNumDisplays(); i++) {
        const char *name = config->getDisplay(i);
        d->displays.emplace_back(name);
        std::vector<std::string> v;
        for (int j = 0; j < config->getNumViews(name); j++)
            v.emplace_back(config->getView(name, j));
        d->views.push_back(std::move(v));
    }
    if (d->displays.empty())
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: OCIO config has no active display",
                            at.c_str());
    for (size_t i = 0; i < d->displays.size(); i++) {
        d->display_ptrs.push_back(d->displays[i].c_str());
        std::vector<const char *> p;
        for (const std::string &v : d->views[i])
            p.push_back(v.c_str());
        d->view_ptrs.push_back(std::move(p));
    }

    d->display = dd.display && dd.display[0] ? dd.display : config->getDefaultDisplay();
    const int di = find(d->displays, d->display);
    if (di < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: no display \"%s\" (displays: %s)",
                            at.c_str(), d->display.c_str(), join(d->displays).c_str());
    d->view = dd.view && dd.view[0] ? dd.view : config->getDefaultView(d->display.c_str());
    if (find(d->views[di], d->view) < 0)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "%s: display \"%s\" has no view \"%s\" (views: %s)", at.c_str(),
                            d->display.c_str(), d->view.c_str(), join(d->views[di]).c_str());

    OCIO::DisplayViewTransformRcPtr dvt = OCIO::DisplayViewTransform::Create();
    dvt->setSrc(OCIO::ROLE_SCENE_LINEAR);
    dvt->setDisplay(d->display.c_str());
    dvt->setView(d->view.c_str());
    OCIO::ConstProcessorRcPtr proc = config->getProcessor(dvt);
    d->cpu = proc->getDefaultCPUProcessor();
    d->cpu8 = proc->getOptimizedCPUProcessor(OCIO::BIT_DEPTH_F16, OCIO::BIT_DEPTH_UINT8,
                                             OCIO::OPTIMIZATION_DEFAULT);

    d->exposure_stops = dd.exposure_stops;
    d->scale = std::exp2(dd.exposure_stops);
    d->gamma = dd.gamma > 0.0f ? dd.gamma : 1.0f;
    d->inv_gamma = 1.0f / d->gamma;
    const unsigned hw = std::thread::hardware_concurrency();
    d->threads = dd.threads > 0 ? dd.threads : std::max(1u, hw);
    *out = d.release();
    return SG_OK;
}

/* One apply call shared by its workers. */
struct job {
    const sg_display *d;            /* the handle                            */
    const float *src;               /* input RGB, row 0 top                  */
    uint8_t *rgba8;                 /* 8-bit output, or NULL                 */
    float *rgbf;                    /* float output, or NULL                 */
    int64_t width, height;          /* image size                            */
    int64_t block_rows;             /* rows per block (>= 1)                 */
    int64_t n_blocks;               /* blocks in the image                   */
    float *scratch;                 /* threads * block_rows * width * 3      */
    uint16_t *hscratch;             /* the same in half floats (invariant 5) */
    std::atomic<int64_t> next{0};   /* next block to take                    */
    std::atomic<bool> failed{false};/* a worker hit an exception             */
    std::mutex mutex;               /* guards message                        */
    std::string message;            /* first worker failure                  */
};

/* Pre-pass, OCIO, post-pass for blocks until none is left (invariant 3). */
void work(job *j, int slot) noexcept
{
    try {
        const sg_display &d = *j->d;
        float *buf = j->scratch + static_cast<size_t>(slot) * j->block_rows * j->width * 3;
        for (;;) {
            const int64_t b = j->next.fetch_add(1);
            if (b >= j->n_blocks || j->failed.load())
                return;
            const int64_t y0 = b * j->block_rows;
            const int64_t rows = std::min(j->block_rows, j->height - y0);
            const int64_t n = rows * j->width * 3, base = y0 * j->width * 3;
            const float *s = j->src + base;
            if (j->hscratch) { /* invariant 5 */
                uint16_t *hb = j->hscratch + static_cast<size_t>(slot) * j->block_rows * j->width * 3;
                uint8_t *o = j->rgba8 + y0 * j->width * 4;
                to_half(s, d.scale, n, hb);
                for (int64_t p = 0; p < rows * j->width; p++)
                    o[4 * p + 3] = 255;
                OCIO::PackedImageDesc in(hb, static_cast<long>(j->width), static_cast<long>(rows),
                                         OCIO::CHANNEL_ORDERING_RGB, OCIO::BIT_DEPTH_F16, 2, 6,
                                         6 * static_cast<ptrdiff_t>(j->width));
                OCIO::PackedImageDesc out(o, static_cast<long>(j->width), static_cast<long>(rows),
                                          OCIO::CHANNEL_ORDERING_RGB, OCIO::BIT_DEPTH_UINT8, 1, 4,
                                          4 * static_cast<ptrdiff_t>(j->width));
                d.cpu8->apply(in, out);
                continue;
            }
            for (int64_t i = 0; i < n; i++) {
                float v = s[i] * d.scale;
                /* NaN and negatives fail v >= 0; +Inf exceeds the maximum. */
                buf[i] = !(v >= 0.0f) ? 0.0f : std::min(v, SG_DISPLAY_MAX_INPUT);
            }
            OCIO::PackedImageDesc img(buf, static_cast<long>(j->width), static_cast<long>(rows), 3);
            d.cpu->apply(img);
            for (int64_t i = 0; i < n; i++) {
                float v = buf[i];
                v = !(v > 0.0f) ? 0.0f : std::min(v, 1.0f);
                if (d.inv_gamma != 1.0f)
                    v = std::pow(v, d.inv_gamma);
                buf[i] = v;
            }
            if (j->rgbf) {
                std::memcpy(j->rgbf + base, buf, static_cast<size_t>(n) * sizeof(float));
            } else {
                uint8_t *o = j->rgba8 + y0 * j->width * 4;
                for (int64_t p = 0; p < rows * j->width; p++) {
                    for (int c = 0; c < 3; c++)
                        o[4 * p + c] = static_cast<uint8_t>(buf[3 * p + c] * 255.0f + 0.5f);
                    o[4 * p + 3] = 255;
                }
            }
        }
    } catch (const std::exception &e) {
        std::lock_guard<std::mutex> lock(j->mutex);
        if (!j->failed.exchange(true))
            j->message = e.what();
    } catch (...) {
        std::lock_guard<std::mutex> lock(j->mutex);
        if (!j->failed.exchange(true))
            j->message = "unknown exception";
    }
}

sg_status apply(const sg_display *d, const sg_image *img, uint8_t *rgba8, float *rgbf,
                sg_error *err)
{
    job j;
    j.d = d;
    j.src = img->data;
    j.rgba8 = rgba8;
    j.rgbf = rgbf;
    j.width = img->width;
    j.height = img->height;
    j.block_rows = std::max<int64_t>(1, BLOCK_PIXELS / j.width);
    j.n_blocks = (j.height + j.block_rows - 1) / j.block_rows;
    const int threads = static_cast<int>(std::min<int64_t>(d->threads, j.n_blocks));
    const size_t scratch_values = static_cast<size_t>(threads) * j.block_rows * j.width * 3;
    const bool half8 = rgba8 && d->inv_gamma == 1.0f; /* invariant 5 */
    std::vector<float> scratch(half8 ? 0 : scratch_values);
    std::vector<uint16_t> hscratch(half8 ? scratch_values : 0);
    j.scratch = scratch.data();
    j.hscratch = half8 ? hscratch.data() : nullptr;

    /* Workers 1..threads-1 on new threads, worker 0 here. A thread that
     * cannot be started is simply missing: the others take its blocks. */
    std::vector<std::thread> pool;
    pool.reserve(static_cast<size_t>(threads));
    for (int t = 1; t < threads; t++) {
        try {
            pool.emplace_back(work, &j, t);
        } catch (const std::system_error &) {
            break;
        }
    }
    work(&j, 0);
    for (std::thread &t : pool)
        t.join();
    if (j.failed.load())
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: OCIO failed to apply \"%s\" / \"%s\": %s",
                            where(*d).c_str(), d->display.c_str(), d->view.c_str(),
                            j.message.c_str());
    return SG_OK;
}

sg_status check_image(const sg_display *d, const sg_image *img, const void *dst, const char *fn,
                      sg_error *err)
{
    if (!d || !img || !dst)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: NULL %s", fn,
                            !d ? "display" : !img ? "image" : "output");
    if (!img->data || img->width <= 0 || img->height <= 0 || img->width > SG_IMAGE_MAX_DIM ||
        img->height > SG_IMAGE_MAX_DIM)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: image %dx%d (data %s) is not a valid image",
                            fn, img->width, img->height, img->data ? "set" : "NULL");
    return SG_OK;
}

/* Maps an exception caught at the boundary to a status (invariant 1). */
template <typename F> sg_status guarded(const std::string &at, sg_error *err, F body)
{
    try {
        return body();
    } catch (const OCIO::ExceptionMissingFile &e) {
        return sg_error_set(err, SG_ERR_IO, "%s: %s", at.c_str(), e.what());
    } catch (const std::bad_alloc &) {
        return sg_error_set(err, SG_ERR_NOMEM, "%s: out of memory", at.c_str());
    } catch (const std::exception &e) {
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: %s", at.c_str(), e.what());
    } catch (...) {
        return sg_error_set(err, SG_ERR_CORRUPT, "%s: unknown error in OpenColorIO", at.c_str());
    }
}

} // namespace

extern "C" sg_status sg_display_create(const sg_display_desc *desc, sg_display **out, sg_error *err)
{
    if (!out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_display_create: out is NULL");
    /* The path is only known inside create; name the likely one here. */
    const char *env = std::getenv("OCIO");
    std::string at = desc && desc->config_path && desc->config_path[0] ? desc->config_path
                     : env && env[0] ? std::string(env) + " (from $OCIO)"
                                     : std::string(SG_OCIO_DEFAULT_CONFIG);
    return guarded(at, err, [&] { return create(desc, out, err); });
}

extern "C" void sg_display_destroy(sg_display *d)
{
    delete d;
}

extern "C" sg_status sg_display_apply(const sg_display *d, const sg_image *linear,
                                      uint8_t *rgba8_out, sg_error *err)
{
    sg_status st = check_image(d, linear, rgba8_out, "sg_display_apply", err);
    if (st != SG_OK)
        return st;
    return guarded(d->config_path, err, [&] { return apply(d, linear, rgba8_out, nullptr, err); });
}

extern "C" sg_status sg_display_apply_float(const sg_display *d, const sg_image *linear,
                                            float *rgb_out, sg_error *err)
{
    sg_status st = check_image(d, linear, rgb_out, "sg_display_apply_float", err);
    if (st != SG_OK)
        return st;
    /* In place is fine: each block is read whole into scratch before its
     * output is written. A partial overlap is not. */
    const size_t n = static_cast<size_t>(linear->width) * static_cast<size_t>(linear->height) * 3;
    const uintptr_t a = reinterpret_cast<uintptr_t>(linear->data);
    const uintptr_t b = reinterpret_cast<uintptr_t>(rgb_out);
    const uintptr_t bytes = n * sizeof(float);
    if (a != b && a < b + bytes && b < a + bytes)
        return sg_error_set(err, SG_ERR_INVALID_ARG,
                            "sg_display_apply_float: output overlaps the input without being it");
    return guarded(d->config_path, err, [&] { return apply(d, linear, nullptr, rgb_out, err); });
}

extern "C" sg_status sg_display_list(const sg_display *d, const char *display,
                                     sg_display_names *out, sg_error *err)
{
    if (!d || !out)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_display_list: NULL %s",
                            !d ? "display" : "out");
    if (!display) {
        out->count = static_cast<int>(d->displays.size());
        out->names = d->display_ptrs.data();
        return SG_OK;
    }
    return guarded(d->config_path, err, [&] {
        const int di = find(d->displays, display);
        if (di < 0)
            return sg_error_set(err, SG_ERR_INVALID_ARG, "%s: no display \"%s\" (displays: %s)",
                                where(*d).c_str(), display, join(d->displays).c_str());
        out->count = static_cast<int>(d->views[di].size());
        out->names = d->view_ptrs[di].data();
        return SG_OK;
    });
}

extern "C" void sg_display_get_info(const sg_display *d, sg_display_info *out)
{
    if (!d || !out)
        return;
    out->config_path = d->config_path.c_str();
    out->config_from = d->config_from.c_str();
    out->display = d->display.c_str();
    out->view = d->view.c_str();
    out->exposure_stops = d->exposure_stops;
    out->gamma = d->gamma;
}

extern "C" sg_status sg_display_set_exposure(sg_display *d, float stops, sg_error *err)
{
    if (!d)
        return sg_error_set(err, SG_ERR_INVALID_ARG, "sg_display_set_exposure: display is NULL");
    sg_status st = check_gamma_exposure(stops, d->gamma, err);
    if (st != SG_OK)
        return st;
    d->exposure_stops = stops;
    d->scale = std::exp2(stops);
    return SG_OK;
}
