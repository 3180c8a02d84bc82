"""What ends up in the output: EXR linear, PNG sRGB (checked against the standard's own numbers),
Sobol points against scipy, and pixel-filter weights against their formulas."""

import numpy as np
import OpenImageIO as oiio
import pyopencl as cl
import pytest
from scipy.stats import qmc

from clrender.cli import main
from clrender.image.files import linear_to_srgb, srgb_to_linear, write_display_image
from clrender.launch import Kernel, kernel_signatures
from clrender.layout import PIXEL_FILTERS
from clrender.scene.scene import Scene
from clrender.trace.renderer import render
from clrender.trace.sampling import sample_offsets
from clrender.trace.tracer import trace_defines

# Linear values whose sRGB codes are known from IEC 61966-2-1, worked by hand:
#   0.5        -> 1.055 * 0.5**(1/2.4) - 0.055 = 0.735357 -> 8-bit round(187.52) = 188
#   0.0031308  -> 12.92 * 0.0031308 = 0.040450 (the break point) -> round(10.31) = 10
#   0.18       -> 0.461356 -> round(117.65) = 118
# A plain gamma 2.2 would give 186, 18 and 117 instead.
KNOWN_LINEAR = (0.5, 0.0031308, 0.18)
KNOWN_SRGB = (0.735357, 0.040450, 0.461356)
KNOWN_8BIT = (188, 10, 118)


def read_stored(path, fmt):
    """The file's pixels in their stored type (no normalisation by our own reader)."""
    inp = oiio.ImageInput.open(str(path))
    try:
        spec = inp.spec()
        return np.asarray(inp.read_image(0, 0, 0, spec.nchannels, fmt)).reshape(spec.height, spec.width, -1)
    finally:
        inp.close()


def test_srgb_curve_matches_the_standards_numbers():
    np.testing.assert_allclose(linear_to_srgb(np.array(KNOWN_LINEAR)), KNOWN_SRGB, atol=2e-6)
    # the other direction, at the break point of the piecewise curve and at mid-grey
    np.testing.assert_allclose(srgb_to_linear(np.array([0.04045, 0.735357, 1.0, 0.0])), [0.0031308, 0.5, 1.0, 0.0], rtol=2e-5)
    # the linear toe below the break point: 12.92 x, not a power law
    np.testing.assert_allclose(linear_to_srgb(np.array([0.001])), [0.01292], rtol=1e-6)


@pytest.fixture
def background_scene(tmp_path):
    """A scene of nothing but background, so every pixel has a known linear value."""
    path = tmp_path / "flat.toml"
    path.write_text(f"width = 6\nheight = 4\nbackground = [{', '.join(map(str, KNOWN_LINEAR))}]\n")
    return path


def test_png_holds_the_srgb_codes_and_exr_the_linear_values(tmp_path, background_scene):
    png, exr = tmp_path / "flat.png", tmp_path / "flat.exr"
    assert main(["-q", "render", str(background_scene), "-o", str(png)]) == 0
    assert main(["-q", "render", str(background_scene), "-o", str(exr)]) == 0
    codes = read_stored(png, "uint8")
    assert codes.shape == (4, 6, 3)
    assert (codes == np.array(KNOWN_8BIT, np.uint8)).all(), codes[0, 0]
    linear = read_stored(exr, "float")
    assert (linear == np.float32(KNOWN_LINEAR)).all(), linear[0, 0]


def test_exr_equals_the_linear_render_pixel_for_pixel(tmp_path):
    exr = tmp_path / "r.exr"
    assert main(["-q", "render", "refract1", "--camera", "1", "--aa", "none", "--width", "20", "--height", "15", "-o", str(exr)]) == 0
    expected = render("refract1", width=20, height=15)
    assert expected.max() > 0.2 and expected.std() > 0.05  # a real picture, not a blank
    np.testing.assert_array_equal(read_stored(exr, "float"), expected)


def test_png_of_a_render_is_its_srgb_encoding(tmp_path):
    image = render("refract1", width=20, height=15)
    png = write_display_image(tmp_path / "r.png", image)
    x = np.clip(image.astype(np.float64), 0, 1)
    srgb = np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)  # IEC 61966-2-1, float64
    codes = read_stored(png, "uint8").astype(int)
    assert np.abs(codes - np.round(srgb * 255)).max() <= 1  # rounding at exact .5 may go either way
    assert (codes == np.round(srgb * 255)).mean() > 0.99


# ------------------------------------------------------------------ kernel helpers

HELPERS = """
#include "common.h"
#include "sampling.h"
/* the unscrambled Sobol points: dimension 0 is the bit-reversed index */
__kernel void sobol_points(int n, __global uint2 *out) {
    int i = get_global_id(0);
    if (i < n) out[i] = (uint2)(reverse_bits32((uint)i), sobol_dim1((uint)i));
}
__kernel void filter_weights(int filter, int n, __global const float2 *offsets, __global float *out) {
    int i = get_global_id(0);
    if (i < n) out[i] = pixel_filter_weight(filter, offsets[i]);
}
"""


@pytest.fixture(scope="module")
def helpers(device):
    program = device.build(HELPERS, "sampling helpers", trace_defines())
    return {name: Kernel(getattr(program, name), params) for name, params in kernel_signatures(HELPERS).items()}


