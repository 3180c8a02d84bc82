"""Scenes and files that several test folders build: copies of one mesh file (instancing), an alpha checker
texture (alpha testing); flat white surfaces for camera tests; an HDR file; one Mitsuba XML file rendered by both
renderers (the scene-format tests)."""

import math

import numpy as np
import trimesh

from clrender.scene.scene import Scene

CHECKER = 4  # 4 x 4 texels, alpha 255 where i + j is even, 0 elsewhere


def write_checker(tmp_path):
    from PIL import Image

    i, j = np.meshgrid(np.arange(CHECKER), np.arange(CHECKER))
    texels = np.full((CHECKER, CHECKER, 4), 255, np.uint8)
    texels[..., 3] = np.where((i + j) % 2 == 0, 255, 0)
    Image.fromarray(texels, "RGBA").save(tmp_path / "checker.png")


def copies_scene(tmp_path, copies: int, material: dict | None = None) -> Scene:
    """`copies` objects naming one smooth .obj (an icosphere of 1280 faces), on a grid, turned and scaled."""
    trimesh.creation.icosphere(subdivisions=3).export(tmp_path / "ball.obj")
    rng = np.random.default_rng(11)
    objects = [
        {
            "type": "mesh",
            "file": "ball.obj",
            "smooth": True,
            "translate": [1.2 * (i % 6) - 3, 1.2 * (i // 6) - 2.4, 0],
            "rotate": [0, float(rng.uniform(0, 360)), 0],
            "scale": [0.5, float(rng.uniform(0.3, 0.6)), 0.4],
            "material": "m",
        }
        for i in range(copies)
    ]
    data = {
        "cameras": [{"position": [0, 0, 9], "look_at": [0, 0, 0], "fov": 50}],
        "lights": [{"type": "point", "position": [2, 3, 8]}],
        "materials": {"m": material or {"diffuse": [0.8, 0.7, 0.6]}},
        "objects": objects,
    }
    return Scene.from_dict(data, base_dir=tmp_path)


CARD_OBJ = """v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
f 1/1 2/2 3/3
f 1/1 3/3 4/4
"""


def instanced_scene(tmp_path) -> dict:
    """What an instance's hit reads, placed three ways each: copies of a smooth ball (turned, stretched, one mirrored), of
    a uv-mapped card with a tilted normal map (tangents turned to world space), of one whose checker alpha lets rays
    through (glTF MASK, single-sided: camera rays look past its back), over a flat floor and a flat sphere, under a
    point light and a constant environment."""
    import math

    from PIL import Image

    write_checker(tmp_path)
    trimesh.creation.icosphere(subdivisions=2).export(tmp_path / "ball.obj")
    (tmp_path / "card.obj").write_text(CARD_OBJ)
    n = np.array([math.sin(math.radians(30)), 0.0, math.cos(math.radians(30))])
    Image.fromarray(np.broadcast_to(np.round((n + 1) / 2 * 255).astype(np.uint8), (2, 2, 3)).copy()).save(tmp_path / "tilt.png")
    placements = [
        ([-1.5, 0.3, 0], [0, 20, 0], [0.5, 0.5, 0.5]),
        ([0, 0.3, -0.5], [10, 60, 0], [0.4, 0.7, 0.5]),
        ([1.5, 0.3, 0], [0, -30, 0], [-0.5, 0.5, 0.5]),  # mirrored
    ]
    objects = []
    for mesh, material, lift in (("ball.obj", "ball", 0.0), ("card.obj", "tilted", 1.3), ("card.obj", "holes", -1.3)):
        for translate, rotate, scale in placements:
            place = {"translate": [translate[0], translate[1] + lift, translate[2]], "rotate": rotate, "scale": scale}
            objects.append({"type": "mesh", "file": mesh, "smooth": mesh == "ball.obj", "material": material, **place})
    objects += [
        {"type": "sphere", "center": [0.8, -0.2, 1.2], "radius": 0.3, "material": "ball"},
        {"type": "quad", "corner": [-5, -2, -3], "edge_a": [10, 0, 0], "edge_b": [0, 0, 6], "material": "floor"},
    ]
    return {
        "width": 16,
        "height": 16,
        "cameras": [{"position": [0, 0.5, 7], "look_at": [0, 0, 0], "fov": 45}],
        "textures": {"checker": {"file": "checker.png", "filter": "nearest"}, "tilt": {"file": "tilt.png"}},
        "materials": {
            "ball": {"base_color": [0.8, 0.5, 0.3], "metallic": 0.5, "roughness": 0.3},
            "tilted": {"base_color": [0.5, 0.6, 0.7], "normal_texture": "tilt"},
            "holes": {"diffuse": [0.9, 0.2, 0.2], "diffuse_texture": "checker", "alpha": {"mode": "mask"}, "double_sided": False},
            "floor": {"diffuse": [0.7, 0.7, 0.7]},
        },
        "lights": [{"type": "point", "position": [1, 4, 5], "intensity": 30, "falloff": "inverse_square"}],
        "environment": {"color": [0.2, 0.25, 0.3]},
        "objects": objects,
    }


# The widest pixel offset at which one sample reaches two pixels, ceil(2 r) - 1 for Mitsuba's filter radii r
# (box 0.5, tent 1, gaussian 4 x 0.5): the z-test's `lag`, without which a filtered image fails it by chance
FILTER_LAG = {"box": 0, "tent": 1, "gaussian": 3}


def xml_against_mitsuba(path, device, *, spp: int, k: int = 4, defines: dict | None = None):
    """The block z-test (tests/reference/ztest.py) of `k` renders a side of one Mitsuba XML file: Mitsuba loads the
    very file (mi.load_file), clrender reads it with Scene.from_file and renders with the file's own settings,
    the test counting the pixel correlations of the file's reconstruction filter (FILTER_LAG).  Skips without
    Mitsuba."""
    import pytest

    from clrender import Renderer
    from clrender.trace.tracer import Tracer

    from tests.reference import mitsuba_scenes
    from tests.reference.ztest import two_sample_z

    variant = "llvm_ad_rgb" if not mitsuba_scenes.unavailable("llvm_ad_rgb") else "scalar_rgb"
    reason = mitsuba_scenes.unavailable(variant)
    if reason:
        pytest.skip(reason)
    mi = mitsuba_scenes.load_mitsuba(variant)
    loaded = mi.load_file(str(path), **(defines or {}))
    theirs = np.stack([mitsuba_scenes.render_loaded(mi, loaded, spp=spp, seed=100 + s) for s in range(k)])
    scene = Scene.from_file(path, defines=defines)
    own = dict(scene.render_settings, spp=spp)
    tracer = Tracer(scene, device=device)
    ours = np.stack([Renderer(scene, tracer=tracer, seed=s, **own).run().image for s in range(k)])
    return two_sample_z(ours, theirs, lag=FILTER_LAG[own.get("rfilter", "box")])


# ---------------------------------------------------------------------- camera tests: surfaces that show exactly 1
WHITE = {"diffuse": [1, 1, 1], "specular": [0, 0, 0], "emission": [1, 1, 1]}
# A light of intensity 0: the Whitted images are ambient x diffuse = 1 on a surface, 0 elsewhere (no "no lights" warning)
DARK_LIGHT = {"type": "directional", "direction": [0, 0, -1], "intensity": 0}


def flat_scene(objects, camera, size=(64, 64)):
    """Surfaces that show exactly 1 (Whitted: ambient 1 x white; path: emission 1) on black."""
    return Scene.from_dict(
        {
            "width": size[0],
            "height": size[1],
            "ambient": [1, 1, 1],
            "cameras": [camera],
            "materials": {"white": WHITE},
            "lights": [DARK_LIGHT],
            "objects": [{**o, "material": "white"} for o in objects],
        }
    )


def square(centre, half):
    """An axis-aligned square facing +z (towards a camera on +z)."""
    x, y, z = centre
    return {"type": "quad", "corner": [x - half, y - half, z], "edge_a": [2 * half, 0, 0], "edge_b": [0, 2 * half, 0]}


def pixels_per_unit(fov, height):
    """Pixels per unit of the perspective image plane at distance 1."""
    return height / (2 * math.tan(math.radians(fov) / 2))


def write_hdr(path, value=2.0, size=(8, 16)):
    import OpenImageIO as oiio

    pixels = np.full((*size, 3), value, np.float32)
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(size[1], size[0], 3, "float"))
    out.write_image(pixels)
    out.close()
    return path
