"""Flatten a Scene into the primitive arrays the kernels read.

Primitive ids count triangles first (every mesh in object order), then
spheres; `object_of[id]` gives the scene object each primitive belongs to.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layout import MATERIAL_DTYPE, OBJECT_DTYPE, PRIM_SLOT_DTYPE, SPHERE_SLOT_DTYPE, VERTEX_ATTRIBUTES_DTYPE
from ..scene.scene import Mesh, Scene, Sphere


@dataclass
class Primitives:
    triangles: np.ndarray  # (T, 3, 3) float64 vertices
    triangle_normals: np.ndarray  # (T, 3, 3) float32 vertex normals (zeros when flat)
    triangle_attributes: np.ndarray  # (T,) layout.VERTEX_ATTRIBUTES_DTYPE: uvs and vertex colours at the vertices
    spheres: np.ndarray  # (S, 4) float64 centre and radius
    object_of: np.ndarray  # (T + S,) int32 object id per primitive id
    objects: np.ndarray  # (O,) layout.OBJECT_DTYPE records: material index and smooth flag
    materials: np.ndarray  # (M,) layout.MATERIAL_DTYPE records
    material_names: list
    textures: list = None  # the scene's decoded textures (scene/textures.py), which the materials index

    @property
    def count(self) -> int:
        return len(self.triangles) + len(self.spheres)

    def bounds(self):
        """Per-primitive axis-aligned bounds (lo, hi), each (N, 3) float32, conservatively rounded."""
        tri_lo, tri_hi = self.triangles.min(axis=1), self.triangles.max(axis=1)
        c, r = self.spheres[:, :3], self.spheres[:, 3:4]
        lo = np.concatenate([tri_lo, c - r]).astype(np.float32)
        hi = np.concatenate([tri_hi, c + r]).astype(np.float32)
        # float32 rounding must never shrink a box
        return np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf)


def flatten(scene: Scene) -> Primitives:
    names = list(scene.materials)
    index = {n: i for i, n in enumerate(names)}
    materials = np.array([scene.materials[n].pack() for n in names], MATERIAL_DTYPE)
    objects = np.zeros(max(len(scene.objects), 1), OBJECT_DTYPE)
    tris, tri_normals, tri_attrs, tri_obj, spheres, sphere_obj = [], [], [], [], [], []
    for oid, obj in enumerate(scene.objects):
        objects[oid]["material"] = index[obj.material]
        if isinstance(obj, Sphere):
            spheres.append([*obj.center, obj.radius])
            sphere_obj.append(oid)
            continue
        assert isinstance(obj, Mesh)
        objects[oid]["smooth"] = int(obj.smooth and obj.vertex_normals is not None)
        tris.append(obj.vertices[obj.faces])
        if objects[oid]["smooth"]:
            tri_normals.append(obj.vertex_normals[obj.faces].astype(np.float32))
        else:
            tri_normals.append(np.zeros((len(obj.faces), 3, 3), np.float32))
        tri_attrs.append(_attributes(obj))
        objects[oid]["vertex_colours"] = int(obj.colours is not None)
        tri_obj.append(np.full(len(obj.faces), oid, np.int32))
    triangles = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
    normals = np.concatenate(tri_normals) if tri_normals else np.zeros((0, 3, 3), np.float32)
    attrs = np.concatenate(tri_attrs) if tri_attrs else np.zeros(0, VERTEX_ATTRIBUTES_DTYPE)
    object_of = np.concatenate([*tri_obj, np.asarray(sphere_obj, np.int32)]).astype(np.int32)
    spheres = np.asarray(spheres, np.float64).reshape(-1, 4)
    return Primitives(triangles, normals, attrs, spheres, object_of, objects, materials, names, list(getattr(scene, "textures", [])))


def _attributes(mesh: Mesh) -> np.ndarray:
    """A mesh's VertexAttributes records, one a face: its uvs (zeros without) and colours (ones without)."""
    out = np.zeros(len(mesh.faces), VERTEX_ATTRIBUTES_DTYPE)
    out["colour"] = 1.0
    for name, values in (("uv", mesh.uvs), ("uv1", mesh.uvs1), ("colour", mesh.colours), ("tangent", mesh.tangents)):
        if values is not None:
            out[name] = np.asarray(values)[mesh.faces]
    if mesh.tangents is None and mesh.uvs is not None:
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
    n_tri = len(prims.triangles)
    out = np.zeros(len(order), PRIM_SLOT_DTYPE)
    is_tri = order < n_tri
    t = prims.triangles[order[is_tri]]
    out["v0"][is_tri] = t[:, 0]
    # the vertices themselves, not edges: a vertex two triangles share must round to the same
    # float32 in both for the watertight test (v0 + (v1 - v0) in float32 is not v1)
    out["v1"][is_tri] = t[:, 1]
    out["v2"][is_tri] = t[:, 2]
    spheres = out.view(SPHERE_SLOT_DTYPE)
    s = prims.spheres[order[~is_tri] - n_tri]
    spheres["centre"][~is_tri] = s[:, :3]
    spheres["radius"][~is_tri] = s[:, 3]
    spheres["sphere"][~is_tri] = 1
    out["id"] = order  # the primitive's index in scene order
    return out
