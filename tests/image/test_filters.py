"""Filters against a direct numpy convolution with reflect-101 borders, plus their invariants."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.image import filters
from clrender.image.files import Image


def reflect101(index: np.ndarray, n: int) -> np.ndarray:
    """Reflect-101 border, repeated: period 2(n-1), ... c b | a b c ... | ... b a."""
    if n == 1:
        return np.zeros_like(index)
    period = 2 * (n - 1)
    index = np.mod(index, period)
    return np.where(index >= n, period - index, index)


def convolve_direct(img: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Direct 2-D convolution in float64 (kernels here are symmetric, so = correlation)."""
    h, w = img.shape[:2]
    ry, rx = kernel.shape[0] // 2, kernel.shape[1] // 2
    out = np.zeros(img.shape, np.float64)
    for dy in range(-ry, ry + 1):
        rows = reflect101(np.arange(h) + dy, h)
        for dx in range(-rx, rx + 1):
            cols = reflect101(np.arange(w) + dx, w)
            out += kernel[dy + ry, dx + rx] * img[rows][:, cols]
    return out


def box(k):
    return np.full((k, k), 1.0 / (k * k))


def gauss(k):
    """Written out again from the documented rule, not taken from the module."""
    sigma = 0.3 * ((k - 1) * 0.5 - 1) + 0.8
    x = np.arange(k) - k // 2
    g = np.exp(-x * x / (2 * sigma * sigma))
    return np.outer(g, g) / g.sum() ** 2


LAPLACE_4 = np.array([[0, -1, 0], [-1, 4, -1], [0, -1, 0]], float)
LAPLACE_8 = np.array([[-1, -1, -1], [-1, 8, -1], [-1, -1, -1]], float)

SHAPES = [(9, 7, 3), (16, 11, 1), (5, 4, 4), (1, 6, 3), (6, 1, 3), (1, 1, 3)]
CASES = [
    ("box_blur_3", box(3)),
    ("box_blur_5", box(5)),
    ("box_blur_15", box(15)),
    ("gauss_blur_3", gauss(3)),
    ("gauss_blur_7", gauss(7)),
    ("gauss_blur_21", gauss(21)),
    ("edge_detect_1", LAPLACE_4),
    ("edge_detect_2", LAPLACE_8),
]


@pytest.mark.parametrize("name,kernel", CASES, ids=[c[0] for c in CASES])
@pytest.mark.parametrize("shape", SHAPES, ids=lambda s: "x".join(map(str, s)))
def test_filter_matches_direct_convolution(name, kernel, shape, rng):
    img = rng.random(shape).astype(np.float32)
    got = filters.apply(img, name)
    assert got.dtype == np.float32 and got.shape == img.shape
    np.testing.assert_allclose(got, convolve_direct(img, kernel), atol=2e-6)


@pytest.mark.parametrize("size", [3, 9, 33])
@pytest.mark.parametrize("shape", [(12, 10, 3), (3, 2, 1), (1, 5, 3)], ids=lambda s: "x".join(map(str, s)))
def test_fft_gaussian_matches_direct_convolution(size, shape, rng):
    """The path used from FFT_FROM_SIZE on, forced at small sizes (kernels wider than the image included)."""
    img = rng.random(shape).astype(np.float32)
    got = filters.separable_fft(img, filters.gaussian_weights(size).astype(np.float32))
    np.testing.assert_allclose(got, convolve_direct(img, gauss(size)), atol=2e-6)


def test_wide_gaussian_takes_fft_path_and_agrees_with_separable(rng, monkeypatch):
    img = rng.random((40, 30, 3)).astype(np.float32)
    size = filters.FFT_FROM_SIZE
    via_fft = filters.apply(img, f"gauss_blur_{size}")
    monkeypatch.setattr(filters, "FFT_FROM_SIZE", 10**9)
    direct = filters.apply(img, f"gauss_blur_{size}")
    np.testing.assert_allclose(via_fft, direct, atol=2e-6)


@pytest.mark.parametrize("name", ["box_blur_1", "box_blur_3", "box_blur_101", "gauss_blur_1", "gauss_blur_5", "gauss_blur_201", "gauss_blur_1001"])
def test_averaging_weights_sum_to_one(name):
    f = filters.parse(name)
    assert f.kernel().sum() == pytest.approx(1.0, abs=1e-12)
    assert np.all(f.kernel() >= 0)
    constant = np.full((23, 17, 3), 0.37, np.float32)
    np.testing.assert_allclose(filters.apply(constant, name), constant, rtol=1e-5)


@pytest.mark.parametrize("name", ["edge_detect_1", "edge_detect_2"])
def test_edge_detect_of_constant_is_zero(name):
    assert filters.parse(name).kernel().sum() == 0
    out = filters.apply(np.full((13, 9, 3), 0.8, np.float32), name)
    assert np.abs(out).max() < 1e-6


