"""The Python API refuses bad input in one UsageError naming the value, instead of answering wrongly:
ray arrays of any leading shape (results come back in it), the Tracer's scene argument, every
RenderSettings field; and it warns (RenderWarning) where the command line prints a `warning:` line."""

import re
import sys
import warnings

import numpy as np
import pytest

import clrender
from clrender.cli import main
from clrender.errors import RenderWarning, UsageError
from clrender.scene.scene import Scene
from clrender.trace.renderer import RenderSettings
from clrender.trace.tracer import Tracer

SPHERE = {"objects": [{"type": "sphere", "center": [0, 0, -5], "radius": 1}]}
LIT = {**SPHERE, "lights": [{"type": "point", "position": [0, 5, 0]}]}


@pytest.fixture(scope="module")
def tracer(device):
    # module-scoped: one BVH and one kernel build for every ray-shape test
    return Tracer(Scene.from_dict(SPHERE), device=device)


def down_the_z_axis(xy):
    """Rays from (x, y, 0) along -z at the sphere of radius 1 centred (0, 0, -5): t = 5 - sqrt(1 - x^2 - y^2)."""
    xy = np.asarray(xy, np.float64)
    origins = np.concatenate([xy, np.zeros(xy.shape[:-1] + (1,))], axis=-1)
    directions = np.broadcast_to([0.0, 0.0, -1.0], origins.shape)
    r2 = (xy**2).sum(-1)
    expected = np.where(r2 < 1, 5 - np.sqrt(np.maximum(1 - r2, 0)), np.inf)
    return origins, directions, expected


# ------------------------------------------------------------------ 1. ray shapes
@pytest.mark.parametrize("rows", [6, 4, 3])
def test_rays_of_four_columns_are_refused_naming_the_shape(tracer, rows):
    # the issue's reproducer: six padded (x, y, z, 1) rays gave 8 results, three of them "hits"
    with pytest.raises(UsageError, match=rf"origins of shape \({rows}, 4\).*\(\.\.\., 3\)"):
        tracer.intersect(np.zeros((rows, 4)), np.tile([0.1, 0, -1, 1], (rows, 1)))
    with pytest.raises(UsageError, match=rf"directions of shape \({rows}, 4\)"):
        tracer.occluded(np.zeros((rows, 3)), np.tile([0.1, 0, -1, 1], (rows, 1)), 10.0)


def test_a_grid_of_rays_comes_back_in_its_shape(tracer):
    xy = np.array([[[0.0, 0.0], [0.5, 0.0]], [[0.0, -0.6], [2.0, 0.0]]])  # the last one misses
    o, d, expected = down_the_z_axis(xy)
    t, prim, obj = tracer.intersect(o, d)
    assert t.shape == prim.shape == obj.shape == (2, 2)
    np.testing.assert_allclose(t, expected, rtol=1e-6)
    np.testing.assert_array_equal(obj, [[0, 0], [0, -1]])
    np.testing.assert_array_equal(prim, [[0, 0], [0, -1]])
    blocked = tracer.occluded(o, d, 10.0)
    assert blocked.shape == (2, 2) and blocked.dtype == bool
    np.testing.assert_array_equal(blocked, np.isfinite(expected))


def test_one_ray_gives_scalar_results(tracer):
    t, prim, obj = tracer.intersect([0.0, 0.0, 0.0], [0.0, 0.0, -1.0])
    assert t.shape == prim.shape == obj.shape == ()
    assert float(t) == 4.0 and int(obj) == 0
    assert tracer.occluded([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 3.9).shape == ()


def test_one_origin_broadcasts_against_many_directions(tracer):
    d = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.1, 0.0, -1.0]])
    t, _, obj = tracer.intersect([0.0, 0.0, 0.0], d)
    t_each, _, obj_each = tracer.intersect(np.zeros((3, 3)), d)
    np.testing.assert_array_equal(t, t_each)
    np.testing.assert_array_equal(obj, [0, -1, 0])


def test_origins_and_directions_that_do_not_broadcast_are_refused(tracer):
    with pytest.raises(UsageError, match=r"origins \(2, 3\) and directions \(5, 3\)"):
        tracer.intersect(np.zeros((2, 3)), np.tile([0.0, 0, -1], (5, 1)))


