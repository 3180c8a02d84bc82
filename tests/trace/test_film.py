"""The path tracer's reconstruction filters (RenderSettings.rfilter, --rfilter; kernels/film.h, clrender/trace/film.py).

References, none from clrender: Mitsuba 3's filter formulas written out in numpy (tent max(0, 1 - |x|), radius 1;
gaussian max(0, exp(-x^2 / (2 s^2)) - exp(-r^2 / (2 s^2))), s = 0.5, r = 4 s); a constant scene stays constant
under any filter (the weights are normalised); a vertical black/white edge seen by an orthographic camera is,
column by column, the step integrated against the filter over the image (samples exist only inside it), over the
filter's integral over the image: (int_edge^W f(X - c) dX) / (int_0^W f(X - c) dX) for column centre c, by a fine
midpoint rule.  That check is a t-test per column on K independent renders' column means (rows share samples, so
the K renders, not the rows, are the independent draws), Šidák over the columns at ALPHA.  Determinism: two
tilings give the same bits.
"""

import numpy as np
import pytest
from scipy import stats

from clrender.launch import Kernel, kernel_signatures
from clrender.scene.scene import Scene
from clrender.trace import film
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer, trace_defines

from tests.clitools import run_cli
from tests.reference.path_scenes import quad
from tests.reference.ztest import sidak

ALPHA = 1e-3
SPLATTING = ("tent", "gaussian")


def tent64(x):
    return np.maximum(0.0, 1.0 - np.abs(x))


def gaussian64(x, s=0.5, r=2.0):
    return np.maximum(0.0, np.exp(-np.square(x) / (2 * s * s)) - np.exp(-(r * r) / (2 * s * s)))


REFERENCE = {"tent": tent64, "gaussian": gaussian64}

HELPER = """
#include "common.h"
#include "film.h"
__kernel void film_weights(int filter, int n, __global const float *x, __global float *out) {
    int i = get_global_id(0);
    if (i < n) out[i] = film_weight(filter, x[i]);
}
"""


@pytest.mark.parametrize("name", SPLATTING)
def test_filter_weights_are_mitsubas_formulas(device, name):
    import pyopencl as cl

    program = device.build(HELPER, "film helper", trace_defines())
    kernel = Kernel(program.film_weights, kernel_signatures(HELPER)["film_weights"])
    x = np.linspace(-3, 3, 1201).astype(np.float32)
    out = device.empty(4 * len(x))
    kernel(device.queue, (len(x),), None, filter=np.int32(film.FILTERS[name]), n=np.int32(len(x)), x=device.to_device(x), out=out)
    got = np.empty(len(x), np.float32)
    cl.enqueue_copy(device.queue, got, out)
    np.testing.assert_allclose(got, REFERENCE[name](x.astype(np.float64)), atol=2e-7)
    assert film.reach(name) == int(np.ceil(film.RADIUS[name])) and np.all(got[np.abs(x) >= film.RADIUS[name]] == 0)


def render(scene, device, **kw):
    loaded = Scene.from_dict(scene)
    return Renderer(loaded, tracer=Tracer(loaded, device=device), integrator="path", **kw).run().image


