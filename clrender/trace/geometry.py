"""Flatten a Scene into the primitive arrays the kernels read.

Primitive ids count triangles first (every mesh in object order), then
spheres; `object_of[id]` gives the scene object each primitive belongs to.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..device import aligned_zeros
from ..layout import MATERIAL_DTYPE, OBJECT_DTYPE, PRIM_SLOT_DTYPE, SPHERE_SLOT_DTYPE, TEXTURE_SLOTS, VERTEX_ATTRIBUTES_DTYPE
from ..scene.scene import Mesh, Scene, Sphere

CHUNK = 1 << 18  # triangles gathered at a time: float64 temporaries of ~19 MB, not 72 B per triangle at once


@dataclass
class Primitives:
    meshes: list  # (vertices (V, 3) float64, faces (F, 3) int) per mesh, the scene's own arrays (not copied)
    smooth: list  # per mesh: its (V, 3) vertex normals when it is shaded smooth, else None
    mesh_objects: list  # per mesh: the Mesh it came from (its uvs, vertex colours and tangents)
    spheres: np.ndarray  # (S, 4) float64 centre and radius
    object_of: np.ndarray  # (T + S,) int32 object id per primitive id
    objects: np.ndarray  # (O,) layout.OBJECT_DTYPE records: material index and smooth flag
    materials: np.ndarray  # (M,) layout.MATERIAL_DTYPE records
    material_names: list
    textures: list = None  # the scene's decoded textures (scene/textures.py), which the materials index
    any_attributes: bool = False  # Scene.has_vertex_attributes: the kernels may read VertexAttributes records

    @property
    def n_triangles(self) -> int:
        return sum(len(f) for _, f in self.meshes)

    @property
    def count(self) -> int:
        return self.n_triangles + len(self.spheres)

    def triangles_at(self, ids: np.ndarray) -> np.ndarray:
        """(len(ids), 3, 3) float64 vertices of triangles `ids` (primitive ids below n_triangles)."""
        out = np.empty((len(ids), 3, 3))
        first = 0
        for v, f in self.meshes:
            mine = (ids >= first) & (ids < first + len(f))
            out[mine] = v[f[ids[mine] - first]]
            first += len(f)
        return out

    @property
    def triangles(self) -> np.ndarray:
        """(T, 3, 3) float64 vertices of every triangle (made on each call: 72 bytes a triangle)."""
        return np.concatenate([v[f] for v, f in self.meshes]) if self.meshes else np.zeros((0, 3, 3))

    @property
    def any_smooth(self) -> bool:
        return any(n is not None for n in self.smooth)

    def triangle_normals_into(self, out: np.ndarray) -> None:
        """Write the (3, 3) float32 vertex normals of every smooth mesh's triangles into out[id] (zeros stay for flat ones)."""
        first = 0
        for (_, f), n in zip(self.meshes, self.smooth):
            for lo in range(0, len(f) if n is not None else 0, CHUNK):
                out[first + lo : first + min(lo + CHUNK, len(f))] = n[f[lo : lo + CHUNK]].astype(np.float32)
            first += len(f)

    def triangle_attributes_into(self, out: np.ndarray, tangents: list | None = None) -> None:
        """Write every triangle's VertexAttributes record into out[id] (uvs zeros and colours ones where none).
        tangents: per mesh, whether a normal map reads its tangents (None: each mesh's material says); tangents
        are generated from the UVs only there (zeros elsewhere: nothing reads them)."""
        first = 0
        if tangents is None:
            normal_mapped = self.normal_mapped_materials()
            tangents = [m.material in normal_mapped for m in self.mesh_objects]
        for m, needs_tangents in zip(self.mesh_objects, tangents):
            out[first : first + len(m.faces)] = _attributes(m, needs_tangents)
            first += len(m.faces)

    def normal_mapped_materials(self) -> set:
        """The names of the materials with a normal map (layout.TEXTURE_SLOTS "normal"), which read tangents."""
        slot = TEXTURE_SLOTS["normal"]
        return {name for name, record in zip(self.material_names, self.materials) if record["textures"][slot] >= 0}

    def bounds(self):
        """Per-primitive axis-aligned bounds (lo, hi), each (N, 3) float32, conservatively rounded."""
        lo, hi = np.empty((self.count, 3), np.float32), np.empty((self.count, 3), np.float32)
        first = 0
        for v, f in self.meshes:
            for a in range(0, len(f), CHUNK):
                tri = v[f[a : a + CHUNK]]
                rows = slice(first + a, first + a + len(tri))
                lo[rows], hi[rows] = tri.min(axis=1), tri.max(axis=1)  # float64 min, then rounded once
            first += len(f)
        c, r = self.spheres[:, :3], self.spheres[:, 3:4]
        lo[first:], hi[first:] = c - r, c + r
        # float32 rounding must never shrink a box
        return np.nextafter(lo, -np.inf, out=lo), np.nextafter(hi, np.inf, out=hi)