def test_edge_kernels_differ_and_respond_to_a_step(rng):
    step = np.zeros((8, 8), np.float32)
    step[:, 4:] = 1
    e1, e2 = filters.apply(step, "edge_detect_1"), filters.apply(step, "edge_detect_2")
    # either side of the step: -1 / +1 for the 4-neighbour kernel, -3 / +3 for the 8-neighbour one
    np.testing.assert_allclose(e1[:, 3], -1)
    np.testing.assert_allclose(e1[:, 4], 1)
    np.testing.assert_allclose(e2[:, 3], -3)
    np.testing.assert_allclose(e2[:, 4], 3)
    assert np.all(e1[:, [0, 1, 2, 5, 6, 7]] == 0)


@pytest.mark.parametrize("factor", ["0", "0.5", "1.5", "2", "1e2", ".25", "3."])
def test_brighten_scales_exactly(factor, rng):
    img = rng.random((7, 5, 3)).astype(np.float32) * 4
    out = filters.apply(img, f"brighten_{factor}")
    assert out.dtype == np.float32
    assert np.array_equal(out, img * np.float32(float(factor)))


def test_chain_equals_successive_single_applications(rng):
    img = rng.random((20, 15, 3)).astype(np.float32)
    names = ["gauss_blur_5", "brighten_1.5", "edge_detect_2", "box_blur_3"]
    expected = img
    for name in names:
        expected = filters.apply(expected, name)
    assert np.array_equal(filters.apply(img, *names), expected)


def test_two_dimensional_input_keeps_its_shape(rng):
    img = rng.random((9, 8)).astype(np.float32)
    out = filters.apply(img, "box_blur_3")
    assert out.shape == (9, 8)
    np.testing.assert_allclose(out, convolve_direct(img, box(3)), atol=2e-6)


def test_many_channels_are_filtered_alike(rng):
    img = rng.random((10, 9, 7)).astype(np.float32)
    out = filters.apply(img, "gauss_blur_5")
    np.testing.assert_allclose(out, convolve_direct(img, gauss(5)), atol=2e-6)


def test_opaque_alpha_gives_the_plain_result_and_stays_one(rng):
    rgb = rng.random((12, 10, 3)).astype(np.float32)
    rgba = np.concatenate([rgb, np.ones((12, 10, 1), np.float32)], axis=2)
    for name in ["gauss_blur_5", "box_blur_3", "edge_detect_1", "brighten_2"]:
        out = filters.apply(rgba, name, alpha_channel=3)
        np.testing.assert_allclose(out[:, :, :3], filters.apply(rgb, name), atol=1e-6)
        np.testing.assert_allclose(out[:, :, 3], 1.0, atol=1e-6)


def test_blur_with_alpha_is_premultiplied(rng):
    """Colour under zero alpha must not bleed; alpha is blurred with the same weights."""
    rgba = rng.random((11, 13, 4)).astype(np.float32)
    rgba[:, :6, 3] = 0  # left part transparent, with random hidden colour
    rgba[:, 6:, :3] = [0.2, 0.5, 0.9]
    out = filters.apply(rgba, "box_blur_5", alpha_channel=3)
    alpha = convolve_direct(rgba[:, :, 3], box(5))
    premult = convolve_direct(rgba[:, :, :3] * rgba[:, :, 3:], box(5))
    np.testing.assert_allclose(out[:, :, 3], alpha, atol=1e-6)
    seen = alpha > 1e-3
    np.testing.assert_allclose(out[:, :, :3][seen], (premult / np.maximum(alpha, 1e-12)[:, :, None])[seen], atol=1e-5)
    # wherever any alpha reached, the colour is exactly the visible colour
    np.testing.assert_allclose(out[:, :, :3][seen], np.broadcast_to([0.2, 0.5, 0.9], out[:, :, :3][seen].shape), atol=1e-5)
    assert np.all(out[:, :, :3][~seen] == 0)


def test_edge_detect_and_brighten_copy_alpha(rng):
    rgba = rng.random((8, 8, 4)).astype(np.float32)
    for name in ["edge_detect_1", "brighten_3"]:
        out = filters.apply(rgba, name, alpha_channel=3)
        assert np.array_equal(out[:, :, 3], rgba[:, :, 3])
        np.testing.assert_allclose(out[:, :, :3], filters.apply(rgba[:, :, :3], name), atol=1e-6)


