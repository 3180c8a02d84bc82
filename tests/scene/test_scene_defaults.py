"""One scene, one meaning: a scene's own default camera and AA (`default_camera`, `aa`), `background` as the
path tracer's environment where the scene names none, and the Whitted tracer's one-line warning that an
environment map lights nothing there."""

import pytest

from clrender.cli import build_parser
from clrender.commands.render import scene_defaults, settings_from_args
from clrender.errors import UsageError
from clrender.scene.scene import Scene
from clrender.trace.renderer import RenderSettings

CAMERAS = [{"position": [0, 0, 5]}, {"position": [0, 5, 5]}, {"position": [5, 0, 5]}]


def settings_for(scene, *argv):
    args = build_parser().parse_args(["render", "x.toml", *argv])
    return scene_defaults(args, settings_from_args(args), scene)


def test_default_camera_and_aa_are_read_and_used_when_the_command_line_gives_none():
    scene = Scene.from_dict({"cameras": CAMERAS, "default_camera": 3, "aa": "edge_detect"})
    assert scene.default_camera == 3 and scene.aa == "edge_detect"
    s = settings_for(scene)
    assert (s.camera, s.aa, s.samples) == (3, "edge_detect", 4)
    s = settings_for(scene, "--camera", "2", "--aa", "full", "--samples", "2")
    assert (s.camera, s.aa, s.samples) == (2, "full", 2)
    s = settings_for(scene, "1", "none", "stratified")  # the positional CAMERA AA_TYPE SAMPLE_TYPE
    assert (s.camera, s.aa) == (1, "none")
    s = settings_for(scene, "--integrator", "path")  # the scene's aa is the Whitted tracer's; paths take --spp
    assert (s.camera, s.aa) == (3, "none")


def test_featured_camera_is_the_older_name_of_default_camera():
    assert Scene.from_dict({"cameras": CAMERAS, "featured_camera": 2}).featured_camera == 2
    with pytest.raises(UsageError, match="give only default_camera"):
        Scene.from_dict({"cameras": CAMERAS, "featured_camera": 2, "default_camera": 2})
    with pytest.raises(UsageError, match="default_camera"):
        Scene.from_dict({"cameras": CAMERAS, "default_camera": 4})
    with pytest.raises(UsageError, match="aa"):
        Scene.from_dict({"aa": "sometimes"})


def test_a_scene_without_its_own_defaults_renders_camera_1_without_aa():
    s = settings_for(Scene.from_dict({"cameras": CAMERAS}))
    assert (s.camera, s.aa, s.samples) == (1, "none", 1)


def test_background_is_the_path_tracers_environment_when_the_scene_names_none():
    scene = Scene.from_dict({"background": [0.2, 0.3, 0.4]})
    assert scene.environment == (0.2, 0.3, 0.4) and scene.background == (0.2, 0.3, 0.4)
    scene = Scene.from_dict({"background": [0.2, 0.3, 0.4], "environment": {"color": [0, 0, 0]}})
    assert scene.environment == (0.0, 0.0, 0.0)  # an [environment] of its own wins, even black
    assert Scene.load("refract1").environment == Scene.load("refract1").background != (0.0, 0.0, 0.0)


def test_the_whitted_tracer_warns_that_an_environment_map_lights_nothing(tmp_path):
    from tests.scenetools import write_hdr

    write_hdr(tmp_path / "sky.hdr")
    scene = Scene.from_dict(
        {"environment": {"file": "sky.hdr"}, "objects": [{"type": "sphere", "center": [0, 0, -3], "radius": 1}]}, base_dir=tmp_path
    )
    said = RenderSettings().pointless(scene)
    assert "the environment map lights nothing under the Whitted integrator (rays that escape show it); use --integrator path" in said
    assert not any("environment map" in m for m in RenderSettings(integrator="path", spp=1).pointless(scene))


@pytest.mark.slow  # two kernel variants' compiles on a cold cache
def test_a_path_traced_miss_shows_the_background():
    """Camera rays that meet nothing see `background` under both integrators (the path tracer used to draw black)."""
    import numpy as np

    import clrender

    data = {"background": [0.2, 0.3, 0.4], "width": 8, "height": 6, "objects": [{"type": "sphere", "center": [0, 0, 5], "radius": 1}]}
    for integrator, extra in (("whitted", {}), ("path", {"spp": 1})):
        image = clrender.Renderer(Scene.from_dict(data), integrator=integrator, **extra).run().image
        assert np.all(image == np.float32([0.2, 0.3, 0.4])), integrator
