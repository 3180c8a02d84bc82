"""Every value and buffer record shared by the host and the kernels, declared once, here.

Values (codes, sizes) become `#define`s and records (numpy structured dtypes) become C structs in one
generated header, `c_header()`, that Device.program puts before every kernel file it builds.  The
kernels read records by field name (`materials[m].ior`) and the host packs them by field name
(`record["ior"]`), so a field added to a dtype here reaches both sides; tests/kernels/test_layout.py has a
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
PATH_LEN = 8  # object ids recorded along each pixel's path (edge detection): IdRecord.path

LIGHT_TYPES = {"point": 0, "directional": 1, "area": 2, "spot": 3}  # Light.type
SPOT_PROFILES = {"mitsuba": 0, "pbrt": 1}  # Light.spot_profile: Mitsuba 3's linear-in-angle falloff, pbrt-v4's smoothstep
LIGHT_FALLOFFS = {"none": 0, "inverse_square": 1}  # Light.falloff: unnormalised (no 1/r^2, no 1/pi), or physical (scene/lights.py)
BSDF_LOBES = {"lambert": 0, "conductor": 1, "dielectric": 2, "rough_dielectric": 3, "gltf": 4}  # kernels/bsdf.h's lobe codes
# the lobes of issue 36 (docs/materials.md): a conductor with complex Fresnel (GGX, and its delta mirror), Mitsuba's
# plastic / roughplastic (a diffuse base under a dielectric coat, smooth and GGX), a thin dielectric sheet (delta)
BSDF_LOBES.update({"metal": 5, "metal_smooth": 6, "coated_diffuse": 7, "coated_diffuse_smooth": 8, "thin_dielectric": 9})
# a perfect mirror (delta), and the Phong material's Lambert-plus-glossy mix (kernels/bsdf.h; docs/materials.md)
BSDF_LOBES.update({"mirror": 10, "phong": 11})
# Material.model: the Phong keys (Lambert + Blinn-Phong, mirror, glass), glTF's metallic-roughness ones, or a `type = ...` material of issue 36
MATERIAL_MODELS = {"phong": 0, "gltf": 1, "conductor": 2, "coated_diffuse": 3, "thin_dielectric": 4}
SMITH_MODELS = {"correlated": 0, "separable": 1}  # Material.smith: GGX masking-shadowing G2, or Mitsuba's G1(wo) G1(wi)
COAT_TABLE_RES = 64  # the rough coat's external transmittance table (Mitsuba's MI_ROUGH_TRANSMITTANCE_RES)
SAMPLERS = {"uniform": 0, "random": 1, "stratified": 2, "sobol": 3}  # pixel samplers, by kernel code
PATH_SAMPLERS = {"independent": 0, "sobol": 1}  # the path tracer's random numbers (kernels/sobol.h), by kernel code
# the path tracer's schedules (RenderSettings.path_schedule; trace/wavefront.py, docs/lanes.md): host-side names, no code
PATH_SCHEDULES = ("megakernel", "wavefront", "lanes")
PIXEL_FILTERS = {"box": 0, "tent": 1, "gaussian": 2}  # reconstruction filters, by kernel code
PROJECTIONS = {"perspective": 0, "orthographic": 1}  # Camera.projection (scene/camera.py, kernels/camera.h)


@dataclass(frozen=True)
class TextureSlot:
    """A material's texture slot: what its texels scale.  TEXTURE_SLOT_TABLE is read by the scene readers (the scene
    key `{name}_texture` and Material attribute, textures.py's colour spaces, gltf.py's keys) and by the kernels'
    one rule, kernels/surface.h's material_at (layout.DEFINES names each slot TEXTURE_{NAME})."""

    name: str  # the slot; the scene key and Material attribute are f"{name}_texture"
    parameters: tuple  # what the texel changes, each with its channels: ("kd", "rgb") scales kd by the texel's rgb
    colour: bool  # texels sRGB-decoded (a colour), else linear (data)
    gltf: str  # the glTF material's textureInfo key path: "pbrMetallicRoughness.baseColorTexture", ...; "" for none
    strength: str = ""  # the textureInfo key of the slot's strength (TextureRef.strength), "" for none
    models: str = "gltf"  # the scene materials whose tables take the key: "gltf", or "all" (every model)
    alias: str = ""  # the key the Phong model (and coated_diffuse) reads the slot by, "" for none


