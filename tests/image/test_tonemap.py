"""The display transform (clrender/image/tonemap.py): the tone curves against their float64 formulas
(tests/reference/tonemap64.py), their shape (0 -> 0, monotone, bounded), exposure as an exact power of
two, clamp equal bit for bit to the PNG written before tone mapping existed, EXR untouched, bad values
refused with one line."""

import numpy as np
import pytest

from clrender.image.files import display_srgb, linear_to_srgb, read_image, srgb8, write_image
from clrender.image.tonemap import DisplaySettings, aces, agx, display_linear

from tests.clitools import run_cli
from tests.reference import tonemap64

GREYS = np.array([0.0, 1e-4, 0.01, 0.18, 0.5, 1.0, 2.0, 4.0, 16.0, 100.0])
COLOURS = np.array([[0.18, 0.18, 0.18], [1.0, 0.2, 0.05], [0.05, 0.6, 0.1], [0.02, 0.03, 3.0], [8.0, 4.0, 0.5], [0.0, 0.0, 0.0]])


@pytest.mark.parametrize("curve, reference", [(aces, tonemap64.aces_hill), (agx, tonemap64.agx_base)], ids=["aces", "agx"])
def test_curves_match_their_formulas_in_float64(curve, reference):
    for rgb in (np.repeat(GREYS[:, None], 3, axis=1), COLOURS):
        np.testing.assert_allclose(curve(rgb), reference(rgb), rtol=1e-12, atol=1e-15)


def test_known_values():
    # Hill's curve on grey: the matrices' rows sum to 1 (to 5 digits), so grey stays grey
    assert tonemap64.hill_curve(1.0) == pytest.approx((1 + 0.0245786 - 0.000090537) / (0.983729 + 0.4329510 + 0.238081))
    np.testing.assert_allclose(aces(np.full((1, 3), 1.0)), tonemap64.hill_curve(1.0), rtol=2e-4)
    assert aces(np.zeros((1, 3))).tolist() == [[0.0, 0.0, 0.0]]  # the fit is -3.8e-4 at 0: clipped to black
    assert agx(np.zeros((1, 3))).tolist() == [[0.0, 0.0, 0.0]]  # the sigmoid is -0.00232 at 0: clipped to black
    assert np.all(aces(np.full((1, 3), 1e6)) > 0.999) and np.all(aces(np.full((1, 3), 1e6)) <= 1.0)
    # AgX puts middle grey 0.18 at about the middle of the display's code values
    assert 0.48 < float(display_srgb(np.full((1, 1, 3), 0.18, np.float32), DisplaySettings(tonemap="agx"))[0, 0, 0]) < 0.52


@pytest.mark.parametrize("curve", [aces, agx], ids=["aces", "agx"])
def test_curves_are_monotone_and_bounded_on_grey(curve):
    x = np.concatenate([[0.0], np.geomspace(1e-6, 1e4, 2000)])
    y = curve(np.repeat(x[:, None], 3, axis=1))
    assert np.all(np.diff(y, axis=0) >= -1e-12)
    assert y.min() >= 0.0 and y.max() <= 1.0
    assert y[-1].min() > 0.98  # highlights roll off towards white, not to a grey


def test_exposure_is_an_exact_power_of_two():
    image = np.random.default_rng(3).random((8, 9, 3)).astype(np.float32) * 4
    for stops in (-3, -1, 1, 2.5):
        got = display_linear(image, DisplaySettings(exposure=stops))
        assert got.dtype == np.float32
        assert np.array_equal(got, image * np.float32(2.0**stops))
    assert np.array_equal(display_linear(image, DisplaySettings(exposure=1)) / 2, image)  # only the exponent moved
    for tonemap in ("aces", "agx"):  # the exposure comes before the curve
        np.testing.assert_array_equal(
            display_linear(image, DisplaySettings(exposure=2, tonemap=tonemap)), display_linear(image * 4, DisplaySettings(tonemap=tonemap))
        )


