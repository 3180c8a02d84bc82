"""Every value and buffer record shared by the host and the kernels, defined once, here.

Device.program passes `DEFINES` to every program build as -D options; the kernels have no copies
(kernels/layout.h stops a build with #error when one is missing), so a change here reaches both
sides.  The record dtypes below say what each buffer element holds; tests/kernels/test_layout.py checks
them against what the kernels see (sizeof, the codes, the strides).
"""

from __future__ import annotations

import numpy as np

# ---- tracing (kernels/common.h, shade.h, sampling.h, trace.cl)
PATH_LEN = 8  # object ids recorded along each pixel's path (edge detection)
ID_RECORD = PATH_LEN + 1  # int32 per pixel: the path's object ids, then the primary hit's facet
PRIM_ROWS = 3  # float4 rows per primitive slot
MATERIAL_ROWS = 3  # float4 rows per material
LIGHT_ROWS = 5  # float4 rows per light
NORMAL_ROWS = 3  # float4 rows per smooth triangle: its vertex normals

LIGHT_TYPES = {"point": 0, "directional": 1, "area": 2}  # the light record's head.x
SAMPLERS = {"uniform": 0, "random": 1, "stratified": 2, "sobol": 3}  # pixel samplers, by kernel code
PIXEL_FILTERS = {"box": 0, "tent": 1, "gaussian": 2}  # reconstruction filters, by kernel code

# ---- splats (kernels/splat_gauss.cl, splat_voronoi.cl)
SPLAT_TILE = 16  # Gaussian splats are binned into TILE x TILE pixel tiles
SPLAT_NGRAD = 10  # floats per gradient entry: d/d(mx, my, A, B2, C, r, g, b, opacity), sum of weights
SPLAT_EPS = 1e-3  # normalized blend: weight of the background colour
VORONOI_STRIP = 8  # pixels per work-item of the grid kernel (one float8)
BVH_NODE_ROWS = 2  # float4 rows per binary BVH node: (bmin, offset), (bmax, count) -- trace/bvh.py's NODE_DTYPE
WIDE_NODE_ROWS = 8  # rows of BVH_WIDTH lanes per wide BVH node: lo/hi per axis (rows 0-5), then child and count
WIDE_CHILD_ROW = 6  # a wide node's row of child indices / first slots (int32 bits)
WIDE_COUNT_ROW = 7  # a wide node's row of slot counts (int32 bits; 0 interior, -1 empty lane)
# Leaf blocks of the wide layouts (trace/bvh_wide.py leaf_blocks): a leaf's primitives in groups of
# BLOCK_LANES, tested at once; rows 0-8 are float4s of v0.x, v0.y, v0.z, v1.x, ... v2.z of each lane's
# triangle, row 9 the lanes' slots (int32 bits: a triangle's slot, -2 - slot for a sphere, -1 empty)
BLOCK_LANES = 4
BLOCK_ROWS = 10
BLOCK_SLOT_ROW = 9

# ---- buffer records (host view of one element; the kernels read them as float4 / int rows)
_F4 = ("<f4", 4)
ID_RECORD_DTYPE = np.dtype([("path", "<i4", PATH_LEN), ("facet", "<i4")])  # -1 past the path's end / no facet
# triangle: (v0, id bits) (v1, 0) (v2, 0); sphere: (centre, id bits) (radius, 0, 0, 1) (0)
PRIM_SLOT_DTYPE = np.dtype([("a", *_F4), ("b", *_F4), ("c", *_F4)])
# (kd.rgb, shininess) (ks.rgb, mirror) (transparency, ior, 0, 0)
MATERIAL_DTYPE = np.dtype([("kd_shininess", *_F4), ("ks_mirror", *_F4), ("transparency_ior", *_F4)])
# (type, samples per side, intensity, falloff) (position | direction of travel | corner, 0) (colour, 0) (edge a, 0) (edge b, 0)
LIGHT_DTYPE = np.dtype([("head", *_F4), ("where", *_F4), ("colour", *_F4), ("edge_a", *_F4), ("edge_b", *_F4)])
# one splat-tile entry of the backward kernel: d/d(mean x, y), d/d(A, B2, C) of the inverse covariance,
# d/d(colour), d/d(opacity), and the splat's summed weight over the tile
SPLAT_GRAD_DTYPE = np.dtype(
    [("mean", "<f4", 2), ("A", "<f4"), ("B2", "<f4"), ("C", "<f4"), ("color", "<f4", 3), ("opacity", "<f4"), ("weight", "<f4")]
)
# each record's size matches its row count: tests/kernels/test_layout.py

DEFINES = {
    "PATH_LEN": PATH_LEN,
    "ID_RECORD": ID_RECORD,
    "PRIM_ROWS": PRIM_ROWS,
    "MATERIAL_ROWS": MATERIAL_ROWS,
    "LIGHT_ROWS": LIGHT_ROWS,
    "NORMAL_ROWS": NORMAL_ROWS,
    **{f"LIGHT_{name.upper()}": code for name, code in LIGHT_TYPES.items()},
    **{f"SAMPLER_{name.upper()}": code for name, code in SAMPLERS.items()},
    **{f"PIXEL_FILTER_{name.upper()}": code for name, code in PIXEL_FILTERS.items()},
    "TILE": SPLAT_TILE,
    "NGRAD": SPLAT_NGRAD,
    "EPS": SPLAT_EPS,
    "STRIP": VORONOI_STRIP,
    "BVH_NODE_ROWS": BVH_NODE_ROWS,
    "WIDE_NODE_ROWS": WIDE_NODE_ROWS,
    "WIDE_CHILD_ROW": WIDE_CHILD_ROW,
    "WIDE_COUNT_ROW": WIDE_COUNT_ROW,
    "BLOCK_LANES": BLOCK_LANES,
    "BLOCK_ROWS": BLOCK_ROWS,
    "BLOCK_SLOT_ROW": BLOCK_SLOT_ROW,
}
