/* scene_file.h — scene descriptions in JSON: models with materials and
 * surface options, an environment map, cameras and render settings.
 *
 * What it does: reads a JSON file (cJSON) into the plain struct
 * sg_scene_file, filling every absent field with its documented default,
 * resolving model and envmap paths against the scene file's folder, and
 * rejecting anything it does not understand with a message that names the
 * file, the JSON path and what was expected:
 *     scene.json: $.models[1].material.roughness: expected a number in
 *     [0,1], got "high"
 * What it does NOT do: load models or envmaps, or check that their files
 * exist (the loaders do, and name the file). No I/O besides reading the
 * scene file itself.
 *
 * Schema (every key optional unless marked REQUIRED; unknown or repeated
 * keys are errors, so typos cannot pass silently):
 *   {
 *     "models": [ REQUIRED, at least one                  -> sg_scene_model
 *       {
 *         "path": "bunny.ply",   .ply, .obj, .xyz, .txt or .pcd (io/mesh.h);
 *                                relative paths resolve against
 *                                the scene file's folder     (exactly one of
 *         "builtin": "bunny",    "bunny" | "ground" | "sphere" path, builtin)
 *                                | "room" (points/room.h: a closed 4 x 4 x
 *                                2.5 room, walls 0.2 thick, one window in
 *                                the +X wall; sampled like a mesh)
 *         "points": 250000,      mesh samples, integer [1, 1e9]; absent = 0 =
 *                                the loader's default (250000 for meshes);
 *                                "ground": a jittered grid of round(sqrt(
 *                                points)) per side (2..20000; default 300)
 *         "radius_k": 8,         splat radius from the k-th neighbour [1, 64]
 *         "radius_scale": 1.0,   radius multiplier (0, 100]
 *         "radius_cap": 8,       estimated radii are capped at this many times
 *                                the median (stray points); 0 = no cap, else
 *                                [1, 1e6] (points/radius.h)
 *         "drop_outliers": false,  drop the points whose radius was capped
 *         "transform": {
 *           "up": "+y",          the model's up axis, turned to +Y first:
 *                                "+y" "-y" "+z" "-z" "+x" "-x" (sign
 *                                optional; "z" for Z-up scans)
 *           "translate": [0,0,0],
 *           "rotate_deg": [0,0,0],  XYZ Euler: about X, then Y, then Z
 *                                   (world axes; Blender's "XYZ" mode)
 *           "scale": 1           number or [sx,sy,sz], each in (0, 1e6]
 *         },                     p' = translate + Rz Ry Rx (scale * U p),
 *                                U the up-axis turn
 *         "material": {          see material/bsdf.h
 *           "type": "lambert",   "lambert" | "ggx"
 *           "albedo": [1,1,1],   each in [0,1]
 *           "roughness": 0.3,    [0,1]
 *           "specular": 0.04,    [0,1], share of the glossy lobe (ggx)
 *           "emission": [0,0,0], radiance, each >= 0
 *           "use_point_colors": true   albedo multiplies the points' colours
 *         },
 *         "surface": {           see surface/scene.h
 *           "model": "mls",      "mls" | "disk" | "iso" | "hybrid" (the model's
 *                                triangles in Ye's hierarchy; a mesh file or
 *                                a builtin, whose "points" then set its
 *                                tessellation: render/world.h)
 *           "kernel": "hat",     "hat" | "gaussian"
 *           "samples_per_cell": 8,      [1, 1024]
 *           "iso_tolerance": 0.05,      (0, 10] smallest radii (iso.h)
 *           "iso_max_depth": 16,        [2, 20]
 *           "iso_leaf_radii": 2,        (0, 16] largest leaf, smallest radii
 *           "iso_lod": 1,               [0, 64] pixels, 0 = off; not hashed
 *                                       (camera rays only: a bake stays valid)
 *           "hybrid_lod": 1,            [0, 64] pixels, 0 = full detail; not hashed
 *                                       (camera rays only: a bake stays valid)
 *           "hybrid_site_spacing": s,   [0, 1e6] world units: triangles larger
 *                                       than s carry lattices of light sites
 *                                       (hybrid.h); absent: none, but the
 *                                       builtin ground and room are 2
 *                                       triangles a rectangle with lattices
 *                                       at their "points" spacing; 0:
 *                                       vertices only, those two gridded
 *                                       (hashed; render/world.c)
 *           "refinements": {"shrink": true, "encourage": true, "collapse": true}
 *         }
 *       } ],
 *     "envmap": {                absent = uniform white    -> sg_scene_env
 *       "path": "sky.exr",       .exr or .hdr, resolved like model paths
 *       "builtin": "uniform",    "uniform" | "sky" | "sunsky" | "studio"
 *                                (at most one of path, builtin; neither =
 *                                "uniform")
 *       "rotation_deg": 0,       turn about +Y (DESIGN.md), finite
 *       "intensity": 1,          radiance multiplier, finite, >= 0
 *       "radiance": [1,1,1]      only with "uniform": its radiance, >= 0
 *     },
 *     "cameras": [               absent or [] = none: the caller frames the
 *       {                        scene itself (sg_camera_frame)
 *         "name": "main",        unique, 1-63 bytes; default "camera<i>"
 *         "eye": [x,y,z],        REQUIRED
 *         "look": [x,y,z],       REQUIRED, != eye
 *         "up": [0,1,0],         not parallel to look - eye
 *         "fov_deg": 40          vertical field of view, (0, 180)
 *       } ],
 *     "render": {
 *       "width": 512, "height": 512,   [1, 16384]
 *       "spp": 64,               samples per pixel [1, 1048576]
 *       "max_depth": 8,          path vertices after the camera [0, 1024]
 *       "seed": 1,               integer [0, 2^53]
 *       "threads": 0             [0, 4096]; 0 = OpenMP default
 *     },
 *     "bake": {                  options of splatgi-bake (and of a viewer's
 *                                bake); its command line overrides them
 *       "ray_cone": 0            [0, 16]: level of detail of the bake's
 *                                rays, in shares of the solid angle per ray
 *                                (bake/transport.h); 0 = off, full detail;
 *                                absent = the bake's default. Not in the
 *                                scene hash (the bake's parameter hash)
 *     }
 *   }
 *
 * Errors: SG_ERR_IO (cannot read the file), SG_ERR_CORRUPT (not JSON — the
 * message gives line:column of cJSON's error position — or a value of the
 * wrong type or range, an unknown or repeated key, a missing required key;
 * the message names the JSON path, e.g. "$.cameras[0].eye"), SG_ERR_NOMEM.
 * *out is written only on SG_OK.
 *
 * Ownership: sg_scene_file owns its arrays and strings (sg_alloc_array);
 * release them with sg_scene_file_free. Thread-safety: no shared state;
 * the hash and transform helpers are pure.
 *
 * Use:
 *     sg_scene_file sf;
 *     if (sg_scene_file_load("examples/bunny_sky.json", &sf, &err) != SG_OK)
 *         fprintf(stderr, "%s\n", err.message);
 *     for (size_t i = 0; i < sf.model_count; ++i) ... sf.models[i].path ...
 *     uint64_t key = sg_scene_file_hash(&sf, SG_SCENE_HASH_BAKE);
 *     sg_scene_file_free(&sf);
 */
