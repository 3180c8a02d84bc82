"""PLY triangle strips: `element tristrips` with a `vertex_indices` list (Stanford's igea.ply and other scans),
which trimesh reads as a point cloud.

A strip a b c d e ... is the triangles (a b c), (c b d), (c d e), ...: triangle k of a run is (s[k], s[k+1], s[k+2])
for even k and (s[k+1], s[k], s[k+2]) for odd k, so every triangle keeps the first one's winding (its front).
An index of -1 ends a run; the next starts afresh (even again).  Triangles that repeat an index (the degenerate
ones strips use to turn corners) are dropped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def strip_faces(indices) -> np.ndarray:
    """(F, 3) int64 triangles of a strip list: vertex indices, -1 between runs."""
    s = np.asarray(indices, np.int64).ravel()
    faces = []
    start = 0
    for end in [*np.flatnonzero(s < 0), len(s)]:
        run = s[start:end]
        start = end + 1
        if len(run) < 3:
            continue
        k = np.arange(len(run) - 2)
        odd = k % 2 == 1
        a = np.where(odd, run[k + 1], run[k])
        b = np.where(odd, run[k], run[k + 1])
        faces.append(np.stack([a, b, run[k + 2]], axis=1))
    if not faces:
        return np.zeros((0, 3), np.int64)
    f = np.concatenate(faces)
    proper = (f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])
    return f[proper]


def read_tristrips(path: Path):
    """A trimesh.Trimesh of a PLY file's vertices and its `tristrips` element, or None when it has none."""
    import trimesh
    from trimesh.exchange import ply

    with open(path, "rb") as file:
        elements, is_ascii, _ = ply._parse_header(file)
        if "tristrips" not in elements or "vertex" not in elements:
            return None
        (ply._ply_ascii if is_ascii else ply._ply_binary)(elements, file)
    vertex = elements["vertex"]["data"]  # trimesh's parser: a dict of arrays per property (a structured array for some files)
    vertices = np.stack([np.asarray(vertex[axis], np.float64).ravel() for axis in "xyz"], axis=1)
    rows = elements["tristrips"]["data"]["vertex_indices"]  # one row (a list of indices) per strip element
    parts = [strip_faces(np.asarray(row, np.int64).ravel()) for row in rows]
    faces = np.concatenate(parts) if parts else np.zeros((0, 3), np.int64)
    return trimesh.Trimesh(vertices, faces, process=False)
