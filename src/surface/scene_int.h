/* scene_int.h — the layout of sg_scene, shared by scene.c (builds and
 * traverses it) and scene_store.c (takes it apart for the world file and
 * puts it together again). Not a public header.
 */
#ifndef SG_SURFACE_SCENE_INT_H
#define SG_SURFACE_SCENE_INT_H

#include "accel/kdtree.h"
#include "surface/hybrid.h"
#include "surface/hybrid_scene.h"
#include "surface/iso.h"
#include "surface/iso_sites.h"
#include "surface/mls.h"
#include "surface/scene.h"
#include "surface/splat_soa.h"

struct sg_scene {
    sg_scene_desc desc;   /* with defaults filled in                        */
    sg_pointset points;   /* own copy of the input                          */
    sg_sites sites;       /* the light sites: a view of the splats          */
    sg_iso *iso;          /* SG_SURFACE_ISO: the octree (no kd-tree then)   */
    sg_iso_sites iso_sites; /* ...and its corners as light sites            */
    sg_hybrid *hybrid;    /* SG_SURFACE_HYBRID: the sphere hierarchy (no
                             kd-tree, no points)                          */
    sg_hybrid_sites hybrid_sites; /* ...its vertices and nodes as sites     */
    sg_kdtree tree;
    sg_splat_soa soa;     /* one entry per reference, leaf by leaf          */
    sg_mls_params mls;
    sg_scene_info info;
    int borrowed;         /* 1: points, tree, soa (and the ISO's and the
                             hybrid's arrays)
                             point into memory the scene does not own (a
                             world file's map, scene_store.c); destroy
                             frees only what it allocated: the struct, the
                             ISO and hybrid structs and their sites       */
};

/* Deepest kd-tree a scene traverses: the traversal's fixed stack holds
 * one far child per level (scene.c STACK_SIZE = 128). */
#define SG_SCENE_MAX_KD_DEPTH 120

#endif