TEXTURE_SLOT_TABLE = (
    TextureSlot(
        "base_color",
        (("kd", "rgb"), ("base_color", "rgb"), ("alpha", "a")),
        colour=True,
        gltf="pbrMetallicRoughness.baseColorTexture",
        alias="diffuse_texture",
    ),
    TextureSlot("metallic_roughness", (("metallic", "b"), ("roughness", "g")), colour=False, gltf="pbrMetallicRoughness.metallicRoughnessTexture"),
    TextureSlot("emissive", (("emission", "rgb"),), colour=True, gltf="emissiveTexture", models="all"),
    TextureSlot("occlusion", (("occlusion", "r"),), colour=False, gltf="occlusionTexture", strength="strength"),
    TextureSlot("normal", (("normal", "rgb"),), colour=False, gltf="normalTexture", strength="scale"),
)
# Material.textures[slot] (and tex_coord, tex_transform) by slot name
TEXTURE_SLOTS = {slot.name: code for code, slot in enumerate(TEXTURE_SLOT_TABLE)}
ALPHA_MODES = {"opaque": 0, "mask": 1, "blend": 2}  # Material.alpha_mode: glTF's alphaMode (kernels/alpha.h, both integrators)
WRAP_MODES = {"repeat": 10497, "clamp_to_edge": 33071, "mirrored_repeat": 33648}  # Texture.wrap_s/t: glTF's sampler codes

# ---- splats (kernels/splat_gauss.cl, splat_voronoi.cl)
SPLAT_TILE = 16  # Gaussian splats are binned into SPLAT_TILE x SPLAT_TILE pixel tiles
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
        if base.names is None and base not in _C_TYPES:
            raise TypeError(f"{record.c_name}.{name}: {base} has no C type here (float32, int32, uint32)")
        if offset > at:
            lines.append(f"    char _pad{at}[{offset - at}];")
        if base.names is not None:  # a record inside a record: its struct, declared before this one
            nested = {r.dtype: r.c_name for r in records() if not r.vectors}.get(base)
            if nested is None:
                raise TypeError(f"{record.c_name}.{name}: a nested record must be one declared in layout.py, of 4-byte fields only")
            decl, dims = f"{nested} {name}", shape
        elif name in record.vectors:
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
def padded(fields: list, itemsize: int) -> np.dtype:
    """The fields packed one after another, the record padded to `itemsize` bytes (for a fill pattern or a row)."""
    packed = np.dtype(fields)
    return np.dtype(
        {
            "names": packed.names,
            "formats": [packed.fields[n][0] for n in packed.names],
            "offsets": [packed.fields[n][1] for n in packed.names],
            "itemsize": itemsize,
        }
    )


# Each section is one part of the kernels; a record is a dtype plus its Record (the C struct's name).

