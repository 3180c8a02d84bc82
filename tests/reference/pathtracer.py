"""A unidirectional path tracer in float64 numpy: the test oracle for clrender's `integrator="path"` (issue 25).

It shares no code with clrender. It reads a subset of the scene dict of docs/scene-format.md and of
issue 25's additions, and returns the mean image with a per-pixel standard error, so a test can
z-test an analytic value or another renderer against it.

What it renders:

* camera: the first (or `camera`-th) of `cameras`: pinhole at `position` looking at `look_at`,
  `up`, vertical `fov` in degrees; row 0 at the top. Each pixel gets `spp` camera rays, at the
  pixel centre (`sampler="center"`), uniformly in the pixel (`"random"`), or one jittered sample
  per cell of an N x N grid (`"stratified"`, spp = N^2); all three estimate the box-filtered pixel;
* objects: `sphere` (center, radius), `triangle` (vertices), `quad` (corner, edge_a, edge_b: the
  triangles corner, +a, +a+b and corner, +a+b, +b), `mesh` given inline by `vertices` and `faces`;
* materials: Lambert `diffuse` albedo kd (BRDF kd/pi), two-sided: the shading normal is the
  geometric one turned towards the incoming ray; `emission` Le, radiance in W/(m^2 sr), one-sided:
  a triangle emits from its front face, the side its normal (v1 - v0) x (v2 - v0) points to (a
  quad: edge_a x edge_b), a sphere outwards. Other material keys (specular, mirror, glass, metal)
  are refused;
* `environment.color`: the constant radiance of every ray that hits nothing (absent: `background`, else black);
* `lights`: `point` and `directional`, with `color` c and `intensity` I by docs/shading.md: with
  falloff "inverse_square" a point light gives irradiance c*I*cos/r^2 and a directional one
  c*I*cos, reflected by kd/pi; with "none" (the default, the classic model) either gives c*I*kd*cos,
  no 1/pi and no 1/r^2. Area lights are refused (issue 25's emitters are emissive geometry).

Estimator, per camera ray (`strategy="mis"`, the default):

* max_depth counts bounces after the primary hit (issue 25's convention, Mitsuba's max_depth minus
  2): at each of the vertices x_1 .. x_{max_depth+1} the path samples the lights (next-event
  estimation) and the BSDF, and the emission of the point the BSDF ray reaches (or the
  environment, when it escapes) is added. max_depth = 0 is direct lighting. In a closed Lambert
  box with albedo rho whose walls all emit Le this sums Le * (1 + rho + ... + rho^(max_depth+1)).
* next-event estimation: one emitter (an emissive triangle or sphere) chosen with probability
  proportional to its power pi*A*mean(Le), a point uniform on its area, and one shadow ray; plus
  one shadow ray to every point and directional light (delta lights: no MIS);
* BSDF sampling: cosine-weighted directions, so the throughput is multiplied by kd;
* MIS: power heuristic (beta = 2) between the light pdf in solid angle, P(emitter) * r^2 /
  (A cos_light), and the BSDF pdf cos/pi, on both sides: light samples weighted
  p_light^2 / (p_light^2 + p_bsdf^2), emitters hit by BSDF rays p_bsdf^2 / (...); the camera ray's
  own hit and the environment (which is never light-sampled) count with weight 1;
* `strategy="nee"` counts emitters only through light samples (and when the camera ray hits them),
  `"bsdf"` only through BSDF rays; all three have the same expectation (the tests check it);
* Russian roulette is off unless `rr_depth` is given (then from that bounce on a path survives with
  probability min(0.95, max throughput) and is divided by it).

Random numbers come from one `numpy.random.Generator(seed)`, drawn for a batch of samples of every
pixel at a time: the same arguments give the same image, but the streams are not clrender's.
Rays leave a surface from its point moved `LEAVE * (1 + max|p|)` along the normal, on the side
they leave to; shadow rays stop a relative `SHADOW_END` short of the sampled point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .whitted import moller_trumbore, sphere_roots

LEAVE = 1e-9  # how far (relative to the point's magnitude) a ray leaves a surface along its normal
SHADOW_END = 1e-7  # shadow rays stop this fraction of their length short of the light's point
SAMPLERS = ("center", "random", "stratified")
STRATEGIES = ("mis", "nee", "bsdf")
BATCH_RAYS = 1 << 15  # camera rays traced together (a batch holds whole samples of every pixel)
MATERIAL_KEYS = {"diffuse", "emission"}
DEFAULT_DIFFUSE = (0.8, 0.8, 0.8)  # docs/scene-format.md's default kd


# ----------------------------------------------------------------- scene
@dataclass
class World:
    triangles: np.ndarray  # (T, 3, 3) corners
    tri_normal: np.ndarray  # (T, 3) unit geometric normal (v1 - v0) x (v2 - v0): the emitting side
    tri_kd: np.ndarray  # (T, 3) Lambert albedo
    tri_le: np.ndarray  # (T, 3) emitted radiance from the front face
    spheres: np.ndarray  # (S, 4) centre, radius
    sph_kd: np.ndarray  # (S, 3)
    sph_le: np.ndarray  # (S, 3) emitted radiance, outwards
    environment: np.ndarray  # (3,) radiance of rays that escape
    points: list  # (position (3,), c*I (3,), physical: bool) per point light
    directions: list  # (unit direction towards the light (3,), c*I (3,), physical) per directional light
    # emitters for next-event estimation: triangles first, then spheres
    emit_prim: np.ndarray  # (E,) triangle index t >= 0, or -1 - sphere index
    emit_area: np.ndarray  # (E,)
    emit_le: np.ndarray  # (E, 3)
    emit_prob: np.ndarray  # (E,) chosen with probability proportional to power pi * A * mean(Le)
    tri_emitter: np.ndarray  # (T,) index into the emitter arrays, -1 for non-emitting triangles
    sph_emitter: np.ndarray  # (S,)


def _vec(x, name):
    a = np.asarray(x, np.float64).reshape(-1)
    if a.shape != (3,):
        raise ValueError(f"{name} must be 3 numbers, got {x!r}")
    return a


def _unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def _dot(a, b):
    return (a * b).sum(-1)


def build_world(scene: dict) -> World:
    """The reference's arrays from a scene dict; NotImplementedError for anything outside its subset."""
    materials = {}
    for name, m in scene.get("materials", {}).items():
        unknown = set(m) - MATERIAL_KEYS
        if unknown:
            raise NotImplementedError(f"material {name!r}: the path reference has Lambert + emission only, not {sorted(unknown)}")
        materials[name] = (_vec(m.get("diffuse", DEFAULT_DIFFUSE), "diffuse"), _vec(m.get("emission", (0, 0, 0)), "emission"))
    materials.setdefault("default", (np.array(DEFAULT_DIFFUSE), np.zeros(3)))
    tris, tri_kd, tri_le, spheres, sph_kd, sph_le = [], [], [], [], [], []
    for o in scene.get("objects", []):
        kd, le = materials[o.get("material", "default")]
        kind = o["type"]
        if kind == "sphere":
            spheres.append([*_vec(o["center"], "center"), float(o["radius"])])
            sph_kd.append(kd)
            sph_le.append(le)
            continue
        if kind == "triangle":
            v, f = np.array(o["vertices"], np.float64), np.array([[0, 1, 2]])
        elif kind == "quad":
            c, a, b = (_vec(o[k], k) for k in ("corner", "edge_a", "edge_b"))
            v, f = np.array([c, c + a, c + a + b, c + b]), np.array([[0, 1, 2], [0, 2, 3]])
        elif kind == "mesh" and "vertices" in o:
            v, f = np.array(o["vertices"], np.float64), np.array(o["faces"], np.int64)
        else:
            raise NotImplementedError(f"the path reference has no {kind!r} object (sphere, triangle, quad, mesh with vertices and faces)")
        tris.append(v[f])
        tri_kd += [kd] * len(f)
        tri_le += [le] * len(f)
    triangles = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    tri_area = np.linalg.norm(cross, axis=1) / 2
    tri_le = np.array(tri_le, np.float64).reshape(-1, 3)
    sph = np.array(spheres, np.float64).reshape(-1, 4)
    sph_le = np.array(sph_le, np.float64).reshape(-1, 3)

    # emitters: every primitive with some emission, chosen in proportion to its power
    t_emit = np.flatnonzero(tri_le.max(axis=1) > 0)
    s_emit = np.flatnonzero(sph_le.max(axis=1) > 0)
    area = np.concatenate([tri_area[t_emit], 4 * np.pi * sph[s_emit, 3] ** 2])
    le = np.concatenate([tri_le[t_emit], sph_le[s_emit]])
    power = np.pi * area * le.mean(axis=1)
    tri_emitter = np.full(len(triangles), -1)
    tri_emitter[t_emit] = np.arange(len(t_emit))
    sph_emitter = np.full(len(sph), -1)
    sph_emitter[s_emit] = len(t_emit) + np.arange(len(s_emit))

    points, directions = [], []
    for light in scene.get("lights", []):
        kind = light.get("type", "point")
        ci = _vec(light.get("color", (1, 1, 1)), "color") * float(light.get("intensity", 1.0))
        physical = light.get("falloff", "none") == "inverse_square"
        if kind == "point":
            points.append((_vec(light["position"], "position"), ci, physical))
        elif kind == "directional":
            directions.append((-_unit(_vec(light["direction"], "direction")), ci, physical))
        else:
            raise NotImplementedError(f"the path reference has no {kind!r} light (point, directional; emitters are geometry)")
    return World(
        triangles=triangles,
        tri_normal=cross / np.maximum(np.linalg.norm(cross, axis=1, keepdims=True), 1e-300),
        tri_kd=np.array(tri_kd, np.float64).reshape(-1, 3),
        tri_le=tri_le,
        spheres=sph,
        sph_kd=np.array(sph_kd, np.float64).reshape(-1, 3),
        sph_le=sph_le,
        environment=_vec(scene.get("environment", {}).get("color", (0, 0, 0)), "environment.color")
        if "environment" in scene
        else _vec(scene.get("background", (0, 0, 0)), "background"),  # no environment: the background is one
        points=points,
        directions=directions,
        emit_prim=np.concatenate([t_emit, -1 - s_emit]),
        emit_area=area,
        emit_le=le,
        emit_prob=power / power.sum() if len(power) else power,
        tri_emitter=tri_emitter,
        sph_emitter=sph_emitter,
    )


