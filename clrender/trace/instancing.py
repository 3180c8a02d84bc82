"""Instancing: which scene objects are copies of one object-space mesh, and where each copy is.

Objects that name the same mesh file, glTF node or built-in generator with the same params (scene.py
gives each such Mesh a `shape_key`, its shared `local_vertices` and its `to_world` matrix) are one
*shape* placed by several *instances*.  A two-level BVH stores each shape's triangles and tree once
(the bottom level, in object space) and a small top-level tree over the instances' world bounds; at an
instance leaf the ray goes into object space by the inverse affine map, its direction not
renormalised, so the distance t it finds is the world one (docs/bvh.md, "Instancing").

Here: `find_instances` groups the objects; `flat_part` is the scene without them (flattened as
usual, clrender/trace/geometry.py); `two_level` appends each unique mesh's tree and slots to the flat
part's and packs one layout.INSTANCE_DTYPE record per instance; the Tracer (Tracer(instancing=True))
builds the top level over the records' world boxes with its own builder and uploads them in that
tree's leaf order (kernels/intersect.h walk_instances reads them).

Primitive ids: the flat part's 0..n_flat-1, then each instance's prim_base + local id (instances in
object order, each as many ids as its mesh has triangles), so every hit's id is unique.

Renders (renderer.py; docs/bvh.md, "Instancing"): the per-primitive records (vertex normals, uvs,
colours, tangents) are the flat part's, then each shape's once in object space (`shape_meshes`), read at the
instance's data_base + local id; `worth_instancing` decides for a render whose settings leave it open;
objects of emissive materials stay flat (`emissive`), where the path tracer's emitter list finds them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import UsageError
from ..layout import INSTANCE_DTYPE, PRIM_SLOT_DTYPE, VERTEX_NORMALS_DTYPE, WIDE_NODE8
from ..scene.scene import Mesh, Scene, mirrored_faces

MIN_COPIES = 2  # a shape used once is left in the flat part of the scene: instancing it saves nothing
# renders (RenderSettings.instancing None) instance by themselves when the copies beyond each shape's first
# stand for at least this many triangles: then the memory saved (~150 bytes a triangle, flat_bytes) is
# megabytes; below it a second tree level would cost time for little (and small scenes keep their bits)
AUTO_MIN_TRIANGLES = 20_000
# bytes per primitive of the flat layout beyond its slot: object id, vertex normals, about one 8-wide
# node per 4 primitives (256 bytes / 4 leaves of ~4) and the leaf blocks' copy of the vertices (148 / 4)
FLAT_EXTRA_BYTES = 4 + VERTEX_NORMALS_DTYPE.itemsize + 64 + 37


@dataclass
class Shape:
    """One object-space mesh that several objects place."""

    key: tuple  # scene.py's _shape_key
    vertices: np.ndarray  # (V, 3) float64, object space
    faces: np.ndarray  # (F, 3) int64
    prim_base: int  # its first primitive id in the unique meshes' concatenation
    objects: list = field(default_factory=list)  # scene object ids of its instances
    bounds: tuple | None = None  # (lo, hi) object-space box, set by two_level


@dataclass
class Instances:
    shapes: list  # Shape, in order of first use
    records: np.ndarray  # layout.INSTANCE_DTYPE, one per instanced object, in object order
    flat_objects: list  # object ids that stay flat (spheres, inline meshes, shapes used once)
    matrices: dict = field(default_factory=dict)  # object id -> float64 (4, 4) object-to-world

    @property
    def unique_triangles(self) -> int:
        return sum(len(s.faces) for s in self.shapes)

    @property
    def instanced_triangles(self) -> int:
        """Triangles the instances stand for (what a flat scene stores for them)."""
        return sum(len(s.faces) * len(s.objects) for s in self.shapes)


def affine_rows(matrix: np.ndarray) -> np.ndarray:
    """The top 3 rows (3x4) of a 4x4 affine matrix."""
    return np.asarray(matrix, np.float64)[:3, :4]


def inverse_affine(matrix: np.ndarray) -> np.ndarray:
    """The 4x4 inverse of an affine matrix (scale, rotate, translate: never singular in a scene,
    scene.py refuses scale factors below MIN_LENGTH)."""
    m = np.asarray(matrix, np.float64)
    inv = np.eye(4)
    inv[:3, :3] = np.linalg.inv(m[:3, :3])
    inv[:3, 3] = -inv[:3, :3] @ m[:3, 3]
    return inv


# An object whose placing matrix is this close to singular stays flat (scene.py placed its vertices in float64):
# its inverse, which carries rays into object space in float32, would overflow or lose the copy (a node scaled
# by 0 along an axis, or by 1e-30); the flat scene renders it as any other mesh.  Singular values of the linear
# part must lie in [INSTANCE_SCALE_MIN, 1 / INSTANCE_SCALE_MIN] and within INSTANCE_CONDITION_MAX of each other.
INSTANCE_SCALE_MIN = 1e-6
INSTANCE_CONDITION_MAX = 1e6


def instanceable(to_world) -> bool:
    """Whether an object placed by `to_world` may be an instance (see INSTANCE_SCALE_MIN)."""
    m = np.asarray(to_world, np.float64)[:3, :3]
    if not np.isfinite(m).all():
        return False
    sv = np.linalg.svd(m, compute_uv=False)
    return bool(sv.min() >= INSTANCE_SCALE_MIN and sv.max() <= 1 / INSTANCE_SCALE_MIN and sv.max() <= INSTANCE_CONDITION_MAX * sv.min())


def emissive(scene: Scene, obj) -> bool:
    """Whether an object's material emits: such objects stay flat, where the path tracer's emitter list
    (clrender/trace/path.py) finds each of their triangles in world space."""
    material = scene.materials.get(obj.material)
    return material is not None and max(material.emission) > 0


def find_instances(scene: Scene, min_copies: int = MIN_COPIES) -> Instances:
    """The scene's shapes used by at least `min_copies` objects, and one Instance record per such object
    (objects of emissive materials stay flat: `emissive`)."""
    by_key: dict = {}
    for oid, obj in enumerate(scene.objects):
        placed = isinstance(obj, Mesh) and obj.shape_key is not None and obj.to_world is not None
        if placed and not emissive(scene, obj) and instanceable(obj.to_world):
            by_key.setdefault(obj.shape_key, []).append(oid)
    shapes, rows, flat, matrices = [], [], set(range(len(scene.objects))), {}
    base = 0
    for key, oids in by_key.items():
        if len(oids) < min_copies:
            continue
        first = scene.objects[oids[0]]
        faces = mirrored_faces(first.faces) if np.linalg.det(first.to_world[:3, :3]) < 0 else first.faces  # object space
        shape = Shape(key, first.local_vertices, faces, base, list(oids))
        base += len(first.faces)
        for oid in oids:
            to_world = scene.objects[oid].to_world
            matrices[oid] = np.asarray(to_world, np.float64)
            rows.append((affine_rows(inverse_affine(to_world)), affine_rows(to_world), 0, 0, -1, 0, 0, shape.prim_base, oid, len(shapes), 0))
            flat.discard(oid)
        shapes.append(shape)
    records = np.array(rows, INSTANCE_DTYPE) if rows else np.zeros(0, INSTANCE_DTYPE)
    records = records[np.argsort(records["object"], kind="stable")]
    return Instances(shapes, records, sorted(flat), matrices)


def object_space(vectors: np.ndarray, to_world: np.ndarray, normals: bool) -> np.ndarray:
    """World vectors back in object space, unit length: normals by M^T (their world ones are M^-T n),
    tangents by M^-1 (theirs are M t); M the linear part of to_world."""
    m = np.asarray(to_world, np.float64)[:3, :3]
    v = np.asarray(vectors, np.float64) @ (m if normals else np.linalg.inv(m).T)
    return v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-30)


def shape_meshes(scene: Scene, instances: Instances) -> list:
    """Each shape as one object-space Mesh that carries what its triangles' per-primitive records need
    (vertex normals, uvs, vertex colours, tangents): the render kernels read them at the instance's
    data_base + local id and turn normals and tangents to world space per hit (kernels/intersect.h)."""
    out = []
    for shape in instances.shapes:
        objs = [scene.objects[o] for o in shape.objects]
        first = objs[0]
        smooth = [o for o in objs if o.smooth and o.has_vertex_normals]  # the first one's world normals are made, no other's
        normals = object_space(smooth[0].vertex_normals, smooth[0].to_world, True) if smooth else None
        tangents = first.tangents
        if tangents is not None:
            tangents = np.concatenate([object_space(tangents[:, :3], first.to_world, False), np.asarray(tangents)[:, 3:]], 1)
        out.append(Mesh(shape.vertices, shape.faces, normals, "default", bool(smooth), first.source, first.uvs, first.uvs1, first.colours, tangents))
    return out


def instanced_object_flags(objects: np.ndarray, scene: Scene, instances: Instances) -> None:
    """The ObjectRecords of the instanced objects (flat_part made them empty meshes): smooth and vertex-colour flags as flatten sets them."""
    for oid in instances.records["object"]:
        obj = scene.objects[int(oid)]
        objects[oid]["smooth"] = int(obj.smooth and obj.has_vertex_normals)  # not obj.vertex_normals: each copy's would be made
        objects[oid]["vertex_colours"] = int(obj.colours is not None)


def worth_instancing(scene: Scene) -> bool:
    """Whether a render of `scene` instances by itself (AUTO_MIN_TRIANGLES)."""
    inst = find_instances(scene)
    return inst.instanced_triangles - inst.unique_triangles >= AUTO_MIN_TRIANGLES


def flat_bytes(triangles: int) -> int:
    """About what the flat layout keeps on the device for `triangles` triangles."""
    return triangles * (PRIM_SLOT_DTYPE.itemsize + FLAT_EXTRA_BYTES)


def instanced_bytes(instances: Instances, flat_triangles: int = 0) -> int:
    """About what a two-level layout would keep: each shape once, one record per instance, and the
    flat rest (a top-level node per instance is within the record's bytes)."""
    per_instance = INSTANCE_DTYPE.itemsize + 64
    return flat_bytes(instances.unique_triangles + flat_triangles) + len(instances.records) * per_instance


# every part of the nodes' buffer starts at a multiple of this (a WideNode8's size, also a multiple of
# a BvhNode's and a LeafBlock's): each tree is read through a pointer to its start (instance_geometry)
TREE_ALIGN = WIDE_NODE8.dtype.itemsize
# an instance's world box is widened by this fraction of its size and position: the ray's float32
# transform into object space errs by a few ulps, which the box must not cull
BOX_SLACK = 1e-5


def flat_part(scene: Scene, instances: Instances) -> Scene:
    """The scene with each instanced object an empty mesh (object ids and materials kept)."""
    from dataclasses import replace

    placed = set(int(o) for o in instances.records["object"])
    objects = [Mesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), None, o.material) if i in placed else o for i, o in enumerate(scene.objects)]
    return replace(scene, objects=objects)


