"""Mitsuba's canonical shapes as triangle meshes, and its `.serialized` mesh files.

Each canonical shape is in its object space, as Mitsuba 3 defines it (src/shapes/*.cpp); the shape's
`to_world` places it.  Front faces (the side the winding's normal points to, which is the side clrender's
emission leaves from) face the way Mitsuba's normals do:

- rectangle: [-1, 1]² in z = 0, facing +z; uv = ((x + 1)/2, (y + 1)/2);
- cube: [-1, 1]³, facing out, four vertices a face;
- disk: radius 1 in z = 0, facing +z (a fan of DISK_SEGMENTS triangles);
- cylinder: radius 1 about z from z = 0 to z = 1, open, facing out (CYLINDER_SEGMENTS quads).

The disk's and cylinder's polygons are widened so that their area is the true shape's (an emitter keeps its
power); their silhouettes differ from the true ones by under 0.1% of the radius.
"""

from __future__ import annotations

import math
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UsageError, shown

DISK_SEGMENTS = 96
CYLINDER_SEGMENTS = 96
SPHERE_SEGMENTS = (48, 96)  # a sphere under a transform that is not a similarity: rings, segments


@dataclass
class MeshArrays:
    vertices: np.ndarray  # (V, 3) float64
    faces: np.ndarray  # (F, 3) int64
    uvs: np.ndarray | None = None  # (V, 2), Mitsuba's (and glTF's) convention: (0, 0) the image's top-left


def rectangle() -> MeshArrays:
    v = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float64)
    return MeshArrays(v, np.array([[0, 1, 2], [0, 2, 3]]), (v[:, :2] + 1) / 2)


def cube() -> MeshArrays:
    verts, faces, uvs = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
            corners = []
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u_axis], p[v_axis] = sign, a, b
                corners.append(p)
                uvs.append(((a + 1) / 2, (b + 1) / 2))
            base = len(verts)
            verts.extend(corners)
            # (u, v, axis) is right-handed: counter-clockwise in (u, v) faces +axis
            faces.extend(
                [[base, base + 1, base + 2], [base, base + 2, base + 3]] if sign > 0 else [[base, base + 2, base + 1], [base, base + 3, base + 2]]
            )
    return MeshArrays(np.array(verts, np.float64), np.array(faces, np.int64), np.array(uvs, np.float64))


def disk(n: int = DISK_SEGMENTS) -> MeshArrays:
    r = math.sqrt(math.pi / (0.5 * n * math.sin(2 * math.pi / n)))  # the polygon's area is pi
    t = 2 * math.pi * np.arange(n) / n
    ring = np.stack([r * np.cos(t), r * np.sin(t), np.zeros(n)], 1)
    v = np.vstack([[0.0, 0.0, 0.0], ring])
    faces = np.array([[0, 1 + i, 1 + (i + 1) % n] for i in range(n)], np.int64)
    uvs = np.vstack([[0.0, 0.0], np.stack([np.full(n, r), t / (2 * math.pi)], 1)])  # Mitsuba's disk: (radius, angle / 2pi)
    return MeshArrays(v, faces, uvs)


def cylinder(n: int = CYLINDER_SEGMENTS) -> MeshArrays:
    r = math.pi / (n * math.sin(math.pi / n))  # the polygon's perimeter is 2 pi: the side's area is the true one
    t = 2 * math.pi * np.arange(n) / n
    ring = np.stack([r * np.cos(t), r * np.sin(t)], 1)
    v = np.vstack([np.hstack([ring, np.zeros((n, 1))]), np.hstack([ring, np.ones((n, 1))])])
    faces = []
    for i in range(n):
        j = (i + 1) % n
        faces += [[i, j, n + j], [i, n + j, n + i]]  # counter-clockwise seen from outside
    uvs = np.vstack([np.stack([t / (2 * math.pi), np.zeros(n)], 1), np.stack([t / (2 * math.pi), np.ones(n)], 1)])
    return MeshArrays(v, np.array(faces, np.int64), uvs)


def uv_sphere(rings: int = SPHERE_SEGMENTS[0], segments: int = SPHERE_SEGMENTS[1]) -> MeshArrays:
    """A unit sphere facing out (for a sphere whose to_world is not a similarity)."""
    theta = np.linspace(0, math.pi, rings + 1)
    phi = 2 * math.pi * np.arange(segments) / segments
    tt, pp = np.meshgrid(theta, phi, indexing="ij")
    v = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1).reshape(-1, 3)
    faces = []
    for i in range(rings):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            c, d = a + segments, b + segments
            if i > 0:
                faces.append([a, d, b])
            if i < rings - 1:
                faces.append([a, c, d])
    return MeshArrays(v, np.array(faces, np.int64))


EMITTER_SPHERE_SEGMENTS = (16, 32)  # an emitting sphere's mesh: rings, segments (992 triangles)


def mesh_area(mesh: MeshArrays) -> float:
    t = mesh.vertices[mesh.faces]
    return float(0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum())


def emitter_sphere() -> MeshArrays:
    """A unit sphere for a sphere that emits, widened to the sphere's area 4 pi so the light keeps its power: the path
    tracer light-samples emissive triangles but finds an analytic sphere's light only by BSDF rays (a small bright
    sphere, as in Veach's MIS scene, is then all fireflies).  Read by the Mitsuba and pbrt readers alike."""
    mesh = uv_sphere(*EMITTER_SPHERE_SEGMENTS)
    return MeshArrays(mesh.vertices * math.sqrt(4 * math.pi / mesh_area(mesh)), mesh.faces, mesh.uvs)