def camera_frame(camera: dict, width: int, height: int):
    """Eye, forward, right, up scaled so that eye + forward + sx*right + sy*up, sx, sy in [-1, 1], spans the image."""
    eye = _vec(camera.get("position", (0, 0, 0)), "position")
    forward = _unit(_vec(camera.get("look_at", (0, 0, -1)), "look_at") - eye)
    right = _unit(np.cross(forward, _vec(camera.get("up", (0, 1, 0)), "up")))
    up = np.cross(right, forward)
    half_h = math.tan(math.radians(camera.get("fov", 60.0)) / 2)
    return eye, forward, right * half_h * width / height, up * half_h


def camera_rays(frame, width, height, pixel, offset):
    """Unit directions through pixels `pixel` (flat indices, row-major from the top-left) at `offset` (n, 2) in the pixel."""
    eye, forward, right, up = frame
    x = pixel % width + offset[:, 0]
    y = pixel // width + offset[:, 1]
    d = forward + (2 * x / width - 1)[:, None] * right + (1 - 2 * y / height)[:, None] * up
    return _unit(d)


# ------------------------------------------------------------ intersection
PRIM_NONE = np.iinfo(np.int64).min  # closest_hit's primitive for a ray that hits nothing


def _triangle_t(world: World, o, d):
    """Distances (N, T) along unit rays to every triangle (inf where missed), Moller-Trumbore (whitted.py's)."""
    return moller_trumbore(o, d, world.triangles)[0]


