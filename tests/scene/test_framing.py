"""A bare mesh file as a scene (scene/framing.py): the framing camera sees the whole bounding sphere, by
projecting it in numpy here; the object covers the fraction of the image a sphere's silhouette predicts; the
default rig's brightness lies between its analytic bounds; scaling the mesh by 1e-3 or 1e3 changes nothing;
the path tracer agrees with the Whitted tracer on a convex mesh (z-test); a glTF file without cameras gets
the same view, and one without lights the same lights; a bare OBJ shows its .mtl colour and map_Kd."""

import math
from pathlib import Path

import numpy as np
import pytest
import trimesh

import clrender
from clrender import Renderer, Scene
from clrender.scene import framing
from clrender.scene.gltf import scene_dict

from tests.gltftools import gltf_file

W, H = 64, 48  # 4:3, the default aspect: the vertical field of view is the narrower
KD = 0.8  # the default material's grey


def project(camera: dict, points, aspect: float) -> np.ndarray:
    """Image coordinates in [-1, 1] x [-1, 1] (x right, y up) of world points seen by a pinhole camera given
    as a scene dict (position, look_at, up, vertical fov in degrees); written out here from the definition."""
    eye = np.asarray(camera["position"], float)
    forward = np.subtract(camera["look_at"], eye)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, camera["up"])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    rel = np.asarray(points, float) - eye
    depth = rel @ forward
    assert (depth > 0).all()  # in front of the eye
    tan_half = math.tan(math.radians(camera["fov"]) / 2)
    return np.stack([(rel @ right) / depth / (tan_half * aspect), (rel @ up) / depth / tan_half], axis=1)


def sphere_points(centre, radius, n=20_000):
    """n points spread over a sphere (Fibonacci lattice)."""
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = k * math.pi * (3 - math.sqrt(5))
    r = np.sqrt(1 - z * z)
    return np.asarray(centre) + radius * np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)


@pytest.mark.parametrize("aspect", [4 / 3, 1.0, 0.5, 2.5])
def test_the_framing_camera_sees_the_whole_bounding_sphere_with_the_margin(rng, aspect):
    settings = framing.FRAMING
    for _ in range(5):
        lo = rng.uniform(-100, 100, 3)
        hi = lo + rng.uniform(1e-3, 50, 3)
        camera = framing.framing_camera(lo, hi, aspect=aspect)
        corners = np.array([[(lo, hi)[(i >> a) & 1][a] for a in range(3)] for i in range(8)])
        assert (np.abs(project(camera, corners, aspect)) < 1).all()
        centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
        ndc = project(camera, sphere_points(centre, radius), aspect)
        # the sphere's silhouette is a circle of tan(asin(sin(h) / margin)) / tan(h) of the narrower half-height h
        narrow = 1 if aspect >= 1 else 0
        h = math.atan(math.tan(math.radians(settings.fov) / 2) * min(1.0, aspect))
        expected = math.tan(math.asin(math.sin(h) / settings.margin)) / math.tan(h)
        assert np.abs(ndc[:, narrow]).max() == pytest.approx(expected, rel=1e-3)
        assert np.abs(ndc).max() < 1


def test_the_camera_looks_from_the_documented_direction_and_the_key_light_is_over_its_shoulder():
    camera = framing.framing_camera([-1, -2, -3], [3, 2, 1])
    view = np.subtract(camera["position"], camera["look_at"])
    np.testing.assert_allclose(camera["look_at"], [1, 0, -1])
    np.testing.assert_allclose(view / np.linalg.norm(view), np.array(framing.FRAMING.direction) / np.linalg.norm(framing.FRAMING.direction))
    light = framing.key_light(camera)
    toward = -np.asarray(light["direction"])
    assert toward @ view > 0 and toward[1] > 0  # it comes from the viewer's side, and from above
    right = np.cross(-view, camera["up"])
    assert toward @ right < 0  # ... and from the left


def mesh_file(tmp_path, mesh, name):
    path = tmp_path / name
    mesh.export(path)
    return path


