"""Every value and buffer record shared by the host and the kernels, declared once, here.

Values (codes, sizes) become `#define`s and records (numpy structured dtypes) become C structs in one
generated header, `c_header()`, that Device.program puts before every kernel file it builds.  The
kernels read records by field name (`materials[m].ior`) and the host packs them by field name
(`record["ior"]`), so a field added to a dtype here reaches both sides; tests/test_layout.py has a
kernel report sizeof and every field's offset of each struct and compares them with the dtypes.

How a dtype becomes a struct (`c_struct`): float32, int32 and uint32 fields become float, int and
uint; a field of shape (n,) becomes an array `name[n]`, or an OpenCL vector `floatN name` when the
record lists it in `vectors` (N = 2, 4, 8 or 16; its offset must be a multiple of its size, as
OpenCL aligns vectors); gaps between fields become `_pad` members.  A struct whose C alignment
would add padding numpy does not have is refused when the header is generated.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

# ---- tracing (kernels/common.h, shade.h, sampling.h, trace.cl)
PATH_LEN = 8  # object ids recorded along each pixel's path (edge detection)
ID_RECORD = PATH_LEN + 1  # int32 per pixel: the path's object ids, then the primary hit's facet
PRIM_ROWS = 3  # float4 rows per primitive slot: TRANSITION (issue 24), until shade.h reads PrimSlot by name
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
# Leaf blocks of the wide layouts (the LeafBlock record below): a leaf's primitives in groups of
# BLOCK_LANES, tested at once with float4 operations
BLOCK_LANES = 4


# ---------------------------------------------------------------- records as C structs
@dataclass(frozen=True)
class Record:
    """A buffer record the kernels read as the C struct `c_name`, generated from `dtype`."""

    c_name: str
    dtype: np.dtype
    vectors: tuple = ()  # fields the kernels read as OpenCL vectors (floatN / intN / uintN), not arrays


_C_TYPES = {np.dtype("<f4"): "float", np.dtype("<i4"): "int", np.dtype("<u4"): "uint"}


def c_struct(record: Record) -> str:
    """`typedef struct { ... } c_name;` with the dtype's fields at the dtype's offsets."""
    dtype = record.dtype
    lines, at, align = [], 0, 4
    for name, (field_dtype, offset) in sorted(dtype.fields.items(), key=lambda item: item[1][1]):
        base, shape = field_dtype.base, field_dtype.shape
        if base not in _C_TYPES:
            raise TypeError(f"{record.c_name}.{name}: {base} has no C type here (float32, int32, uint32)")
        if offset > at:
            lines.append(f"    char _pad{at}[{offset - at}];")
        if name in record.vectors:
            width = shape[-1] if shape else 1
            if width not in (2, 4, 8, 16) or offset % (4 * width):
                raise TypeError(f"{record.c_name}.{name}: a vector needs 2, 4, 8 or 16 lanes at a multiple of its size")
            decl, dims, align = f"{_C_TYPES[base]}{width} {name}", shape[:-1], max(align, 4 * width)
        else:
            decl, dims = f"{_C_TYPES[base]} {name}", shape
        lines.append("    " + decl + "".join(f"[{n}]" for n in dims) + ";")
        at = offset + field_dtype.itemsize
    if dtype.itemsize > at:
        lines.append(f"    char _pad{at}[{dtype.itemsize - at}];")
    if dtype.itemsize % align:
        raise TypeError(f"{record.c_name}: {dtype.itemsize} bytes is not a multiple of its alignment {align}")
    return "typedef struct {\n" + "\n".join(lines) + f"\n}} {record.c_name};"


# ---------------------------------------------------------------- records
# Each section is one part of the kernels; a record is a dtype plus its Record (the C struct's name).

# ---- geometry and traversal (kernels/intersect.h, packet.h, shaft.h; packed by trace/geometry.py, bvh*.py, tracer.py)
_F4 = ("<f4", 4)
# A primitive slot (48 bytes), in the tree's leaf order: one buffer read through two records, PrimSlot
# for a triangle and SphereSlot for a sphere, which keep `id` (the primitive's index in scene order)
# and `sphere` (1 for a sphere, 0 for a triangle) at the same offsets.  A triangle holds its vertices
# themselves, not edges: two triangles that share a vertex read bit-identical floats there
# (watertight).  Each vertex starts a 16-byte row (v0, v1, v2 at 0, 16, 32), the layout shade.h still
# reads as PRIM_ROWS float4 rows (TRANSITION, issue 24).
PRIM_SLOT_DTYPE = np.dtype(
    {
        "names": ["v0", "id", "v1", "sphere", "v2"],
        "formats": [("<f4", 3), "<i4", ("<f4", 3), "<i4", ("<f4", 3)],
        "offsets": [0, 12, 16, 28, 32],
        "itemsize": 48,
    }
)
PRIM_SLOT = Record("PrimSlot", PRIM_SLOT_DTYPE)
SPHERE_SLOT_DTYPE = np.dtype(
    {
        "names": ["centre", "id", "radius", "sphere"],
        "formats": [("<f4", 3), "<i4", "<f4", "<i4"],
        "offsets": [0, 12, 16, 28],
        "itemsize": 48,
    }
)
SPHERE_SLOT = Record("SphereSlot", SPHERE_SLOT_DTYPE)
# a smooth triangle's vertex normals, by primitive id (xyz; w unused); zeros for a flat one
VERTEX_NORMALS_DTYPE = np.dtype([("n0", "<f4", 4), ("n1", "<f4", 4), ("n2", "<f4", 4)])
VERTEX_NORMALS = Record("VertexNormals", VERTEX_NORMALS_DTYPE, vectors=("n0", "n1", "n2"))
# a binary BVH node (trace/bvh.py builds them): its box, and a leaf's first slot and count (> 0), or an
# interior node's far child (its near child follows it) and count 0
BVH_NODE_DTYPE = np.dtype([("bmin", "<f4", 3), ("offset", "<i4"), ("bmax", "<f4", 3), ("count", "<i4")])
BVH_NODE = Record("BvhNode", BVH_NODE_DTYPE)


def wide_node_dtype(width: int) -> np.dtype:
    """A wide BVH node of `width` lanes (trace/bvh_wide.py), one child per lane, its fields OpenCL vectors
    of `width` lanes: bounds[2 axis] and bounds[2 axis + 1] hold the children's lo and hi along the
    axis; child is an interior child's wide node, or a leaf child's first slot (in the buffer the
    kernels read, bvh_wide.tree_buffer: its first LeafBlock, counted from the buffer's start); count is
    0 for an interior child, the leaf's primitives (> 0), or -1 for an empty lane (whose box is
    [+inf, -inf], missed by every ray)."""
    return np.dtype([("bounds", "<f4", (6, width)), ("child", "<i4", width), ("count", "<i4", width)])


WIDE_NODE4 = Record("WideNode4", wide_node_dtype(4), vectors=("bounds", "child", "count"))  # 128 bytes
WIDE_NODE8 = Record("WideNode8", wide_node_dtype(8), vectors=("bounds", "child", "count"))  # 256 bytes
WIDE_NODE_DTYPES = {4: WIDE_NODE4.dtype, 8: WIDE_NODE8.dtype}
# A leaf block (160 bytes): BLOCK_LANES primitives of a wide tree's leaf, one per float4 lane, for the
# kernels to test at once: v0[axis], v1[axis], v2[axis] are the lanes' triangles' vertex coordinates
# along x, y, z (copied bit for bit from their slots); slot is each lane's triangle slot, -2 - slot for
# a sphere (tested on its own; its vertex lanes hold zeros), -1 for an empty lane.
LEAF_BLOCK_DTYPE = np.dtype(
    [("v0", "<f4", (3, BLOCK_LANES)), ("v1", "<f4", (3, BLOCK_LANES)), ("v2", "<f4", (3, BLOCK_LANES)), ("slot", "<i4", BLOCK_LANES)]
)
LEAF_BLOCK = Record("LeafBlock", LEAF_BLOCK_DTYPE, vectors=("v0", "v1", "v2", "slot"))

# ---- shading and the render kernel (kernels/shade.h, trace.cl; packed by scene/*.py, trace/renderer.py)
# a material: the seed's Blinn-Phong colours and exponent, mirror and transparency fractions, index of refraction
MATERIAL_DTYPE = np.dtype(
    {
        "names": ["kd", "shininess", "ks", "mirror", "transparency", "ior"],
        "formats": [("<f4", 3), "<f4", ("<f4", 3), "<f4", "<f4", "<f4"],
        "offsets": [0, 12, 16, 28, 32, 36],
        "itemsize": 48,
    }
)
MATERIAL = Record("Material", MATERIAL_DTYPE)
OBJECT_DTYPE = np.dtype([("material", "<i4"), ("smooth", "<i4")])  # an object's material index; 1: smooth-shaded mesh
OBJECT = Record("ObjectRecord", OBJECT_DTYPE)
# (type, samples per side, intensity, falloff) (position | direction of travel | corner, 0) (colour, 0) (edge a, 0) (edge b, 0)
LIGHT_DTYPE = np.dtype([("head", *_F4), ("where", *_F4), ("colour", *_F4), ("edge_a", *_F4), ("edge_b", *_F4)])
ID_RECORD_DTYPE = np.dtype([("path", "<i4", PATH_LEN), ("facet", "<i4")])  # -1 past the path's end / no facet

# ---- splats (kernels/splat_gauss.cl, splat_voronoi.cl; packed by splat/*.py)
# one splat-tile entry of the backward kernel: d/d(mean x, y), d/d(A, B2, C) of the inverse covariance,
# d/d(colour), d/d(opacity), and the splat's summed weight over the tile
SPLAT_GRAD_DTYPE = np.dtype(
    [("mean", "<f4", 2), ("A", "<f4"), ("B2", "<f4"), ("C", "<f4"), ("color", "<f4", 3), ("opacity", "<f4"), ("weight", "<f4")]
)

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
    "BLOCK_LANES": BLOCK_LANES,
}


def records() -> list[Record]:
    """Every record declared in this module, in declaration order."""
    return [value for value in globals().values() if isinstance(value, Record)]


@functools.cache
def c_header() -> str:
    """The header every kernel build starts with: the shared values, then the records' structs."""
    defines = [f"#define {name} {c_value(value)}" for name, value in DEFINES.items()]
    structs = [c_struct(record) for record in records()]
    return "\n".join(["/* generated from clrender/layout.py: do not edit */", "#define CLRENDER_LAYOUT 1", *defines, *structs, ""])


def c_value(value) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return repr(value) + "f"
    return str(value)