PRIMITIVES = {"rectangle": rectangle, "cube": cube, "disk": disk, "cylinder": cylinder}


# ---------------------------------------------------------------------- .serialized
SERIALIZED_MAGIC = 0x041C
SERIALIZED_VERSIONS = (3, 4)
HAS_NORMALS, HAS_TEXCOORDS, HAS_COLORS, FACE_NORMALS, SINGLE, DOUBLE = 0x1, 0x2, 0x8, 0x10, 0x1000, 0x2000
MAX_SERIALIZED_VERTICES = 30_000_000


def read_serialized(path: Path, shape_index: int, what: str) -> tuple[MeshArrays, bool]:
    """One mesh of a Mitsuba `.serialized` file (the format of src/shapes/serialized.cpp: a little-endian
    uint16 magic 0x041C and version 3 or 4, then a zlib stream of flags, the name (v4), vertex and face
    counts (uint64), positions, optional normals, uvs and colours (float32 or float64) and uint32 faces;
    several meshes are concatenated, with a table of their offsets at the end).  Returns the mesh and
    whether the file asks for face normals."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise UsageError(f"{what}: cannot read {shown(str(path))} ({exc.strerror})") from None
    bad = lambda why: UsageError(f"{what}: {shown(path.name)} is not a Mitsuba .serialized mesh ({why})")
    if len(data) < 4:
        raise bad("too short")
    magic, version = struct.unpack_from("<HH", data, 0)
    if magic != SERIALIZED_MAGIC or version not in SERIALIZED_VERSIONS:
        raise bad(f"header {magic:#06x} version {version}; expected 0x041c version 3 or 4")
    offset = 0
    if shape_index > 0:
        (count,) = struct.unpack_from("<I", data, len(data) - 4)
        if shape_index >= count:
            raise UsageError(f"{what}: shape_index {shape_index}; {shown(path.name)} holds meshes 0 to {count - 1}")
        size = 8 if version == 4 else 4
        (offset,) = struct.unpack_from("<Q" if size == 8 else "<I", data, len(data) - 4 - size * (count - shape_index))
        if not 0 <= offset < len(data) - 4:
            raise bad("a mesh offset lies outside the file")
    try:
        stream = zlib.decompressobj().decompress(data[offset + 4 :], 2**31 - 1)
    except zlib.error as exc:
        raise bad(f"zlib: {exc}") from None
    return _serialized_body(stream, version, bad)


def _serialized_body(stream: bytes, version: int, bad) -> tuple[MeshArrays, bool]:
    pos = 4
    if len(stream) < 4:
        raise bad("truncated")
    (flags,) = struct.unpack_from("<I", stream, 0)
    if version == 4:
        end = stream.find(b"\0", pos)
        if end < 0:
            raise bad("unterminated name")
        pos = end + 1
    if len(stream) < pos + 16:
        raise bad("truncated")
    n_vertices, n_faces = struct.unpack_from("<QQ", stream, pos)
    pos += 16
    if n_vertices == 0 or n_faces == 0 or n_vertices > MAX_SERIALIZED_VERTICES or n_faces > MAX_SERIALIZED_VERTICES:
        raise bad(f"{n_vertices} vertices and {n_faces} triangles; allowed: 1 to {MAX_SERIALIZED_VERTICES} of each")
    dtype = np.dtype("<f8" if flags & DOUBLE else "<f4")

    def take(count, dt):
        nonlocal pos
        size = count * np.dtype(dt).itemsize
        if pos + size > len(stream):
            raise bad("truncated")
        out = np.frombuffer(stream, dt, count, pos)
        pos += size
        return out

    vertices = take(3 * n_vertices, dtype).reshape(-1, 3).astype(np.float64)
    if flags & HAS_NORMALS:
        take(3 * n_vertices, dtype)  # clrender computes its own shading normals
    uvs = take(2 * n_vertices, dtype).reshape(-1, 2).astype(np.float64) if flags & HAS_TEXCOORDS else None
    if flags & HAS_COLORS:
        take(3 * n_vertices, dtype)
    faces = take(3 * n_faces, "<u4").reshape(-1, 3).astype(np.int64)
    if faces.max() >= n_vertices:
        raise bad(f"face index {faces.max()}; allowed: 0 to {n_vertices - 1}")
    if not np.isfinite(vertices).all():
        raise bad("NaN or infinite vertices")
    return MeshArrays(vertices, faces, uvs), bool(flags & FACE_NORMALS)


def write_serialized(path: Path, meshes: list, double: bool = False) -> None:
    """Write meshes (MeshArrays) as a version-4 `.serialized` file (for tests and `clrender convert`'s round trips)."""
    parts, offsets, at = [], [], 0
    for m in meshes:
        flags = (DOUBLE if double else SINGLE) | (HAS_TEXCOORDS if m.uvs is not None else 0)
        dt = "<f8" if double else "<f4"
        body = struct.pack("<I", flags) + b"mesh\0" + struct.pack("<QQ", len(m.vertices), len(m.faces))
        body += np.asarray(m.vertices, dt).tobytes() + (np.asarray(m.uvs, dt).tobytes() if m.uvs is not None else b"")
        body += np.asarray(m.faces, "<u4").tobytes()
        chunk = struct.pack("<HH", SERIALIZED_MAGIC, 4) + zlib.compress(body)
        offsets.append(at)
        at += len(chunk)
        parts.append(chunk)
    path.write_bytes(b"".join(parts) + b"".join(struct.pack("<Q", o) for o in offsets) + struct.pack("<I", len(meshes)))
