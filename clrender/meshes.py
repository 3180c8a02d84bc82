"""Procedural meshes for scenes and benchmarks (numpy + trimesh, deterministic).

* `dense_mesh(n, seed)` -- a lumpy sphere of about n triangles (ray and BVH benchmarks)
"""
from __future__ import annotations

import numpy as np
import trimesh

from .errors import UsageError

MAX_DENSE_TRIANGLES = 50_000_000


def uv_sphere_faces(rings: int, segments: int) -> np.ndarray:
    """Faces of a sphere with two poles (vertices 0 and 1) and `rings` - 1 rings of `segments`
    vertices (ring r, segment s at 2 + r * segments + s), wound counter-clockwise seen from outside."""
    s = np.arange(segments)
    s1 = (s + 1) % segments
    top = np.stack([np.zeros(segments, np.int64), 2 + s, 2 + s1], axis=1)
    last = 2 + (rings - 2) * segments
    bottom = np.stack([np.ones(segments, np.int64), last + s1, last + s], axis=1)
    r = np.arange(rings - 2)[:, None] * segments + 2
    a, b = r + s, r + s1  # ring r
    c, d = a + segments, b + segments  # ring r + 1
    quads = np.stack([np.stack([a, d, b], -1), np.stack([a, c, d], -1)], axis=2).reshape(-1, 3)
    return np.concatenate([top, quads, bottom])


def uv_sphere_directions(rings: int, segments: int) -> np.ndarray:
    """Unit vectors for the vertices of `uv_sphere_faces` (poles at +y and -y)."""
    theta = np.pi * np.arange(1, rings) / rings
    phi = 2 * np.pi * np.arange(segments) / segments
    st, ct = np.sin(theta)[:, None], np.cos(theta)[:, None]
    ring = np.stack([st * np.sin(phi), np.broadcast_to(ct, (len(theta), segments)), st * np.cos(phi)], axis=-1)
    ring = ring.reshape(-1, 3)
    return np.concatenate([[[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]], ring])


def dense_mesh(n_triangles: int = 100_000, seed: int = 0) -> trimesh.Trimesh:
    """A closed lumpy sphere (radius about 1, centred at the origin) of about `n_triangles` triangles.

    The surface is a UV sphere displaced along its normals by a sum of random waves; `seed` picks
    the waves.  The count is exact for n = 4 r (r - 1) with r rings, the nearest such otherwise.
    """
    n_triangles = int(n_triangles)
    if not 8 <= n_triangles <= MAX_DENSE_TRIANGLES:
        raise UsageError(f"dense mesh triangle count {n_triangles}; allowed: 8 to {MAX_DENSE_TRIANGLES}")
    rings = max(2, int(round(0.5 + np.sqrt(0.25 + n_triangles / 4.0))))
    segments = 2 * rings
    faces = uv_sphere_faces(rings, segments)
    dirs = uv_sphere_directions(rings, segments)
    rng = np.random.default_rng(seed)
    waves = 24
    k = rng.normal(size=(waves, 3))
    k *= (rng.uniform(1.5, 9.0, waves) / np.linalg.norm(k, axis=1))[:, None]  # spatial frequencies
    amp = 0.25 / np.sqrt(waves) / (1 + 0.2 * np.linalg.norm(k, axis=1))
    phase = rng.uniform(0, 2 * np.pi, waves)
    radius = 1.0 + np.sin(dirs @ k.T + phase) @ amp
    vertices = dirs * radius[:, None]
    return trimesh.Trimesh(vertices, faces, process=False)


def dense(n_triangles: int = 100_000, seed: int = 0) -> trimesh.Trimesh:
    """Scene generator name for `dense_mesh` (about 100k triangles)."""
    return dense_mesh(n_triangles, seed)