def test_a_sphere_covers_the_fraction_of_the_image_its_silhouette_predicts(tmp_path):
    path = mesh_file(tmp_path, trimesh.creation.icosphere(subdivisions=4), "ball.obj")
    result = Renderer(str(path), width=W, height=H, aa="none").run()
    ids = result.ids
    assert (ids[0] == -1).all() and (ids[-1] == -1).all() and (ids[:, 0] == -1).all() and (ids[:, -1] == -1).all()
    # a unit sphere in the box [-1, 1]^3 (bounding sphere sqrt 3), seen from the framing distance: a disc of
    # radius tan(asin(1 / d)) / tan(half fov) half-heights in an image 2 aspect x 2 half-heights
    d = framing.camera_distance(math.sqrt(3), W / H)
    r = math.tan(math.asin(1 / d)) / math.tan(math.radians(framing.FRAMING.fov) / 2)
    expected = math.pi * r * r / (4 * W / H)
    assert (ids >= 0).mean() == pytest.approx(expected, rel=0.05)


@pytest.mark.parametrize(
    "name,mesh",
    [
        ("box.ply", trimesh.creation.box((1.0, 2.0, 0.5))),
        ("capsule.stl", trimesh.creation.capsule(2.0, 0.5)),
        ("ring.off", trimesh.creation.torus(1.0, 0.3)),
    ],
)
def test_each_mesh_format_renders_whole_and_between_the_rigs_bounds(tmp_path, name, mesh):
    result = Renderer(str(mesh_file(tmp_path, mesh, name)), width=W, height=H, aa="none").run()
    ids, image = result.ids, result.image
    border = np.concatenate([ids[0], ids[-1], ids[:, 0], ids[:, -1]])
    assert (border == -1).all()  # nothing cut off
    assert 0.05 < (ids >= 0).mean() < 0.8
    # Whitted, the default grey, a directional key light and ambient: kd fill <= every lit pixel <= kd (fill + key)
    s = framing.FRAMING
    on = image[ids >= 0]
    assert on.min() >= KD * s.fill - 1e-6 and on.max() <= KD * (s.fill + s.key_intensity) + 1e-6
    assert on.max() > KD * (s.fill + 0.5 * s.key_intensity)  # some face turns toward the key
    assert (image[ids < 0] == 0).all()  # the seed's black background


def test_the_image_does_not_change_when_the_mesh_is_scaled(tmp_path, rng):
    hull = trimesh.convex.convex_hull(rng.normal(size=(60, 3)) * [1.0, 0.6, 0.3] + [0.2, -0.1, 0.4])
    results = {}
    for scale in (1e-3, 1.0, 1e3):
        scaled = hull.copy()
        scaled.apply_scale(scale)
        results[scale] = Renderer(str(mesh_file(tmp_path, scaled, f"hull_{scale:g}.obj")), width=W, height=H, aa="none").run()
    for scale in (1e-3, 1e3):
        mismatched = (results[scale].ids != results[1.0].ids).sum()
        assert mismatched <= 2  # a pixel whose centre grazes an edge may fall on either side in float32
        same = results[scale].ids == results[1.0].ids
        np.testing.assert_allclose(results[scale].image[same], results[1.0].image[same], atol=1e-3)


def test_the_path_tracer_agrees_with_whitted_on_a_convex_mesh(tmp_path):
    """On a convex object nothing is shadowed or reflected onto it, so both integrators estimate
    kd (fill + key cos) (the fill as ambient or as a constant environment): the pixel-wise difference has
    mean 0 (z-test, |z| < 4: a false failure about 1 run in 16,000 for a fixed seed, i.e. never) and the
    camera rays that miss see the environment."""
    path = str(mesh_file(tmp_path, trimesh.creation.icosphere(subdivisions=3), "ball.ply"))
    whitted = Renderer(path, width=W, height=H, aa="full", samples=6).run()
    traced = Renderer(path, width=W, height=H, integrator="path", spp=64, seed=3).run()
    inside, outside = whitted.ids >= 0, whitted.ids < 0
    for axis in (0, 1):  # pixels whose neighbours are on the same side: the silhouette's pixels mix both
        inside &= np.roll(inside, 1, axis) & np.roll(inside, -1, axis)
        outside &= np.roll(outside, 1, axis) & np.roll(outside, -1, axis)
    diff = (traced.image - whitted.image)[inside].mean(axis=1)
    z = diff.mean() / (diff.std(ddof=1) / math.sqrt(diff.size))
    assert abs(z) < 4, (diff.mean(), z)
    assert abs(diff.mean()) < 0.01  # and the mean itself is small next to the ~0.5 it is taken from
    np.testing.assert_allclose(traced.image[outside], framing.FRAMING.fill, rtol=1e-6)


