"""The path tracer's test helpers: renders with seeds 1..K, the exact-image test at a stated false-alarm level
(per-pixel t-tests and a pooled z), a binomial count test, and the scenes with closed forms or float64 references
(a closed emitting box, a lamp over a floor, a scene with every kind of vertex).  Used by tests/trace/test_path.py
and test_path_sampler.py."""

import math
from statistics import NormalDist

import numpy as np

from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests.reference import path_scenes
from tests.reference.path_scenes import camera, quad
from tests.reference.ztest import sidak, two_sample_z

ALPHA = 1e-3  # false-alarm probability of each statistical test function, for a random seed


K = 8  # independent renders (seeds 1..K) where a test needs each pixel's variance


def renders(scene: dict, device, k: int = K, **settings) -> np.ndarray:
    """(k, H, W, 3) float64: path-traced renders with seeds 1..k, one Tracer for all."""
    loaded = Scene.from_dict(scene)
    tracer = Tracer(loaded, device=device)
    images = [Renderer(loaded, tracer=tracer, integrator="path", seed=s, **settings).run().image for s in range(1, k + 1)]
    return np.stack(images).astype(np.float64)


def render_once(scene: dict, device, **settings):
    loaded = Scene.from_dict(scene)
    return Renderer(loaded, tracer=Tracer(loaded, device=device), integrator="path", **settings).run()


def pooled_z(images: np.ndarray, expected) -> np.ndarray:
    """Per channel: the summed differences of every pixel's mean from `expected` over their standard error."""
    k = len(images)
    diff = (images.mean(axis=0) - expected).reshape(-1, 3)
    var = (images.var(axis=0, ddof=1) / k).reshape(-1, 3)
    return diff.sum(axis=0) / np.sqrt(var.sum(axis=0) + 1e-30)


POOLED_LIMIT = NormalDist().inv_cdf(1 - sidak(ALPHA / 2, 3) / 2)  # 3.76: the three channels' pooled z at ALPHA / 2


def assert_expected(images: np.ndarray, expected, what: str):
    """The module docstring's test against an exact image: per-pixel t-tests at ALPHA / 2 and pooled z at ALPHA / 2."""
    per_pixel = two_sample_z(images, np.broadcast_to(np.asarray(expected, np.float64), images.shape), block=1, alpha=ALPHA / 2)
    assert per_pixel.passed, f"{what}: per pixel, {per_pixel.report()}"
    z = pooled_z(images, expected)
    assert np.abs(z).max() <= POOLED_LIMIT, f"{what}: pooled z {np.round(z, 2)}, limit {POOLED_LIMIT:.2f}"


def assert_binomial(successes: float, trials: int, p: float, what: str):
    """Two-sided normal test of a binomial count at ALPHA."""
    z = (successes - trials * p) / math.sqrt(trials * p * (1 - p))
    limit = NormalDist().inv_cdf(1 - ALPHA / 2)
    assert abs(z) <= limit, f"{what}: {successes:.1f} of {trials} against p = {p:.4f} (expected {trials * p:.1f}), z {z:+.2f}, limit {limit:.2f}"


def fan_cube(inward_point=(0.3, -0.2)) -> tuple[list, list]:
    """The cube [-1, 1]^3 with each face a fan of four triangles around an off-centre point of it (areas 0.7, 1.2,
    1.3 and 0.8: unequal, so choosing emitters by power is not choosing them uniformly), wound so that every normal
    (v1 - v0) x (v2 - v0) points into the cube.  Watertight: the fans meet only along the cube's edges."""
    vertices, faces = [], []
    for axis in range(3):
        for side in (-1.0, 1.0):
            u, v = [a for a in range(3) if a != axis]
            ring = []
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                corner = [0.0, 0.0, 0.0]
                corner[axis], corner[u], corner[v] = side, a, b
                ring.append(corner)
            centre = [0.0, 0.0, 0.0]
            centre[axis], centre[u], centre[v] = side, *inward_point
            base = len(vertices)
            vertices += ring + [centre]
            for i in range(4):
                tri = [base + 4, base + i, base + (i + 1) % 4]
                normal = np.cross(np.subtract(vertices[tri[1]], vertices[tri[0]]), np.subtract(vertices[tri[2]], vertices[tri[0]]))
                faces.append(tri if normal[axis] * side < 0 else tri[::-1])
    return vertices, faces


def closed_box(rho: float = 0.5, le: float = 1.0, size: int = 16) -> dict:
    """The camera inside fan_cube's cube, whose walls all have albedo rho and emit Le inwards."""
    return path_scenes.closed_box(*fan_cube(), rho, le, size)


def closed_box_radiance(rho: float, le: float, max_depth: int) -> float:
    return le * (1 - rho ** (max_depth + 2)) / (1 - rho)


def lamp_over_floor(size: int = 16, area_light: bool = False) -> dict:
    """A 1 x 1 lamp of radiance 2 facing down 1 above a diffuse floor, a diffuse ball casting a shadow, looked at
    from above (the lamp itself out of view): an emissive quad, or with `area_light` a two-sided physical area
    light (docs/materials.md), which lights the floor the same."""
    corner, edge_a, edge_b = [-0.5, 1.0, -0.4], [1.0, 0, 0], [0, 0, 1.0]  # edge_a x edge_b = -y: facing the floor
    scene = {
        "width": size,
        "height": size,
        "cameras": [camera([0, 0.9, 1.3], [0.15, 0, 0.4], 40)],
        "materials": {"floor": {"diffuse": [0.6, 0.48, 0.3]}, "lamp": {"diffuse": [0, 0, 0], "emission": [2.0] * 3}},
        "objects": [
            quad([-1.5, 0, -1.5], [0, 0, 3], [3, 0, 0], "floor"),
            {"type": "sphere", "center": [0.45, 0.3, 0.3], "radius": 0.3, "material": "floor"},
        ],
    }
    if area_light:
        light = {"type": "area", "corner": corner, "edge_a": edge_a, "edge_b": edge_b, "intensity": 2.0, "falloff": "inverse_square"}
        scene["lights"] = [light]
    else:
        scene["objects"].append(quad(corner, edge_a, edge_b, "lamp"))
    return scene