def world_bounds(lo: np.ndarray, hi: np.ndarray, to_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The world box of an object-space box's eight corners placed by to_world, widened by BOX_SLACK."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])], np.float64)
    world = corners @ to_world[:3, :3].T + to_world[:3, 3]
    w_lo, w_hi = world.min(axis=0), world.max(axis=0)
    slack = BOX_SLACK * (np.abs(w_lo) + np.abs(w_hi) + (w_hi - w_lo)).max()
    return np.nextafter((w_lo - slack).astype(np.float32), -np.inf), np.nextafter((w_hi + slack).astype(np.float32), np.inf)


def _padded(buffer: np.ndarray) -> np.ndarray:
    raw = np.ascontiguousarray(buffer).view(np.uint8).reshape(-1)
    return np.concatenate([raw, np.zeros(-len(raw) % TREE_ALIGN, np.uint8)])


def two_level(instances: Instances, flat_nodes, flat_slots, n_flat: int, build_tree):
    """The nodes' buffer (the flat part's tree, then each unique mesh's, object space), the slots (likewise)
    and the instances' records.  build_tree(Primitives) -> (tree buffer, slots): the Tracer's builder."""
    from ..scene.scene import Scene as _Scene
    from .geometry import flatten

    parts, slot_parts = [_padded(flat_nodes)], [flat_slots]
    node_at, slot_at, counts = [], [], []
    offset, slot_offset = len(parts[0]), len(flat_slots)
    for shape in instances.shapes:
        prims = flatten(_Scene(objects=[Mesh(shape.vertices, shape.faces)]))
        nodes, slots = build_tree(prims)
        node_at.append(offset)
        slot_at.append(slot_offset)
        counts.append(prims.count)
        lo, hi = shape.vertices.min(axis=0), shape.vertices.max(axis=0)
        shape.bounds = (lo, hi)
        parts.append(_padded(nodes))
        slot_parts.append(slots)
        offset += len(parts[-1])
        slot_offset += len(slots)
    records = instances.records.copy()
    prim_base = n_flat
    for i in range(len(records)):
        r = records[i : i + 1]
        k = int(r["shape"][0])
        r["node_bytes"], r["slot_base"], r["n_prims"], r["prim_base"] = node_at[k], slot_at[k], counts[k], prim_base
        r["data_base"] = n_flat + instances.shapes[k].prim_base  # the shapes' records follow the flat part's (Tracer)
        prim_base += counts[k]
        r["bmin"][0], r["bmax"][0] = world_bounds(*instances.shapes[k].bounds, instances.matrices[int(r["object"][0])])
    if offset >= 2**31 or prim_base >= 2**31:
        raise UsageError(f"an instanced scene of {prim_base} primitive ids and {offset} bytes of trees; allowed: below 2^31 of each")
    slots = np.zeros(slot_offset, flat_slots.dtype)  # not np.concatenate: it drops the record's padding
    at = 0
    for part in slot_parts:
        slots[at : at + len(part)] = part
        at += len(part)
    return np.concatenate(parts), slots, records
