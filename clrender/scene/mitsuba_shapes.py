"""Mitsuba 3's shape plugins as scene-dict objects (mitsuba_plugins.Reader.shape calls `shape_objects`).

Mesh files (`obj`, `ply`) stay files: the object names the file and places it by the shape's whole
`to_world` (`matrix`), so every shape naming one file shares its vertices (clrender's instancing).  The
canonical shapes (mitsuba_meshes.py) and `.serialized` meshes are written inline.  A `sphere` whose
`to_world` is a similarity (rotation, uniform scale, translation) is clrender's analytic sphere; any other
transform tessellates it.  `flip_normals` reverses the winding (the side a surface emits from);
`face_normals` draws flat faces, else normals are interpolated (clrender computes them: a file's own are not read).
"""

from __future__ import annotations

import numpy as np

from .confine import scene_file
from .mitsuba_meshes import PRIMITIVES, MeshArrays, emitter_sphere, read_serialized, uv_sphere


def shape_objects(reader, p, matrix: np.ndarray, material: str) -> list:
    flip = bool(p.get("flip_normals", False))
    smooth = not bool(p.get("face_normals", False))
    if p.type == "sphere":
        return [_sphere(reader, p, matrix, material, flip, emits=bool(p.nested("emitter")))]
    if p.type in ("obj", "ply", "serialized") and np.linalg.det(matrix[:3, :3]) < 0:
        flip = not flip  # Mitsuba's mesh faces its world winding; clrender reverses a mirrored mesh's (scene.mirrored_faces)
    if p.type in ("obj", "ply"):
        name = p.get("filename")
        if not isinstance(name, str):
            p.fail(f'shape "{p.type}" needs a filename')
        if not scene_file(reader.doc.folder, name, reader.root, f"{p.where}: filename").is_file():
            p.fail(f'shape "{p.type}" file {name!r} does not exist')
        if not flip:
            return [{"type": "mesh", "file": name, "matrix": matrix.tolist(), "smooth": smooth, "material": material}]
        return [_inline(_file_mesh(reader, p, name), matrix, material, smooth, flip)]
    if p.type == "serialized":
        name = p.get("filename")
        if not isinstance(name, str):
            p.fail('shape "serialized" needs a filename')
        path = scene_file(reader.doc.folder, name, reader.root, f"{p.where}: filename")
        if not path.is_file():
            p.fail(f"serialized mesh {name!r} does not exist")
        mesh, face_normals = read_serialized(path, int(p.get("shape_index", 0)), f"{p.where}: filename")
        return [_inline(mesh, matrix, material, smooth and not face_normals, flip)]
    mesh = PRIMITIVES[p.type]()
    if p.type == "cylinder":
        mesh = _cylinder(reader, p, mesh)
    return [_inline(mesh, matrix, material, p.type == "cylinder" and smooth, flip)]


def _file_mesh(reader, p, name: str) -> MeshArrays:
    """A mesh file's triangles read here (to be written inline, reversed), checked as scene.py reads mesh files."""
    from .mesh_files import load_mesh_file

    path = scene_file(reader.doc.folder, name, reader.root, f"{p.where}: filename")
    tm = load_mesh_file(path, f"{p.where}: filename", root=reader.root)
    return MeshArrays(np.asarray(tm.vertices, np.float64), np.asarray(tm.faces, np.int64))


def _inline(mesh: MeshArrays, matrix, material, smooth, flip) -> dict:
    faces = mesh.faces[:, ::-1] if flip else mesh.faces
    obj = {
        "type": "mesh",
        "vertices": mesh.vertices.tolist(),
        "faces": faces.tolist(),
        "matrix": matrix.tolist(),
        "smooth": bool(smooth),
        "material": material,
    }
    if mesh.uvs is not None:
        obj["uvs"] = mesh.uvs.tolist()
    return obj


def _cylinder(reader, p, mesh: MeshArrays) -> MeshArrays:
    """Mitsuba's cylinder from p0 to p1 with `radius`: the canonical one placed by a frame along p1 - p0."""
    p0 = np.asarray(p.get("p0", (0.0, 0.0, 0.0)), np.float64)
    p1 = np.asarray(p.get("p1", (0.0, 0.0, 1.0)), np.float64)
    radius = reader.scalar(p, "radius", 1.0)
    axis = p1 - p0
    length = np.linalg.norm(axis)
    if length == 0 or radius <= 0:
        p.fail('shape "cylinder" needs p0 != p1 and radius > 0')
    z = axis / length
    x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    v = mesh.vertices
    placed = p0 + radius * (v[:, :1] * x + v[:, 1:2] * y) + length * v[:, 2:3] * z
    return MeshArrays(placed, mesh.faces, mesh.uvs)


def _sphere(reader, p, matrix, material, flip, emits: bool = False) -> dict:
    """clrender's analytic sphere where to_world is a similarity, else a UV sphere; an emitting sphere is always
    a mesh (mitsuba_meshes.emitter_sphere)."""
    center = np.asarray(p.get("center", (0.0, 0.0, 0.0)), np.float64)
    radius = reader.scalar(p, "radius", 1.0)
    m3 = matrix[:3, :3]
    gram = m3.T @ m3
    s2 = np.trace(gram) / 3
    if flip:
        reader.refuse(p, 'shape "sphere" with flip_normals is not supported (a sphere emits outwards)', "outward")
    if not emits and np.allclose(gram, s2 * np.eye(3), rtol=1e-6, atol=1e-9 * s2):
        c = matrix[:3, :3] @ center + matrix[:3, 3]
        return {"type": "sphere", "center": c.tolist(), "radius": float(radius * np.sqrt(s2)), "material": material}
    mesh = emitter_sphere() if emits else uv_sphere()
    local = np.eye(4)
    local[:3, :3] *= radius
    local[:3, 3] = center
    return _inline(mesh, matrix @ local, material, True, False)