def _sphere_t(world: World, o, d):
    """Distance (N, S) to the first crossing in front of each ray (inf where missed)."""
    near, far = sphere_roots(world, o, d)
    t = np.where(near > 0, near, np.where(far > 0, far, np.inf))
    return np.where(np.isnan(t), np.inf, t)


def closest_hit(world: World, o, d):
    """t (inf on a miss) and primitive: triangle index >= 0, -1 - sphere index, or PRIM_NONE."""
    n = len(d)
    best, prim = np.full(n, np.inf), np.full(n, PRIM_NONE)
    rows = np.arange(n)
    if len(world.triangles):
        t = _triangle_t(world, o, d)
        k = t.argmin(axis=1)
        best, prim = t[rows, k], np.where(np.isfinite(t[rows, k]), k, PRIM_NONE)
    if len(world.spheres):
        t = _sphere_t(world, o, d)
        k = t.argmin(axis=1)
        nearer = t[rows, k] < best
        best, prim = np.where(nearer, t[rows, k], best), np.where(nearer, -1 - k, prim)
    return best, prim


def unoccluded(world: World, o, d, t_max):
    """True where nothing lies on the ray between o and o + t_max * d."""
    clear = np.ones(len(d), bool)
    for t_of, present in ((_triangle_t, len(world.triangles)), (_sphere_t, len(world.spheres))):
        if present:
            clear &= ~(t_of(world, o, d) < t_max[:, None]).any(axis=1)
    return clear


