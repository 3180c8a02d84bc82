/* The values and record structs shared with the host are declared once, in clrender/layout.py, and
 * clrender.device.Device.program puts the header generated from them (layout.c_header) before every
 * kernel file it builds; a build without it stops here instead of using a stale copy.  Included
 * first by every kernel file. */
#ifndef CLRENDER_LAYOUT_H
#define CLRENDER_LAYOUT_H

#ifndef CLRENDER_LAYOUT
#error "clrender/layout.py's header is missing: build through clrender.device.Device.program"
#endif
#if BLOCK_LANES != 4
#error "BLOCK_LANES must be 4: a leaf block is tested with float4 operations"
#endif
#if VORONOI_STRIP != 8
#error "VORONOI_STRIP must be 8: the Voronoi grid kernel keeps a strip of pixels in one float8"
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
