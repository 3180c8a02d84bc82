/* The scene tables: the Tracer's small per-scene records (instances, the top tree, objects, materials, textures)
 * in one arena, `tables`, whose regions a SceneTables record places (clrender/layout.py; packed by
 * clrender/trace/tracer.py with clrender/arena.py).  Every render and ray-query kernel takes its scene as the
 * geometry's big buffers and this arena, and makes its Geometry here. */
#ifndef CLRENDER_TABLES_H
#define CLRENDER_TABLES_H

#include "common.h"
#include "intersect.h"
#include "texture.h"

/* The scene's Geometry: `shading` false leaves out the objects (ray queries read none; their tables hold none). */
INLINE Geometry scene_geometry(__global const TreeNode *nodes, __global const PrimSlot *prims, __global const int *prim_object,
                               __global const char *tables, SceneTables at, int n_prims, int n_instances, bool shading) {
    Geometry g = geometry(nodes, prims, prim_object, shading ? REGION(tables, const ObjectRecord, at.objects) : 0, n_prims);
    with_instances(&g, REGION(tables, const Instance, at.instances), REGION(tables, const BvhNode, at.top), n_instances);
    return g;
}

/* The scene's materials and textures as the shading reads them (a render's tables hold them). */
INLINE TextureView scene_textures(__global const VertexAttributes *attributes, __global const char *tables, SceneTables at,
                                  __global const float4 *texels) {
    return texture_view(attributes, REGION(tables, const Texture, at.textures), REGION(tables, const Material, at.materials), texels);
}

#endif
