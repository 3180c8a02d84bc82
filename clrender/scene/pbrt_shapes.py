"""pbrt-v4 Shape directives as clrender objects (docs/scene-formats-pbrt.md).

Every triangle shape is written as an inline `mesh` (world-space `vertices` and `faces`, numpy arrays: a dict
made in Python may hold them, and a big mesh is then checked as whole arrays): pbrt's transforms
are arbitrary 4×4 matrices and the mirror into clrender's world (pbrt.MIRROR) reverses winding, neither of
which a `file` mesh's translate/rotate/scale can say.  Which way a surface faces follows pbrt-v4's rule
(shapes.cpp: with normals `N` a triangle faces them; otherwise its winding's normal, turned over when
ReverseOrientation is set or the transform changes handedness), reproduced through the mirror by `_faces`.
"""

from __future__ import annotations

import math

import numpy as np

from .mitsuba_meshes import emitter_sphere
from .pbrt_parse import fail

MAX_PBRT_TRIANGLES = 10_000_000
DISK_SEGMENTS = 64  # a pbrt disk becomes a fan (or ring) of this many triangles


def shape(reader, d, state):
    kind = d.args[0]
    handler = {"trianglemesh": _trianglemesh, "plymesh": _plymesh, "sphere": _sphere, "disk": _disk, "bilinearmesh": _bilinearmesh}.get(kind)
    if handler is None:
        reader.unsupported(d, f'Shape "{kind}"', ("trianglemesh", "plymesh", "sphere", "disk", "bilinearmesh"), "left out")
        return
    handler(reader, d, state)


def _array(p, kind, width, where_name):
    values = p.values
    if p.type != kind and not (kind in ("point3", "normal") and p.type in ("point3", "normal", "normal3", "point", "vector3")):
        fail(p.where, f'"{where_name}": expected {kind}, got {p.type}')
    if len(values) == 0 or len(values) % width:
        fail(p.where, f'"{where_name}": {len(values)} numbers; allowed: a non-zero multiple of {width}')
    return np.asarray(values, np.float64).reshape(-1, width)


def _indices(p, count, per, points, where):
    if p is None:
        if points != per:
            fail(where, f'without "integer indices" a shape needs exactly {per} points, got {points}')
        return np.arange(per).reshape(1, per)
    if p.type != "integer":
        fail(p.where, f'"indices": expected integer, got {p.type}')
    idx = np.asarray(p.values, np.float64)
    if len(idx) == 0 or len(idx) % per or not np.all(idx == np.round(idx)) or idx.min() < 0 or idx.max() >= count:
        fail(p.where, f'"indices": {len(idx)} values; allowed: whole numbers from 0 to {count - 1}, {per} a face')
    if len(idx) // per > MAX_PBRT_TRIANGLES:
        fail(p.where, f"{len(idx) // per} faces; allowed: at most {MAX_PBRT_TRIANGLES}")
    return idx.astype(np.int64).reshape(-1, per)


def _faces(faces, points, normals, ctm, reverse):
    """The faces with the winding that makes clrender's front the side pbrt's surface faces, after the mirror."""
    faces = faces.copy()
    if normals is not None:  # pbrt faces each triangle towards its vertex normals, whatever else holds
        a, b, c = (points[faces[:, i]] for i in range(3))
        toward = (np.cross(b - a, c - a) * (normals[faces[:, 0]] + normals[faces[:, 1]] + normals[faces[:, 2]])).sum(axis=1)
        faces[toward < 0] = faces[toward < 0][:, ::-1]
        reverse = False
    if (np.linalg.det(ctm[:3, :3]) > 0) != reverse:  # the mirror flips the winding's side back to pbrt's
        faces = faces[:, ::-1]
    return faces