def flatten(scene: Scene) -> Primitives:
    names = list(scene.materials)
    index = {n: i for i, n in enumerate(names)}
    materials = np.array([scene.materials[n].pack() for n in names], MATERIAL_DTYPE)
    objects = np.zeros(max(len(scene.objects), 1), OBJECT_DTYPE)
    meshes, smooth, mesh_objects, tri_obj, spheres, sphere_obj = [], [], [], [], [], []
    for oid, obj in enumerate(scene.objects):
        objects[oid]["material"] = index[obj.material]
        if isinstance(obj, Sphere):
            spheres.append([*obj.center, obj.radius])
            sphere_obj.append(oid)
            continue
        assert isinstance(obj, Mesh)
        objects[oid]["smooth"] = int(obj.smooth and obj.vertex_normals is not None)
        meshes.append((obj.vertices, obj.faces))
        smooth.append(obj.vertex_normals if objects[oid]["smooth"] else None)
        mesh_objects.append(obj)
        objects[oid]["vertex_colours"] = int(obj.colours is not None)
        tri_obj.append(np.full(len(obj.faces), oid, np.int32))
    object_of = np.concatenate([*tri_obj, np.asarray(sphere_obj, np.int32)]).astype(np.int32)
    spheres = np.asarray(spheres, np.float64).reshape(-1, 4)
    textures = list(getattr(scene, "textures", []))
    return Primitives(meshes, smooth, mesh_objects, spheres, object_of, objects, materials, names, textures, scene.has_vertex_attributes)


def _attributes(mesh: Mesh, needs_tangents: bool = True) -> np.ndarray:
    """A mesh's VertexAttributes records, one a face: its uvs (zeros without) and colours (ones without), and
    its tangents where it has them or, when a normal map needs them, from its UVs (vertex_tangents)."""
    out = np.zeros(len(mesh.faces), VERTEX_ATTRIBUTES_DTYPE)
    out["colour"] = 1.0
    for name, values in (("uv", mesh.uvs), ("uv1", mesh.uvs1), ("colour", mesh.colours), ("tangent", mesh.tangents)):
        if values is not None:
            out[name] = np.asarray(values)[mesh.faces]
    if mesh.tangents is None and mesh.uvs is not None and needs_tangents:
        normals = mesh.vertex_normals if mesh.smooth and mesh.vertex_normals is not None else None
        out["tangent"] = vertex_tangents(mesh.vertices, mesh.faces, np.asarray(mesh.uvs), normals)
    return out


def _corner_angles(tri: np.ndarray) -> np.ndarray:
    """(F, 3) the triangle's angle at each corner (0 for degenerate ones)."""
    out = np.zeros(tri.shape[:2])
    for k in range(3):
        a, b = tri[:, (k + 1) % 3] - tri[:, k], tri[:, (k + 2) % 3] - tri[:, k]
        out[:, k] = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
    return out


