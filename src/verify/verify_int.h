/* verify_int.h — what the verifier's parts share (verify.c, stability.c,
 * sweeps.c): the resolved options, progress lines, tables written whole,
 * and one measured comparison with its difference image. Internal. */
#ifndef SG_VERIFY_VERIFY_INT_H
#define SG_VERIFY_VERIFY_INT_H

#include <stddef.h>
#include <stdio.h>

#include "bake/bake.h"
#include "core/error.h"
#include "io/image.h"
#include "metrics/image_metrics.h"
#include "surface/scene.h"
#include "verify/verify.h"

/* The surface models the verifier compares (stability map, surfaces and
 * scaling sweeps), in sg_surface_model order, by their scene-file names
 * (io/scene_file.h "surface": {"model": ...}): a model added to
 * surface/scene.h is one more name here, and every part and CSV runs it. */
#define SG_VERIFY__MODELS 3
static inline const char *sg_verify__model_name(sg_surface_model m)
{
    static const char *const names[SG_VERIFY__MODELS] = {"mls", "disk", "iso"};
    return (unsigned)m < SG_VERIFY__MODELS ? names[m] : "unknown";
}

typedef struct vctx {
    sg_verify_desc d;          /* defaults filled in                       */
    sg_verify_summary *sum;
    char best_config[128];     /* BAKE's pick for HEADLINE, "" = none yet  */
    sg_bake_desc best_desc;    /* its parameters                           */
} vctx;

void sg_verify__log(const vctx *c, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

/* A text table built in memory and written whole (temporary name, rename). */
typedef struct vtable {
    char *buf;
    size_t len, cap;
    int failed;                /* an allocation failed                     */
    int rows;
} vtable;

void sg_verify__tprintf(vtable *t, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
sg_status sg_verify__twrite(vtable *t, const char *dir, const char *name, sg_error *err);
void sg_verify__tfree(vtable *t);

int sg_verify__make_dirs(const char *path);

/* Compares a with ref; writes a false-colour difference PNG at
 * <diff_dir>/<name>.png (scale: half the reference's mean luminance) when
 * name is non-NULL. A failed PNG write is only logged. */
sg_status sg_verify__compare(const vctx *c, const sg_image *a, const sg_image *ref, const char *name,
                             sg_image_metrics *m, sg_error *err);

/* Resident set size of this process now, MiB (0 if unknown). */
double sg_verify__rss_mib(void);

sg_status sg_verify__stability(vctx *c, sg_error *err);
sg_status sg_verify__sweeps(vctx *c, sg_error *err);
sg_status sg_verify__gi(vctx *c, sg_error *err);

#endif