#ifndef SG_IO_SCENE_FILE_H
#define SG_IO_SCENE_FILE_H

#include <stddef.h>
#include <stdint.h>

#include "core/error.h"
#include "material/bsdf.h"
#include "math/vec3.h"
#include "points/model_points.h"
#include "surface/scene.h"

#define SG_SCENE_NAME_MAX 64 /* camera names: at most 63 bytes + NUL */

typedef enum sg_scene_model_kind {
    SG_SCENE_MODEL_FILE = 0,   /* "path": a .ply or .obj file            */
    SG_SCENE_MODEL_BUNNY = 1,  /* "builtin": "bunny" (assets/bunny.ply)   */
    SG_SCENE_MODEL_GROUND = 2, /* "builtin": "ground"                     */
    SG_SCENE_MODEL_SPHERE = 3, /* "builtin": "sphere"                     */
    SG_SCENE_MODEL_ROOM = 4    /* "builtin": "room" (points/room.h)       */
} sg_scene_model_kind;

typedef enum sg_scene_env_kind {
    SG_SCENE_ENV_FILE = 0,    /* "path": a lat-long .exr or .hdr          */
    SG_SCENE_ENV_UNIFORM = 1, /* constant radiance (default)              */
    SG_SCENE_ENV_SKY = 2,
    SG_SCENE_ENV_SUNSKY = 3,
    SG_SCENE_ENV_STUDIO = 4
} sg_scene_env_kind;