# ---- geometry and traversal (kernels/intersect.h, packet.h, shaft.h; packed by trace/geometry.py, bvh*.py, tracer.py)
_F4 = ("<f4", 4)
# A primitive slot (48 bytes), in the tree's leaf order: one buffer read through two records, PrimSlot
# for a triangle and SphereSlot for a sphere, which keep `id` (the primitive's index in scene order)
# and `sphere` (1 for a sphere, 0 for a triangle) at the same offsets.  A triangle holds its vertices
# themselves, not edges: two triangles that share a vertex read bit-identical floats there
# (watertight).  Each vertex starts a 16-byte row (v0, v1, v2 at 0, 16, 32).
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
# a material (scene/materials.py): the Phong model's Blinn-Phong colours and exponent, mirror and transparency
# fractions, index of refraction; the glTF metallic-roughness parameters and emission the path tracer reads
MATERIAL_DTYPE = np.dtype(
    [
        ("kd", "<f4", 3),
        ("shininess", "<f4"),
        ("ks", "<f4", 3),
        ("mirror", "<f4"),
        ("transparency", "<f4"),
        ("ior", "<f4"),
        ("base_color", "<f4", 3),  # the Phong model: kd
        ("metallic", "<f4"),
        ("roughness", "<f4"),  # perceptual: GGX alpha = roughness^2
        ("transmission", "<f4"),
        ("emission", "<f4", 3),  # radiance of the front faces
        ("model", "<i4"),  # MATERIAL_MODELS code
        # textures (kernels/texture.h), per TEXTURE_SLOTS slot: the Texture record's index (-1: none), the UV set
        # it reads (0: TEXCOORD_0, 1: TEXCOORD_1) and KHR_texture_transform as a 2 x 3 matrix, row-major:
        # uv' = (m0 u + m1 v + m2, m3 u + m4 v + m5)
        ("textures", "<i4", len(TEXTURE_SLOTS)),
        ("tex_coord", "<i4", len(TEXTURE_SLOTS)),
        ("tex_transform", "<f4", (len(TEXTURE_SLOTS), 6)),
        ("occlusion_strength", "<f4"),  # glTF occlusionTexture.strength: occlusion = 1 + s (texel.r - 1)
        ("normal_scale", "<f4"),  # glTF normalTexture.scale: the tangent-space normal's x and y are scaled by it
        ("alpha", "<f4"),  # coverage: times the base colour texture's alpha (glTF baseColorFactor[3])
        ("alpha_mode", "<i4"),  # ALPHA_MODES code
        ("alpha_cutoff", "<f4"),  # mask: a point whose alpha is below this is not there
        ("double_sided", "<i4"),  # 0: camera rays do not see the back faces (glTF doubleSided false; kernels/alpha.h)
        # the `type = ...` materials (scene/materials.py, docs/materials.md); kd is the coated diffuse's base
        ("smith", "<i4"),  # SMITH_MODELS code, every GGX lobe of the path tracer
        ("eta", "<f4", 3),  # conductor: real part of the complex IOR, per channel
        ("k", "<f4", 3),  # conductor: imaginary part (extinction), per channel
        ("tint", "<f4", 3),  # specular reflectance (Mitsuba's specular_reflectance)
        ("transmit_tint", "<f4", 3),  # thin dielectric: specular transmittance
        ("lobe_ior", "<f4"),  # coat / thin sheet IOR, inside over outside (the Whitted stand-in keeps `ior`)
        ("nonlinear", "<i4"),  # coated diffuse: 1 for Mitsuba's nonlinear internal scattering
        ("coat_weight", "<f4"),  # coated diffuse: Mitsuba's specular_sampling_weight, mean(tint) / (mean(kd) + mean(tint))
        ("coat_internal", "<f4"),  # coated diffuse: internal diffuse reflectance of the coat (fdr_int, or the rough coat's)
        ("coat_transmittance", "<f4", COAT_TABLE_RES),  # rough coat: external transmittance at cos = i / (RES - 1)
    ]
)
MATERIAL = Record("Material", MATERIAL_DTYPE)
# an object's material index; 1: smooth-shaded mesh; 1: a mesh whose vertex colours (VertexAttributes.colour) multiply its base colour
OBJECT_DTYPE = np.dtype([("material", "<i4"), ("smooth", "<i4"), ("vertex_colours", "<i4")])
OBJECT = Record("ObjectRecord", OBJECT_DTYPE)
# a light (scene/lights.py packs it; its units are in that module's docstring)
LIGHT_DTYPE = np.dtype(
    [
        ("type", "<i4"),  # LIGHT_TYPES code
        ("samples", "<i4"),  # area light: samples per side (n x n); RenderParams.light_samples > 0 overrides it
        ("intensity", "<f4"),
        ("falloff", "<i4"),  # LIGHT_FALLOFFS code
        ("position", "<f4", 3),  # point light: its position; area light: the corner its edges leave from
        ("direction", "<f4", 3),  # directional light: the direction light travels
        ("colour", "<f4", 3),  # linear RGB
        ("edge_a", "<f4", 3),  # area light: the parallelogram's edges from the corner
        ("edge_b", "<f4", 3),
        # spot light: position, and `direction` its unit axis; the cone's half-angles in radians and their cosines
        ("spot_cutoff", "<f4"),  # light stops beyond this angle from the axis
        ("spot_beam", "<f4"),  # full intensity within it
        ("spot_cos_cutoff", "<f4"),
        ("spot_cos_beam", "<f4"),
        ("spot_profile", "<i4"),  # SPOT_PROFILES code
    ]
)
LIGHT = Record("Light", LIGHT_DTYPE)
# per primitive id: a smooth triangle's unit normals at its vertices v0, v1, v2 (zeros for other primitives)
VERTEX_NORMALS_DTYPE = np.dtype([("normal", "<f4", (3, 3))])
VERTEX_NORMALS = Record("VertexNormals", VERTEX_NORMALS_DTYPE)
# per primitive id: a triangle's texture coordinates at v0, v1, v2 (TEXCOORD_0 in uv, TEXCOORD_1 in uv1; glTF's
# convention, (0, 0) the image's top-left) and linear RGB vertex colours (COLOR_0); zeros for uvs and ones for
# colours where a mesh has none, and for spheres
# and tangents for normal maps (xyz a unit vector along increasing u, w = +-1: bitangent = w normal x tangent, towards
# decreasing v, glTF's convention): glTF TANGENT, else generated per vertex from the UVs (trace/geometry.py vertex_tangents; zeros: none)
VERTEX_ATTRIBUTES_DTYPE = np.dtype([("uv", "<f4", (3, 2)), ("uv1", "<f4", (3, 2)), ("colour", "<f4", (3, 3)), ("tangent", "<f4", (3, 4))])
VERTEX_ATTRIBUTES = Record("VertexAttributes", VERTEX_ATTRIBUTES_DTYPE)
# an image texture (scene/textures.py packs them): its texels' first index in the one float4 texel buffer (row-major,
# row 0 the image's top, linear values), its size, the glTF sampler's wrap modes (WRAP_MODES codes) and 1 for
# nearest-texel lookups (magFilter NEAREST), 0 for bilinear
TEXTURE_DTYPE = np.dtype([("offset", "<i4"), ("width", "<i4"), ("height", "<i4"), ("wrap_s", "<i4"), ("wrap_t", "<i4"), ("nearest", "<i4")])
TEXTURE = Record("Texture", TEXTURE_DTYPE)
# an instance of a unique mesh (clrender/trace/instancing.py; docs/bvh.md, "Instancing"): rows of the affine
# maps (x' = M[:, :3] x + M[:, 3]), the mesh's bottom-level tree and primitives, and the scene object it is.
# A ray enters object space by world_to_object, its direction not renormalised, so t stays the world t.
INSTANCE_DTYPE = np.dtype(
    [
        ("world_to_object", "<f4", (3, 4)),
        ("object_to_world", "<f4", (3, 4)),
        ("bmin", "<f4", 3),  # the instance's world bounds (the top level's box)
        ("bmax", "<f4", 3),
        ("node_bytes", "<i4"),  # where the unique mesh's tree starts in the nodes' buffer, in bytes
        ("slot_base", "<i4"),  # its first slot: the tree's slots count from there
        ("n_prims", "<i4"),  # its primitives
        ("prim_base", "<i4"),  # this instance's first primitive id: hits report prim_base + local id
        ("object", "<i4"),  # the scene object (material, smooth flag)
        ("shape", "<i4"),  # index of the unique mesh
        ("data_base", "<i4"),  # its mesh's first entry in the per-primitive arrays (vertex normals, attributes): data_base + local id
    ]
)
INSTANCE = Record("Instance", INSTANCE_DTYPE)
# the camera (scene/camera.py, Camera.frame; kernels/camera.h, camera_ray), sx and sy going from -1 to 1 across the
# image.  Perspective: a pinhole ray leaves `origin` towards forward + sx right + sy up (the image plane at unit
# distance); orthographic: it leaves origin + sx right + sy up along forward.  A thin lens (aperture > 0) moves the
# ray's start to a point of the lens disc and aims it at where the pinhole ray meets the plane in focus.
CAMERA_DTYPE = np.dtype(
    [
        ("origin", "<f4", 3),  # the eye (the lens centre)
        ("forward", "<f4", 3),  # unit view direction
        ("right", "<f4", 3),  # unit right times the half-width of the image plane (orthographic: in world units)
        ("up", "<f4", 3),  # unit up times its half-height
        ("lens_right", "<f4", 3),  # unit right times the lens radius (0 for a pinhole)
        ("lens_up", "<f4", 3),  # unit up times the lens radius
        ("aperture", "<f4"),  # the lens radius; 0: a pinhole, which draws no random numbers
        ("focus_distance", "<f4"),  # distance along forward to the plane in focus
        ("projection", "<i4"),  # PROJECTIONS code
    ]
)
CAMERA = Record("Camera", CAMERA_DTYPE)
# per pixel: the object ids met along the path (depth-first order, -1 past its end), and the primary hit's facet
# (its primitive id on a flat-shaded mesh, where the shading jumps from face to face, else -1)
ID_RECORD_DTYPE = np.dtype([("path", "<i4", PATH_LEN), ("facet", "<i4")])
ID_RECORD = Record("IdRecord", ID_RECORD_DTYPE)
# per pixel, with -DWRITE_AOV=1: the primary hit's facts (trace/aov.py): the unit shading normal facing the camera,
# the distance along the ray, the material's kd; all 0 on a miss.  32 bytes: a fill pattern clears it.
AOV_DTYPE = padded([("normal", "<f4", 3), ("depth", "<f4"), ("albedo", "<f4", 3)], 32)
AOV = Record("AovRecord", AOV_DTYPE)

