"""Integrators as types (clrender/trace/integrators.py): one factory by name, each with its own checks, kernel and
launch record; the two launch records share one FrameParams instead of repeating its fields."""

import pytest

from clrender import layout
from clrender.errors import UsageError
from clrender.scene.scene import Scene
from clrender.trace.integrators import INTEGRATORS, PathIntegrator, WhittedIntegrator, integrator_type
from clrender.trace.renderer import RenderSettings

SPHERE = [{"type": "sphere", "center": [0, 0, -5], "radius": 1}]
SCENE = Scene.from_dict({"width": 4, "height": 3, "objects": SPHERE, "lights": [{"type": "point", "position": [0, 5, 0]}]})


def test_the_factory_builds_each_integrator_by_its_name_and_the_cli_offers_those_names():
    from clrender.trace.renderer import INTEGRATORS as NAMES

    assert integrator_type("whitted") is WhittedIntegrator and integrator_type("path") is PathIntegrator
    assert NAMES == tuple(INTEGRATORS) == ("whitted", "path")
    assert WhittedIntegrator.kernel == ("trace.cl", "render") and PathIntegrator.kernel == ("path.cl", "render_path")


def test_the_launch_records_share_the_frame_and_repeat_none_of_its_fields():
    frame = set(layout.FRAME_PARAMS_DTYPE.names)
    for dtype in (layout.WHITTED_PARAMS_DTYPE, layout.PATH_PARAMS_DTYPE):
        assert dtype.fields["frame"][0] == layout.FRAME_PARAMS_DTYPE and dtype.fields["frame"][1] == 0
        assert not frame & set(dtype.names), frame & set(dtype.names)
    assert {"width", "height", "seed", "max_depth", "n_work", "record", "camera", "env_map"} <= frame


@pytest.mark.parametrize(
    "settings, message",
    [
        (dict(integrator="path", aa="edge_detect"), "--aa edge_detect is a Whitted feature"),
        (dict(integrator="whitted", rfilter="tent"), "--rfilter tent is the path tracer's film"),
        (dict(integrator="whitted", max_depth=17), "max depth 17 must be from 0 to 16"),
    ],
)
def test_each_integrator_refuses_what_it_cannot_render(settings, message):
    with pytest.raises(UsageError, match=message):
        RenderSettings(**settings).validate(SCENE)
    assert RenderSettings(integrator="path", max_depth=17).validate(SCENE).max_depth == 17  # paths keep no ray stack


def test_each_integrator_says_what_does_nothing_under_it():
    assert RenderSettings(spp=4).pointless(SCENE) == [
        "--spp and --time-budget have no effect with --integrator whitted (they set the path tracer's samples)"
    ]
    assert RenderSettings(integrator="path", spp=4).pointless(SCENE) == []
    assert RenderSettings(integrator="path", thickness=2.0).pointless(SCENE) == [
        "--thickness has no effect with --integrator path (it widens the edge mask of --aa edge_detect)"
    ]