def vertex_tangents(vertices: np.ndarray, faces: np.ndarray, uvs: np.ndarray, normals: np.ndarray | None) -> np.ndarray:
    """(F, 3, 4) tangents at each face's corners, generated as MikkTSpace does (Mikkelsen 2008), so that normal maps
    baked with it show no seams: each face's tangent (face_tangents) is projected into the plane of each corner's
    normal (the vertex normal, or the face's without `normals`) and summed, weighted by the corner's angle, over
    the corners that share position, normal, UV and handedness (welded by value, as MikkTSpace does, so split
    vertices join again); the sum, made orthogonal to the normal (Gram-Schmidt) and unit, is the corner's tangent,
    w its handedness.  Corners whose group has no usable face get zeros (the kernel then keeps the unmapped normal)."""
    tri, uv = vertices[faces].astype(np.float64), uvs[faces].astype(np.float64)
    face_t = face_tangents(tri, uv)  # (F, 4): unit tangent, handedness (0: degenerate UVs)
    face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    face_n /= np.maximum(np.linalg.norm(face_n, axis=1, keepdims=True), 1e-300)
    n = normals[faces].astype(np.float64) if normals is not None else np.repeat(face_n[:, None], 3, axis=1)
    sign = np.where(face_t[:, 3] < 0, -1.0, 1.0)
    keys = np.concatenate([tri, n, uv, np.repeat(sign[:, None, None], 3, axis=1)], axis=2).reshape(-1, 9)
    _, group = np.unique(keys, axis=0, return_inverse=True)
    group = group.reshape(-1)
    n_flat = n.reshape(-1, 3)
    t = np.repeat(face_t[:, None, :3], 3, axis=1).reshape(-1, 3)
    t_proj = t - n_flat * np.einsum("ij,ij->i", n_flat, t)[:, None]
    length = np.linalg.norm(t_proj, axis=1, keepdims=True)
    weight = (_corner_angles(tri) * (face_t[:, 3:] != 0)).reshape(-1, 1)
    contribution = np.where(length > 1e-12, t_proj / np.maximum(length, 1e-300), 0.0) * weight
    summed = np.zeros((group.max() + 1 if len(group) else 0, 3))
    np.add.at(summed, group, contribution)
    tangent = summed[group]
    tangent -= n_flat * np.einsum("ij,ij->i", n_flat, tangent)[:, None]
    length = np.linalg.norm(tangent, axis=1, keepdims=True)
    usable = (length[:, 0] > 1e-12) & np.isfinite(tangent).all(axis=1)
    out = np.zeros((len(group), 4))
    out[usable, :3] = tangent[usable] / length[usable]
    out[usable, 3] = np.repeat(sign, 3)[usable]
    return out.reshape(-1, 3, 4)


def face_tangents(tri: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """(F, 4) per-triangle tangents from the UV derivatives (MikkTSpace's per-face step, without its welding):
    xyz the unit direction of increasing u, w = +-1 so that w n x t points towards decreasing v (up the image,
    glTF's convention for the green channel), n the face normal; zeros where the UVs are degenerate."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    du1, dv1 = uv[:, 1, 0] - uv[:, 0, 0], uv[:, 1, 1] - uv[:, 0, 1]
    du2, dv2 = uv[:, 2, 0] - uv[:, 0, 0], uv[:, 2, 1] - uv[:, 0, 1]
    det = du1 * dv2 - du2 * dv1
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(det != 0, 1.0 / det, 0.0)[:, None]
        t = (e1 * dv2[:, None] - e2 * dv1[:, None]) * r  # d position / d u
        b = (e2 * du1[:, None] - e1 * du2[:, None]) * r  # d position / d v: down the image
        length = np.linalg.norm(t, axis=1, keepdims=True)
        t = np.where(length > 0, t / np.maximum(length, 1e-300), 0.0)
    n = np.cross(e1, e2)
    w = np.where(np.einsum("ij,ij->i", np.cross(n, t), -b) < 0, -1.0, 1.0)
    out = np.zeros((len(tri), 4))
    out[:, :3], out[:, 3] = t, np.where(np.isfinite(t).all(axis=1) & (length[:, 0] > 0), w, 0.0)
    out[~np.isfinite(out).all(axis=1)] = 0.0
    return out


def pack_slots(prims: Primitives, order: np.ndarray) -> np.ndarray:
    """The primitive slots in slot order, layout.PRIM_SLOT_DTYPE records (a sphere's filled through its
    SphereSlot view of the same bytes); slot s holds primitive order[s]."""
    n_tri = prims.n_triangles
    out = aligned_zeros(len(order), PRIM_SLOT_DTYPE)  # a CPU device's buffer as it is (Device.adopt)
    is_tri = order < n_tri
    for a in range(0, len(order), CHUNK):  # float64 vertices a chunk at a time
        chunk, tri = out[a : a + CHUNK], is_tri[a : a + CHUNK]
        t = prims.triangles_at(order[a : a + CHUNK][tri])
        chunk["v0"][tri] = t[:, 0]
        # the vertices themselves, not edges: a vertex two triangles share must round to the same
        # float32 in both for the watertight test (v0 + (v1 - v0) in float32 is not v1)
        chunk["v1"][tri] = t[:, 1]
        chunk["v2"][tri] = t[:, 2]
    spheres = out.view(SPHERE_SLOT_DTYPE)
    s = prims.spheres[order[~is_tri] - n_tri]
    spheres["centre"][~is_tri] = s[:, :3]
    spheres["radius"][~is_tri] = s[:, 3]
    spheres["sphere"][~is_tri] = 1
    out["id"] = order  # the primitive's index in scene order
    return out
