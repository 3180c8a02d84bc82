"""clrender's renderer against an independent float64 Whitted tracer (tests/reference/whitted.py).

Each small scene switches on some of docs/shading.md's rules; together they cover
spheres, triangles, quads and OBJ meshes (flat and smooth), point,
directional and area lights (both falloff models), ambient, Lambert and
Blinn-Phong, mirrors, refraction through spheres and meshes with total
internal reflection, Schlick's Fresnel term, shadows through glass and
meshes, media met inside other objects, cameras with their own up vector,
and max depth.  The two must agree pixel for pixel to float32 precision
wherever the pixel's ray, moved a twentieth of a pixel either way, makes the
same discrete choices (same objects hit, same shadow visibility, same
refract-or-reflect branch).
"""

from pathlib import Path

import numpy as np
import pytest
import trimesh

import clrender

from tests.reference.whitted import render_steady

W, H = 48, 36
TOLERANCE = 1e-4  # absolute, linear RGB: float32 rounding and ray offsets; measured at most 2.2e-5 (glass meshes)


def write_obj(path: Path, vertices, faces):
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(vertices, float).tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(faces).tolist()]
    path.write_text("\n".join(lines) + "\n")
    return path.name


def icosphere(tmp_path, subdivisions=2):
    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    return write_obj(tmp_path / f"ico{subdivisions}.obj", s.vertices, s.faces)


def prism(tmp_path):
    """A triangular glass prism along z, cross-section an equilateral-ish triangle."""
    tri = np.array([[-0.7, -0.5], [0.7, -0.5], [0.0, 0.7]])
    v = np.array([[x, y, z] for z in (-0.8, 0.8) for x, y in tri])
    f = [[0, 2, 1], [3, 4, 5], [0, 1, 4], [0, 4, 3], [1, 2, 5], [1, 5, 4], [2, 0, 3], [2, 3, 5]]
    return write_obj(tmp_path / "prism.obj", v, f)


FLOOR = {"type": "quad", "corner": [-6, -1, 2], "edge_a": [12, 0, 0], "edge_b": [0, 0, -14], "material": "floor"}
STRIPES = [{"type": "quad", "corner": [-5 + 2 * i, -1, -6], "edge_a": [2, 0, 0], "edge_b": [0, 6, 0], "material": f"stripe{i % 3}"} for i in range(5)]
BASE_MATERIALS = {
    "floor": {"diffuse": [0.7, 0.7, 0.6]},
    "red": {"diffuse": [0.8, 0.2, 0.15], "specular": [0.5, 0.5, 0.5], "shininess": 24},
    "blue": {"diffuse": [0.15, 0.25, 0.8]},
    "stripe0": {"diffuse": [0.9, 0.3, 0.2]},
    "stripe1": {"diffuse": [0.2, 0.8, 0.3]},
    "stripe2": {"diffuse": [0.2, 0.3, 0.9]},
    "glass": {"diffuse": [0.1, 0.1, 0.1], "specular": [0.6, 0.6, 0.6], "shininess": 64, "transparency": 0.9, "ior": 1.5},
    "water": {"diffuse": [0.1, 0.1, 0.1], "transparency": 1.0, "ior": 1.33},
    "mirror": {"diffuse": [0.3, 0.3, 0.3], "mirror": 0.85},
    "shiny": {"diffuse": [0.5, 0.4, 0.3], "specular": [0.9, 0.9, 0.9], "shininess": 48},
}
CAMERA = [{"position": [0, 0.6, 3.5], "look_at": [0, 0, -1.5], "fov": 50}]
POINT = {"type": "point", "position": [2, 4, 2], "intensity": 0.9}


def scene(objects, lights, **extra):
    return {
        "background": [0.3, 0.4, 0.6],
        "ambient": [0.06, 0.05, 0.04],
        "cameras": CAMERA,
        "materials": BASE_MATERIALS,
        "lights": lights,
        "objects": objects,
        **extra,
    }