def test_a_gltf_file_without_cameras_gets_the_same_view_and_keeps_its_own_cameras(tmp_path):
    bare = scene_dict(gltf_file(tmp_path, [{"mesh": 0, "translation": [5, 0, 0]}], name="bare.gltf"))
    # the quad's box: x 4..6, y -1..1, z 0
    assert bare["cameras"] == [framing.framing_camera(np.array([4.0, -1, 0]), np.array([6.0, 1, 0]))]
    own = {"type": "perspective", "perspective": {"yfov": 0.5}, "name": "hero"}
    named = scene_dict(gltf_file(tmp_path, [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 4]}], cameras=[own], name="own.gltf"))
    assert [c["name"] for c in named["cameras"]] == ["hero"] and named["cameras"][0]["position"] == [0, 0, 4]


def test_a_gltf_file_without_lights_gets_the_bare_mesh_rig_and_one_with_lights_keeps_them(tmp_path):
    """The quad (z = 0, facing +z) as a glTF without lights and as a bare OBJ: the same key light, ambient and
    environment; both integrators show the default grey x (fill + key cos) on it, cos from the light the dict
    holds (the old headlight along the view would give kd x cos(view) with no fill).  A file with a
    KHR_lights_punctual light keeps just that light: no fill."""
    gltf = scene_dict(gltf_file(tmp_path, [{"mesh": 0}], name="unlit.gltf"))
    mesh = trimesh.Trimesh(np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], float), [[0, 1, 2], [0, 2, 3]])
    bare = Scene.load(mesh_file(tmp_path, mesh, "quad.obj"))
    (light,) = gltf["lights"]
    (bare_light,) = bare.lights
    np.testing.assert_allclose(light["direction"], bare_light.direction, rtol=1e-12)
    assert light["intensity"] == bare_light.intensity == framing.FRAMING.key_intensity
    fill = framing.FRAMING.fill
    assert gltf["ambient"] == list(bare.ambient) == [fill] * 3 and gltf["environment"] == {"color": [fill] * 3}
    toward = -np.asarray(light["direction"]) / np.linalg.norm(light["direction"])
    expected = KD * (fill + framing.FRAMING.key_intensity * toward[2])  # the quad's normal is +z
    path = tmp_path / "unlit.gltf"
    whitted = Renderer(str(path), width=W, height=H, aa="none").run()
    traced = Renderer(str(path), width=W, height=H, integrator="path", spp=256, max_depth=0).run()
    on_quad = whitted.ids == 0
    assert on_quad.mean() > 0.1
    np.testing.assert_allclose(whitted.image[on_quad], expected, rtol=1e-5)
    inside = on_quad.copy()  # the path tracer's ray lands anywhere in its pixel: pixels on the quad's outline mix both sides
    for axis in (0, 1):
        inside &= np.roll(on_quad, 1, axis) & np.roll(on_quad, -1, axis)
    # max_depth 0: NEE picks the key light or the fill (the environment, every direction of which escapes over a quad
    # facing +z) at random, weighted by 1 / its probability (docs/materials.md): each pixel's mean is `expected`.  The
    # two values a sample takes are within 3x of it, so over the inside pixels' 256 samples each the mean's relative
    # standard error is under 0.2% and 1% is past 5 sigma
    np.testing.assert_allclose(traced.image[inside].mean(), expected, rtol=0.01)
    np.testing.assert_allclose(traced.image[whitted.ids < 0].mean(), fill, rtol=0.05)  # misses see the fill
    lit = scene_dict(gltf_file(tmp_path, [{"mesh": 0}, {"extensions": {"KHR_lights_punctual": {"light": 0}}}], lights=[{"type": "point"}]))
    assert [entry["type"] for entry in lit["lights"]] == ["point"] and "ambient" not in lit and "environment" not in lit


def obj_quad(tmp_path, mtl: str, name="quad") -> Path:
    """The 2 x 2 quad at z = 0 facing +z as an OBJ with vt (u along +x, v up +y) and a .mtl beside it."""
    (tmp_path / f"{name}.mtl").write_text(f"newmtl paint\n{mtl}\n")
    path = tmp_path / f"{name}.obj"
    path.write_text(
        f"mtllib {name}.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl paint\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
    )
    return path


