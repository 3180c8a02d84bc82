"""`clrender convolve`: bit depth, colour space and alpha through files; bad input exits 2 and writes nothing."""

import subprocess
import sys

import numpy as np
import pytest

from clrender.cli import main
from clrender.image import filters
from clrender.image.files import linear_to_srgb, probe_image, read_image, srgb_to_linear, write_image

RGBA = ("R", "G", "B", "A")


def make(path, rng, shape=(24, 31, 3), format="uint8", scale=1.0, names=None):
    pixels = (rng.random(shape) * scale).astype(np.float32)
    write_image(path, pixels, format=format, channel_names=names)
    return read_image(path).pixels  # as stored (quantised)


def convolve(*argv):
    return main(["convolve", *map(str, argv)])


@pytest.mark.parametrize(
    "ext,format",
    [
        (".png", "uint8"),
        (".png", "uint16"),
        (".tif", "uint8"),
        (".tif", "uint16"),
        (".jpg", "uint8"),
        (".exr", "half"),
        (".exr", "float"),
        (".tif", "float"),
        (".hdr", "float"),
    ],
)
def test_identity_filter_keeps_format_and_values(tmp_path, rng, ext, format):
    src, dst = tmp_path / f"in{ext}", tmp_path / f"out{ext}"
    stored = make(src, rng, format=format)
    assert convolve(src, dst, "box_blur_1") == 0
    out = read_image(dst)
    assert out.format == format
    if ext != ".jpg":  # JPEG re-encodes lossily; the rest must come back bit for bit
        # (for integer files: sRGB decode + encode in float32 moves no code)
        assert np.array_equal(out.pixels, stored)


@pytest.mark.parametrize("format,step", [("uint8", 255), ("uint16", 65535)])
def test_integer_files_are_blurred_in_linear_light(tmp_path, rng, format, step):
    src, dst = tmp_path / "in.png", tmp_path / "out.png"
    stored = make(src, rng, format=format)
    assert convolve(src, dst, "gauss_blur_5", "brighten_0.8", "--space", "linear") == 0
    expected = linear_to_srgb(filters.apply(srgb_to_linear(stored), "gauss_blur_5", "brighten_0.8"))
    got = read_image(dst)
    assert got.format == format
    assert np.abs(got.pixels - expected).max() <= 0.5001 / step  # rounding to the nearest code only


def test_default_filters_the_stored_values_as_the_seed(tmp_path, rng, capsys):
    # the seed (and OpenCV, oiiotool, ImageMagick): brighten_1.5 multiplies each stored 8-bit code by 1.5
    src, dst = tmp_path / "in.png", tmp_path / "out.png"
    stored = make(src, rng, scale=0.6)
    assert convolve(src, dst, "brighten_1.5") == 0
    assert np.abs(read_image(dst).pixels - stored * 1.5).max() <= 0.5001 / 255
    out = capsys.readouterr()
    assert out.out == f"{dst}\n"  # stdout: only the written path
    assert "clrender:" not in out.err  # the prefix is for errors only


def test_space_stored_filters_the_stored_values(tmp_path, rng):
    src, dst = tmp_path / "in.tif", tmp_path / "out.tif"
    stored = make(src, rng, format="uint16")
    assert convolve(src, dst, "edge_detect_2", "--space", "stored") == 0
    expected = np.clip(filters.apply(stored, "edge_detect_2"), 0, 1)  # clamped only because the file is integer
    assert np.abs(read_image(dst).pixels - expected).max() <= 0.5001 / 65535


def test_exr_stays_float_unclamped(tmp_path, rng):
    src, dst = tmp_path / "in.exr", tmp_path / "out.exr"
    stored = make(src, rng, format="float", scale=5.0)
    assert convolve(src, dst, "edge_detect_1", "brighten_3") == 0
    out = read_image(dst)
    assert out.format == "float"
    expected = filters.apply(stored, "edge_detect_1", "brighten_3")
    assert expected.min() < 0 and expected.max() > 1  # nothing was clamped
    np.testing.assert_array_equal(out.pixels, expected)