# the BSDF probe kernels' lobe parameters (tests only: clrender/trace/bsdf.py, kernels/bsdf_probe.cl)
# (then the issue 36 lobes' parameters and the Phong lobe's specular_prob, BsdfParams' fields of the same names;
# smith and nonlinear as 0.0 / 1.0)
BSDF_PROBE_DTYPE = np.dtype(
    [
        ("colour", "<f4", 3),
        ("alpha", "<f4"),
        ("eta", "<f4"),
        ("metallic", "<f4"),
        ("smith", "<f4"),
        ("nonlinear", "<f4"),
        ("eta3", "<f4", 3),
        ("k3", "<f4", 3),
        ("tint", "<f4", 3),
        ("transmit_tint", "<f4", 3),
        ("coat_weight", "<f4"),
        ("coat_internal", "<f4"),
        ("coat_transmittance", "<f4", COAT_TABLE_RES),
        ("specular_prob", "<f4"),
        ("lobe", "<f4"),  # the lobe's BSDF_LOBES code: a batch may mix lobes, as a packet of paths does
    ]
)
BSDF_PROBE = Record("BsdfProbeParams", BSDF_PROBE_DTYPE)

# ---- the path tracer (kernels/path.cl; packed by trace/path.py)
# an emissive triangle: its vertices (as the primitive slots hold them), area and primitive id (its chance of being
# NEE's light is its LightChoice record)
EMITTER_DTYPE = np.dtype([("v0", "<f4", 3), ("v1", "<f4", 3), ("v2", "<f4", 3), ("area", "<f4"), ("prim", "<i4")])
EMITTER = Record("Emitter", EMITTER_DTYPE)
# next-event estimation's one light a vertex (path.cl pick_light; packed by trace/light_choice.py): a record per light,
# the scene's lights, then the emissive triangles, then the environment; its probability (by power) and the running sum
LIGHT_CHOICE_DTYPE = np.dtype([("prob", "<f4"), ("cdf", "<f4")])
LIGHT_CHOICE = Record("LightChoice", LIGHT_CHOICE_DTYPE)
# the image-based environment light (kernels/envmap.h; packed by trace/envmap.py from scene/environment.py's map),
# passed by value beside its texels (float4: RGB radiance times intensity, and the texel's density over (u, v)),
# the sampling CDFs and their guides; width 0: no map (the path tracer's constant `environment`, the Whitted background)
ENV_MAP_DTYPE = np.dtype(
    [
        ("width", "<i4"),  # texels per row (u), 0: no map
        ("height", "<i4"),  # rows (v)
        ("cos_rotation", "<f4"),  # the map turned by `rotation` about +y: local = R_y(-rotation) world
        ("sin_rotation", "<f4"),
        ("sampled", "<i4"),  # 1: next-event estimation samples the map (0: a black map, nothing to sample)
        ("row_buckets", "<i4"),  # buckets of the marginal CDF's guide (a power of two; scene/environment.py guide)
        ("column_buckets", "<i4"),  # buckets of each conditional CDF's guide
    ]
)
ENV_MAP = Record("EnvMap", ENV_MAP_DTYPE)

