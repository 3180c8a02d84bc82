"""Denoising with Intel Open Image Denoise (clrender/image/denoise.py, `render --denoise`).

A 16-path render denoised must be much closer to a 1024-path render of the same scene (an independent
estimate of the same expectation, other seed) than the noisy render is, keep its mean brightness, and
get the albedo and normal AOVs as OIDN's auxiliary images.  Without pyoidn these are skipped, except
the test that fakes its absence: the install hint, exit 2, nothing written, before any rendering.
"""

import hashlib
import sys

import numpy as np
import pytest

from clrender import Renderer, Scene
from clrender.image import denoise as denoise_module
from clrender.image.files import read_image

from tests.clitools import run_cli
from tests.reference import path_scenes


def oidn_installed() -> bool:
    try:
        import pyoidn  # noqa: F401
    except ImportError:
        return False
    return True


needs_oidn = pytest.mark.skipif(
    not oidn_installed(),
    reason="pyoidn is not installed (pip install 'clrender[denoise]')",
)
SIZE = 64


@pytest.fixture(scope="module")
def cornell():
    """The Cornell box (tests/reference/path_scenes.py) at 64x64: a 16-path render with its AOVs and a
    1024-path reference (seeds 1 and 7: independent samples)."""
    scene = Scene.from_dict(path_scenes.cornell_box(SIZE))
    noisy = Renderer(scene, integrator="path", spp=16, seed=1, aovs=("albedo", "normal")).run()
    reference = Renderer(scene, integrator="path", spp=1024, seed=7).run().image
    return noisy, reference


def displayed(image):
    """What a PNG shows (clamp): the MSE is taken there, where the emitter's radiance 8 does not swamp it."""
    return np.clip(image, 0.0, 1.0)


@needs_oidn
def test_denoised_is_much_closer_to_the_reference_and_keeps_its_brightness(cornell):
    noisy, reference = cornell
    denoised = denoise_module.denoise_result(noisy).image
    assert denoised.shape == noisy.image.shape and denoised.dtype == np.float32

    def mse(image):
        return float(np.mean((displayed(image) - displayed(reference)) ** 2))

    # measured 0.12 (5.6e-4 against 4.7e-3); without the auxiliary images 0.11 but blurred edges
    assert mse(denoised) < 0.3 * mse(noisy.image)
    # the mean radiance (the emitter's pixels included) within 3% of the noisy image's and the reference's
    assert denoised.mean() == pytest.approx(noisy.image.mean(), rel=0.03)
    assert denoised.mean() == pytest.approx(reference.mean(), rel=0.03)
    # OIDN on the CPU: the same bits for the same input, run to run
    assert hashlib.sha256(denoise_module.denoise_result(noisy).image.tobytes()).digest() == hashlib.sha256(denoised.tobytes()).digest()


@needs_oidn
def test_the_albedo_and_normal_aovs_are_passed_to_oidn(monkeypatch):
    import pyoidn

    result = Renderer("refract1", integrator="path", spp=2, width=24, height=16, aovs=("albedo", "normal")).run()
    seen = {}

    def spy(color, albedo=None, normal=None, **options):
        seen.update(color=color, albedo=albedo, normal=normal, **options)
        return np.array(color)

    monkeypatch.setattr(pyoidn, "denoise", spy)
    denoise_module.denoise_result(result)
    assert seen["hdr"] is True and seen["clean_aux"] is True
    for name in ("color", "albedo", "normal"):
        image = seen[name]
        assert image.shape == (16, 24, 3) and image.dtype == np.float32 and image.flags.c_contiguous, name
    assert seen["albedo"].min() >= 0 and seen["albedo"].max() <= 1 and seen["albedo"].max() > 0.1
    assert np.array_equal(seen["albedo"], np.clip(result.aovs["albedo"], 0, 1))
    hit = np.linalg.norm(seen["normal"], axis=-1) > 0
    assert hit.mean() > 0.5  # the floor and the spheres fill most of the view
    length = np.linalg.norm(seen["normal"][hit], axis=-1)  # the mean of a pixel's unit normals: shorter where they spread
    assert (length <= 1 + 1e-4).all() and np.median(length) > 0.999
    with pytest.raises(ValueError, match="albedo"):
        denoise_module.denoise_result(Renderer("refract1", integrator="path", spp=1, width=8, height=8).run())


@needs_oidn
def test_cli_writes_the_denoised_and_the_noisy_image(tmp_path, capsys):
    common = ("render", "refract1", "--integrator", "path", "--spp", "4", "--width", "32", "--height", "24")
    plain, out, noisy = tmp_path / "plain.exr", tmp_path / "out.exr", tmp_path / "noisy.exr"
    assert run_cli(capsys, *common, "-o", str(plain))[0] == 0
    code, stdout, err = run_cli(capsys, *common, "--denoise", "--noisy-out", str(noisy), "-o", str(out))
    assert code == 0, err
    assert stdout.split() == [str(out), str(noisy)] and "denoise" in err
    # the noisy image is the render without --denoise, bit for bit (the extra AOVs change nothing)
    assert np.array_equal(read_image(noisy).pixels, read_image(plain).pixels)
    denoised = read_image(out).pixels
    assert denoised.shape == (24, 32, 3) and read_image(out).channel_names == ("R", "G", "B")  # no AOVs asked for
    assert not np.array_equal(denoised, read_image(plain).pixels)


@pytest.mark.parametrize(
    "options, words",
    [
        (("--denoise",), ("--denoise", "--integrator path")),
        (("--integrator", "path", "--noisy-out", "n.png"), ("--noisy-out", "--denoise")),
        (("--integrator", "path", "--denoise", "--turntable", "2"), ("--denoise", "--turntable")),
    ],
)
def test_denoise_where_it_does_not_apply_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch, options, words):
    monkeypatch.chdir(tmp_path)
    code, stdout, err = run_cli(capsys, "render", "refract1", "--width", "8", "--height", "8", "-o", "o.png", *options)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert all(w in err for w in words), err
    assert list(tmp_path.iterdir()) == []


def test_missing_pyoidn_gives_the_install_hint_before_rendering(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # `import pyoidn` raises ImportError

    def no_render(*args, **kwargs):
        raise AssertionError("rendered although the denoiser is missing")

    monkeypatch.setattr(Scene, "load", no_render)
    out = tmp_path / "o.png"
    noisy = tmp_path / "n.png"
    code, stdout, err = run_cli(capsys, "render", "refract1", "--integrator", "path", "--denoise", "-o", str(out), "--noisy-out", str(noisy))
    assert code == 2 and stdout == ""
    assert err.strip().splitlines() == ["clrender: " + denoise_module.INSTALL_HINT]
    assert "pip install 'clrender[denoise]'" in err
    assert list(tmp_path.iterdir()) == []