def emit_mesh(reader, d, state, points, faces, normals=None, smooth=False, uv=None):
    if len(faces) == 0:
        return
    faces = _faces(faces, points, normals, state.full_ctm, state.reverse)
    uvs = None if uv is None else np.stack([uv[:, 0], 1.0 - uv[:, 1]], axis=1)  # pbrt-v4 reads images at (u, 1 - v)
    obj = {"type": "mesh", "material": reader.material_for(state), "smooth": bool(smooth)}
    if state.instance is None:  # world-space vertices
        world = reader.to_world(state.ctm)
        obj.update(vertices=points @ world[:3, :3].T + world[:3, 3], faces=faces)
    else:  # an instance: the definition's arrays, made once (per winding), placed by the instance's matrix
        matrix = reader.to_world(state.instance)
        mirrors = bool(np.linalg.det(matrix[:3, :3]) < 0)  # the scene reverses such a copy's winding (scene.mirrored_faces): undone here
        key = (id(d), bool(np.linalg.det(state.full_ctm[:3, :3]) > 0), mirrors)  # the winding depends on these alone
        if key not in reader.instanced:
            local = points @ state.ctm[:3, :3].T + state.ctm[:3, 3]
            reader.instanced[key] = {"vertices": local, "faces": faces[:, [0, 2, 1]] if mirrors else faces}
        obj.update(reader.instanced[key], matrix=matrix)
    if uvs is not None:
        obj["uvs"] = reader.instanced.setdefault((id(d), "uvs"), uvs) if state.instance is not None else uvs
    reader.objects.append(obj)


def _uv(p, count):
    if "uv" not in p:
        return None
    uv = _array(p["uv"], "point2", 2, "uv")
    if len(uv) != count:
        fail(p["uv"].where, f'"uv": {len(uv)} pairs for {count} points; allowed: one a point')
    return uv


MESH_PARAMS = ("P", "indices", "N", "uv", "S", "faceIndices", "alpha")


def _alpha(reader, d, p):
    if "alpha" in p and not (p["alpha"].type == "float" and p["alpha"].values == [1.0]):
        reader.unsupported(d, f'Shape "{d.args[0]}" parameter "alpha"', ("opaque shapes",), "opaque")


def _trianglemesh(reader, d, state):
    p = reader.params(d, MESH_PARAMS)
    _alpha(reader, d, p)
    if "P" not in p:
        fail(d.where, 'Shape "trianglemesh" needs "point3 P"')
    points = _array(p["P"], "point3", 3, "P")
    faces = _indices(p.get("indices"), len(points), 3, len(points), d.where)
    normals = _array(p["N"], "normal", 3, "N") if "N" in p else None
    if normals is not None and len(normals) != len(points):
        fail(p["N"].where, f'"N": {len(normals)} normals for {len(points)} points; allowed: one a point')
    emit_mesh(reader, d, state, points, faces, normals, smooth=normals is not None, uv=_uv(p, len(points)))


def _bilinearmesh(reader, d, state):
    """pbrt's bilinear patches (vertices p00, p10, p01, p11 of each) as two triangles each, (p00, p10, p11) and
    (p00, p11, p01): exact for planar patches, whose normal is dp/du × dp/dv as these windings'."""
    p = reader.params(d, ("P", "indices", "N", "uv", "emissionfilename"))
    if "emissionfilename" in p:
        reader.unsupported(d, 'bilinearmesh "emissionfilename"', ("uniform emission",), "ignored")
    if "P" not in p:
        fail(d.where, 'Shape "bilinearmesh" needs "point3 P"')
    points = _array(p["P"], "point3", 3, "P")
    quads = _indices(p.get("indices"), len(points), 4, len(points), d.where)
    faces = np.concatenate([quads[:, [0, 1, 3]], quads[:, [0, 3, 2]]])
    normals = _array(p["N"], "normal", 3, "N") if "N" in p else None
    if normals is not None and len(normals) != len(points):
        fail(p["N"].where, f'"N": {len(normals)} normals for {len(points)} points; allowed: one a point')
    emit_mesh(reader, d, state, points, faces, normals, smooth=normals is not None, uv=_uv(p, len(points)))