def test_a_bare_obj_on_the_command_line_brings_its_mtl_colour(tmp_path, capsys):
    """`clrender render quad.obj` with Kd 0.9 0.1 0.05 in quad.mtl: the quad shows Kd x (fill + key cos) in every
    channel under the framing rig (the written PNG: red far above green and blue), not the default grey."""
    from PIL import Image

    from clrender.cli import main

    path = obj_quad(tmp_path, "Kd 0.9 0.1 0.05\nKs 0 0 0")
    kd = np.array([0.9, 0.1, 0.05])
    scene = Scene.load(path)
    (light,) = scene.lights
    toward = -np.asarray(light.direction) / np.linalg.norm(light.direction)
    image = Renderer(str(path), width=W, height=H, aa="none").run()
    on_quad = image.ids == 0
    assert on_quad.mean() > 0.1
    np.testing.assert_allclose(
        image.image[on_quad], np.broadcast_to(kd * (framing.FRAMING.fill + light.intensity * toward[2]), (on_quad.sum(), 3)), rtol=1e-5
    )
    out = tmp_path / "quad.png"
    assert main(["render", str(path), "--width", str(W), "--height", str(H), "-o", str(out)]) == 0, capsys.readouterr().err
    pixels = np.asarray(Image.open(out), np.float64)[on_quad]
    assert (pixels[:, 0] > 2 * pixels[:, 1] + 20).all() and (pixels[:, 0] > 2 * pixels[:, 2] + 20).all()


def test_a_bare_obj_shows_its_map_kd_texture_the_right_way_round(tmp_path):
    """map_Kd a 4 x 1 PNG, red red blue blue: the quad's left half (x < 0, u < 0.5) is red and its right half blue;
    where the bilinear lookup reads only red (or only blue) texels the pixel is exactly texel x (fill + key cos)."""
    from PIL import Image

    Image.fromarray(np.array([[[255, 0, 0], [255, 0, 0], [0, 0, 255], [0, 0, 255]]], np.uint8)).save(tmp_path / "stripes.png")
    path = obj_quad(tmp_path, "Kd 1 1 1\nKs 0 0 0\nmap_Kd stripes.png")
    scene = Scene.load(path)
    (light,) = scene.lights
    toward = -np.asarray(light.direction) / np.linalg.norm(light.direction)
    lit = framing.FRAMING.fill + light.intensity * toward[2]
    result = Renderer(scene, width=W, height=H, aa="none").run()
    image, on_quad = result.image.astype(np.float64), result.ids == 0
    assert (image[on_quad][:, 1] == 0).all()  # no green in either texel
    red, blue = on_quad & (image[..., 0] > 0.99 * lit) & (image[..., 2] == 0), on_quad & (image[..., 2] > 0.99 * lit) & (image[..., 0] == 0)
    assert red.sum() > 0.2 * on_quad.sum() and blue.sum() > 0.2 * on_quad.sum()
    np.testing.assert_allclose(image[red][:, 0], lit, rtol=1e-5)
    np.testing.assert_allclose(image[blue][:, 2], lit, rtol=1e-5)
    columns = np.arange(W)[None, :].repeat(H, 0)
    assert columns[red].max() < columns[blue].min()  # red on the left (x < 0 is image left from the framing view)


def test_the_python_api_takes_a_mesh_file(tmp_path):
    path = mesh_file(tmp_path, trimesh.creation.icosphere(), "ball.stl")
    scene = Scene.load(path)
    assert (scene.width, scene.height, len(scene.cameras), scene.triangle_count) == (640, 480, 1, 1280)
    image = clrender.render(str(path), width=32, height=24)
    assert image.shape == (24, 32, 3) and image.max() > 0.3


def test_scene_from_file_takes_a_mesh_file_too(tmp_path):
    path = mesh_file(tmp_path, trimesh.creation.box(), "cube.off")
    for scene in (Scene.from_file(path), Scene.from_file(path, allow_outside=False), Scene.load(str(path))):
        assert scene.name == "cube" and scene.triangle_count == 12 and scene.cameras[0].look_at == (0.0, 0.0, 0.0)
