"""Camera keys (aperture, focus_distance, projection, ortho_height): defaults, the kernels' record, bad values as
one line (exit 2 on the command line), edge-only AA refused behind a lens, glTF orthographic cameras."""

import math

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.layout import PROJECTIONS
from clrender.scene.camera import Camera
from clrender.scene.scene import Scene
from clrender.trace.renderer import RenderSettings

from tests.clitools import run_cli
from tests.gltftools import gltf_file

SPHERE = {"type": "sphere", "center": [0, 0, -5], "radius": 1}


def camera_of(**keys) -> Camera:
    return Scene.from_dict({"cameras": [keys], "objects": [SPHERE]}).cameras[0]


def test_defaults_are_a_perspective_pinhole_focused_on_the_look_at_point():
    camera = camera_of(position=[1, 2, 3], look_at=[1, 2, -1])
    assert (camera.aperture, camera.projection, camera.focus_distance, camera.ortho_height) == (0.0, "perspective", None, None)
    assert camera.focus == 4.0
    # orthographic without ortho_height: the height the perspective view spans at the look-at point
    assert camera_of(look_at=[0, 0, -3], fov=90, projection="orthographic").view_height == pytest.approx(6.0)


def test_the_dict_and_the_record_carry_the_lens():
    camera = camera_of(position=[0, 0, 0], look_at=[0, 0, -2], fov=90, aperture=0.25, focus_distance=7, projection="perspective")
    frame = camera.frame(200, 100)
    assert np.allclose(frame["right"], [2, 0, 0]) and np.allclose(frame["up"], [0, 1, 0])  # tan 45 = 1; aspect 2
    assert np.allclose(frame["lens_right"], [0.25, 0, 0]) and np.allclose(frame["lens_up"], [0, 0.25, 0])
    assert (float(frame["aperture"]), float(frame["focus_distance"]), int(frame["projection"])) == (0.25, 7.0, PROJECTIONS["perspective"])
    ortho = camera_of(look_at=[0, 0, -2], projection="orthographic", ortho_height=3).frame(200, 100)
    assert np.allclose(ortho["up"], [0, 1.5, 0]) and np.allclose(ortho["right"], [3, 0, 0])  # world units
    assert int(ortho["projection"]) == PROJECTIONS["orthographic"] and float(ortho["focus_distance"]) == 2.0


def test_a_lens_point_aims_at_the_pinhole_rays_point_on_the_focal_plane():
    camera = Camera(position=(0, 0, 0), look_at=(0, 0, -1), fov=40, aperture=0.3, focus_distance=6.0)
    pin_o, pin_d = camera.rays(9, 7)
    lens_o, lens_d = camera.rays(9, 7, lens=(0.6, -0.8))
    assert np.allclose(lens_o - pin_o, [0.18, -0.24, 0])
    # both reach the plane z = -6 at the same point
    at_pin = pin_o + pin_d * (6 / -pin_d[..., 2:])
    at_lens = lens_o + lens_d * (6 / -lens_d[..., 2:])
    assert np.allclose(at_pin, at_lens, atol=1e-6)


@pytest.mark.parametrize(
    ("keys", "words"),
    [
        ({"aperture": -0.1}, ["cameras[0].aperture", ">= 0"]),
        ({"aperture": "wide"}, ["cameras[0].aperture", "expected a number"]),
        ({"focus_distance": 0}, ["cameras[0].focus_distance", "> 0"]),
        ({"focus_distance": -2}, ["cameras[0].focus_distance", "> 0"]),
        ({"projection": "fisheye"}, ["cameras[0].projection", "'fisheye'", "'orthographic'"]),
        ({"projection": "orthographic", "ortho_height": 0}, ["cameras[0].ortho_height", "> 0"]),
        ({"ortho_height": -1}, ["cameras[0].ortho_height", "> 0"]),
    ],
)
def test_bad_lens_and_projection_values_name_the_key(keys, words):
    with pytest.raises(UsageError) as err:
        Scene.from_dict({"cameras": [keys], "objects": [SPHERE]}, where="test.toml")
    message = str(err.value)
    assert message.startswith("test.toml: ") and "\n" not in message
    for w in words:
        assert w in message


@pytest.mark.parametrize(
    "keys",
    [
        dict(aperture=-1.0),
        dict(aperture=math.nan),
        dict(aperture="wide"),
        dict(focus_distance=0.0),
        dict(projection="fisheye"),
        dict(ortho_height=-2.0),
    ],
)
def test_a_camera_made_in_python_is_checked_too(keys):
    with pytest.raises(UsageError) as err:
        Camera(**keys)
    assert next(iter(keys)) in str(err.value)


def test_bad_camera_value_on_the_command_line_is_one_line_and_exit_2(tmp_path, capsys):
    scene = tmp_path / "lens.toml"
    scene.write_text('[[cameras]]\naperture = -0.5\n\n[[objects]]\ntype = "sphere"\ncenter = [0, 0, -5]\nradius = 1\n')
    out = tmp_path / "out.png"
    code, _, err = run_cli(capsys, "render", str(scene), "-o", str(out), "--width", "8", "--height", "6")
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and "cameras[0].aperture" in err
    assert not out.exists()


def test_edge_only_aa_is_refused_behind_a_lens():
    scene = Scene.from_dict({"cameras": [{}, {"aperture": 0.1}], "objects": [SPHERE], "lights": [{"position": [0, 5, 0]}]})
    RenderSettings(aa="edge_detect", camera=1).validate(scene)  # a pinhole: fine
    with pytest.raises(UsageError, match="edge_detect needs a pinhole camera.*aperture 0.1.*--aa full"):
        RenderSettings(aa="edge_detect", camera=2).validate(scene)
    RenderSettings(aa="full", camera=2).validate(scene)
    # one ray a pixel behind a lens: allowed, and warned about
    assert any("lens" in line for line in RenderSettings(aa="none", camera=2).pointless(scene))
    assert not any("lens" in line for line in RenderSettings(aa="none", camera=1).pointless(scene))


def test_gltf_orthographic_magnifications_are_checked(tmp_path):
    nodes = [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 5]}]
    for params, words in (({"xmag": 1.0, "ymag": 0.0}, "ymag"), ({"xmag": "1", "ymag": 1.0}, "xmag"), ({"xmag": 1e-3, "ymag": 1.0}, "xmag / ymag")):
        path = gltf_file(tmp_path, nodes, cameras=[{"type": "orthographic", "orthographic": params}])
        with pytest.raises(UsageError, match=words):
            Scene.from_file(path)
    path = gltf_file(tmp_path, nodes, cameras=[{"type": "orthographic", "orthographic": {"xmag": -2.0, "ymag": -1.0}}])
    camera = Scene.from_file(path).cameras[0]  # negative: read by size (the spec says they should not be)
    assert (camera.projection, camera.ortho_height, camera.aperture, camera.focus_distance) == ("orthographic", 2.0, 0.0, None)
    path = gltf_file(tmp_path, nodes, cameras=[{"type": "fisheye"}])
    with pytest.raises(UsageError, match="not perspective or orthographic"):
        Scene.from_file(path)