def scenes(tmp_path):
    """name -> (scene dict, render settings); every rule of docs/shading.md is switched on somewhere."""
    ico, coarse, tri_prism = icosphere(tmp_path, 2), icosphere(tmp_path, 1), prism(tmp_path)
    mesh = lambda file, **kw: {"type": "mesh", "file": file, **kw}
    return {
        "lambert_shadows": (
            scene(
                [
                    FLOOR,
                    {"type": "sphere", "center": [-0.8, 0, -1.5], "radius": 1, "material": "blue"},
                    {"type": "triangle", "vertices": [[0.5, -0.6, -0.5], [1.8, -0.6, -1.0], [1.1, 0.9, -1.2]]},
                ],
                [POINT],
            ),
            {},
        ),
        "blinn_phong_directional": (
            scene(
                [
                    FLOOR,
                    {"type": "sphere", "center": [-1, 0, -2], "radius": 1, "material": "red"},
                    {"type": "sphere", "center": [1.2, -0.2, -1.2], "radius": 0.8, "material": "shiny"},
                ],
                [
                    {"type": "point", "position": [-3, 3, 3], "color": [1, 0.9, 0.8], "intensity": 0.7},
                    {"type": "directional", "direction": [1, -2, -1], "color": [0.6, 0.7, 1.0], "intensity": 0.6},
                ],
            ),
            {},
        ),
        "mirrors": (
            scene(
                [
                    FLOOR,
                    {"type": "quad", "corner": [-4, -1, -4], "edge_a": [8, 0, 0], "edge_b": [0, 4, 0], "material": "mirror"},
                    {"type": "sphere", "center": [0.8, 0, -1.5], "radius": 0.9, "material": "mirror"},
                    {"type": "sphere", "center": [-1.2, -0.3, -1], "radius": 0.7, "material": "red"},
                ],
                [POINT],
            ),
            {"max_depth": 4},
        ),
        "glass_sphere_shadow": (scene([FLOOR, *STRIPES, {"type": "sphere", "center": [0, 0, -1.5], "radius": 1, "material": "glass"}], [POINT]), {}),
        "glass_sphere_fresnel": (
            scene(
                [
                    FLOOR,
                    *STRIPES,
                    {"type": "sphere", "center": [0.3, 0, -1.5], "radius": 1, "material": "water"},
                    {"type": "sphere", "center": [-1.6, -0.4, -2.5], "radius": 0.6, "material": "glass"},
                ],
                [POINT],
            ),
            {"fresnel": True, "max_depth": 5},
        ),
        "flat_mesh_shadow": (
            scene(
                [FLOOR, mesh(coarse, translate=[0, 0, -1.5], scale=1.0, rotate=[10, 20, 0], material="shiny")],
                [{"type": "directional", "direction": [-1, -2, -0.5], "intensity": 0.9}],
            ),
            {},
        ),
        "smooth_mesh": (
            scene(
                [
                    FLOOR,
                    mesh(ico, translate=[0.2, 0, -1.5], smooth=True, material="red"),
                    mesh(coarse, translate=[-1.6, -0.4, -0.8], scale=0.6, smooth=True, material="shiny"),
                ],
                [POINT],
            ),
            {},
        ),
        "glass_meshes": (
            scene(
                [
                    FLOOR,
                    *STRIPES,
                    mesh(ico, translate=[0.9, 0, -1.5], scale=0.9, smooth=True, material="glass"),
                    mesh(tri_prism, translate=[-1.2, 0, -1.2], rotate=[0, 30, 0], material="water"),
                ],
                [POINT],
            ),
            {"fresnel": True, "max_depth": 4},
        ),
        "area_light": (
            scene(
                [
                    FLOOR,
                    {"type": "sphere", "center": [-0.6, 0, -1.5], "radius": 1, "material": "red"},
                    {"type": "triangle", "vertices": [[0.8, -0.8, -0.4], [1.9, -0.8, -0.9], [1.2, 0.5, -1.1]], "material": "shiny"},
                ],
                [{"type": "area", "corner": [-1, 3, -1], "edge_a": [2, 0, 0], "edge_b": [0, 0.3, 1.5], "samples": 3, "intensity": 0.9}],
            ),
            {},
        ),
        "inverse_square_lights_camera_2": (
            scene(
                [FLOOR, {"type": "sphere", "center": [0, 0, -1.5], "radius": 1, "material": "shiny"}],
                [
                    {"type": "point", "position": [2, 3, 1], "intensity": 12, "falloff": "inverse_square"},
                    {
                        "type": "area",
                        "corner": [-3, 2, -2],
                        "edge_a": [1, 0, 0],
                        "edge_b": [0, 0, 1],
                        "samples": 2,
                        "intensity": 3,
                        "falloff": "inverse_square",
                    },
                ],
                cameras=[*CAMERA, {"position": [1, 1.5, 3], "look_at": [0, 0, -1.5], "up": [0.3, 1, 0], "fov": 65}],
            ),
            {"camera": 2},
        ),
        "nested_media": (
            scene(
                [
                    FLOOR,
                    *STRIPES,
                    {"type": "sphere", "center": [0, 0, -1.5], "radius": 1.1, "material": "water"},
                    {"type": "sphere", "center": [0.1, 0, -1.5], "radius": 0.5, "material": "glass"},
                ],
                [POINT],
            ),
            {"max_depth": 6},
        ),
        "hall_of_mirrors_depth2": (hall(), {"max_depth": 2}),
        "hall_of_mirrors_depth0": (hall(), {"max_depth": 0}),
    }