def sky(width=20, height=12, objects=(), materials=None, ortho=None) -> dict:
    cam = {"position": [0, 0, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40}
    if ortho:
        cam.update(projection="orthographic", ortho_height=ortho)
    return {
        "width": width,
        "height": height,
        "cameras": [cam],
        "environment": {"color": [0.3, 0.5, 0.7]},
        "materials": materials or {},
        "objects": list(objects),
    }


@pytest.mark.parametrize("name", SPLATTING)
def test_a_constant_scene_is_unchanged_by_any_filter(device, name):
    img = render(sky(), device, spp=4, rfilter=name)
    np.testing.assert_allclose(img, np.broadcast_to([0.3, 0.5, 0.7], img.shape), rtol=3e-7)


def edge_expected(name: str, width: int, edge: float) -> np.ndarray:
    """Each column's expected value across a black (X < edge) / white step, X in pixels from the image's left."""
    k = 4000
    xs = (np.arange(width * k) + 0.5) / k  # midpoints over the image
    lit = xs > edge
    out = []
    for c in np.arange(width) + 0.5:
        f = REFERENCE[name](xs - c)
        out.append((f * lit).sum() / f.sum())
    return np.array(out)


@pytest.mark.parametrize("name", SPLATTING)
def test_a_half_plane_edge_is_the_step_convolved_with_the_filter(device, name):
    width, height, edge, k = 24, 12, 12.3, 6  # the edge 0.3 px into column 12; one world unit a pixel
    black = quad([edge - width / 2 - 50, -50, 0], [50, 0, 0], [0, 100, 0], "black")
    scene = sky(width, height, [black], {"black": {"diffuse": [0, 0, 0]}}, ortho=float(height))
    scene["environment"] = {"color": [1, 1, 1]}
    columns = np.array([render(scene, device, spp=256, samples=16, rfilter=name, seed=s)[..., 0].mean(axis=0) for s in range(k)])
    expected = edge_expected(name, width, edge)
    mean, se = columns.mean(axis=0), columns.std(axis=0, ddof=1) / np.sqrt(k)
    exact = se == 0  # columns far from the edge: every sample the same
    np.testing.assert_array_equal(mean[exact], np.round(expected[exact]))
    t = (mean[~exact] - expected[~exact]) / se[~exact]
    limit = stats.t.ppf(1 - sidak(ALPHA, width) / 2, k - 1)
    assert np.all(np.abs(t) < limit), f"columns {mean} vs {expected}: t {t}"
    # and it is not the box filter's answer: the column left of the edge sees the light beyond it
    assert mean[11] > 0.005 and expected[11] > 0.01


@pytest.mark.parametrize("name", SPLATTING)
def test_filtered_images_have_the_same_bits_on_any_tiling(device, name):
    scene = sky(13, 9, [{"type": "sphere", "center": [0.2, 0, 0], "radius": 0.7, "material": "m"}], {"m": {"diffuse": [0.8, 0.4, 0.2]}})
    a = render(scene, device, spp=8, rfilter=name, tile_size=128)
    b = render(scene, device, spp=8, rfilter=name, tile_size=4)
    assert a.tobytes() == b.tobytes()


def test_box_is_the_unfiltered_kernel():
    """box adds no kernel variant and one slot: the render is today's, bit for bit (tools checked it on every
    path scene of tests/reference/path_scenes.py against main)."""
    assert film.defines("box") == {} and film.slots("box") == 1
    assert (film.slots("tent"), film.slots("gaussian")) == (9, 25)


def test_rfilter_settings_and_the_command_line(tmp_path, capsys):
    from clrender.cli import build_parser
    from clrender.commands.render import settings_from_args

    args = build_parser().parse_args(["render", "refract1", "--integrator", "path", "--rfilter", "tent"])
    assert settings_from_args(args).rfilter == "tent"
    code, out, err = run_cli(capsys, "render", "refract1", "--rfilter", "gaussian", "-o", str(tmp_path / "a.png"))
    assert code == 2 and err.count("\n") == 1 and "--rfilter gaussian is the path tracer's" in err
    assert not (tmp_path / "a.png").exists()
    code, out, err = run_cli(
        capsys, "render", "refract1", "--integrator", "path", "--rfilter", "tent", "--pixel-filter", "tent", "-o", str(tmp_path / "b.png")
    )
    assert code == 2 and "not both" in err and not (tmp_path / "b.png").exists()
    code, out, err = run_cli(capsys, "render", "refract1", "--integrator", "path", "--rfilter", "mitchell", "-o", str(tmp_path / "c.png"))
    assert code == 2 and "mitchell" in err and not (tmp_path / "c.png").exists()
