"""`--exposure auto` (clrender/image/tonemap.py): never brighter than rendered; darker by exactly the stops that
bring the 97th percentile of luminance to 1. The default of path-traced PNG/JPEG, never of Whitted renders."""

import numpy as np
import pytest

from clrender.cli import build_parser
from clrender.commands.render import auto_exposure_wanted
from clrender.image.tonemap import AUTO_PERCENTILE, auto_exposure


def image_of(values, bright, n_bright):
    """A (1, N, 3) grey image: values, then n_bright pixels of `bright`."""
    v = np.concatenate([np.asarray(values, np.float64), np.full(n_bright, bright)])
    return np.repeat(v[None, :, None], 3, axis=2).astype(np.float32)


def test_an_image_that_fits_keeps_its_exposure():
    assert auto_exposure(image_of(np.linspace(0, 1, 1000), 0, 0)) == 0.0
    assert auto_exposure(np.zeros((4, 4, 3), np.float32)) == 0.0
    # light sources brighter than white on under 3% of the pixels: they clip, the rest stays as rendered
    assert auto_exposure(image_of(np.full(980, 0.5), 40.0, 20)) == 0.0


def test_an_image_brighter_than_white_is_darkened_to_put_the_percentile_at_1():
    """Luminance 4 on every pixel: -2 stops, exactly; a grey pixel's luminance is its value (weights sum to 1)."""
    assert auto_exposure(np.full((8, 8, 3), 4.0, np.float32)) == pytest.approx(-2.0, abs=1e-6)
    values = np.linspace(0.0, 8.0, 10001)  # numpy's linear percentile of an arithmetic sequence: exact
    expected = -np.log2(np.percentile(values, AUTO_PERCENTILE))
    assert auto_exposure(image_of(values, 0, 0)) == pytest.approx(expected, rel=1e-6)
    assert expected == pytest.approx(-np.log2(8.0 * 0.97), rel=1e-9)


def test_luminance_weights_the_channels_by_rec_709():
    red = np.zeros((4, 4, 3), np.float32)
    red[..., 0] = 8.0  # luminance 0.2126 * 8 = 1.7008
    assert auto_exposure(red) == pytest.approx(-np.log2(0.2126 * 8.0), rel=1e-6)


def test_nan_and_inf_pixels_are_ignored():
    image = np.full((10, 10, 3), 2.0, np.float32)
    image[0, :5] = np.nan
    image[1, :5] = np.inf
    assert auto_exposure(image) == pytest.approx(-1.0, abs=1e-6)


@pytest.mark.parametrize(
    "argv, auto",
    [
        ([], False),
        (["--integrator", "path"], True),
        (["--integrator", "path", "--exposure", "-1"], False),
        (["--exposure", "auto"], True),
    ],
)
def test_auto_is_the_default_of_path_renders_only(argv, auto):
    args = build_parser().parse_args(["render", "refract1", *argv])
    assert auto_exposure_wanted(args) is auto


def test_a_bad_exposure_is_refused(capsys):
    with pytest.raises(SystemExit) as caught:
        build_parser().parse_args(["render", "refract1", "--exposure", "bright"])
    assert caught.value.code == 2 and "'bright' is not a number of stops; allowed: a number from -64 to 64, or auto" in capsys.readouterr().err