/* A model's up axis (scanners and photogrammetry often write Z-up). */
typedef enum sg_scene_up {
    SG_SCENE_UP_POS_Y = 0, /* default: already Y-up */
    SG_SCENE_UP_NEG_Y = 1,
    SG_SCENE_UP_POS_Z = 2,
    SG_SCENE_UP_NEG_Z = 3,
    SG_SCENE_UP_POS_X = 4,
    SG_SCENE_UP_NEG_X = 5
} sg_scene_up;

typedef struct sg_scene_transform {
    sg_vec3 translate;   /* world units; default 0                       */
    sg_vec3 rotate_deg;  /* XYZ Euler angles, degrees; default 0         */
    sg_vec3 scale;       /* per-axis factors > 0; default 1              */
    sg_scene_up up;      /* turned to +Y before the rest; default +Y     */
} sg_scene_transform;

typedef struct sg_scene_model {
    sg_scene_model_kind kind;
    char *path;                  /* resolved path for SG_SCENE_MODEL_FILE,
                                    NULL for builtins                       */
    sg_model_points_desc points; /* points (0 = loader default), radius_k
                                    (default 8), radius_scale (default 1),
                                    radius_cap (SG_RADIUS_CAP_DEFAULT; -1
                                    for the file's 0 = no cap),
                                    drop_outliers; seed 0                  */
    sg_scene_transform transform;
    sg_material material;        /* defaults: sg_material_default()        */
    sg_scene_desc surface;       /* model, kernel, kd_disable and
                                    samples_per_cell (default 8) set; the
                                    other fields 0 (= scene.h defaults)    */
} sg_scene_model;

typedef struct sg_scene_env {
    sg_scene_env_kind kind;  /* default SG_SCENE_ENV_UNIFORM                */
    char *path;              /* resolved path for SG_SCENE_ENV_FILE, else NULL */
    float rotation_deg;      /* about +Y; default 0                         */
    float intensity;         /* multiplier; default 1                       */
    sg_vec3 radiance;        /* SG_SCENE_ENV_UNIFORM only; default (1,1,1)  */
} sg_scene_env;

typedef struct sg_scene_camera {
    char name[SG_SCENE_NAME_MAX]; /* unique within the file                 */
    sg_vec3 eye, look, up;        /* world space; up default (0,1,0)        */
    float fov_deg;                /* vertical; default 40                   */
} sg_scene_camera;

typedef struct sg_scene_render {
    int width, height;   /* pixels; default 512 x 512                       */
    int spp;             /* samples per pixel; default 64                   */
    int max_depth;       /* default 8                                       */
    uint64_t seed;       /* default 1                                       */
    int threads;         /* default 0 (OpenMP default)                      */
} sg_scene_render;

/* "bake": options of the bake that the scene asks for; a program's own
 * option (splatgi-bake --ray-cone) overrides them. Not in the scene hash:
 * the bake's parameter hash holds them (bake.h). */