def surface(world: World, o, d, t, prim):
    """Hit point (sphere points put back on the radius), unit geometric normal (a triangle's front side,
    a sphere's outside), albedo and emitted radiance towards -d (0 from a back face)."""
    p = o + t[:, None] * d
    is_tri = prim >= 0
    n = np.empty_like(p)
    kd, le = np.empty_like(p), np.empty_like(p)
    ti = prim[is_tri]
    n[is_tri], kd[is_tri], le[is_tri] = world.tri_normal[ti], world.tri_kd[ti], world.tri_le[ti]
    si = -1 - prim[~is_tri]
    c, r = world.spheres[si, :3], world.spheres[si, 3:]
    n[~is_tri] = _unit(p[~is_tri] - c)
    p[~is_tri] = c + r * n[~is_tri]
    kd[~is_tri], le[~is_tri] = world.sph_kd[si], world.sph_le[si]
    front = _dot(d, n) < 0
    le = np.where(front[:, None], le, 0.0)
    return p, n, kd, le, front


def emitter_of(world: World, prim):
    """Index of the emitter each primitive is (-1: none)."""
    emitter = np.full(len(prim), -1)
    is_tri = prim >= 0
    emitter[is_tri] = world.tri_emitter[prim[is_tri]]
    emitter[~is_tri] = world.sph_emitter[-1 - prim[~is_tri]]
    return emitter


# ----------------------------------------------------------------- shading
def lambert(kd, cos_theta):
    """The Lambert BRDF times the cosine at the receiver, f * cos = kd / pi * max(cos, 0): what a light
    sample's radiance is multiplied by. (Tests replace it to plant bugs; BSDF sampling does not use it.)"""
    return kd / np.pi * np.maximum(cos_theta, 0.0)[:, None]


def power_heuristic(pdf_a, pdf_b):
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        w = pdf_a**2 / (pdf_a**2 + pdf_b**2)
    return np.where(np.isfinite(w), w, np.where(np.isinf(pdf_a), 1.0, 0.0))


def light_pdf(world: World, emitter, dist, cos_light):
    """Solid-angle pdf of next-event estimation choosing this emitter's point: P(emitter) / A * r^2 / cos."""
    with np.errstate(divide="ignore"):
        return np.where(cos_light > 0, world.emit_prob[emitter] / world.emit_area[emitter] * dist**2 / cos_light, np.inf)


def sample_emitter_points(world: World, rng, n):
    """Emitter index (n,), a point uniform on its area and the unit normal there."""
    e = rng.choice(len(world.emit_prob), size=n, p=world.emit_prob)
    prim = world.emit_prim[e]
    u1, u2 = rng.random(n), rng.random(n)
    y, ny = np.empty((n, 3)), np.empty((n, 3))
    is_tri = prim >= 0
    tri = world.triangles[prim[is_tri]]
    su = np.sqrt(u1[is_tri])  # uniform on a triangle: b0 = 1 - sqrt(u1), b1 = sqrt(u1) (1 - u2), b2 = sqrt(u1) u2
    y[is_tri] = tri[:, 0] * (1 - su)[:, None] + tri[:, 1] * (su * (1 - u2[is_tri]))[:, None] + tri[:, 2] * (su * u2[is_tri])[:, None]
    ny[is_tri] = world.tri_normal[prim[is_tri]]
    sph = world.spheres[-1 - prim[~is_tri]]
    z = 1 - 2 * u1[~is_tri]  # uniform on the sphere
    ring, phi = np.sqrt(np.maximum(0.0, 1 - z * z)), 2 * np.pi * u2[~is_tri]
    ny[~is_tri] = np.stack([ring * np.cos(phi), ring * np.sin(phi), z], axis=1)
    y[~is_tri] = sph[:, :3] + sph[:, 3:] * ny[~is_tri]
    return e, y, ny


