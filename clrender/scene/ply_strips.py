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


# PLY's scalar types as numpy's (both the old names and the sized ones)
TYPES = {
    **dict.fromkeys(("char", "int8"), "i1"),
    **dict.fromkeys(("uchar", "uint8"), "u1"),
    **dict.fromkeys(("short", "int16"), "i2"),
    **dict.fromkeys(("ushort", "uint16"), "u2"),
    **dict.fromkeys(("int", "int32"), "i4"),
    **dict.fromkeys(("uint", "uint32"), "u4"),
    **dict.fromkeys(("float", "float32"), "f4"),
    **dict.fromkeys(("double", "float64"), "f8"),
}


def _header(file):
    """(format, [(element name, count, [(property name, type, list count type or None)])]) of a PLY header."""
    if file.readline().strip() != b"ply":
        raise ValueError("not a PLY file")
    fmt, elements = None, []
    for _ in range(10000):
        words = file.readline().decode("ascii", "replace").split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "end_header":
            return fmt, elements
        if words[0] == "format":
            fmt = words[1]
        elif words[0] == "element":
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property" and words[1] == "list":
            elements[-1][2].append((words[4], TYPES[words[3]], TYPES[words[2]]))
        elif words[0] == "property":
            elements[-1][2].append((words[2], TYPES[words[1]], None))
    raise ValueError("no end_header")


def _read_element(file, fmt: str, count: int, properties, tokens):
    """One element's rows: a structured array when every property is a scalar, else a list of dicts."""
    if fmt == "ascii":
        rows = []
        for _ in range(count):
            row = {}
            for name, kind, list_kind in properties:
                n = int(next(tokens)) if list_kind else 1
                values = np.array([next(tokens) for _ in range(n)], np.float64 if kind.startswith("f") else np.int64)
                row[name] = values if list_kind else values[0]
            rows.append(row)
        return rows
    order = "<" if fmt == "binary_little_endian" else ">"
    if all(list_kind is None for _, _, list_kind in properties):
        dtype = np.dtype([(name, order + kind) for name, kind, _ in properties])
        return np.frombuffer(file.read(dtype.itemsize * count), dtype, count)
    rows = []
    for _ in range(count):
        row = {}
        for name, kind, list_kind in properties:
            n = int(np.frombuffer(file.read(np.dtype(list_kind).itemsize), order + list_kind)[0]) if list_kind else 1
            values = np.frombuffer(file.read(n * np.dtype(kind).itemsize), order + kind, n)
            row[name] = values if list_kind else values[0]
        rows.append(row)
    return rows


def read_tristrips(path: Path):
    """A trimesh.Trimesh of a PLY file's vertices and its `tristrips` element, or None when it has none (or has
    faces too: trimesh reads those).  trimesh itself refuses a binary file whose strips differ in length."""
    import trimesh

    with open(path, "rb") as file:
        fmt, elements = _header(file)
        names = [e[0] for e in elements]
        if "tristrips" not in names or "vertex" not in names or any(e[0] == "face" and e[1] > 0 for e in elements):
            return None  # faces (or nothing to read): trimesh's reader
        tokens = iter(file.read().split()) if fmt == "ascii" else None
        read = {}
        for name, count, properties in elements[: max(names.index("tristrips"), names.index("vertex")) + 1]:
            read[name] = _read_element(file, fmt, count, properties, tokens)
    vertex = read["vertex"]
    vertices = (
        np.array([[row[a] for a in "xyz"] for row in vertex], np.float64)
        if isinstance(vertex, list)
        else np.stack([vertex[a].astype(np.float64) for a in "xyz"], axis=1)
    )
    parts = [strip_faces(row["vertex_indices"]) for row in read["tristrips"]]
    faces = np.concatenate(parts) if parts else np.zeros((0, 3), np.int64)
    return trimesh.Trimesh(vertices, faces, process=False)
