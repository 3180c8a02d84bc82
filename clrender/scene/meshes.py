"""Procedural meshes for scenes and benchmarks (numpy + trimesh, deterministic).

* `bunny(resolution)` -- a sitting rabbit, surface nets of a smooth union of ellipsoids and
  capsules; cached under cache_dir() after the first build
* `dense_mesh(n, seed)` (scene name `dense`, cached like the bunny) -- a lumpy sphere of about
  n triangles, for the ray and BVH benchmarks
* `wizard_hat()`, `tower()` (lathe profiles) and `cat()` (surface nets) -- low-poly props
* `shading_normals(vertices, faces, given)` -- the normals a `smooth = true` mesh is shaded with:
  a file's or generator's where usable, else computed and welded across patch borders

Scene files use them with `generator = "bunny"` and keyword arguments in `params = {...}`, through
`generate(name, **params)`, which returns bare arrays (`MeshArrays`): trimesh is imported only by the
functions that return a `trimesh.Trimesh`, because its import (scipy with it) took 0.34 s of a
3.8 s `clrender render wizard_cat` (docs/bvh.md).
Every generated mesh carries its vertex normals, computed here with numpy (`vertex_normals`):
trimesh's own routine needs scipy and otherwise falls back to a per-vertex Python loop
(72 s for the 120k-triangle rock of refract2) with a traceback on stderr.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import platformdirs

from ..errors import UsageError
from ..memory import MAX_TRIANGLES, triangles_bytes
from ..memory import require as require_memory

if TYPE_CHECKING:
    import trimesh

MAX_DENSE_TRIANGLES = MAX_TRIANGLES  # memory.py: about 640 bytes each to load, build and trace


def _check_range(what: str, value, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not low <= value <= high:
        raise UsageError(f"{what} {value!r}; allowed: whole numbers {low} to {high}")
    return int(value)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit vertex normals: each face's unit normal weighted by its corner angle at the vertex
    (Thuermer and Wuethrich 1998, trimesh's rule), summed by np.bincount.  Degenerate faces add
    nothing; a vertex no face uses gets a zero normal."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    corners = v[f]  # (F, 3 corners, 3 xyz)
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(n, axis=1, keepdims=True)
    face_n = np.where(length > 0, n / np.where(length > 0, length, 1), 0)
    # corner angle at corner k between the edges to the two other corners
    e1 = np.roll(corners, -1, axis=1) - corners
    e2 = np.roll(corners, 1, axis=1) - corners
    cos = (e1 * e2).sum(-1) / np.maximum(np.linalg.norm(e1, axis=-1) * np.linalg.norm(e2, axis=-1), 1e-300)
    angle = np.arccos(np.clip(cos, -1, 1))  # (F, 3)
    weighted = angle[:, :, None] * face_n[:, None, :]  # (F, 3, 3)
    summed = np.stack([np.bincount(f.ravel(), weighted[..., a].ravel(), minlength=len(v)) for a in range(3)], axis=1)
    norm = np.linalg.norm(summed, axis=1, keepdims=True)
    return np.where(norm > 0, summed / np.where(norm > 0, norm, 1), 0)


WELD_CREASE_DEGREES = 60.0  # copies of one position share a normal unless their sides fold sharper than this


def welded_vertex_normals(vertices: np.ndarray, faces: np.ndarray, crease_degrees: float = WELD_CREASE_DEGREES) -> np.ndarray:
    """`vertex_normals` across patch borders: vertices at bit-for-bit the same position (files
    often repeat them where patches meet, like the Utah teapot's 403) are welded, so a smooth
    surface gets one normal there instead of a seam.  A copy whose own side's normal is more than
    half `crease_degrees` from the welded one keeps its own, so a fold the file splits on purpose
    (a cube's corners, a cylinder's rim) stays sharp.  A used vertex whose faces' normals cancel
    takes one of its faces' normals rather than zero."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    own = vertex_normals(v, f)
    positions, group = np.unique(v + 0.0, axis=0, return_inverse=True)  # + 0.0: -0.0 welds with 0.0
    group = group.reshape(-1)
    out = own
    if len(positions) < len(v):
        welded = vertex_normals(positions, group[f])[group]
        agree = (welded * own).sum(axis=1) >= np.cos(np.radians(crease_degrees) / 2)
        out = np.where(agree[:, None], welded, own)
    used = np.zeros(len(v), bool)
    used[f.ravel()] = True
    lost = used & ~(np.linalg.norm(out, axis=1) > 0.5)
    if lost.any():  # angle-weighted normals cancelled (a doubled sheet): any of its faces' normals
        n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        length = np.linalg.norm(n, axis=1, keepdims=True)
        face_n = np.where(length > 0, n / np.where(length > 0, length, 1), 0)
        fallback = np.zeros_like(v)
        for k in range(3):
            fallback[f[:, k]] = face_n
        out = np.where(lost[:, None], fallback, out)
    return out


def shading_normals(vertices: np.ndarray, faces: np.ndarray, given: np.ndarray | None = None) -> np.ndarray:
    """Vertex normals for smooth shading: `given` (a file's or a generator's) where they are
    finite and not zero, `welded_vertex_normals` elsewhere.  Zero normals are a common exporter
    output, and a zero or NaN normal interpolated in the kernel would turn every hit into NaN.
    `given` is returned unchanged (the same bits) when it is all usable."""
    if given is None:
        return welded_vertex_normals(vertices, faces)
    given = np.asarray(given, np.float64)
    with np.errstate(over="ignore", invalid="ignore"):
        length = np.linalg.norm(given, axis=1)
    bad = ~(np.isfinite(length) & (length > 1e-6))  # a unit normal, or what is left of a zero one
    if not bad.any():
        return given
    return np.where(bad[:, None], welded_vertex_normals(vertices, faces), given)


@dataclass
class MeshArrays:
    """What a scene reads of a generated mesh, with the dtypes trimesh.Trimesh(process=False) gives."""

    vertices: np.ndarray  # (n, 3) float64
    faces: np.ndarray  # (m, 3) int64, counter-clockwise seen from outside
    vertex_normals: np.ndarray  # (n, 3) float64, unit

    def to_trimesh(self) -> trimesh.Trimesh:
        import trimesh

        mesh = trimesh.Trimesh(self.vertices, self.faces, process=False)
        mesh.vertex_normals = self.vertex_normals  # kept until the vertices or faces change
        return mesh


def with_normals(vertices, faces) -> MeshArrays:
    """The mesh with its vertex normals from `vertex_normals`, so nobody asks trimesh, and so scipy, for them."""
    vertices, faces = np.asarray(vertices, np.float64), np.asarray(faces, np.int64)
    return MeshArrays(vertices, faces, vertex_normals(vertices, faces))


def signed_volume(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Volume enclosed by a closed mesh, positive when its faces wind counter-clockwise seen from outside."""
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    return float(np.einsum("ij,ij->", a, np.cross(b, c))) / 6.0


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
    """`dense_mesh_arrays` as a trimesh.Trimesh."""
    return dense_mesh_arrays(n_triangles, seed).to_trimesh()


def dense_mesh_arrays(n_triangles: int = 100_000, seed: int = 0) -> MeshArrays:
    """A closed lumpy sphere (radius about 1, centred at the origin) of about `n_triangles` triangles.

    The surface is a UV sphere displaced along its normals by a sum of random waves; `seed` picks
    the waves.  The count is exact for n = 4 r (r - 1) with r rings, the nearest such otherwise.
    """
    n_triangles = _check_range("dense mesh triangle count", n_triangles, 8, MAX_DENSE_TRIANGLES)
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
    return with_normals(vertices, faces)


DENSE_VERSION = 1  # bump when dense_mesh's shape changes: names the cache file


def dense(n_triangles: int = 100_000, seed: int = 0) -> trimesh.Trimesh:
    """Scene generator name for `dense_mesh` (about 100k triangles), cached like the bunny."""
    return dense_arrays(n_triangles, seed).to_trimesh()


def dense_arrays(n_triangles: int = 100_000, seed: int = 0) -> MeshArrays:
    n_triangles = _check_range("dense mesh triangle count", n_triangles, 8, MAX_DENSE_TRIANGLES)
    require_memory(triangles_bytes(n_triangles), f"a dense mesh of {n_triangles} triangles")
    return cached_mesh(f"dense-v{DENSE_VERSION}-n{n_triangles}-s{seed!r}", lambda: dense_mesh_arrays(n_triangles, seed))


# ------------------------------------------------------------ implicit surfaces
def sd_ellipsoid(p: np.ndarray, center, radii) -> np.ndarray:
    """Approximate signed distance to an axis-aligned ellipsoid (Quilez's bound), p (..., 3)."""
    q = (p - np.asarray(center, p.dtype)) / np.asarray(radii, p.dtype)
    k0 = np.linalg.norm(q, axis=-1)
    k1 = np.linalg.norm(q / np.asarray(radii, p.dtype), axis=-1)
    centre = k1 < 1e-6  # the bound is 0 / 0 there: use the depth of the centre
    return np.where(centre, -min(radii), k0 * (k0 - 1) / np.where(centre, 1, k1))


def sd_capsule(p: np.ndarray, a, b, r_a: float, r_b: float | None = None) -> np.ndarray:
    """Signed distance (approximate when tapered) to a capsule from a to b, radius r_a .. r_b."""
    a, b = np.asarray(a, p.dtype), np.asarray(b, p.dtype)
    r_b = r_a if r_b is None else r_b
    ab = b - a
    h = np.clip(((p - a) @ ab) / (ab @ ab), 0, 1)
    return np.linalg.norm(p - a - h[..., None] * ab, axis=-1) - (r_a + (r_b - r_a) * h)


def smooth_union(ds, k: float) -> np.ndarray:
    """Polynomial smooth minimum of signed distances (blend width k)."""
    d = ds[0]
    for e in ds[1:]:
        h = np.maximum(k - np.abs(d - e), 0) / k
        d = np.minimum(d, e) - h * h * k * 0.25
    return d


def surface_nets(field, lo, hi, resolution: int, project: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Mesh the surface field(p) = 0 (negative inside) in the box [lo, hi], about `resolution` cells
    along its longest side, by naive surface nets: one vertex per cell the surface crosses (the mean
    of its edge crossings, then `project` Newton steps onto the surface), one quad per crossed grid
    edge, split along its shorter diagonal.  Faces wind counter-clockwise seen from outside.
    The field must be positive on the box's boundary.  Returns (vertices, faces)."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    h = (hi - lo).max() / resolution
    shape = np.ceil((hi - lo) / h).astype(int) + 1
    axes = [lo[a] + h * np.arange(shape[a]) for a in range(3)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    f = field(grid.reshape(-1, 3).astype(np.float32)).astype(np.float64).reshape(shape)
    inside = f < 0
    nx, ny, nz = shape
    cells = (nx - 1, ny - 1, nz - 1)
    corner_offsets = [(i, j, k) for i in (0, 1) for j in (0, 1) for k in (0, 1)]

    def corner(arr, o):
        return arr[o[0] : o[0] + nx - 1, o[1] : o[1] + ny - 1, o[2] : o[2] + nz - 1]

    n_in = sum(corner(inside, o).astype(np.int8) for o in corner_offsets)
    active = (n_in > 0) & (n_in < 8)
    cell_ids = np.flatnonzero(active)
    vid = np.full(cells, -1, np.int64)
    vid.ravel()[cell_ids] = np.arange(len(cell_ids))
    ci = np.stack(np.unravel_index(cell_ids, cells), axis=1)
    # vertex: mean of the crossings on the cell's 12 edges
    acc = np.zeros((len(ci), 3))
    num = np.zeros(len(ci))
    for a in range(3):
        for o in corner_offsets:
            if o[a]:
                continue
            o2 = list(o)
            o2[a] = 1
            fa = f[ci[:, 0] + o[0], ci[:, 1] + o[1], ci[:, 2] + o[2]]
            fb = f[ci[:, 0] + o2[0], ci[:, 1] + o2[1], ci[:, 2] + o2[2]]
            cross = (fa < 0) != (fb < 0)
            t = np.where(cross, fa / np.where(cross, fa - fb, 1), 0)
            p = ci + np.asarray(o, float)
            p[:, a] += t
            acc += p * cross[:, None]
            num += cross
    verts = lo + h * acc / num[:, None]
    for _ in range(project):  # Newton steps onto the surface, at most half a cell each
        e = h * 0.05
        fv = field(verts)
        g = np.stack([(field(verts + e * np.eye(3)[a]) - field(verts - e * np.eye(3)[a])) / (2 * e) for a in range(3)], axis=1)
        step = -(fv / np.maximum((g * g).sum(1), 1e-12))[:, None] * g
        norm = np.linalg.norm(step, axis=1, keepdims=True)
        verts = verts + step * np.minimum(1, 0.5 * h / np.maximum(norm, 1e-30))
    # quads around every crossed grid edge, ordered counter-clockwise around the outward axis
    quads = []
    rings = {
        0: [(0, -1, -1), (0, 0, -1), (0, 0, 0), (0, -1, 0)],
        1: [(-1, 0, -1), (-1, 0, 0), (0, 0, 0), (0, 0, -1)],
        2: [(-1, -1, 0), (0, -1, 0), (0, 0, 0), (-1, 0, 0)],
    }
    for a in range(3):
        o = [0, 0, 0]
        o[a] = 1
        lo_in = inside[: nx - o[0], : ny - o[1], : nz - o[2]]
        hi_in = inside[o[0] :, o[1] :, o[2] :]
        e = np.argwhere(lo_in != hi_in)
        b = [x for x in range(3) if x != a]
        e = e[(e[:, b[0]] > 0) & (e[:, b[1]] > 0)]  # edges on the grid's boundary faces have no ring
        q = np.stack([vid[e[:, 0] + d[0], e[:, 1] + d[1], e[:, 2] + d[2]] for d in rings[a]], axis=1)
        outward_up = lo_in[e[:, 0], e[:, 1], e[:, 2]]  # inside below: the surface faces +axis
        q[~outward_up] = q[~outward_up][:, ::-1]
        quads.append(q)
    q = np.concatenate(quads)
    d02 = np.linalg.norm(verts[q[:, 0]] - verts[q[:, 2]], axis=1)
    d13 = np.linalg.norm(verts[q[:, 1]] - verts[q[:, 3]], axis=1)
    use02 = (d02 <= d13)[:, None]
    t1 = np.where(use02, q[:, [0, 1, 2]], q[:, [0, 1, 3]])
    t2 = np.where(use02, q[:, [0, 2, 3]], q[:, [1, 2, 3]])
    return verts, np.concatenate([t1, t2])


# ------------------------------------------------------------ bunny
BUNNY_VERSION = 1  # bump when the shape changes: names the cache file


def bunny_field(p: np.ndarray) -> np.ndarray:
    """Signed distance (approximate) of a sitting rabbit, y up, facing +z, about 2.6 units tall."""
    parts = [
        sd_ellipsoid(p, (0, 0.72, -0.15), (0.62, 0.62, 0.82)),  # body
        sd_ellipsoid(p, (0.38, 0.48, -0.35), (0.32, 0.42, 0.55)),  # haunches
        sd_ellipsoid(p, (-0.38, 0.48, -0.35), (0.32, 0.42, 0.55)),
        sd_ellipsoid(p, (0, 0.85, 0.42), (0.42, 0.5, 0.42)),  # chest
        sd_ellipsoid(p, (0, 1.42, 0.62), (0.36, 0.34, 0.42)),  # head
        sd_ellipsoid(p, (0, 1.33, 0.98), (0.19, 0.17, 0.17)),  # snout
        sd_ellipsoid(p, (0.14, 1.28, 0.88), (0.16, 0.14, 0.16)),  # cheeks
        sd_ellipsoid(p, (-0.14, 1.28, 0.88), (0.16, 0.14, 0.16)),
        sd_capsule(p, (0.12, 1.62, 0.5), (0.3, 2.45, 0.12), 0.1, 0.075),  # ears
        sd_capsule(p, (-0.12, 1.62, 0.5), (-0.24, 2.5, 0.2), 0.1, 0.075),
        sd_ellipsoid(p, (0, 0.62, -1.0), (0.2, 0.2, 0.17)),  # tail
        sd_capsule(p, (0.2, 0.62, 0.5), (0.2, 0.13, 0.66), 0.1, 0.085),  # front legs
        sd_capsule(p, (-0.2, 0.62, 0.5), (-0.2, 0.13, 0.66), 0.1, 0.085),
        sd_ellipsoid(p, (0.2, 0.09, 0.74), (0.11, 0.09, 0.19)),  # front paws
        sd_ellipsoid(p, (-0.2, 0.09, 0.74), (0.11, 0.09, 0.19)),
        sd_ellipsoid(p, (0.42, 0.09, -0.1), (0.16, 0.09, 0.45)),  # hind feet
        sd_ellipsoid(p, (-0.42, 0.09, -0.1), (0.16, 0.09, 0.45)),
    ]
    return smooth_union(parts, 0.12)


def cache_dir() -> Path:
    """The user's cache folder for clrender: $XDG_CACHE_HOME/clrender or ~/.cache/clrender on Linux,
    ~/Library/Caches/clrender on macOS, %LOCALAPPDATA%\\clrender\\Cache on Windows."""
    return Path(platformdirs.user_cache_dir("clrender", appauthor=False))


def build_bunny(resolution: int = 112) -> MeshArrays:
    """Mesh `bunny_field` (no cache): scaled to fit a unit box, sitting on y = 0, centred in x and z."""
    verts, faces = surface_nets(bunny_field, (-1.0, -0.2, -1.4), (1.0, 2.8, 1.4), resolution)
    lo, hi = verts.min(0), verts.max(0)
    verts = (verts - [(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2]) / (hi - lo).max()
    return with_normals(verts, faces)


def bunny(resolution: int = 112, cache: bool = True) -> trimesh.Trimesh:
    """`bunny_arrays` as a trimesh.Trimesh."""
    return bunny_arrays(resolution, cache).to_trimesh()


def bunny_arrays(resolution: int = 112, cache: bool = True) -> MeshArrays:
    """A closed bunny-like mesh (body, head, two long ears, tail, legs; about 3.5 * resolution^2
    triangles, 43,840 at the default), scaled to fit a unit box, sitting on y = 0, facing +z.
    Watertight at the default resolution (surface nets can leave a few non-manifold edges at others).

    The first build (about two seconds) is cached with its vertex normals as
    cache_dir()/bunny-v<version>-r<resolution>.npz; later calls load that file (about 10 ms).
    cache=False always rebuilds and writes nothing."""
    resolution = _check_range("bunny resolution", resolution, 16, 256)
    if not cache:
        return build_bunny(resolution)
    return cached_mesh(f"bunny-v{BUNNY_VERSION}-r{resolution}", lambda: build_bunny(resolution))


def cached_mesh(key: str, build) -> MeshArrays:
    """cache_dir()/<key>.npz if it is there and readable, else build() saved under that name.
    Generating the bunny (2 s) or the 120k-triangle rock (0.3 s) on every scene load would
    dominate a small render; loading the .npz takes milliseconds."""
    path = cache_dir() / f"{key}.npz"
    mesh = load_cached_mesh(path)
    if mesh is None:
        mesh = build()
        save_cached_mesh(path, mesh)
    return mesh


def load_cached_mesh(path: Path) -> MeshArrays | None:
    """A mesh saved by `save_cached_mesh`, or None when the file is missing or damaged."""
    try:
        with np.load(path) as data:
            vertices, faces, normals = data["vertices"], data["faces"], data["normals"]
        if len(faces) == 0 or normals.shape != vertices.shape or not 0 <= faces.min() <= faces.max() < len(vertices):
            return None
        return MeshArrays(np.asarray(vertices, np.float64), np.asarray(faces, np.int64), np.asarray(normals, np.float64))
    except Exception:  # missing, truncated or foreign: rebuild it
        return None


def save_cached_mesh(path: Path, mesh: MeshArrays) -> None:
    """Write vertices, faces and vertex normals as .npz (temp file + rename, so a reader never
    sees half a file); a read-only home just means no cache."""
    try:
        from ..outputs import save_npz

        path.parent.mkdir(parents=True, exist_ok=True)
        save_npz(path, join=False, vertices=mesh.vertices, faces=mesh.faces.astype(np.int32), normals=mesh.vertex_normals)
    except OSError:
        pass


# ------------------------------------------------------------ low-poly props
def lathe(profile, segments: int) -> MeshArrays:
    """Revolve a profile [(radius, y), ...] around the y axis.  The profile starts and ends on the
    axis (radius 0) and runs bottom to top; the result is closed and wound outward."""
    prof = np.asarray(profile, np.float64)
    if prof[0, 0] != 0 or prof[-1, 0] != 0:
        raise ValueError("a lathe profile must start and end on the axis")
    inner = prof[1:-1]  # rings; the two ends become single pole vertices
    rings = len(inner)
    phi = 2 * np.pi * np.arange(segments) / segments
    ring_v = np.stack([inner[:, :1] * np.sin(phi), np.broadcast_to(inner[:, 1:], (rings, segments)), inner[:, :1] * np.cos(phi)], axis=-1).reshape(
        -1, 3
    )
    verts = np.concatenate([[[0, prof[0, 1], 0], [0, prof[-1, 1], 0]], ring_v])
    # the same connectivity as a UV sphere: a pole, `rings` rings, a pole
    verts, faces = np.asarray(verts, np.float64), uv_sphere_faces(rings + 1, segments)
    if signed_volume(verts, faces) < 0:
        faces = np.ascontiguousarray(faces[:, ::-1])  # wound outward (trimesh's invert: the columns reversed)
    return with_normals(verts, faces)


def wizard_hat(segments: int = 48) -> trimesh.Trimesh:
    """`wizard_hat_arrays` as a trimesh.Trimesh."""
    return wizard_hat_arrays(segments).to_trimesh()


def wizard_hat_arrays(segments: int = 48) -> MeshArrays:
    """A pointed hat with a brim and a tip bent back (-z): brim radius 0.5, height about 0.9, on y = 0."""
    segments = _check_range("wizard_hat segments", segments, 3, 4096)
    cone = [(0.24 * (1 - t) ** 1.3, 0.04 + 0.86 * t) for t in np.linspace(0, 1, 14)[1:]]
    profile = [(0, 0), (0.5, 0), (0.5, 0.02), (0.26, 0.04), *cone]
    profile[-1] = (0, profile[-1][1])
    mesh = lathe(profile, segments)
    v = mesh.vertices.copy()
    bend = np.clip((v[:, 1] - 0.45) / 0.45, 0, None)
    v[:, 2] -= 0.22 * bend**2  # the droop of the tip
    v[:, 1] -= 0.06 * bend**3
    return with_normals(v, mesh.faces)


def tower(segments: int = 24) -> trimesh.Trimesh:
    """`tower_arrays` as a trimesh.Trimesh."""
    return tower_arrays(segments).to_trimesh()


def tower_arrays(segments: int = 24) -> MeshArrays:
    """A round tower: a cylinder (radius 0.3, 1.5 high) with a battlement lip and a cone roof."""
    segments = _check_range("tower segments", segments, 3, 4096)
    profile = [(0, 0), (0.3, 0), (0.3, 1.5), (0.36, 1.52), (0.36, 1.62), (0.0, 2.2)]
    return lathe(profile, segments)


def cat(resolution: int = 40) -> trimesh.Trimesh:
    """`cat_arrays` as a trimesh.Trimesh."""
    return cat_arrays(resolution).to_trimesh()


def cat_arrays(resolution: int = 40) -> MeshArrays:
    """A low-poly sitting cat facing +z, about 1 tall, on y = 0: body, head, pointed ears, tail."""
    resolution = _check_range("cat resolution", resolution, 16, 256)

    def field(p):
        return smooth_union(
            [
                sd_ellipsoid(p, (0, 0.32, -0.05), (0.26, 0.32, 0.3)),  # body
                sd_ellipsoid(p, (0, 0.16, 0.02), (0.3, 0.16, 0.34)),  # haunches
                sd_ellipsoid(p, (0, 0.72, 0.1), (0.19, 0.17, 0.17)),  # head
                sd_ellipsoid(p, (0, 0.68, 0.24), (0.08, 0.06, 0.06)),  # muzzle
                sd_capsule(p, (0.1, 0.8, 0.08), (0.14, 0.96, 0.06), 0.06, 0.012),  # ears
                sd_capsule(p, (-0.1, 0.8, 0.08), (-0.14, 0.96, 0.06), 0.06, 0.012),
                sd_capsule(p, (0.09, 0.3, 0.2), (0.09, 0.04, 0.24), 0.055),  # front legs
                sd_capsule(p, (-0.09, 0.3, 0.2), (-0.09, 0.04, 0.24), 0.055),
                sd_capsule(p, (0.05, 0.06, -0.32), (0.3, 0.05, -0.1), 0.045),  # tail curled around
                sd_capsule(p, (0.3, 0.05, -0.1), (0.3, 0.05, 0.15), 0.045, 0.035),
            ],
            0.05,
        )

    verts, faces = surface_nets(field, (-0.5, -0.1, -0.5), (0.5, 1.1, 0.5), resolution)
    verts[:, 1] -= verts[:, 1].min()
    return with_normals(verts, faces)


# scene generator name -> the function a scene calls (scene.py checks the names and params: GENERATOR_PARAMS)
GENERATORS = {"bunny": bunny_arrays, "dense": dense_arrays, "wizard_hat": wizard_hat_arrays, "tower": tower_arrays, "cat": cat_arrays}


def generate(name: str, **params) -> MeshArrays:
    """The built-in mesh `name` (a key of GENERATORS) with its keyword arguments, as bare arrays."""
    return GENERATORS[name](**params)