def test_srgb8_is_what_the_png_stores(tmp_path):
    image = np.random.default_rng(4).random((16, 16, 3)).astype(np.float32) * 3
    for display in (DisplaySettings(), DisplaySettings(exposure=-1, tonemap="aces"), DisplaySettings(tonemap="agx")):
        path = write_image(tmp_path / f"{display.tonemap}.png", display_srgb(image, display), format="uint8")
        assert np.array_equal(np.round(read_image(path).pixels * 255).astype(np.uint8), srgb8(image, display))
    # and clamp's codes are the sRGB OETF's, computed here in float64 (within the float32 rounding)
    reference = np.round(255 * tonemap64.srgb_oetf(image))
    assert np.abs(srgb8(image).astype(int) - reference).max() <= 1


def render(capsys, out, *options):
    code, _, err = run_cli(capsys, "render", "refract1", "--width", "40", "--height", "30", "-o", str(out), *options)
    assert code == 0, err
    return err


def test_clamp_is_the_png_of_before_bit_for_bit_and_exr_stays_linear(tmp_path, capsys):
    render(capsys, tmp_path / "linear.exr")
    linear = read_image(tmp_path / "linear.exr").pixels
    # the PNG as written before the display transform existed: sRGB OETF, then OpenImageIO's 8-bit conversion
    before = write_image(tmp_path / "before.png", linear_to_srgb(linear), format="uint8")
    render(capsys, tmp_path / "default.png")
    render(capsys, tmp_path / "clamp.png", "--tonemap", "clamp", "--exposure", "0")
    for name in ("default.png", "clamp.png"):
        assert (tmp_path / name).read_bytes() == before.read_bytes()
    # exposure and tone curve leave float outputs scene-linear, with a warning that they changed nothing
    err = render(capsys, tmp_path / "graded.exr", "--tonemap", "agx", "--exposure", "2")
    assert "warning:" in err and "scene-linear" in err
    assert np.array_equal(read_image(tmp_path / "graded.exr").pixels, linear)
    # a PNG with an exposure and a curve is that transform of the same linear pixels
    render(capsys, tmp_path / "aces.png", "--tonemap", "aces", "--exposure", "-1")
    expected = np.round(255 * tonemap64.srgb_oetf(tonemap64.aces_hill(linear.astype(np.float64) / 2)))
    got = np.round(read_image(tmp_path / "aces.png").pixels * 255)
    assert np.abs(got - expected).max() <= 1


@pytest.mark.parametrize(
    "options, words",
    [
        (("--tonemap", "filmic"), ("--tonemap", "filmic", "clamp", "aces", "agx")),
        (("--exposure", "nan"), ("exposure", "nan", "allowed")),
        (("--exposure", "100"), ("exposure", "100", "-64 to 64")),
        (("--exposure", "two"), ("--exposure", "two")),
    ],
)
def test_bad_display_options_are_one_line_and_exit_2(tmp_path, capsys, options, words):
    out = tmp_path / "o.png"
    code, stdout, err = run_cli(capsys, "render", "refract1", "--width", "8", "--height", "8", "-o", str(out), *options)
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and err.startswith("clrender:")
    assert all(w in err for w in words), err
    assert not out.exists() and stdout == ""


def test_python_api_takes_the_display_transform():
    from clrender import Renderer

    result = Renderer("refract1", width=24, height=16).run()
    assert np.array_equal(result.srgb8(), srgb8(result.image))
    assert np.array_equal(result.srgb8(exposure=1, tonemap="agx"), srgb8(result.image, DisplaySettings(1, "agx")))
    with pytest.raises(ValueError, match="allowed: clamp|aces|agx"):
        result.srgb8(tonemap="reinhard")


def test_turntable_frames_take_the_display_transform(tmp_path, capsys):
    tiny = ("render", "refract1", "--camera", "2", "--width", "16", "--height", "12", "--turntable", "2")
    assert run_cli(capsys, *tiny, "-o", str(tmp_path / "f{:d}.exr"))[0] == 0
    code, _, err = run_cli(capsys, *tiny, "--tonemap", "agx", "--exposure", "1", "-o", str(tmp_path / "f{:d}.png"))
    assert code == 0, err
    for k in range(2):
        linear = read_image(tmp_path / f"f{k}.exr").pixels
        expected = np.round(255 * tonemap64.srgb_oetf(tonemap64.agx_base(2.0 * linear.astype(np.float64))))
        assert np.abs(np.round(read_image(tmp_path / f"f{k}.png").pixels * 255) - expected).max() <= 1
