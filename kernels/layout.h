/* Values shared with the host.  They are defined once, in clrender/layout.py, and every build gets
 * them as -D options (clrender.device.Device.program); a build without them stops here instead of
 * using a stale copy.  Included first by every kernel file. */
#ifndef CLRENDER_LAYOUT_H
#define CLRENDER_LAYOUT_H

#ifndef PATH_LEN
#error "PATH_LEN is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef ID_RECORD
#error "ID_RECORD is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef PRIM_ROWS
#error "PRIM_ROWS is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef MATERIAL_ROWS
#error "MATERIAL_ROWS is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef LIGHT_ROWS
#error "LIGHT_ROWS is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef LIGHT_POINT
#error "LIGHT_POINT is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef LIGHT_DIRECTIONAL
#error "LIGHT_DIRECTIONAL is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef LIGHT_AREA
#error "LIGHT_AREA is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef SAMPLER_UNIFORM
#error "SAMPLER_UNIFORM is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef SAMPLER_RANDOM
#error "SAMPLER_RANDOM is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef SAMPLER_STRATIFIED
#error "SAMPLER_STRATIFIED is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef SAMPLER_SOBOL
#error "SAMPLER_SOBOL is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef PIXEL_FILTER_BOX
#error "PIXEL_FILTER_BOX is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef PIXEL_FILTER_TENT
#error "PIXEL_FILTER_TENT is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef PIXEL_FILTER_GAUSSIAN
#error "PIXEL_FILTER_GAUSSIAN is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef TILE
#error "TILE is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef NGRAD
#error "NGRAD is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef EPS
#error "EPS is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef STRIP
#error "STRIP is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef BVH_NODE_ROWS
#error "BVH_NODE_ROWS is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef WIDE_NODE_ROWS
#error "WIDE_NODE_ROWS is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef WIDE_CHILD_ROW
#error "WIDE_CHILD_ROW is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef WIDE_COUNT_ROW
#error "WIDE_COUNT_ROW is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef BLOCK_LANES
#error "BLOCK_LANES is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef BLOCK_ROWS
#error "BLOCK_ROWS is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#ifndef BLOCK_SLOT_ROW
#error "BLOCK_SLOT_ROW is missing: build through clrender.device.Device.program, which passes clrender/layout.py's values"
#endif
#if BLOCK_LANES != 4
#error "BLOCK_LANES must be 4: a leaf block is tested with float4 operations"
#endif
#if STRIP != 8
#error "STRIP must be 8: the Voronoi grid kernel keeps a strip of pixels in one float8"
#endif

/* Helpers are always inlined in optimised builds: PoCL (LLVM 14) otherwise leaves many of them as
 * calls, and a call in the traversal loop costs more than the box test it wraps.  Builds without
 * __OPTIMIZE__ (-cl-opt-disable; Oclgrind, whose interpreter lacks the intrinsics forced inlining
 * brings) keep plain inline. */
#ifdef __OPTIMIZE__
#define INLINE inline __attribute__((always_inline))
#else
#define INLINE inline
#endif

#endif
