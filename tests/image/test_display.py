"""Images in notebooks: PNG bytes that decode to the expected sRGB codes, `_repr_png_` on results,
clrender.show inline under IPython and as a file without any display; the example script runs."""

import os
import subprocess
import sys
import types
from pathlib import Path

import cv2
import numpy as np
import pytest

import clrender
from clrender.image.display import png_bytes

ROOT = Path(__file__).resolve().parents[2]


def decode(png: bytes) -> np.ndarray:
    """PNG bytes -> uint8 array, RGB order (grey stays 2-D)."""
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    pixels = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    return pixels[..., 2::-1] if pixels.ndim == 3 else pixels


def srgb_codes(linear):
    """The sRGB transfer function (IEC 61966-2-1), written out here as the reference."""
    x = np.clip(np.asarray(linear, np.float64), 0, 1)
    return np.round(255 * np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)).astype(np.uint8)


def test_linear_image_is_srgb_encoded():
    linear = np.random.default_rng(1).random((5, 7, 3)).astype(np.float32)
    got = decode(png_bytes(linear))
    assert got.shape == (5, 7, 3)
    assert np.abs(got.astype(int) - srgb_codes(linear)).max() <= 1


def test_stored_values_and_masks_are_not_encoded():
    stored = np.array([[0.0, 0.5, 1.0, 2.0]], np.float32)  # 2.0 clips
    assert decode(png_bytes(stored, linear=False)).tolist() == [[0, 128, 255, 255]]
    mask = np.array([[True, False], [False, True]])
    assert decode(png_bytes(mask)).tolist() == [[255, 0], [0, 255]]  # a bool mask is never encoded


def test_unshowable_shapes_are_refused():
    with pytest.raises(ValueError, match="cannot show"):
        png_bytes(np.zeros((2, 2, 5)))
    with pytest.raises(ValueError, match="cannot show"):
        png_bytes(np.zeros(4))


def test_render_result_shows_its_image():
    result = clrender.Renderer("refract1", width=12, height=9).run()
    got = decode(result._repr_png_())
    assert got.shape == (9, 12, 3)
    assert np.abs(got.astype(int) - srgb_codes(result.image)).max() <= 1


def test_splat_results_show_their_stored_values():
    from clrender.splat.fit import FitResult
    from clrender.splat.voronoi import VoronoiResult

    image = np.random.default_rng(2).random((4, 6, 3)).astype(np.float32)
    codes = np.round(image * 255).astype(np.uint8)
    fit = FitResult(params=None, image=image, psnr=0.0, steps=0, seconds=0.0)
    cells = VoronoiResult(sites=np.zeros((1, 2), np.float32), colors=np.zeros((1, 3), np.float32), index=np.zeros((4, 6), np.int32), image=image)
    for result in (fit, cells):
        assert np.abs(decode(result._repr_png_()).astype(int) - codes).max() <= 1


def test_show_displays_inline_under_ipython(monkeypatch):
    shown = []
    fake = types.ModuleType("IPython")
    fake.get_ipython = lambda: types.SimpleNamespace(kernel=object())  # a notebook kernel is running
    display = types.ModuleType("IPython.display")
    display.Image = lambda data: ("Image", data)
    display.display = shown.append
    monkeypatch.setitem(sys.modules, "IPython", fake)
    monkeypatch.setitem(sys.modules, "IPython.display", display)
    mask = np.eye(3, dtype=bool)
    result = clrender.show(mask)
    assert result is None, "a cell's last line would show a returned Image a second time"
    assert len(shown) == 1 and shown[0][0] == "Image"
    assert decode(shown[0][1]).tolist() == (np.eye(3) * 255).astype(int).tolist()


def test_show_without_any_display_writes_a_png(monkeypatch, tmp_path):
    import matplotlib

    monkeypatch.setattr(matplotlib, "get_backend", lambda: "agg")
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)
    with pytest.warns(UserWarning, match="no display available") as warned:
        path = clrender.show(np.full((2, 3, 3), 0.5, np.float32))
    assert path.parent == tmp_path and path.suffix == ".png"
    assert f"wrote {path}" in str(warned[0].message)
    assert decode(path.read_bytes()).shape == (2, 3, 3)


@pytest.mark.slow
def test_example_script_renders_and_compares_the_aa_modes(tmp_path):
    out = tmp_path / "aa.png"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "aa_modes.py"), "40", str(out)],
        capture_output=True,
        text=True,
        timeout=600,
        env=dict(os.environ, MPLBACKEND="agg"),
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip().splitlines()[-1] == str(out)
    assert "% of the pixels resampled" in proc.stdout
    assert "Traceback" not in proc.stderr and "Warning" not in proc.stderr
    picture = decode(out.read_bytes())
    assert picture.shape[0] > 400 and picture.shape[1] > 800  # the 2 x 4 panel figure
