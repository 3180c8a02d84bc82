"""RenderSettings.hide_emitters and rr_depth.  hide_emitters (Mitsuba's integrator `hide_emitters`, kernels/path.cl HIDE_EMITTERS): camera rays
look past emitting triangles and area lights and see no environment; every later vertex sees them as before.

Fast: exact values where a camera ray meets only an emitter or the environment.  Slow, against Mitsuba 3: one XML
file with a one-sided emitting rectangle in front of a diffuse wall, an emitting sphere and a constant environment,
`path` and `direct`, block z-test (tests/scenetools.py `xml_against_mitsuba`).
"""

import numpy as np
import pytest

from clrender import Renderer
from clrender.errors import UsageError
from clrender.scene.scene import Scene
from clrender.trace.tracer import Tracer

from tests.scenetools import xml_against_mitsuba

SIZE = 16


def scene() -> Scene:
    """An emitting square (emission 2, black) over the left half of the view, half of it in front of a white wall
    (the top half of the view); the constant environment 1 elsewhere."""
    quad = lambda corner, a, b, m: {"type": "quad", "corner": corner, "edge_a": a, "edge_b": b, "material": m}
    return Scene.from_dict(
        {
            "width": SIZE,
            "height": SIZE,
            "cameras": [{"position": [0, 0, 5], "look_at": [0, 0, 0], "fov": 30}],
            "environment": {"color": [1, 1, 1]},
            "materials": {"lamp": {"diffuse": [0, 0, 0], "emission": [2, 2, 2]}, "wall": {"diffuse": [0.8, 0.8, 0.8]}},
            "objects": [
                quad([-3, -3, 0.5], [3, 0, 0], [0, 6, 0], "lamp"),
                quad([-3, 0, -0.5], [6, 0, 0], [0, 3, 0], "wall"),
            ],
        }
    )


@pytest.mark.parametrize("max_depth", [0, 2])
def test_camera_rays_see_past_emitters_and_no_environment(device, max_depth):
    s = scene()
    tracer = Tracer(s, device=device)
    shown, hidden = (
        Renderer(s, tracer=tracer, integrator="path", spp=4, max_depth=max_depth, hide_emitters=hide, seed=1).run().image for hide in (False, True)
    )
    lamp_alone, sky = np.s_[SIZE - 3 :, : SIZE // 2 - 2], np.s_[SIZE - 3 :, SIZE // 2 + 2 :]
    np.testing.assert_array_equal(shown[lamp_alone], 2.0)
    np.testing.assert_array_equal(shown[sky], 1.0)
    np.testing.assert_array_equal(hidden[lamp_alone], 0.0)
    np.testing.assert_array_equal(hidden[sky], 0.0)
    wall_behind_lamp = hidden[:3, : SIZE // 2 - 2]
    assert wall_behind_lamp.mean() > 0.05, wall_behind_lamp.mean()  # the wall, lit by the sky, seen through the hidden lamp
    np.testing.assert_array_equal(hidden[:3, SIZE // 2 + 2 :], shown[:3, SIZE // 2 + 2 :])  # the wall alone: unchanged


def test_hide_emitters_and_rr_depth_are_checked():
    with pytest.raises(UsageError, match="hide_emitters"):
        Renderer(scene(), integrator="path", hide_emitters="yes")
    with pytest.raises(UsageError, match="rr depth"):
        Renderer(scene(), integrator="path", rr_depth=-1)


HIDDEN = """<scene version="3.0.0"><integrator type="{integrator}"><boolean name="hide_emitters" value="true"/>{depth}</integrator>
<sensor type="perspective"><float name="fov" value="40"/>
<transform name="to_world"><lookat origin="0, 1, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
<sampler type="independent"><integer name="sample_count" value="64"/></sampler>
<film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/><rfilter type="box"/></film></sensor>
<shape type="rectangle"><transform name="to_world"><scale value="0.5"/><translate x="-0.4" z="0.5"/></transform>
<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf><emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>
<shape type="sphere"><point name="center" x="0.9" y="0.3" z="0.3"/><float name="radius" value="0.3"/>
<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf><emitter type="area"><rgb name="radiance" value="3, 2, 1"/></emitter></shape>
<shape type="rectangle"><transform name="to_world"><scale value="1.2"/><translate z="-0.5"/></transform><bsdf type="diffuse"/></shape>
<emitter type="constant"><rgb name="radiance" value="0.7"/></emitter>
</scene>"""


@pytest.mark.slow
@pytest.mark.parametrize("integrator, depth", [("path", '<integer name="max_depth" value="5"/>'), ("direct", "")])
def test_hidden_emitters_match_mitsuba(tmp_path, device, integrator, depth):
    """Mitsuba 3 (3.6 on) hides an area emitter from camera rays by looking past it: the wall shows behind the
    rectangle, black where the sky would be.  The emitters are black from behind (reflectance 0), where Mitsuba's
    one-sided diffuse and clrender's two-sided one would differ."""
    path = tmp_path / "hidden.xml"
    path.write_text(HIDDEN.format(integrator=integrator, depth=depth))
    result = xml_against_mitsuba(path, device, spp=64)
    assert result.passed, result.report()


def test_rr_depth_moves_russian_roulette_and_keeps_the_mean(device):
    """rr_depth 0 (roulette from the primary hit) against the kernel's 3: other bits, the same expected image
    (block z-test over 4 seeds a side, Šidák at alpha 0.01)."""
    from tests.reference.ztest import two_sample_z

    s = scene()
    tracer = Tracer(s, device=device)
    renders = {
        rr: np.stack([Renderer(s, tracer=tracer, integrator="path", spp=16, max_depth=6, rr_depth=rr, seed=k).run().image for k in range(4)])
        for rr in (None, 0)
    }
    assert not np.array_equal(renders[None], renders[0])
    builds = {Renderer(s, tracer=tracer, integrator="path", rr_depth=rr).variant.key() for rr in (None, 0, 5)}
    assert len(builds) == 1  # the depth is PathParams.rr_depth, a launch value: one build serves every depth
    result = two_sample_z(renders[None], renders[0])
    assert result.passed, result.report()
