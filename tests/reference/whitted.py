"""A Whitted ray tracer in float64 numpy, written from docs/shading.md's rules, as a test oracle.

It shares no code with clrender: it reads the same scene dict (spheres,
triangles, quads, OBJ meshes), builds the camera from its definition in docs/scene-format.md
and shades by the rules of docs/shading.md:

* pinhole camera: forward = look_at - position, right = forward x up,
  vertical field of view `fov`, one ray through each pixel centre, row 0 at
  the top;
* at each hit, surface = ambient*kd + sum over lights of
  c*I*T*(kd*max(0, n.l) + ks*(n.h)^shininess) (the specular term only where
  n.l > 0), h = unit(l + v); T is the shadow transmittance: 0 past an opaque
  surface, times `transparency` at every crossing of a transparent one
  (shadow rays are not bent);
* pixel = (1 - tr)*((1 - mirror)*surface + mirror*reflected) + tr*refracted;
  Snell's law with eta = n1/n2, total internal reflection sends the refracted
  share to the reflection, optional Schlick Fresnel splits it instead;
  rays entering an object go from the current medium into the object's IOR,
  rays leaving go back to air;
* max_depth bounces after the primary hit; a miss shows the background;
* area lights: n x n samples corner + (p+xi)/n a + (q+xi')/n b, each adding
  I/n^2 times the point-light term (falloff "none"); with
  falloff "inverse_square" (the physical model: BRDF kd/pi + ks (s+8)/(8 pi) (n.h)^s,
  times n.l) a point light gives c*I*cos/r^2 and an area light's
  I is radiance (each sample weighted by A*|cos_light|/r^2);
* smooth meshes interpolate angle-weighted vertex normals with the hit's
  barycentrics; a shading normal that faces away from the viewer falls back to
  the face normal.

Besides the image it returns, per pixel, a signature of every discrete choice
made along the path (objects hit, refraction or total internal reflection,
which side of the terminator, each shadow ray's transmittance).
`render_steady` compares it with the signatures of rays moved a twentieth of
a pixel, so tests can leave out pixels that lie that close to a branch
boundary: there float32 and float64 may legitimately pick different branches.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import counter_rng

DEFAULT_MATERIAL = dict(diffuse=(0.8, 0.8, 0.8), specular=(0.0, 0.0, 0.0), shininess=32.0, mirror=0.0, transparency=0.0, ior=1.0)
LEAVE = 1e-9  # how far (relative to the point's magnitude) a ray leaves a surface along its face normal


# ----------------------------------------------------------------- scene
@dataclass
class World:
    spheres: np.ndarray  # (S, 4) centre, radius
    sphere_object: np.ndarray  # (S,)
    triangles: np.ndarray  # (T, 3, 3)
    triangle_object: np.ndarray  # (T,)
    vertex_normals: np.ndarray  # (T, 3, 3) per-corner normals, NaN on flat triangles
    kd: np.ndarray  # per object (O, 3)
    ks: np.ndarray
    shininess: np.ndarray  # (O,)
    mirror: np.ndarray
    transparency: np.ndarray
    ior: np.ndarray
    lights: list = field(default_factory=list)
    background: np.ndarray = field(default_factory=lambda: np.zeros(3))
    ambient: np.ndarray = field(default_factory=lambda: np.zeros(3))

    def bounds(self):
        """(triangle indices, bounding-sphere centre, radius) of each object's triangles, padded a little."""
        if not hasattr(self, "_bounds"):
            self._bounds = []
            for obj in np.unique(self.triangle_object):
                index = np.flatnonzero(self.triangle_object == obj)
                points = self.triangles[index].reshape(-1, 3)
                centre = (points.min(0) + points.max(0)) / 2
                radius = np.linalg.norm(points - centre, axis=1).max() * (1 + 1e-6) + 1e-9
                self._bounds.append((index, centre, radius))
        return self._bounds