typedef struct sg_scene_bake {
    float ray_cone;      /* sg_bake_desc.ray_cone: >= 0 as in the file (0:
                            off); -1: not given (the bake's default)      */
} sg_scene_bake;

typedef struct sg_scene_file {
    sg_scene_model *models;   /* model_count >= 1 entries, file order        */
    size_t model_count;
    sg_scene_env env;
    sg_scene_camera *cameras; /* camera_count entries (may be 0; then NULL)  */
    size_t camera_count;
    sg_scene_render render;
    sg_scene_bake bake;
} sg_scene_file;

/* Reads and parses the file at path. Messages begin with path. */
sg_status sg_scene_file_load(const char *path, sg_scene_file *out, sg_error *err);

/* Parses len bytes of JSON text (need not be NUL-terminated). name starts
 * every message; relative paths resolve against base_dir (NULL or "" =
 * leave them relative to the working directory). */
sg_status sg_scene_file_parse(const char *text, size_t len, const char *name, const char *base_dir,
                              sg_scene_file *out, sg_error *err);

/* Frees everything and zeroes *sf; NULL and zeroed structs are fine. */
void sg_scene_file_free(sg_scene_file *sf);

/* Writes sf as a scene file that loads back to the same scene (equal
 * sg_scene_file_hash over every part), every key spelt out so a user sees
 * what can be edited; model and envmap paths made absolute (realpath) so
 * the file may live anywhere. Written to a temporary name and renamed
 * (core/file_mode.h permissions). SG_ERR_IO names path; SG_ERR_NOMEM.
 * (scene_file_write.c) */
sg_status sg_scene_file_write(const sg_scene_file *sf, const char *path, sg_error *err);

/* The camera called name, or NULL. */
const sg_scene_camera *sg_scene_file_find_camera(const sg_scene_file *sf, const char *name);

/* Which parts of the scene a hash covers. A bake depends on models and the
 * envmap; a reference image on everything but the thread count (results
 * do not depend on it, DESIGN.md "Determinism"). */
enum sg_scene_hash_parts {
    SG_SCENE_HASH_MODELS = 1u << 0,  /* paths, transforms, materials, surface */
    SG_SCENE_HASH_ENV = 1u << 1,
    SG_SCENE_HASH_CAMERAS = 1u << 2,
    SG_SCENE_HASH_RENDER = 1u << 3,  /* all of render except threads        */
    SG_SCENE_HASH_BAKE = 3u,
    SG_SCENE_HASH_ALL = 15u
};

/* 64-bit FNV-1a over a canonical little-endian serialisation of the chosen
 * parts of the parsed struct: equal for files that differ only in key order,
 * whitespace, or spelling a default out. It covers paths as strings, not the
 * files' contents: mix in a content hash where files may change. */
uint64_t sg_scene_file_hash(const sg_scene_file *sf, uint32_t parts);

/* "+z", "z", "-X", ... -> *out (SG_OK), else SG_ERR_INVALID_ARG with *out
 * untouched (the caller names the option in its message). */
sg_status sg_scene_up_parse(const char *s, sg_scene_up *out);

/* Canonical name: "+y", "-z", ... */
const char *sg_scene_up_name(sg_scene_up up);

/* U v: the rotation that takes axis `up` to +Y (a quarter or half turn). */
sg_vec3 sg_scene_up_apply(sg_scene_up up, sg_vec3 v);

/* Transform helpers (semantics as in the schema). point: translate + R S U p.
 * normal: R S^-1 U n, normalised (the inverse transpose of R S U). radius:
 * r times the largest scale factor, so disks still cover the surface under
 * a non-uniform scale (U keeps lengths). */
sg_vec3 sg_scene_transform_point(const sg_scene_transform *t, sg_vec3 p);
sg_vec3 sg_scene_transform_normal(const sg_scene_transform *t, sg_vec3 n);
float sg_scene_transform_radius(const sg_scene_transform *t, float r);

#endif