# ---- the render kernels' launch (kernels/trace.cl render, path.cl render_path; packed by trace/integrators.py)
# A render kernel takes its buffers as a few arenas: one buffer each, whose regions a record below places by byte
# offset from the buffer's start (clrender/arena.py packs them); the kernel turns each offset into a typed pointer
# (common.h, REGION).  The Tracer's scene tables (trace/tracer.py): its small per-scene records
SCENE_TABLES_DTYPE = np.dtype([(name, "<u4") for name in ("instances", "top", "objects", "materials", "textures")])
SCENE_TABLES = Record("SceneTables", SCENE_TABLES_DTYPE)
# the ray-query kernels' values (trace.cl intersect_rays, occluded_rays; Tracer._query_params), passed by value
QUERY_PARAMS_DTYPE = np.dtype([("tables", SCENE_TABLES_DTYPE), ("n_prims", "<i4"), ("n_instances", "<i4"), ("n_rays", "<i4")])
QUERY_PARAMS = Record("QueryParams", QUERY_PARAMS_DTYPE)
# the renderer's world: the lights, the environment map's texels and sampling distribution (trace/envmap.py), the path
# tracer's emissive triangles and each primitive's index among them (trace/path.py), its light choice (trace/light_choice.py)
WORLD_REGIONS_DTYPE = np.dtype(
    [
        (name, "<u4")
        for name in ("lights", "env_texels", "env_marginal", "env_conditional", "env_guides", "emitters", "emitter_of_prim", "light_choices")
    ]
)
WORLD_REGIONS = Record("WorldRegions", WORLD_REGIONS_DTYPE)
# one launch's outputs, per pixel: colour (float4; the path tracer's film: SPLAT_SLOTS of them), IdRecord, a float per
# light of shadow (Whitted), uint2 BVH visits and rays, AovRecord (-DWRITE_AOV=1)
OUT_REGIONS_DTYPE = np.dtype([(name, "<u4") for name in ("colour", "ids", "shadow", "stats", "aov")])
OUT_REGIONS = Record("OutRegions", OUT_REGIONS_DTYPE)
# what every render launch of either integrator shares: the image, its pixels' samples, the scene's counts, and where
# the arenas' regions are
FRAME_PARAMS_DTYPE = np.dtype(
    [
        ("camera", CAMERA_DTYPE),
        ("env_map", ENV_MAP_DTYPE),  # width 0: no map (Whitted: escaping rays look it up; path: NEE samples it too)
        ("tables", SCENE_TABLES_DTYPE),
        ("world", WORLD_REGIONS_DTYPE),
        ("out", OUT_REGIONS_DTYPE),
        ("n_work", "<i4"),  # pixels in this launch (work-items past it return at once)
        ("width", "<i4"),  # the image's size in pixels
        ("height", "<i4"),
        ("sampler", "<i4"),  # SAMPLERS code
        ("samples_per_side", "<i4"),  # N: N x N samples per pixel (the path tracer: its pixel positions when spp is N^2)
        ("pixel_filter", "<i4"),  # PIXEL_FILTERS code
        ("seed", "<u4"),  # seeds every random number (kernels/rng.h)
        ("max_depth", "<i4"),  # bounces after the primary hit
        ("record", "<i4"),  # 1: write the first sample's ids, shadows and AOVs
        ("n_lights", "<i4"),
        ("n_prims", "<i4"),  # the flat part's primitives
        ("n_instances", "<i4"),  # instances (read by -DINSTANCED=1 kernels)
    ]
)
FRAME_PARAMS = Record("FrameParams", FRAME_PARAMS_DTYPE)
# the Whitted kernel's launch (trace.cl render), passed by value
WHITTED_PARAMS_DTYPE = np.dtype(
    [
        ("frame", FRAME_PARAMS_DTYPE),
        ("background", "<f4", 3),  # linear RGB of a ray that meets nothing
        ("ambient", "<f4", 3),  # ambient light, times each surface's kd
        ("fresnel", "<i4"),  # 0: transparency splits by its fixed fraction; 1: Schlick
        ("light_samples", "<i4"),  # > 0: every area light's samples per side; 0: each light's own
        ("light_stratified", "<i4"),  # 1: one jittered sample per cell of an area light; 0: uniform random
    ]
)
WHITTED_PARAMS = Record("WhittedParams", WHITTED_PARAMS_DTYPE)
# the path kernel's launch (path.cl render_path), passed by value
PATH_PARAMS_DTYPE = np.dtype(
    [
        ("frame", FRAME_PARAMS_DTYPE),
        ("environment", "<f4", 3),  # radiance from every direction that meets nothing
        ("n_emitters", "<i4"),
        ("spp", "<i4"),  # paths per pixel in this pass
        ("first_sample", "<u4"),  # index of the pass's first path in each pixel's sequence (passes * spp; below 2**32)
        ("rr_depth", "<i4"),  # Russian roulette from this many bounces on (RenderSettings.rr_depth; Mitsuba's rr_depth - 1)
    ]
)
PATH_PARAMS = Record("PathParams", PATH_PARAMS_DTYPE)
# one path in flight, as both of the path tracer's schedules step it (kernels/path.cl; docs/lanes.md): the megakernel
# keeps it in private memory, the wavefront (kernels/wavefront.cl, trace/wavefront.py) one record a slot in a buffer
PATH_STATE_DTYPE = np.dtype(
    [
        ("o", "<f4", 3),  # the ray the extend step traces next
        ("d", "<f4", 3),
        ("beta", "<f4", 3),  # throughput
        ("eta_scale", "<f4"),  # the product of eta^2 over the path's refractions: Russian roulette's beta x eta_scale
        ("radiance", "<f4", 3),  # this sample's radiance so far
        ("prev_n", "<f4", 3),  # the previous vertex's shading normal (the constant environment's MIS)
        ("prev_pdf", "<f4"),  # the previous lobe's density of the ray's direction
        ("prev_delta", "<i4"),  # 1: the previous lobe was a delta (or the ray is the camera's)
        ("depth", "<i4"),  # bounces after the primary hit
        ("live", "<i4"),  # wavefront: 1 while the slot's pixel has a path in flight
        ("ended", "<i4"),  # wavefront: 1 once the path ended at this vertex (its shadow ray still to add)
        ("pixel", "<i4"),  # the image pixel whose samples the path's slot takes
        ("sample", "<u4"),  # the path's sample index in this pass (first_sample + sample in the pixel's sequence)
        ("rng_dim", "<u4"),  # the path's Rng beyond (seed, pixel, sample): kernels/rng.h
        ("rng_base", "<u4"),
        ("rng_extra", "<u4"),
        ("off", "<f4", 2),  # the sample's position in its pixel
        ("weight", "<f4"),  # its pixel filter weight
        ("hit_t", "<f4"),  # the extend step's hit (kernels/intersect.h Hit)
        ("hit_slot", "<i4"),
        ("hit_id", "<i4"),
        ("hit_u", "<f4"),
        ("hit_v", "<f4"),
        ("hit_instance", "<i4"),
        ("fh_normal", "<f4", 3),  # the sample's first hit (path.cl FirstHit)
        ("fh_albedo", "<f4", 3),
        ("fh_depth", "<f4"),
        ("fh_object", "<i4"),
        ("shadowed", "<i4"),  # 1: NEE left a shadow ray below to trace
        ("shadow_o", "<f4", 3),
        ("shadow_d", "<f4", 3),
        ("shadow_t_max", "<f4"),
        ("shadow_l", "<f4", 3),  # NEE's estimate, which the shadow ray adds (times shadow_beta) if nothing blocks it
        ("shadow_beta", "<f4", 3),  # the throughput at the shadow ray's vertex
        ("sum", "<f4", 3),  # the pixel's filtered sums over its finished samples
        ("weight_sum", "<f4"),
        ("normal_sum", "<f4", 3),
        ("albedo_sum", "<f4", 3),
        ("first_object", "<i4"),  # the pixel's first sample's first hit, for its id and depth AOV
        ("first_depth", "<f4"),
        ("visits", "<u4"),  # the pixel's BVH visits and rays
        ("rays", "<u4"),
    ]
)
PATH_STATE = Record("PathState", PATH_STATE_DTYPE)