def test_alpha_survives_and_is_copied_by_brighten(tmp_path, rng):
    src, dst = tmp_path / "in.png", tmp_path / "out.png"
    stored = make(src, rng, shape=(20, 18, 4), format="uint16", names=RGBA)
    assert convolve(src, dst, "brighten_1.25") == 0
    out = read_image(dst)
    assert out.format == "uint16" and out.pixels.shape[2] == 4 and out.alpha_channel == 3
    assert np.array_equal(out.pixels[:, :, 3], stored[:, :, 3])


def test_alpha_is_blurred_with_the_colour(tmp_path, rng):
    src, dst = tmp_path / "in.exr", tmp_path / "out.exr"
    stored = make(src, rng, shape=(20, 18, 4), format="float", names=RGBA)
    assert convolve(src, dst, "box_blur_3") == 0
    out = read_image(dst)
    np.testing.assert_allclose(out.pixels, filters.apply(stored, "box_blur_3", alpha_channel=3), atol=1e-6)
    np.testing.assert_allclose(out.pixels[:, :, 3], filters.apply(stored[:, :, 3], "box_blur_3"), atol=1e-6)


def test_alpha_is_dropped_for_jpeg_with_a_note(tmp_path, rng, capsys):
    src, dst = tmp_path / "in.png", tmp_path / "out.jpg"
    make(src, rng, shape=(16, 16, 4), names=RGBA)
    assert convolve(src, dst, "box_blur_3") == 0
    assert probe_image(dst).nchannels == 3
    assert "alpha dropped" in capsys.readouterr().err


def test_float_input_to_png_is_srgb_encoded_16_bit(tmp_path, rng):
    src, dst = tmp_path / "in.exr", tmp_path / "out.png"
    stored = make(src, rng, format="half")
    assert convolve(src, dst, "box_blur_1") == 0
    out = read_image(dst)
    assert out.format == "uint16"
    assert np.abs(out.pixels - linear_to_srgb(stored)).max() <= 0.5001 / 65535


def test_overwrite_allows_output_equal_to_input(tmp_path, rng):
    src = tmp_path / "in.png"
    stored = make(src, rng)
    assert convolve(src, src, "brighten_0", "--overwrite") == 0
    assert read_image(src).pixels.max() == 0 and stored.max() > 0


def test_list_prints_the_names(capsys):
    assert convolve("--list") == 0
    out = capsys.readouterr().out
    assert len(out.splitlines()) == 5 and "edge_detect_2" in out


BAD = [
    (["in.png", "out.png", "box_blur_4"], "box_blur_4"),
    (["in.png", "out.png", "gauss_blur_0"], "gauss_blur_0"),
    (["in.png", "out.png", "brighten_x"], "brighten_x"),
    (["in.png", "out.png", "brighten_nan"], "brighten_nan"),
    (["in.png", "out.png", "brighten_-2"], "brighten_-2"),
    (["in.png", "out.png", "gauss_blur_3", "blur"], "'blur'"),
    (["missing.png", "out.png", "box_blur_3"], "missing.png"),
    (["text.png", "out.png", "box_blur_3"], "text.png"),
    (["in.png", "out.xyz", "box_blur_3"], ".xyz"),
    (["in.png", "out", "box_blur_3"], "no extension"),
    (["in.png", "in.png", "box_blur_3"], "--overwrite"),
    (["in.png", "existing.png", "box_blur_3"], "--overwrite"),
    (["in.png", "nodir/out.png", "box_blur_3"], "nodir"),
    (["in.png", "out.png"], "FILTER"),
    (["in.png"], "FILTER"),
    (["in.png", "out.png", "box_blur_3", "--space", "log"], "log"),
]


@pytest.mark.parametrize("argv,says", BAD, ids=[" ".join(a) for a, _ in BAD])
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, rng, monkeypatch, capsys, argv, says):
    monkeypatch.chdir(tmp_path)
    make(tmp_path / "in.png", rng)
    make(tmp_path / "existing.png", rng)
    (tmp_path / "text.png").write_text("not an image\n")
    before = {p: p.stat().st_mtime_ns for p in tmp_path.iterdir()}
    try:
        code = convolve(*argv)
    except SystemExit as exc:  # argparse's own errors (bad --space choice)
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert err.startswith("clrender: ") and err.count("\n") == 1 and says in err
    assert {p: p.stat().st_mtime_ns for p in tmp_path.iterdir()} == before