def test_unscrambled_sobol_points_equal_scipys(device, helpers):
    n = 1024
    buf = device.empty(8 * n)
    helpers["sobol_points"](device.queue, (n,), None, n=n, out=buf)
    ours = np.empty((n, 2), np.uint32)
    cl.enqueue_copy(device.queue, ours, buf)
    reference = qmc.Sobol(d=2, scramble=False).random(n)  # 32-bit direction numbers, Joe and Kuo
    # scipy walks the sequence in Gray-code order: its n-th point is point gray(n) in index order
    gray = np.arange(n) ^ (np.arange(n) >> 1)
    np.testing.assert_array_equal(ours[gray] / 2.0**32, reference)


def test_sobol_scrambling_differs_per_pixel_but_keeps_the_net(device):
    pixels = np.arange(0, 400, 7)
    s = sample_offsets(pixels, "sobol", 4, seed=5, device=device)
    # every pair of pixels gets its own scramble: no two pixels share a point set
    flat = s.reshape(len(pixels), -1)
    same = (flat[:, None, :] == flat[None, :, :]).all(-1)
    assert same.sum() == len(pixels)  # only the diagonal
    assert (s[1:, 0] != s[:-1, 0]).all(axis=-1).all()  # even the first sample moves
    # and each pixel's 16 points still fall one per 1/4 x 1/4 cell
    cells = np.floor(s * 4).astype(int)
    for row in cells[..., 1] * 4 + cells[..., 0]:
        assert sorted(row) == list(range(16))


FILTERS = PIXEL_FILTERS


def formula_weight(name, dx, dy):
    """Weights about the pixel centre, as docs/shading.md and sampling.h state them (sigma 0.25 px)."""
    if name == "box":
        return np.ones_like(dx)
    if name == "tent":
        return np.maximum(0, 1 - 2 * np.abs(dx)) * np.maximum(0, 1 - 2 * np.abs(dy))
    return np.exp(-(dx**2 + dy**2) / (2 * 0.25**2))


@pytest.mark.parametrize("name", list(FILTERS))
def test_pixel_filter_weights_match_their_formulas(device, helpers, name):
    g = (np.arange(11) + 0.5) / 11
    off = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2).astype(np.float32)
    out = device.empty(4 * len(off))
    helpers["filter_weights"](device.queue, (len(off),), None, filter=FILTERS[name], n=len(off), offsets=device.to_device(off), out=out)
    w = np.empty(len(off), np.float32)
    cl.enqueue_copy(device.queue, w, out)
    expected = formula_weight(name, off[:, 0] - 0.5, off[:, 1] - 0.5)
    np.testing.assert_allclose(w, expected, atol=2e-6, rtol=1e-5)


def contrast_scene(width, height):
    return Scene.from_dict(
        {
            "width": width,
            "height": height,
            "background": [0.1, 0.2, 0.4],
            "cameras": [{"position": [0, 0, 5], "look_at": [0, 0, 0], "fov": 40}],
            "materials": {"red": {"diffuse": [0.9, 0.1, 0.1]}, "white": {"diffuse": [1, 1, 1]}},
            "lights": [{"type": "point", "position": [2, 3, 4]}],
            "objects": [
                {"type": "sphere", "center": [-0.6, 0.2, 0], "radius": 0.7, "material": "red"},
                {"type": "sphere", "center": [0.8, -0.3, -0.5], "radius": 0.6, "material": "white"},
            ],
        }
    )


@pytest.mark.parametrize("name", ["tent", "gaussian"])
def test_pixel_filter_weights_a_rendered_pixel_as_the_formula_says(device, name):
    """With the uniform sampler, sample (p, q) of pixel (x, y) is the centre of pixel (3x+q, 3y+p) of an
    image three times larger, so the filtered render is a weighted mean of 3x3 blocks of that image."""
    n, w, h = 3, 24, 18
    filtered = render(contrast_scene(w, h), aa="full", sampler="uniform", samples=n, pixel_filter=name)
    fine = render(contrast_scene(n * w, n * h)).reshape(h, n, w, n, 3)
    d = (np.arange(n) + 0.5) / n - 0.5
    weights = formula_weight(name, d[None, :], d[:, None])  # [p, q]
    predicted = np.einsum("ypxqc,pq->yxc", fine, weights) / weights.sum()
    box = fine.mean(axis=(1, 3))
    assert (np.abs(predicted - box).max(-1) > 1e-3).mean() > 0.05  # enough pixels where the weighting matters
    close = np.abs(filtered - predicted).max(-1) < 1e-4
    assert close.mean() > 0.97, close.mean()  # a ray on an exact silhouette may round to the other side


def test_random_samples_of_one_pixel_are_independent_of_each_other(device):
    """Each sample of a pixel draws its own numbers: positions differ within a pixel and sample k
    says nothing about sample k + 1 (the hash takes the sample index)."""
    s = sample_offsets(np.arange(4000), "random", 3, seed=8, device=device)  # 9 samples per pixel
    assert all(len(np.unique(row, axis=0)) == 9 for row in s[:200])
    for k in range(8):
        assert abs(np.corrcoef(s[:, k, 0], s[:, k + 1, 0])[0, 1]) < 0.06
        assert abs(np.corrcoef(s[:, k, 1], s[:, k + 1, 1])[0, 1]) < 0.06
    # the jitter inside the stratified sub-squares is independent too
    j = sample_offsets(np.arange(4000), "stratified", 3, seed=8, device=device) * 3 % 1
    assert abs(np.corrcoef(j[:, 0, 0], j[:, 4, 0])[0, 1]) < 0.06
