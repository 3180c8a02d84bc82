"""Float images with NaN, infinite or huge pixels are refused by the splat commands in one line naming the file.

The red team's EXR/HDR/PFM inputs reached `--init gradient`'s sampling probabilities ("Probabilities
contain NaN", an internal error).  Allowed: finite values within ±1e6 (clrender/splat/pixels.py).
"""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.image.files import read_image, write_image
from clrender.splat.fit import FitConfig, Fitter
from clrender.splat.pixels import MAX_PIXEL, check_pixels
from clrender.splat.voronoi import VoronoiSettings, splat

from tests.clitools import run_cli


def float_photo(path, value):
    rng = np.random.default_rng(5)
    pixels = rng.random((24, 32, 3)).astype(np.float32)
    pixels[7, 9, 1] = value
    if path.suffix == ".hdr":  # by hand: RGBE's largest value, 255/256 * 2^127 = 1.7e38 (writers clamp)
        rgbe = np.full((24, 32, 4), [128, 128, 128, 129], np.uint8)
        rgbe[7, 9] = 255
        path.write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 24 +X 32\n" + rgbe.tobytes())
    else:
        write_image(path, pixels)
    stored = read_image(path).pixels
    assert not (np.abs(stored) <= MAX_PIXEL).all()  # the format kept the hostile value (or an inf for it)
    return path


CASES = [(".exr", np.nan), (".exr", np.inf), (".exr", -np.inf), (".exr", 3e38), (".pfm", np.nan), (".pfm", 3e38), (".hdr", 1.7e38)]
COMMANDS = [["splat", "voronoi", "--splats", "8"], ["splat", "gauss", "--epochs", "1", "--splats", "8"]]


@pytest.mark.parametrize("command", COMMANDS, ids=["voronoi", "gauss"])
@pytest.mark.parametrize(("suffix", "value"), CASES)
def test_hostile_float_pixels_are_refused_naming_the_file(tmp_path, capsys, command, suffix, value):
    photo = float_photo(tmp_path / f"in{suffix}", value)
    out = tmp_path / "out.exr"
    code, stdout, err = run_cli(capsys, *command[:2], str(photo), "-o", str(out), *command[2:])
    assert code == 2 and stdout == "" and not out.exists(), err
    assert err.count("\n") == 1 and err.startswith("clrender: ") and str(photo) in err, err
    assert "allowed: finite values from -1e+06 to 1e+06" in err


def test_the_python_api_refuses_them_too(device):
    image = np.full((8, 8, 3), 0.5, np.float32)
    image[2, 3, 0] = np.nan
    with pytest.raises(UsageError, match="the target image holds 1 pixel values"):
        Fitter(device, image, FitConfig(splats=4, epochs=1))
    with pytest.raises(UsageError, match="the image holds 1 pixel values"):
        splat(device, image, VoronoiSettings(n=4))


def test_values_at_the_limit_are_accepted():
    check_pixels(np.float32([[-MAX_PIXEL, MAX_PIXEL, 0.0]]), "x")
    check_pixels(np.full((2, 2), 255, np.uint8), "x")
    with pytest.raises(UsageError, match=r"such as 1000001\)"):
        check_pixels(np.float64([[MAX_PIXEL * (1 + 1e-6)]]), "x")


@pytest.mark.parametrize("command", COMMANDS, ids=["voronoi", "gauss"])
def test_a_folder_of_photos_names_the_bad_one(tmp_path, capsys, command):
    folder = tmp_path / "photos"
    folder.mkdir()
    write_image(folder / "a.png", np.full((16, 16, 3), 0.5, np.float32))
    bad = float_photo(folder / "b.exr", np.inf)
    code, stdout, err = run_cli(capsys, *command[:2], str(folder), "-o", str(tmp_path / "out"), *command[2:])
    assert code == 2 and stdout == "" and err.count("\n") == 1 and str(bad) in err, err
    assert not any((tmp_path / "out").glob("*"))