# ---- splats (kernels/splat_gauss.cl, splat_voronoi.cl; packed by splat/*.py)
# A Gaussian splat as the host uploads it: GaussParams' groups, under the same names (splat/gauss.py) ...
SPLAT_PARAMS_DTYPE = np.dtype([("xy", "<f4", 2), ("log_scale", "<f4", 2), ("theta", "<f4"), ("color", "<f4", 3), ("lum", "<f4"), ("opacity", "<f4")])
SPLAT_PARAMS = Record("SplatParams", SPLAT_PARAMS_DTYPE)
# ... and the three records splat_prepare makes of it.  The splat: its centre (mx, my); the quadratic form
# q = A dx^2 + B2 dx dy + C dy^2 of its inverse covariance S^-1 (B2 twice the off-diagonal); its opacity; and
# q along pixel row dy as a parabola in x, A (x - xc)^2 + row_q dy^2 with xc = mx + row_shift dy
# (row_shift = Sxy / Syy, row_q = 1 / Syy; splat_forward)
GAUSS_SPLAT_DTYPE = np.dtype([(name, "<f4") for name in ("mx", "my", "A", "B2", "C", "opacity", "log2_opacity", "row_shift", "row_q")])
GAUSS_SPLAT = Record("GaussSplat", GAUSS_SPLAT_DTYPE)
SPLAT_COLOR_DTYPE = np.dtype({"names": ["r", "g", "b"], "formats": ["<f4"] * 3, "offsets": [0, 4, 8], "itemsize": 16})  # luminance * colour
SPLAT_COLOR = Record("SplatColor", SPLAT_COLOR_DTYPE)
# the pixels [x0, x1) x [y0, y1) whose centres may lie in the 3-sigma ellipse (q < 9), clipped to the image
SPLAT_BOX_DTYPE = np.dtype([("x0", "<i4"), ("y0", "<i4"), ("x1", "<i4"), ("y1", "<i4")])
SPLAT_BOX = Record("SplatBox", SPLAT_BOX_DTYPE)
# one splat-tile entry of the backward kernel: d/d(mean x, y), d/d(A, B2, C) of the inverse covariance,
# d/d(colour), d/d(opacity), and the splat's summed weight over the tile
SPLAT_GRAD_DTYPE = np.dtype(
    [("mean", "<f4", 2), ("A", "<f4"), ("B2", "<f4"), ("C", "<f4"), ("color", "<f4", 3), ("opacity", "<f4"), ("weight", "<f4")]
)
SPLAT_GRAD = Record("SplatGrad", SPLAT_GRAD_DTYPE)
# splat_voronoi.cl keeps OpenCL vectors where it does vector math on the whole value: a site is a float2
# (x, y) in pixels, and so is each (pixel, neighbour) gradient of a site's position; a soft model's colour,
# each pixel's blend and dL/dblend are float4s of up to 4 channels, the unused ones 0.