def mixed_scene(size=(20, 12)) -> dict:
    """Lambert, glTF metal and glass under an emissive quad and a dim sky: every kind of vertex."""
    return {
        "width": size[0],
        "height": size[1],
        "cameras": [camera([0, 1.2, 4], [0, 0.5, 0], 45)],
        "environment": {"color": [0.1, 0.12, 0.15]},
        "materials": {
            "floor": {"diffuse": [0.7, 0.7, 0.7]},
            "metal": {"base_color": [0.9, 0.6, 0.3], "metallic": 1.0, "roughness": 0.3},
            "glass": {"transparency": 1.0, "ior": 1.5},
            "lamp": {"diffuse": [0, 0, 0], "emission": [3, 2.5, 2]},
        },
        "objects": [
            quad([-3, 0, -3], [0, 0, 6], [6, 0, 0], "floor"),
            {"type": "sphere", "center": [-0.6, 0.5, 0], "radius": 0.5, "material": "metal"},
            {"type": "sphere", "center": [0.6, 0.4, 0.3], "radius": 0.4, "material": "glass"},
            quad([-0.5, 2, -0.5], [1, 0, 0], [0, 0, 1], "lamp"),
        ],
    }


AOVS = ("depth", "normal", "albedo", "id")  # every AOV a path render records: what the schedules must agree on


def assert_same(a, b) -> None:
    """Two renders of one scene under two path schedules: the same image, ids, AOVs and ray and visit counts, byte
    for byte."""
    assert a.image.tobytes() == b.image.tobytes(), f"{(a.image != b.image).any(axis=-1).mean():.3%} of pixels differ"
    assert a.path_ids.tobytes() == b.path_ids.tobytes()
    assert sorted(a.aovs) == sorted(b.aovs)
    for name in a.aovs:
        assert a.aovs[name].tobytes() == b.aovs[name].tobytes(), name
    assert (a.rays, a.node_visits) == (b.rays, b.node_visits)


def blend_card() -> dict:
    """A half-transparent (glTF BLEND) card over a floor under a directional light and an area light."""
    return {
        "width": 16,
        "height": 16,
        "cameras": [{"position": [0, 3, 8], "look_at": [0, 0, 0], "fov": 40}],
        "materials": {"card": {"diffuse": [1, 0.2, 0.1], "alpha": {"mode": "blend", "factor": 0.4}}, "floor": {"diffuse": [0.8, 0.8, 0.8]}},
        "lights": [{"type": "directional", "direction": [0.3, -1, -0.2]}],
        "objects": [
            {"type": "quad", "corner": [-1, 0.2, -1], "edge_a": [2, 0, 0], "edge_b": [0, 2, 0.5], "material": "card"},
            {"type": "quad", "corner": [-4, 0, -4], "edge_a": [0, 0, 8], "edge_b": [8, 0, 0], "material": "floor"},
        ],
        "environment": {"color": [0.2, 0.25, 0.3]},
    }


def env_map_scene(tmp_path) -> dict:
    """A rough glass sphere and a Lambert one on a floor under a random 8 x 16 HDR map (NEE samples it, BSDF rays
    meet it)."""
    import OpenImageIO as oiio

    pixels = np.random.default_rng(3).uniform(0, 4, (8, 16, 3)).astype(np.float32)
    out = oiio.ImageOutput.create(str(tmp_path / "sky.exr"))
    assert out.open(str(tmp_path / "sky.exr"), oiio.ImageSpec(16, 8, 3, "float"))
    assert out.write_image(pixels)
    out.close()
    return {
        "width": 16,
        "height": 12,
        "cameras": [path_scenes.camera([0, 1, 4], [0, 0.4, 0], 45)],
        "environment": {"file": "sky.exr"},
        "materials": {
            "floor": {"diffuse": [0.6, 0.6, 0.6]},
            "glass": {"transparency": 1.0, "ior": 1.5},
            "clay": {"diffuse": [0.7, 0.3, 0.2]},
        },
        "objects": [
            path_scenes.quad([-3, 0, -3], [0, 0, 6], [6, 0, 0], "floor"),
            {"type": "sphere", "center": [-0.5, 0.4, 0], "radius": 0.4, "material": "glass"},
            {"type": "sphere", "center": [0.5, 0.4, 0], "radius": 0.4, "material": "clay"},
        ],
    }


def render_both(scene, schedule: str, kernel_type, megakernel_tiles: int = 64, tiles: int = 7, **settings):
    """(megakernel result, result under `schedule`, that Renderer) of `scene` with `settings`, each on its tiling; the
    second renders with a kernel of `kernel_type` (the schedule took the scene), the first not."""
    from clrender.trace.tracer import as_scene

    scene = Scene.from_dict(scene) if isinstance(scene, dict) else as_scene(scene)
    a = Renderer(scene, integrator="path", path_schedule="megakernel", tile_size=megakernel_tiles, **settings)
    b = Renderer(scene, integrator="path", path_schedule=schedule, tile_size=tiles, tracer=a.tracer, **settings)
    assert isinstance(b.kernel, kernel_type) and not isinstance(a.kernel, kernel_type)
    return a.run(), b.run(), b