def _plymesh(reader, d, state):
    from .mesh_files import load_mesh_file

    p = reader.params(d, ("filename", "displacement", "edgelength", "alpha"))
    _alpha(reader, d, p)
    if "displacement" in p:
        reader.unsupported(d, 'plymesh "displacement"', ("undisplaced meshes",), "ignored")
    if "filename" not in p or p["filename"].type != "string":
        fail(d.where, 'Shape "plymesh" needs a "string filename"')
    what = f"{d.where}: plymesh"
    path = reader.resolve(p["filename"].values[0], what)
    tm = load_mesh_file(path, what, root=reader.root)
    emit_mesh(reader, d, state, np.asarray(tm.vertices, np.float64), np.asarray(tm.faces, np.int64))


def _sphere(reader, d, state):
    p = reader.params(d, ("radius", "zmin", "zmax", "phimax", "alpha"))
    _alpha(reader, d, p)
    radius = reader.number(d, p.get("radius"), 1.0)
    full = reader.number(d, p.get("zmin"), -radius) <= -radius and reader.number(d, p.get("zmax"), radius) >= radius
    if not full or reader.number(d, p.get("phimax"), 360.0) < 360:
        reader.unsupported(d, 'a partial Shape "sphere" (zmin, zmax, phimax)', ("whole spheres",), "the whole sphere")
    world = reader.to_world(state.full_ctm)
    stretch = np.linalg.svd(world[:3, :3], compute_uv=False)
    if stretch.max() - stretch.min() > 1e-9 * stretch.max():
        what = 'Shape "sphere" under a non-uniform scale (an ellipsoid)'
        reader.unsupported(d, what, ("spheres under rotation and uniform scale",), "a sphere of the mean scale")
    if state.reverse and state.area is not None:
        reader.unsupported(d, "an emitting sphere under ReverseOrientation", ("spheres that emit outwards",), "outward emission")
    if state.area is not None:  # an emitting sphere is a mesh the path tracer light-samples (mitsuba_meshes.emitter_sphere)
        unit = emitter_sphere()
        emit_mesh(reader, d, state, unit.vertices * radius, unit.faces, normals=unit.vertices, smooth=True)
        return
    reader.objects.append(
        {"type": "sphere", "center": world[:3, 3].tolist(), "radius": float(radius * stretch.mean()), "material": reader.material_for(state)}
    )


def _disk(reader, d, state):
    """A disk (or ring, with innerradius) at z = height facing +z, as DISK_SEGMENTS segments of triangles."""
    p = reader.params(d, ("height", "radius", "innerradius", "phimax", "alpha"))
    _alpha(reader, d, p)
    h, r, ri = (reader.number(d, p.get(k), v) for k, v in (("height", 0.0), ("radius", 1.0), ("innerradius", 0.0)))
    phimax = min(reader.number(d, p.get("phimax"), 360.0), 360.0)
    if not phimax > 0:
        fail(d.where, f'Shape "disk": phimax {phimax:g}; allowed: more than 0 (degrees)')
    if r <= 0 or not 0 <= ri < r:
        fail(d.where, f'Shape "disk": radius {r:g}, innerradius {ri:g}; allowed: 0 <= innerradius < radius')
    n = max(3, math.ceil(DISK_SEGMENTS * phimax / 360))
    phi = np.radians(phimax) * np.arange(n + 1) / n
    ring = lambda radius: np.stack([radius * np.cos(phi), radius * np.sin(phi), np.full(n + 1, h)], axis=1)  # noqa: E731
    i = np.arange(n)
    if ri == 0:
        points = np.concatenate([[[0.0, 0.0, h]], ring(r)])
        faces = np.stack([np.zeros(n, np.int64), i + 1, i + 2], axis=1)
    else:
        points = np.concatenate([ring(r), ring(ri)])
        inner = i + n + 1
        faces = np.concatenate([np.stack([i, i + 1, inner + 1], 1), np.stack([i, inner + 1, inner], 1)])
    emit_mesh(reader, d, state, points, faces)