def cosine_directions(n, rng):
    """Cosine-weighted unit directions about the unit normals n (pdf cos / pi)."""
    u1, u2 = rng.random(len(n)), rng.random(len(n))
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    local = np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0.0, 1 - u1))], axis=1)
    helper = np.where((np.abs(n[:, 0]) > 0.9)[:, None], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    t = _unit(np.cross(helper, n))
    b = np.cross(n, t)
    return local[:, :1] * t + local[:, 1:2] * b + local[:, 2:] * n


def leave(p, n):
    """p moved off the surface along n (the side the next ray leaves to)."""
    return p + n * (LEAVE * (1 + np.abs(p).max(axis=1)))[:, None]


# ------------------------------------------------------------ integrator
@dataclass
class PathImage:
    image: np.ndarray  # (H, W, 3) mean radiance, linear RGB
    stderr: np.ndarray  # (H, W, 3) standard error of that mean, sample std / sqrt(spp): exact for "center" and "random",
    # too large (so tests stay conservative) for "stratified", whose samples are not independent
    spp: int


def radiance(world: World, o, d, rng, max_depth, strategy="mis", rr_depth=None):
    """One-sample estimates (N, 3) of the radiance arriving at o from direction -d (unit d)."""
    n = len(d)
    L = np.zeros((n, 3))
    beta = np.ones((n, 3))
    idx = np.arange(n)  # which path each live ray belongs to
    t, prim = closest_hit(world, o, d)
    light_sampling = strategy in ("mis", "nee") and len(world.emit_prob) > 0
    last_p = last_pdf = None  # the BSDF ray's origin and pdf, for MIS when it reaches an emitter
    for bounce in range(max_depth + 2):
        # what the ray reached: the environment, or emission at its hit point
        miss = prim == PRIM_NONE
        L[idx[miss]] += beta[miss] * world.environment
        keep = ~miss
        idx, o, d, t, prim, beta = idx[keep], o[keep], d[keep], t[keep], prim[keep], beta[keep]
        if last_p is not None:
            last_p, last_pdf = last_p[keep], last_pdf[keep]
        if not len(idx):
            break
        p, n_geo, kd, le, _ = surface(world, o, d, t, prim)
        if bounce == 0 or strategy == "bsdf":
            weight = np.ones(len(idx))
        else:
            emitter = emitter_of(world, prim)
            lit = emitter >= 0
            weight = np.ones(len(idx)) if strategy == "mis" else np.where(lit, 0.0, 1.0)
            if strategy == "mis" and lit.any():
                dist = np.linalg.norm(p[lit] - last_p[lit], axis=1)
                pdf_l = light_pdf(world, emitter[lit], dist, _dot(-d[lit], n_geo[lit]))
                weight[lit] = power_heuristic(last_pdf[lit], pdf_l)
        L[idx] += beta * le * weight[:, None]
        if bounce == max_depth + 1:
            break

        # the vertex: two-sided Lambert, the shading normal faces the incoming ray
        n_s = np.where((_dot(d, n_geo) < 0)[:, None], n_geo, -n_geo)
        origin = leave(p, n_s)
        if light_sampling:
            e, y, ny = sample_emitter_points(world, rng, len(idx))
            wi = y - origin
            dist = np.linalg.norm(wi, axis=1)
            wi /= dist[:, None]
            cos_x, cos_l = _dot(wi, n_s), _dot(-wi, ny)
            useful = (cos_x > 0) & (cos_l > 0)
            useful[useful] = unoccluded(world, origin[useful], wi[useful], dist[useful] * (1 - SHADOW_END))
            pdf_l = light_pdf(world, e, dist, cos_l)
            w = power_heuristic(pdf_l, np.maximum(cos_x, 0) / np.pi) if strategy == "mis" else np.ones(len(idx))
            with np.errstate(invalid="ignore", divide="ignore"):
                contrib = lambert(kd, cos_x) * world.emit_le[e] * (w / pdf_l)[:, None]
            L[idx[useful]] += beta[useful] * contrib[useful]
        for kind, lights in (("point", world.points), ("directional", world.directions)):
            for where, ci, physical in lights:
                if kind == "point":
                    wi = where - origin
                    dist = np.linalg.norm(wi, axis=1)
                    wi /= dist[:, None]
                    falloff = 1 / dist**2 if physical else np.ones(len(idx))
                    t_max = dist
                else:
                    wi = np.broadcast_to(where, origin.shape)
                    falloff, t_max = np.ones(len(idx)), np.full(len(idx), np.inf)
                cos_x = _dot(wi, n_s)
                useful = cos_x > 0
                useful[useful] = unoccluded(world, origin[useful], wi[useful], t_max[useful])
                # physical: kd / pi * c I cos (/ r^2); "none", the classic model: c I kd cos
                scale = falloff * (1.0 if physical else np.pi)
                L[idx[useful]] += (beta * lambert(kd, cos_x) * ci * scale[:, None])[useful]

        # BSDF sampling: cosine-weighted, so f cos / pdf = kd
        d = cosine_directions(n_s, rng)
        last_p, last_pdf = origin, _dot(d, n_s) / np.pi
        beta = beta * kd
        if rr_depth is not None and bounce >= rr_depth:
            survive = np.minimum(0.95, beta.max(axis=1))
            alive = rng.random(len(idx)) < survive
            beta = beta / np.maximum(survive, 1e-300)[:, None]
        else:
            alive = beta.max(axis=1) > 0
        idx, o, d, beta, last_p, last_pdf = idx[alive], origin[alive], d[alive], beta[alive], last_p[alive], last_pdf[alive]
        t, prim = closest_hit(world, o, d)
    return L


def render(
    scene: dict,
    *,
    spp: int = 64,
    max_depth: int = 8,
    seed: int = 0,
    sampler: str = "random",
    strategy: str = "mis",
    camera: int = 1,
    width: int | None = None,
    height: int | None = None,
    rr_depth: int | None = None,
) -> PathImage:
    """Mean radiance per pixel over `spp` paths and its standard error (see the module docstring)."""
    if sampler not in SAMPLERS or strategy not in STRATEGIES:
        raise ValueError(f"sampler must be one of {SAMPLERS} and strategy one of {STRATEGIES}")
    grid = math.isqrt(spp)
    if sampler == "stratified" and grid * grid != spp:
        raise ValueError(f"the stratified sampler needs spp = N^2, not {spp}")
    if spp < 2:
        raise ValueError("spp must be at least 2 to estimate a standard error")
    world = build_world(scene)
    width = int(width or scene.get("width", 640))
    height = int(height or scene.get("height", 480))
    frame = camera_frame(scene.get("cameras", [{}])[camera - 1], width, height)
    rng = np.random.default_rng(seed)
    n_pix = width * height
    total, total_sq = np.zeros((n_pix, 3)), np.zeros((n_pix, 3))
    per_batch = max(1, BATCH_RAYS // n_pix)  # whole samples of every pixel per batch
    for first in range(0, spp, per_batch):
        samples = np.arange(first, min(spp, first + per_batch))
        pixel = np.tile(np.arange(n_pix), len(samples))
        sample = np.repeat(samples, n_pix)
        if sampler == "center":
            offset = np.full((len(pixel), 2), 0.5)
        elif sampler == "random":
            offset = rng.random((len(pixel), 2))
        else:
            cell = np.stack([sample % grid, sample // grid], axis=1)
            offset = (cell + rng.random((len(pixel), 2))) / grid
        d = camera_rays(frame, width, height, pixel, offset)
        o = np.broadcast_to(frame[0], d.shape).copy()
        L = radiance(world, o, d, rng, max_depth, strategy, rr_depth)
        for c in range(3):
            total[:, c] += np.bincount(pixel, L[:, c], n_pix)
            total_sq[:, c] += np.bincount(pixel, L[:, c] ** 2, n_pix)
    mean = total / spp
    variance = np.maximum(total_sq / spp - mean**2, 0.0) * spp / (spp - 1)
    return PathImage(mean.reshape(height, width, 3), np.sqrt(variance / spp).reshape(height, width, 3), spp)