# ---- BVH build (kernels/bvh_build.cl; packed by trace/bvh.py)
# The builder bounds boxes with lane-wise float4 min and max, so its boxes are float4 vectors: lanes x, y,
# z, and a w lane that means nothing unless said here.
# a primitive slot: the primitive's box, its id in lo's w lane (int32 bits), hi.w 0
BUILD_PRIM_DTYPE = np.dtype([("lo", "<f4", 4), ("hi", "<f4", 4)])
BUILD_PRIM = Record("BuildPrim", BUILD_PRIM_DTYPE, ("lo", "hi"))
# a node's bounds: of its primitives' boxes (bmin, bmax) and of their lo + hi, twice their centroids
# (cmin, cmax: only comparisons and ranges of centroids matter)
BUILD_BOUNDS_DTYPE = np.dtype([(name, "<f4", 4) for name in ("bmin", "bmax", "cmin", "cmax")])
BUILD_BOUNDS = Record("BuildBounds", BUILD_BOUNDS_DTYPE, ("bmin", "bmax", "cmin", "cmax"))
# a node to split, or whose subtree to build: its primitives' first slot and count, its tree level (the
# root's 1), and the node its subtree starts at (build_subtree; split_level ignores it)
BUILD_TASK_DTYPE = np.dtype([("first", "<i4"), ("count", "<i4"), ("level", "<i4"), ("first_node", "<i4")])
BUILD_TASK = Record("BuildTask", BUILD_TASK_DTYPE)
# the split rules every split_level and build_subtree launch of one SAH build takes (trace/bvh.py): nodes of at most
# max_leaf primitives are leaves, and so are nodes of at most leaf_cap whose best cut costs more than the leaf,
# except that a large primitive, whose box has at least large_area half surface area measured with its sides times
# root_unit (1 / the root box's longest side, so that no scale of the scene overflows it), shares its leaf with at
# most one other; nodes of more than `samples` bin an evenly strided sample of that many; nodes of at most
# halving_below are split in halves; max_levels is the tree's level cap, root included
BUILD_RULES_DTYPE = np.dtype(
    [
        *[(name, "<i4") for name in ("max_leaf", "leaf_cap", "samples", "halving_below", "max_levels")],
        *[(name, "<f4") for name in ("large_area", "root_unit")],
    ]
)
BUILD_RULES = Record("BuildRules", BUILD_RULES_DTYPE)
# a built subtree's move to its depth-first place: `nodes` nodes from scratch node `source` to node `target`
SUBTREE_MOVE_DTYPE = np.dtype([("source", "<i4"), ("target", "<i4"), ("nodes", "<i4")])
SUBTREE_MOVE = Record("SubtreeMove", SUBTREE_MOVE_DTYPE)