def read_obj(path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of a Wavefront OBJ (v and f lines; polygons fanned)."""
    vertices, faces = [], []
    for line in Path(path).read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            vertices.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            idx = [int(p.split("/")[0]) for p in parts[1:]]
            idx = [i - 1 if i > 0 else len(vertices) + i for i in idx]
            faces += [[idx[0], idx[k], idx[k + 1]] for k in range(1, len(idx) - 1)]
    return np.array(vertices, np.float64), np.array(faces, np.int64)


def rotation(degrees) -> np.ndarray:
    """Rotation about x, then y, then z (docs/scene-format.md: rotate = degrees about x, y, z)."""
    ax, ay, az = np.radians(degrees)

    def about(axis, a):
        c, s = math.cos(a), math.sin(a)
        i, j = (axis + 1) % 3, (axis + 2) % 3  # right-handed: x turns y into z, y turns z into x, z turns x into y
        m = np.eye(3)
        m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
        return m

    return about(2, az) @ about(1, ay) @ about(0, ax)


def angle_weighted_normals(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Vertex normals: incident face normals weighted by the corner angle (Thuermer and Wuethrich)."""
    face_n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    face_n /= np.linalg.norm(face_n, axis=1, keepdims=True)
    acc = np.zeros_like(v)
    for k in range(3):
        a, b, c = v[f[:, k]], v[f[:, (k + 1) % 3]], v[f[:, (k + 2) % 3]]
        x, y = b - a, c - a
        cos = (x * y).sum(1) / (np.linalg.norm(x, axis=1) * np.linalg.norm(y, axis=1))
        np.add.at(acc, f[:, k], face_n * np.arccos(np.clip(cos, -1, 1))[:, None])
    return acc / np.linalg.norm(acc, axis=1, keepdims=True)


def build_world(scene: dict, base_dir=".") -> World:
    materials = {"default": dict(DEFAULT_MATERIAL)}
    for name, m in scene.get("materials", {}).items():
        materials[name] = {**DEFAULT_MATERIAL, **m}
    spheres, sphere_obj, tris, tri_obj, tri_n = [], [], [], [], []
    mats = []
    for oid, o in enumerate(scene.get("objects", [])):
        mats.append(materials[o.get("material", "default")])
        kind = o["type"]
        if kind == "sphere":
            spheres.append([*o["center"], o["radius"]])
            sphere_obj.append(oid)
            continue
        smooth = False
        if kind == "triangle":
            v, f = np.array(o["vertices"], np.float64), np.array([[0, 1, 2]])
        elif kind == "quad":
            c, a, b = (np.array(o[k], np.float64) for k in ("corner", "edge_a", "edge_b"))
            v, f = np.array([c, c + a, c + a + b, c + b]), np.array([[0, 1, 2], [0, 2, 3]])
        elif kind == "mesh":
            v, f = read_obj(Path(base_dir) / o["file"])
            scale = o.get("scale", 1.0)
            scale = np.full(3, float(scale)) if np.isscalar(scale) else np.array(scale, np.float64)
            v = (v * scale) @ rotation(o.get("rotate", (0, 0, 0))).T + np.array(o.get("translate", (0, 0, 0)), np.float64)
            smooth = bool(o.get("smooth", False))
        else:
            raise NotImplementedError(f"the reference has no {kind!r}")
        tris.append(v[f])
        tri_obj.append(np.full(len(f), oid))
        tri_n.append(angle_weighted_normals(v, f)[f] if smooth else np.full((len(f), 3, 3), np.nan))
    field_of = lambda key: np.array([m[key] for m in mats], np.float64).reshape(len(mats), -1)
    return World(
        spheres=np.array(spheres, np.float64).reshape(-1, 4),
        sphere_object=np.array(sphere_obj, int),
        triangles=np.concatenate(tris) if tris else np.zeros((0, 3, 3)),
        triangle_object=np.concatenate(tri_obj) if tri_obj else np.zeros(0, int),
        vertex_normals=np.concatenate(tri_n) if tri_n else np.zeros((0, 3, 3)),
        kd=field_of("diffuse"),
        ks=field_of("specular"),
        shininess=field_of("shininess")[:, 0],
        mirror=field_of("mirror")[:, 0],
        transparency=field_of("transparency")[:, 0],
        ior=field_of("ior")[:, 0],
        lights=list(scene.get("lights", [])),
        background=np.array(scene.get("background", (0, 0, 0)), np.float64),
        ambient=np.array(scene.get("ambient", (0, 0, 0)), np.float64),
    )


def camera_rays(camera: dict, width: int, height: int, offset=(0.5, 0.5)):
    """Eye and unit directions (H*W, 3) through each pixel at `offset` (the centre), row-major from the top-left."""
    eye = np.array(camera.get("position", (0, 0, 0)), np.float64)
    forward = np.array(camera.get("look_at", (0, 0, -1)), np.float64) - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.array(camera.get("up", (0, 1, 0)), np.float64))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    half_h = math.tan(math.radians(camera.get("fov", 60.0)) / 2)
    half_w = half_h * width / height
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
    sx = (2 * (xs + offset[0]) / width - 1) * half_w
    sy = (1 - 2 * (ys + offset[1]) / height) * half_h
    d = forward + sx[..., None] * right + sy[..., None] * up
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    return eye, d.reshape(-1, 3)