def test_image_objects_use_their_alpha_channel(rng):
    rgba = rng.random((8, 8, 4)).astype(np.float32)
    image = Image(rgba, "uint8", ("R", "G", "B", "A"))
    out = filters.apply(image, "brighten_2")
    assert isinstance(out, Image) and out.format == "uint8" and out.channel_names == image.channel_names
    assert np.array_equal(out.pixels[:, :, 3], rgba[:, :, 3])
    assert np.array_equal(out.pixels[:, :, :3], rgba[:, :, :3] * np.float32(2))


@pytest.mark.parametrize(
    "name,says",
    [
        ("box_blur_4", "odd"),
        ("gauss_blur_0", "odd"),
        ("box_blur_-3", "odd"),
        ("gauss_blur_10003", "odd"),
        ("box_blur_x", "whole number"),
        ("box_blur_", "whole number"),
        ("gauss_blur_3.0", "whole number"),
        ("brighten_x", "not a number"),
        ("brighten_nan", "not a number"),
        ("brighten_inf", "not a number"),
        ("brighten_-1", ">= 0"),
        ("brighten_1e999", "finite"),
        ("brighten_", "not a number"),
        ("edge_detect_3", "allowed"),
        ("sharpen", "allowed"),
        ("", "allowed"),
        ("BOX_BLUR_3", "allowed"),
    ],
)
def test_bad_names_are_refused_with_the_allowed_forms(name, says):
    with pytest.raises(UsageError, match=says) as info:
        filters.parse(name)
    assert "\n" not in str(info.value)
    assert repr(name) in str(info.value)


def test_a_bad_name_in_a_chain_is_refused_before_any_work(rng, monkeypatch):
    calls = []
    monkeypatch.setattr(filters.Filter, "__call__", lambda self, px: calls.append(self) or px)
    with pytest.raises(UsageError, match="box_blur_2"):
        filters.apply(rng.random((4, 4, 3)), "gauss_blur_3", "box_blur_2")
    assert calls == []
    with pytest.raises(UsageError, match="no filter"):
        filters.apply(rng.random((4, 4, 3)))


def test_list_names_every_form():
    text = filters.describe()
    for form in ["brighten_", "box_blur_", "gauss_blur_", "edge_detect_1", "edge_detect_2"]:
        assert form in text
    assert len(text.splitlines()) == 5


# ----------------------------------------------------------------------------- range: NaN, inf, overflow

FLOAT_MAX = float(np.finfo(np.float32).max)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_pixels_are_refused(value):
    pixels = np.ones((5, 6, 3), np.float32)
    pixels[2, 3, 1] = value
    with pytest.raises(UsageError, match="1 pixel values are NaN or infinite; allowed: finite numbers"):
        filters.apply(pixels, "box_blur_3")


@pytest.mark.parametrize(
    ("value", "factor", "expected"),
    [(3e38, 1.5, FLOAT_MAX), (-3e38, 1.5, -FLOAT_MAX), (1.0, 1e300, FLOAT_MAX), (0.0, 1e300, 0.0), (2.0, 1.5, 3.0)],
)
def test_brighten_clamps_to_the_float32_range(value, factor, expected):
    pixels = np.full((2, 2, 3), value, np.float32)
    out = filters.apply(pixels, f"brighten_{factor!r}")
    assert out.dtype == np.float32 and (out == np.float32(expected)).all()


@pytest.mark.parametrize("name", ["edge_detect_1", "edge_detect_2"])
def test_edge_detect_of_a_huge_constant_is_still_zero(name):
    # 8 * 2^127 overflows float32: without the power-of-two rescaling the sum is inf - inf = NaN
    # (a power of two, so that every partial sum is exact and the answer is exactly 0)
    assert (filters.apply(np.full((7, 9, 3), 2.0**127, np.float32), name) == 0).all()


@pytest.mark.parametrize("name", ["box_blur_5", "gauss_blur_7", "gauss_blur_151", "edge_detect_2"])
def test_huge_values_filter_as_the_same_values_scaled_by_a_power_of_two(name, rng):
    # float arithmetic commutes with power-of-two scales, so the rescaled path is exact
    pixels = rng.random((40, 37, 3)).astype(np.float32)
    small = filters.apply(pixels, name)
    huge = filters.apply(pixels * np.float32(2.0**120), name)
    assert np.isfinite(huge).all()
    np.testing.assert_array_equal(huge, small * np.float32(2.0**120))


def test_sizes_of_thousands_of_digits_are_refused_in_one_line():
    name = "gauss_blur_" + "9" * 5000
    with pytest.raises(UsageError) as err:
        filters.parse(name)
    message = str(err.value)
    assert "5000 digits long" in message and "K odd in 1..10001" in message and len(message) < 400


def test_border_is_opencvs_reflect_101():
    """filters.BORDER is written as a number so that importing the module does not import OpenCV."""
    import cv2

    assert filters.BORDER == cv2.BORDER_REFLECT_101