def test_console_script_runs_the_seed_example(tmp_path, rng):
    """The seed's Convolve.blur(src, out, "box_blur_33"), as one command line."""
    src, dst = tmp_path / "treebranch_source.jpg", tmp_path / "treebranch_convolution.jpg"
    make(src, rng, shape=(48, 64, 3))
    done = subprocess.run(
        [sys.executable, "-m", "clrender", "convolve", str(src), str(dst), "box_blur_33"], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"{dst}\n"  # the written path, as every command prints it
    assert probe_image(dst).width == 64


def test_image_too_large_for_memory_is_refused_before_reading(tmp_path, rng, monkeypatch, capsys):
    from clrender import memory
    from clrender.commands import convolve as command

    src = tmp_path / "in.png"
    make(src, rng)
    monkeypatch.setattr(memory, "available_bytes", lambda: 1000)
    monkeypatch.setattr(command.image_files, "read_image", lambda path: pytest.fail("read before the memory check"))
    assert convolve(src, tmp_path / "out.png", "box_blur_3") == 2
    err = capsys.readouterr().err
    assert "MiB" in err and "31x24x3" in err
    assert not (tmp_path / "out.png").exists()


# ----------------------------------------------------------------------------- range: NaN, inf, overflow


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_non_finite_pixels_are_refused_naming_the_file(tmp_path, capsys, value):
    pixels = np.full((6, 8, 3), 0.5, np.float32)
    pixels[3, 4, 0] = value
    src = tmp_path / "in.exr"
    write_image(src, pixels)
    out = tmp_path / "out.exr"
    assert convolve(src, out, "gauss_blur_3") == 2 and not out.exists()
    out_text, err = capsys.readouterr()
    assert out_text == "" and err.count("\n") == 1 and str(src) in err and "NaN or infinite" in err, err


@pytest.mark.parametrize(("format", "value", "expected"), [("float", 3e38, float(np.finfo(np.float32).max)), ("half", 65504.0, 65504.0)])
def test_brighten_of_the_largest_values_is_clamped_to_the_output_type(tmp_path, capsys, format, value, expected):
    pixels = np.full((4, 5, 3), 0.25, np.float32)
    pixels[1, 2] = value
    src, out = tmp_path / "in.exr", tmp_path / "out.exr"
    write_image(src, pixels, format=format)
    assert convolve(src, out, "brighten_1.5") == 0, capsys.readouterr().err
    result = read_image(out)
    assert result.format == format
    assert np.isfinite(result.pixels).all()
    assert (result.pixels[1, 2] == np.float32(expected)).all()
    assert (np.delete(result.pixels.reshape(-1, 3), 1 * 5 + 2, axis=0) == 0.375).all()  # the rest: exactly 1.5 times


def test_a_size_of_5000_digits_is_one_line_naming_the_allowed_sizes(tmp_path, capsys, rng):
    src = tmp_path / "in.png"
    make(src, rng)
    out = tmp_path / "out.png"
    assert convolve(src, out, "gauss_blur_" + "1" * 5000) == 2 and not out.exists()
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("clrender: ") and "K odd in 1..10001" in err and len(err) < 600, err


def test_clrender_max_memory_in_the_environment_applies_to_convolve(tmp_path, rng, monkeypatch, capsys):
    src = tmp_path / "in.png"
    make(src, rng, shape=(256, 256, 3))  # 6 working copies of 256x256x3 floats: 4.5 MiB
    monkeypatch.setenv("CLRENDER_MAX_MEMORY", "1M")
    assert convolve(src, tmp_path / "out.png", "box_blur_3") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "256x256x3" in err and "--max-memory is 1 MiB" in err, err
    assert not (tmp_path / "out.png").exists()