# ------------------------------------------------------------ intersection
def moller_trumbore(o, d, tri):
    """Distances (N, T) from rays to triangles (inf where missed) and barycentrics u, v of corners 1 and 2."""
    v0, e1, e2 = tri[:, 0], tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    pvec = np.cross(d[:, None, :], e2[None])
    det = (e1[None] * pvec).sum(-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        tvec = o[:, None, :] - v0[None]
        u = (tvec * pvec).sum(-1) * inv
        qvec = np.cross(tvec, e1[None])
        v = (d[:, None, :] * qvec).sum(-1) * inv
        t = (e2[None] * qvec).sum(-1) * inv
        ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return np.where(ok, t, np.inf), u, v


def _triangle_hits(world: World, o, d):
    """Distances (N, T) to every triangle (inf where missed) and barycentrics u, v of corners 1 and 2.
    Only rays that pass through an object's bounding sphere are tested against its triangles."""
    n, T = len(d), len(world.triangles)
    t, u, v = np.full((n, T), np.inf), np.zeros((n, T)), np.zeros((n, T))
    for index, centre, radius in world.bounds():
        oc = centre - o
        b = (oc * d).sum(-1)
        near = ((oc * oc).sum(-1) - b * b <= radius * radius) & (b + radius >= 0)
        if near.any():
            rows = np.flatnonzero(near)
            block = np.ix_(rows, index)
            t[block], u[block], v[block] = moller_trumbore(o[rows], d[rows], world.triangles[index])
    return t, u, v


def sphere_roots(world: World, o, d):
    """Both roots (N, S) of |o + t d - c| = r for unit d (NaN where the ray misses)."""
    c, r = world.spheres[:, :3], world.spheres[:, 3]
    oc = o[:, None, :] - c[None]
    b = (oc * d[:, None, :]).sum(-1)
    disc = b * b - ((oc * oc).sum(-1) - r * r)
    with np.errstate(invalid="ignore"):
        root = np.sqrt(disc)
    return -b - root, -b + root


def closest_hit(world: World, o, d):
    """t (inf on a miss), object id (-1), triangle index (-1 for spheres), u, v."""
    n = len(d)
    best_t, obj, tri_index = np.full(n, np.inf), np.full(n, -1), np.full(n, -1)
    bu, bv = np.zeros(n), np.zeros(n)
    if len(world.triangles):
        t, u, v = _triangle_hits(world, o, d)
        k = np.argmin(t, axis=1)
        tk = t[np.arange(n), k]
        hit = tk < best_t
        best_t[hit], obj[hit], tri_index[hit] = tk[hit], world.triangle_object[k[hit]], k[hit]
        bu[hit], bv[hit] = u[np.arange(n), k][hit], v[np.arange(n), k][hit]
    if len(world.spheres):
        t0, t1 = sphere_roots(world, o, d)
        t = np.where(t0 > 0, t0, np.where(t1 > 0, t1, np.inf))
        t = np.where(np.isnan(t), np.inf, t)
        k = np.argmin(t, axis=1)
        tk = t[np.arange(n), k]
        hit = tk < best_t
        best_t[hit], obj[hit], tri_index[hit] = tk[hit], world.sphere_object[k[hit]], -1 - k[hit]
    return best_t, obj, tri_index, bu, bv


def transmittance(world: World, o, d, t_max):
    """Fraction of light passing from o to o + t_max d: transparency per crossing, 0 past anything opaque."""
    T = np.ones(len(d))
    t_max = np.asarray(t_max, np.float64)[:, None]
    if len(world.triangles):
        t, _, _ = _triangle_hits(world, o, d)
        crossings = (t < t_max).astype(float)
        T *= np.prod(world.transparency[world.triangle_object][None] ** crossings, axis=1)
    if len(world.spheres):
        t0, t1 = sphere_roots(world, o, d)
        with np.errstate(invalid="ignore"):
            crossings = ((t0 > 0) & (t0 < t_max)).astype(float) + ((t1 > 0) & (t1 < t_max))
        T *= np.prod(world.transparency[world.sphere_object][None] ** crossings, axis=1)
    return T


# ----------------------------------------------------------------- shading
def _unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def _dot(a, b):
    return (a * b).sum(-1)


def schlick(cos_i, n1, n2, cos_t):
    """Schlick's reflectance, with the cosine taken on the side of the lower index (the larger angle)."""
    r0 = ((n1 - n2) / (n1 + n2)) ** 2
    c = np.where(n1 <= n2, cos_i, cos_t)
    return r0 + (1 - r0) * (1 - c) ** 5


class _Render:
    def __init__(self, world: World, width, height, max_depth, fresnel, seed, light_samples):
        self.w, self.width, self.height = world, width, height
        self.max_depth, self.fresnel, self.seed, self.light_samples = max_depth, fresnel, seed, light_samples
        n = width * height
        self.image = np.zeros((n, 3))
        self.signature = np.zeros(n, np.uint64)
        self.rng_dim = np.zeros(n, np.int64)  # next random dimension of each pixel's stream
        # which effects each pixel's path met, so tests can check a scene exercises what it claims
        self.seen = {
            k: np.zeros(n, bool)
            for k in ("mirror", "refraction", "tir", "fresnel", "smooth_normal", "shadow", "glass_shadow", "highlight", "partial_light")
        }

    def mark(self, effect, pix, where):
        self.seen[effect][pix[where]] = True

    def note(self, pix, event):
        """Fold a discrete event (an int per ray) into the pixels' signatures."""
        with np.errstate(over="ignore"):
            s = self.signature[pix] * np.uint64(1000003) + np.asarray(event, np.int64).astype(np.uint64) + np.uint64(7)
        self.signature[pix] = s

    def direct_light(self, pix, p, n, n_geo, v, kd, ks, shininess):
        w = self.w
        total = np.zeros_like(p)
        origin = p + n_geo * (LEAVE * (1 + np.abs(p).max(axis=1)))[:, None]
        for light in w.lights:
            kind = light.get("type", "point")
            colour = np.array(light.get("color", (1, 1, 1)), np.float64)
            intensity = float(light.get("intensity", 1.0))
            physical = light.get("falloff", "none") == "inverse_square"
            if kind == "area":
                corner, a, b = (np.array(light[k], np.float64) for k in ("corner", "edge_a", "edge_b"))
                side = self.light_samples or int(light.get("samples", 5))
                normal = np.cross(a, b)
                area = np.linalg.norm(normal)
                normal /= area
                cells = [(i, j) for i in range(side) for j in range(side)]
            else:
                side, cells = 1, [(0, 0)]
            visible_sum = 0
            for i, j in cells:
                if kind == "directional":
                    l = np.broadcast_to(-_unit(np.array(light["direction"], np.float64)), p.shape)
                    dist = np.full(len(p), np.inf)
                    falloff = np.ones(len(p))
                else:
                    if kind == "area":
                        xi_a = counter_rng.uniform(self.seed, pix, 0, self.rng_dim[pix])
                        xi_b = counter_rng.uniform(self.seed, pix, 0, self.rng_dim[pix] + 1)
                        self.rng_dim[pix] += 2
                        target = corner + ((i + xi_a) / side)[:, None] * a + ((j + xi_b) / side)[:, None] * b
                    else:
                        target = np.array(light["position"], np.float64)
                    l = target - p
                    dist = np.linalg.norm(l, axis=1)
                    l = l / dist[:, None]
                    falloff = 1 / dist**2 if physical else np.ones(len(p))
                    if physical and kind == "area":
                        falloff = falloff * area * np.abs(l @ normal)
                n_dot_l = _dot(n, l)
                facing = n_dot_l > 0
                T = np.zeros(len(p))
                if facing.any():
                    t_max = np.linalg.norm(p[facing] + l[facing] * dist[facing, None] - origin[facing], axis=1)
                    T[facing] = transmittance(w, origin[facing], l[facing], t_max)
                h = _unit(l + v)
                with np.errstate(invalid="ignore", divide="ignore"):
                    spec = np.maximum(_dot(n, h), 0.0) ** shininess
                if physical:  # energy-conserving BRDF: kd / pi + ks (s + 8) / (8 pi) (n.h)^s, times n.l
                    brdf = kd / np.pi + ks * ((shininess + 8) / (8 * np.pi) * np.where(facing, spec, 0.0))[:, None]
                    term = brdf * np.maximum(n_dot_l, 0)[:, None]
                else:  # the seed's model: kd n.l + ks (n.h)^s, no 1/pi
                    term = kd * np.maximum(n_dot_l, 0)[:, None] + ks * np.where(facing, spec, 0.0)[:, None]
                total += (T * falloff * intensity / side**2)[:, None] * colour * term
                self.mark("shadow", pix, facing & (T == 0))
                self.mark("glass_shadow", pix, facing & (T > 0) & (T < 1))
                self.mark("highlight", pix, facing & (T > 0) & (ks.max(axis=1) * spec > 0.05))
                if kind == "area":
                    visible_sum = visible_sum + (facing & (T > 0))
            if kind == "area":
                self.mark("partial_light", pix, (visible_sum > 0) & (visible_sum < len(cells)))
                self.note(pix, np.where(facing, 1 + np.round(T * 1000).astype(np.int64), 0))
        return total

    def trace(self, o, d, weight, medium, depth, pix, primary):
        w = self.w
        t, obj, tri, u, v = closest_hit(w, o, d)
        self.note(pix, obj)
        miss = obj < 0
        self.image[pix[miss]] += weight[miss] * w.background
        hit = ~miss
        o, d, weight, medium, pix, t, obj, tri, u, v = (a[hit] for a in (o, d, weight, medium, pix, t, obj, tri, u, v))
        if not len(pix):
            return
        p = o + t[:, None] * d
        is_tri = tri >= 0
        n_geo = np.zeros_like(p)
        if is_tri.any():
            corners = w.triangles[tri[is_tri]]
            n_geo[is_tri] = _unit(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]))
        if (~is_tri).any():
            sph = w.spheres[-1 - tri[~is_tri]]
            n_geo[~is_tri] = (p[~is_tri] - sph[:, :3]) / sph[:, 3:]
        n_shade = n_geo.copy()
        if is_tri.any():
            vn = w.vertex_normals[tri[is_tri]]
            smooth = ~np.isnan(vn[:, 0, 0])
            ui, vi = u[is_tri][:, None], v[is_tri][:, None]
            interpolated = _unit((1 - ui - vi) * vn[:, 0] + ui * vn[:, 1] + vi * vn[:, 2])
            n_shade[is_tri] = np.where(smooth[:, None], interpolated, n_geo[is_tri])
            self.mark("smooth_normal", pix[is_tri], smooth)
        front_face = _dot(d, n_geo) < 0
        n_geo[~front_face] *= -1
        n_shade[~front_face] *= -1
        faces_away = _dot(n_shade, d) >= 0
        n_shade[faces_away] = n_geo[faces_away]
        self.note(pix, faces_away)

        kd, ks, shine = w.kd[obj], w.ks[obj], w.shininess[obj]
        tr, mirror, ior = w.transparency[obj], w.mirror[obj], w.ior[obj]
        surface_weight = weight * ((1 - tr) * (1 - mirror))[:, None]
        shade = (surface_weight.max(axis=1) > 0) | primary
        if shade.any():
            s = shade
            surface = w.ambient * kd[s] + self.direct_light(pix[s], p[s], n_shade[s], n_geo[s], -d[s], kd[s], ks[s], shine[s])
            self.image[pix[s]] += surface_weight[s] * surface
        if depth >= self.max_depth:
            return

        w_reflect = weight * ((1 - tr) * mirror)[:, None]
        w_refract = np.zeros_like(weight)
        n1 = np.where(front_face, medium, ior)
        n2 = np.where(front_face, ior, 1.0)  # leaving an object enters air: objects do not nest
        eta = n1 / n2
        cos_i = -_dot(d, n_shade)
        sin2_t = eta**2 * np.maximum(0, 1 - cos_i**2)
        cannot_refract = sin2_t > 1
        cos_t = np.sqrt(np.maximum(0, 1 - sin2_t))
        refracted = _unit(eta[:, None] * d + (eta * cos_i - cos_t)[:, None] * n_shade)
        F = schlick(cos_i, n1, n2, cos_t) if self.fresnel else np.zeros(len(d))
        F = np.where(cannot_refract, 1.0, F)  # total internal reflection: all of it is reflected
        transparent = tr > 0
        self.note(pix, np.where(transparent, 1 + cannot_refract, 0))
        self.mark("mirror", pix, mirror > 0)
        self.mark("refraction", pix, transparent & ~cannot_refract)
        self.mark("tir", pix, transparent & cannot_refract)
        self.mark("fresnel", pix, transparent & ~cannot_refract & (F > 0))
        w_reflect += weight * (tr * F)[:, None]
        w_refract += weight * (tr * (1 - F))[:, None]
        leave = (LEAVE * (1 + np.abs(p).max(axis=1)))[:, None]

        go = w_reflect.max(axis=1) > 0
        if go.any():
            r = d[go] + 2 * cos_i[go, None] * n_shade[go]  # d - 2 (d.n) n
            self.trace(p[go] + n_geo[go] * leave[go], r, w_reflect[go], medium[go], depth + 1, pix[go], False)
        go = w_refract.max(axis=1) > 0
        if go.any():
            self.trace(p[go] - n_geo[go] * leave[go], refracted[go], w_refract[go], n2[go], depth + 1, pix[go], False)