DEFINES = {
    "PATH_LEN": PATH_LEN,
    **{f"LIGHT_{name.upper()}": code for name, code in LIGHT_TYPES.items()},
    **{f"SPOT_PROFILE_{name.upper()}": code for name, code in SPOT_PROFILES.items()},
    **{f"SMITH_{name.upper()}": code for name, code in SMITH_MODELS.items()},
    "COAT_TABLE_RES": COAT_TABLE_RES,
    **{f"MATERIAL_MODEL_{name.upper()}": code for name, code in MATERIAL_MODELS.items()},
    **{f"BSDF_{name.upper()}": code for name, code in BSDF_LOBES.items()},
    **{f"LIGHT_FALLOFF_{name.upper()}": code for name, code in LIGHT_FALLOFFS.items()},
    **{f"SAMPLER_{name.upper()}": code for name, code in SAMPLERS.items()},
    **{f"PATH_SAMPLER_{name.upper()}": code for name, code in PATH_SAMPLERS.items()},
    **{f"PIXEL_FILTER_{name.upper()}": code for name, code in PIXEL_FILTERS.items()},
    **{f"PROJECTION_{name.upper()}": code for name, code in PROJECTIONS.items()},
    **{f"TEXTURE_{name.upper()}": code for name, code in TEXTURE_SLOTS.items()},
    "TEXTURE_SLOTS": len(TEXTURE_SLOTS),
    **{f"WRAP_{name.upper()}": code for name, code in WRAP_MODES.items()},
    **{f"ALPHA_{name.upper()}": code for name, code in ALPHA_MODES.items()},
    "SPLAT_TILE": SPLAT_TILE,
    "SPLAT_EPS": SPLAT_EPS,
    "VORONOI_STRIP": VORONOI_STRIP,
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