def hall():
    """Two facing mirrors and a sphere between them, seen from above the sphere."""
    objects = [
        FLOOR,
        {"type": "quad", "corner": [-2, -1, -6], "edge_a": [0, 0, 8], "edge_b": [0, 4, 0], "material": "mirror"},
        {"type": "quad", "corner": [2, -1, -6], "edge_a": [0, 4, 0], "edge_b": [0, 0, 8], "material": "mirror"},
        {"type": "sphere", "center": [0.6, -0.3, -2], "radius": 0.5, "material": "red"},
    ]
    return scene(objects, [POINT], cameras=[{"position": [-0.5, 1.2, 3], "look_at": [0.3, -0.2, -2], "fov": 70}])


# what each scene is there to check: effects the reference meets on pixels that are compared
EFFECTS = {
    "lambert_shadows": ["shadow"],
    "blinn_phong_directional": ["shadow", "highlight"],
    "mirrors": ["mirror", "highlight", "shadow"],
    "glass_sphere_shadow": ["refraction", "glass_shadow", "highlight"],
    "glass_sphere_fresnel": ["refraction", "fresnel", "glass_shadow"],
    "flat_mesh_shadow": ["shadow", "highlight"],
    "smooth_mesh": ["smooth_normal", "highlight", "shadow"],
    "glass_meshes": ["refraction", "tir", "fresnel", "smooth_normal", "glass_shadow"],
    "area_light": ["partial_light", "shadow", "highlight"],
    "inverse_square_lights_camera_2": ["partial_light", "shadow", "highlight"],
    "nested_media": ["refraction", "glass_shadow"],
    "hall_of_mirrors_depth2": ["mirror"],
    "hall_of_mirrors_depth0": [],
}
SCENE_NAMES = list(EFFECTS)


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_renderer_matches_the_float64_reference(name, tmp_path):
    data, settings = scenes(tmp_path)[name]
    settings = {"max_depth": 8, "fresnel": False, **settings}
    ours = clrender.Renderer(clrender.Scene.from_dict(data, base_dir=tmp_path), aa="none", width=W, height=H, **settings).run().image
    reference = render_steady(data, W, H, base_dir=tmp_path, **settings)
    ref, steady = reference.image, reference.steady
    for effect in EFFECTS[name]:
        assert (reference.seen[effect] & steady).sum() >= 5, f"{name} barely shows {effect}"
    assert steady.mean() > 0.8, f"only {steady.mean():.0%} of the pixels are away from edges"
    diff = np.abs(ours - ref).max(axis=-1)[steady]
    assert ref[steady].max() > 0.05  # the scene is lit where compared
    assert diff.max() < TOLERANCE, (
        f"{name}: max |clrender - reference| = {diff.max():.2e} over {steady.sum()} pixels ({(diff >= TOLERANCE).sum()} over tolerance)"
    )
