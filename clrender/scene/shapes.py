"""Shapes: a mesh's geometry, read or built once, however many scene objects place it.

A `Shape` is what a mesh object's `file` (or one node of a glTF file), `generator` with its `params`, or
numpy `vertices` placed by a `matrix` give: its points in its own space, faces, the smooth-shading normals
and the vertex attributes (uvs, vertex colours, tangents), each made on first use and then kept.  scene.py
keeps one Shape per shape key for a whole scene (Checks.shapes), and each mesh object places it by its own
transform in its own material (scene.Mesh's `instance`, an `Instance`, and its `material`); the instanced
Tracer stores each shape once (clrender/trace/instancing.py).  A glTF node's Shape also carries the
node's placement of its glTF mesh (`gltf`): nodes that place one glTF mesh are copies of it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .checks import UV_LIMIT


@dataclass(eq=False)
class Shape:
    """One object-space mesh.  Its arrays are read-only by convention: every object that places it shares them."""

    key: tuple  # what it is made from (scene.py's _shape_key): equal keys, one Shape
    mesh: object = field(repr=False)  # what was read: a trimesh.Trimesh, a gltf.NodeMesh, a generator's or inline arrays
    source: str  # the file, node or generator it came from, for messages
    generated: bool = False  # a built-in generator's: its own vertex normals are given, not a file's
    gltf: tuple | None = None  # a glTF node's (its glTF mesh's key, that mesh's own vertices, the node's world matrix)

    @cached_property
    def points(self) -> np.ndarray:
        """(V, 3) float64: what an object's matrix places (a glTF node's: the node's world points)."""
        return np.asarray(self.mesh.vertices, np.float64)

    @cached_property
    def faces(self) -> np.ndarray:
        return np.asarray(self.mesh.faces, np.int64)

    @cached_property
    def box(self) -> tuple:
        """(lo, hi) of `points`."""
        return self.points.min(axis=0), self.points.max(axis=0)

    @cached_property
    def normals(self) -> np.ndarray:
        """(V, 3) smooth-shading normals: a generator's or a glTF node's own (trimesh drops a file's) where usable,
        computed (welded across patches) elsewhere."""
        from .meshes import shading_normals

        given = self.mesh.vertex_normals if self.generated else getattr(self.mesh, "normals", None)  # inline: None
        return shading_normals(self.mesh.vertices, self.mesh.faces, given)

    @cached_property
    def attributes(self) -> tuple:
        """(uvs, uvs1, colours, tangents), each None when the mesh has none (vertex_attributes)."""
        return vertex_attributes(self.mesh)

    @cached_property
    def mirrored_faces(self) -> np.ndarray:
        """`faces` for an object whose matrix mirrors (mirrored_faces)."""
        return mirrored_faces(self.faces)


@dataclass(frozen=True, eq=False)
class Instance:
    """Where a mesh object puts its shape: objects whose Instances have one `shape_key` place one object-space mesh
    (`vertices`, one array for every copy, and the object's faces) by their own `to_world` (clrender/trace/instancing.py
    stores it once).  A glTF node's shape is its glTF mesh, placed by the node's world matrix and then the object's."""

    shape_key: tuple | None  # the shape (scene.py's _shape_key); None: inline vertices, which no other object shares
    vertices: np.ndarray  # (V, 3) float64 before to_world
    to_world: np.ndarray  # (4, 4) object-to-world matrix: world vertices = vertices @ M[:3, :3].T + M[:3, 3]


def mirrored_faces(faces: np.ndarray) -> np.ndarray:
    """The faces of a mesh placed by a mirroring matrix (determinant < 0), winding reversed, so that its front
    stays the side the object-space winding's normal points to, carried by the inverse transpose (glTF: "the
    determinant of the node's global transform defines the winding order"; pbrt's transformSwapsHandedness;
    the instanced kernels' normal_to_world).  Swapping the 2nd and 3rd corner keeps each face's first vertex."""
    return np.ascontiguousarray(np.asarray(faces)[:, [0, 2, 1]])


def vertex_attributes(tm):
    """(uvs, uvs1, colours, tangents) of a mesh, each None when it has none: a glTF node's (gltf.NodeMesh), or the
    texture coordinates trimesh read (an OBJ's `vt`, whose v runs up the image: flipped to glTF's convention)."""
    if hasattr(tm, "uv0"):
        return tm.uv0, tm.uv1, tm.colours, tm.tangents
    visual = getattr(tm, "visual", None)
    uv = getattr(visual, "uv", None) if getattr(visual, "kind", None) == "texture" else None
    if uv is None or np.shape(uv) != (len(tm.vertices), 2):
        return None, None, None, None
    uv = np.asarray(uv, np.float64)
    uv = np.where(np.isfinite(uv) & (np.abs(uv) <= UV_LIMIT), uv, 0.0)  # as glTF's are bounded (gltf.primitive_attributes)
    return np.stack([uv[:, 0], 1.0 - uv[:, 1]], axis=1), None, None, None