@dataclass
class Rendering:
    image: np.ndarray  # (H, W, 3) float64 linear RGB
    signature: np.ndarray  # (H, W) uint64 hash of the discrete choices along each pixel's path
    seen: dict  # effect name -> (H, W) bool: the pixel's path met it (mirror, tir, glass_shadow, ...)
    steady: np.ndarray | None = None  # (H, W) bool, from render_steady


def render(
    scene: dict,
    width: int,
    height: int,
    *,
    camera: int = 1,
    max_depth: int = 8,
    fresnel: bool = False,
    seed: int = 0,
    light_samples: int = 0,
    base_dir=".",
    offset=(0.5, 0.5),
) -> Rendering:
    """The scene dict rendered with one ray per pixel (through its centre unless `offset` says otherwise)."""
    world = build_world(scene, base_dir)
    cameras = scene.get("cameras", [{}])
    eye, d = camera_rays(cameras[camera - 1], width, height, offset)
    job = _Render(world, width, height, max_depth, fresnel, seed, light_samples)
    n = width * height
    job.trace(np.broadcast_to(eye, d.shape).copy(), d, np.ones((n, 3)), np.ones(n), 0, np.arange(n), True)
    return Rendering(
        job.image.reshape(height, width, 3), job.signature.reshape(height, width), {k: v.reshape(height, width) for k, v in job.seen.items()}
    )


def render_steady(scene: dict, width: int, height: int, margin: float = 0.05, **settings) -> Rendering:
    """`render`, plus where the image is steady: pixels whose rays, moved by `margin` of a pixel in
    any direction, make the same discrete choices (so float32 rounding cannot change the branch)."""
    result = render(scene, width, height, **settings)
    result.steady = np.ones(result.signature.shape, bool)
    for dx, dy in ((-1, -1), (1, -1), (-1, 1), (1, 1)):
        moved = render(scene, width, height, offset=(0.5 + dx * margin, 0.5 + dy * margin), **settings)
        result.steady &= moved.signature == result.signature
    return result