def test_t_min_and_t_max_broadcast_to_the_rays_shape(tracer):
    o, d, expected = down_the_z_axis(np.zeros((2, 3, 2)))  # six rays down the axis: t = 4
    t_min = np.array([[0.0], [4.5]])  # per row: the second row starts past the near side
    t, _, _ = tracer.intersect(o, d, t_min=t_min)
    np.testing.assert_allclose(t, [[4.0] * 3, [6.0] * 3], rtol=1e-6)
    np.testing.assert_array_equal(tracer.occluded(o, d, t_max=np.array([3.0, 5.0, 7.0])), [[False, True, True]] * 2)


@pytest.mark.parametrize("name", ["t_min", "t_max"])
def test_t_min_or_t_max_of_another_shape_is_refused_naming_it(tracer, name):
    o, d, _ = down_the_z_axis(np.zeros((2, 2, 2)))
    bad = {name: np.zeros(3)} if name == "t_min" else {"t_max": np.full(3, 9.0)}
    with pytest.raises(UsageError, match=rf"{name} of shape \(3,\).*\(2, 2\)"):
        if name == "t_min":
            tracer.intersect(o, d, **bad)
        else:
            tracer.occluded(o, d, **bad)


@pytest.mark.parametrize(
    "origins",
    [
        np.zeros((2, 3), np.complex128),
        np.array([[0, 0, 0], [0, 0, "x"]], object),
        np.array([["0", "0", "0"], ["1", "0", "0"]]),  # numpy would parse these
        np.zeros((2, 3), bool),
        [[0, 0, 0], [0, 0]],  # ragged
        None,
    ],
    ids=["complex", "object", "strings", "bool", "ragged", "None"],
)
def test_non_numeric_rays_are_refused(tracer, origins):
    with pytest.raises(UsageError, match="origins"):
        tracer.intersect(origins, [[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])


def test_non_numeric_distances_are_refused(tracer):
    with pytest.raises(UsageError, match="t_max"):
        tracer.occluded([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], t_max=1j)
    with pytest.raises(UsageError, match="t_min"):
        tracer.intersect([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], t_min="0")


# ------------------------------------------------------------------ 2. the Tracer's scene argument
TRIANGLE = np.array([[0.0, 0, -1], [1, 0, -1], [0, 1, -1]])


@pytest.mark.parametrize("faces, says", [([[0, 1, 3]], "face index 3"), ([[0, -1, 2]], "face index -1")], ids=["past the end", "negative"])
def test_face_indices_out_of_range_are_refused(faces, says):
    with pytest.raises(UsageError, match=rf"{says} is not a vertex; allowed: 0 to 2 \(the 3 vertices\)"):
        Tracer((TRIANGLE, np.array(faces)))


@pytest.mark.parametrize(
    "vertices, faces, says",
    [
        (TRIANGLE[:, :2], [[0, 1, 2]], r"vertices of shape \(3, 2\)"),
        (TRIANGLE, [[0, 1]], r"faces of shape \(1, 2\)"),
        (TRIANGLE, [[0.0, 1.0, 2.0]], "faces.*whole numbers"),
        (np.where(np.eye(3, dtype=bool), np.nan, TRIANGLE), [[0, 1, 2]], "vertices.*finite"),
        (TRIANGLE.astype(complex), [[0, 1, 2]], "vertices.*real numbers"),
    ],
    ids=["2d vertices", "two-index faces", "float faces", "NaN", "complex"],
)
def test_bad_vertex_and_face_arrays_are_refused(vertices, faces, says):
    with pytest.raises(UsageError, match=says):
        Tracer((vertices, np.array(faces)))


@pytest.mark.parametrize("scene", [np.zeros((3, 3)), 42, None, (TRIANGLE,)], ids=["array", "int", "None", "1-tuple"])
def test_what_is_not_a_scene_is_refused_saying_what_a_tracer_takes(scene):
    with pytest.raises(UsageError, match=r"a Tracer takes a Scene.*\(vertices, faces\)") as refused:
        Tracer(scene)
    assert "unknown scene" not in str(refused.value)


@pytest.mark.parametrize(
    "scene, got", [(np.zeros((3, 3)), r"a numpy array of shape \(3, 3\)"), (42, "int"), (None, "NoneType"), (b"refract1", "bytes")]
)
def test_what_is_not_a_scene_is_refused_by_the_renderer_naming_its_type(scene, got):
    with pytest.raises(UsageError, match=r"^a scene is a Scene, a scene dict, a bundled scene name or a path .*; got " + got + "$") as refused:
        clrender.Renderer(scene)
    assert "\n" not in str(refused.value) and "unknown scene" not in str(refused.value)


@pytest.mark.parametrize(
    "option, says",
    [({"builder": ["sah"]}, "BVH builder"), ({"use_bvh": "no"}, "use_bvh 'no'"), ({"bvh_width": 8.5}, "BVH width 8.5"), ({"device": 3}, "device 3")],
)
def test_bad_tracer_options_are_refused(option, says):
    with pytest.raises(UsageError, match=says):
        Tracer((TRIANGLE, [[0, 1, 2]]), **option)


# ------------------------------------------------------------------ 2. RenderSettings
SCENE = Scene.from_dict(LIT)


@pytest.mark.parametrize(
    "field, value, says",
    [
        ("width", "320", r"width '320' must be a whole number >= 1"),
        ("width", 320.5, r"width 320.5 must be a whole number >= 1"),
        ("height", True, r"height True must be a whole number"),
        ("camera", 1.0, r"camera 1.0 must be a whole number"),
        ("samples", "4", r"samples '4' must be an integer from 1 to 64"),
        ("samples", 2.5, r"samples 2.5 must be an integer from 1 to 64"),
        ("thickness", "2", r"thickness '2' must be a real number >= 0"),
        ("contrast", None, r"contrast None must be a real number >= 0"),
        ("light_samples", 1.5, r"light samples 1.5 must be from 0"),
        ("max_depth", "8", r"max depth '8' must be from 0 to 16"),
        ("seed", 0.5, r"seed 0.5 must be from 0 to 2\*\*32-1"),
        ("tile_size", 64.0, r"tile size 64.0 must be"),
        ("aa", ["none"], r"unknown anti-aliasing mode '\['none'\]'; allowed: none, full, edge_detect"),
        ("sampler", {"a": 1}, r"unknown sampler"),
        ("pixel_filter", 0, r"unknown pixel filter 0"),
        ("light_sampler", None, r"unknown light sampler"),
        ("bvh_builder", ["sah"], r"unknown BVH builder"),
        ("shadow_edges", "yes", r"shadow_edges 'yes' must be True or False"),
        ("fresnel", 1, r"fresnel 1 must be True or False"),
        ("bvh", None, r"bvh None must be True or False"),
        ("device", 0, r"device 0 must be a device name \(a string\) or None"),
        ("aovs", "depth", r"aovs 'depth' must be a tuple of names"),
    ],
)
def test_every_setting_of_the_wrong_type_is_refused_naming_it(field, value, says):
    with pytest.raises(UsageError, match=says):
        RenderSettings(**{field: value}).validate(SCENE)


def test_the_issues_render_calls_raise_usage_errors():
    with pytest.raises(UsageError, match="width '320'"):
        clrender.render(LIT, width="320", height=240)
    with pytest.raises(UsageError, match="width 320.5"):
        clrender.render(LIT, width=320.5, height=240)


def test_numpy_integers_are_whole_numbers_and_come_back_as_python_ints():
    # 65536 x 65536 is 2**32 pixels, which int32 arithmetic wraps to 0 (under the limit): the product must be taken in Python ints
    with pytest.raises(UsageError, match="too large"):
        RenderSettings(width=np.int32(65536), height=np.int32(65536)).validate(SCENE)
    s = RenderSettings(width=np.int64(40), height=np.int32(30), aa="edge_detect", samples=np.uint8(2), thickness=np.float32(0.5)).validate(SCENE)
    assert (s.width, s.height, s.samples) == (40, 30, 2) and type(s.width) is int and type(s.samples) is int
    assert type(s.thickness) is float and s.thickness == 0.5


def test_the_command_line_and_python_give_the_same_message(capsys):
    with pytest.raises(UsageError) as refused:
        RenderSettings(samples=99).validate(Scene.load("refract1"))
    assert main(["render", "refract1", "--samples", "99", "-o", "never.png"]) == 2
    assert capsys.readouterr().err == f"clrender: {refused.value}\n"


# ------------------------------------------------------------------ 3. warnings
def render_warnings(scene, **settings) -> list:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        RenderSettings(**settings).validate(scene)
    return [w for w in caught if issubclass(w.category, RenderWarning)]


@pytest.mark.parametrize(
    "settings, says",
    [
        ({"samples": 3}, "3 x 3 samples have no effect with --aa none"),
        ({"thickness": 2.0}, "--thickness has no effect with --aa none"),
        ({"aa": "full", "thickness": 2.0}, "--thickness has no effect with --aa full"),
    ],
)
def test_settings_without_effect_warn_in_python(settings, says):
    caught = render_warnings(SCENE, **settings)
    assert len(caught) == 1 and str(caught[0].message).startswith(says)
    assert caught[0].filename == __file__  # pointed at the caller's line, not inside clrender


@pytest.mark.parametrize("settings", [{}, {"aa": "edge_detect", "samples": 2, "thickness": 2.0}, {"thickness": 2.0, "aovs": ("edges",)}])
def test_settings_with_effect_do_not_warn(settings):
    assert render_warnings(SCENE, **settings) == []


def test_a_dask_worker_rechecking_the_clients_settings_says_nothing(monkeypatch):
    # a worker's stderr is the client's terminal, and the client has warned already
    class OnAWorker:
        @staticmethod
        def get_worker():
            return object()

    assert len(render_warnings(SCENE, samples=3)) == 1
    monkeypatch.setitem(sys.modules, "distributed", OnAWorker)
    assert render_warnings(SCENE, samples=3) == []


def test_a_scene_without_lights_warns_and_still_renders():
    dark = {**SPHERE, "ambient": [0.2, 0.2, 0.2]}
    with pytest.warns(RenderWarning, match="scene 'scene' has no lights: only the ambient term and the background will show"):
        image = clrender.render(dark, width=8, height=6)
    assert image.shape == (6, 8, 3) and image[3, 4].max() > 0  # the ambient term lights the sphere


def test_the_command_line_prints_each_warning_once_as_a_warning_line(tmp_path, capsys):
    scene = tmp_path / "dark.toml"
    scene.write_text('ambient = [0.2, 0.2, 0.2]\n[[objects]]\ntype = "sphere"\ncenter = [0, 0, -3]\nradius = 1\n')
    code = main(["-q", "render", str(scene), "--samples", "3", "--width", "8", "--height", "6", "-o", str(tmp_path / "r.png")])
    assert code == 0
    assert capsys.readouterr().err == (
        "warning: 3 x 3 samples have no effect with --aa none (one ray through each pixel centre); use --aa full or edge_detect\n"
        "warning: scene 'dark' has no lights: only the ambient term and the background will show\n"
    )


# ------------------------------------------------------------------ foreign exceptions (issue 38, item 11)
@pytest.mark.parametrize(
    "exposure, tonemap, shown",
    [("1", "clamp", "exposure '1' is not allowed"), (True, "clamp", "exposure True"), (0.0, ["agx"], "tonemap ['agx'] is not allowed")],
)
def test_srgb8_refuses_a_bad_exposure_or_tone_curve_in_one_usage_error(exposure, tonemap, shown):
    result = clrender.RenderResult(np.zeros((1, 1, 3), np.float32), None, None, None, None)
    with pytest.raises(UsageError, match=f"^{re.escape(shown)}.*allowed: ") as caught:
        result.srgb8(exposure=exposure, tonemap=tonemap)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("settings, shown", [("fast", "settings 'fast' is not allowed"), ({"spp": 4}, "settings '{'spp': 4}'")])
def test_renderer_refuses_settings_that_are_not_render_settings(settings, shown):
    with pytest.raises(UsageError, match=re.escape(shown) + ".*allowed: a clrender.RenderSettings or None"):
        clrender.Renderer(SPHERE, settings=settings)


def test_renderer_refuses_an_unknown_keyword_setting_naming_it():
    with pytest.raises(UsageError, match=r"unknown render setting 'sppp'; allowed: width, height, "):
        clrender.Renderer(SPHERE, sppp=4)


@pytest.mark.parametrize("image, shown", [(np.zeros((4, 5), np.float32), "(4, 5)"), (np.zeros((4, 5, 4), np.float32), "(4, 5, 4)")])
def test_denoise_refuses_an_image_that_is_not_h_w_3(image, shown):
    with pytest.raises(UsageError, match=re.escape(f"the image to denoise has shape {shown}; allowed: (H, W, 3)")):
        clrender.denoise(image)
