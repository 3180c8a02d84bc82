"""bench/quality.py, equal-time quality against Mitsuba 3: its error arithmetic against float64 numpy, its spp
calibration, its reference cache, and a tiny run of the whole harness (Mitsuba's side skipped where it cannot run)."""

import csv
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bench.quality import cached_parts, digest, errors, spp_for_budget

ROOT = Path(__file__).resolve().parents[2]


def numpy_errors(image, parts):
    """The errors bench/quality.py reports, written out in float64 from their definitions."""
    image, parts = np.asarray(image, np.float64), np.asarray(parts, np.float64)
    reference = parts.sum(axis=0) / len(parts)
    mse = np.sum((image - reference) ** 2) / image.size
    s2 = np.sum((parts - reference) ** 2, axis=0) / (len(parts) - 1)  # each pixel's sample variance over the parts
    return np.sqrt(mse), np.sqrt(mse) / reference.mean(), np.sqrt(max(mse - s2.mean() / len(parts), 0.0))


def test_errors_are_the_float64_rmse_and_take_the_references_own_noise_out():
    """A known image under Gaussian noise: rmse, rel_rmse and rmse_own equal the float64 formulas (to 1e-12), and
    rmse_own estimates the image's own noise, sigma = 0.1, where rmse also holds the reference's (8 parts of sigma 0.2:
    the reference's sigma is 0.2 / sqrt(8) = 0.0707, so rmse ~ sqrt(0.01 + 0.005) = 0.122).  With 64 x 64 x 3 = 12,288
    values, the estimate of a variance has a relative standard error of about sqrt(2 / 12288) ~ 1.3% (more with the
    parts' own noise: about 2.5%), so 8% is over three standard errors."""
    rng = np.random.default_rng(1)
    truth = rng.uniform(0.2, 1.0, (64, 64, 3))
    parts = truth + rng.normal(0, 0.2, (8, 64, 64, 3))
    image = (truth + rng.normal(0, 0.1, truth.shape)).astype(np.float32)
    got = errors(image, parts.astype(np.float32))
    want = numpy_errors(image, parts.astype(np.float32))
    assert [got["rmse"], got["rel_rmse"], got["rmse_own"]] == pytest.approx(list(want), rel=1e-12)
    assert got["rmse"] == pytest.approx(np.sqrt(0.1**2 + 0.2**2 / 8), rel=0.08)
    assert got["rmse_own"] == pytest.approx(0.1, rel=0.08)
    # an image no noisier than its reference: nothing left once the reference's noise is out (not a negative root)
    assert errors(parts[0], parts[1:])["rmse_own"] >= 0.0


def test_spp_for_budget_solves_the_line_through_two_timed_renders():
    """Renders of 0.05 s fixed cost + 1 ms per spp: 950 spp fill 1 s; a pair that does not rise (timer noise)
    falls back to the line through the origin and the last point."""
    line = lambda spp: 0.05 + 0.001 * spp  # noqa: E731
    assert spp_for_budget(1.0, [(64, line(64)), (128, line(128))]) == 950
    assert spp_for_budget(1.0, [(16, 0.3), (64, line(64)), (256, line(256))]) == 950  # the last two points
    assert spp_for_budget(1.0, [(64, 0.2), (128, 0.1)]) == 1280
    assert spp_for_budget(0.01, [(64, 0.5), (128, 1.0)]) == 1  # never less than one


def test_reference_cache_renders_once_per_key_and_digests_file_contents(tmp_path):
    """cached_parts renders P parts at seeds 10000.. once; the same key reads them back, a new key renders again.
    digest counts a `file` entry's bytes, not its path."""
    calls = []

    def render(spp, seed):
        calls.append((spp, seed))
        return np.full((2, 3, 3), seed + spp / 100, np.float32)

    first, hit = cached_parts(tmp_path, "scene_r", "a" * 64, render, 3, 16)
    assert not hit and calls == [(16, 10_000), (16, 10_001), (16, 10_002)]
    again, hit = cached_parts(tmp_path, "scene_r", "a" * 64, render, 3, 16)
    assert hit and len(calls) == 3 and np.array_equal(first, again)
    cached_parts(tmp_path, "scene_r", "b" * 64, render, 3, 16)
    assert len(calls) == 6
    a, b = tmp_path / "a.png", tmp_path / "b.png"
    a.write_bytes(b"same")
    b.write_bytes(b"same")
    assert digest({"file": str(a)}) == digest({"file": str(b)})
    b.write_bytes(b"other")
    assert digest({"file": str(a)}) != digest({"file": str(b)})
    assert digest({"x": np.zeros(3, np.float32)}) != digest({"x": np.zeros(3, np.float64)})
    # an EXR counts by its pixels: OpenImageIO writes a time stamp into the header
    import OpenImageIO as oiio

    def exr(path, stamp, value):
        spec = oiio.ImageSpec(4, 2, 3, "float")
        spec.attribute("DateTime", stamp)
        out = oiio.ImageOutput.create(str(path))
        out.open(str(path), spec)
        out.write_image(np.full((2, 4, 3), value, np.float32))
        out.close()
        return str(path)

    one, two = exr(tmp_path / "1.exr", "2026:01:01 00:00:00", 2.0), exr(tmp_path / "2.exr", "2026:01:01 00:00:01", 2.0)
    other = exr(tmp_path / "3.exr", "2026:01:01 00:00:00", 3.0)
    assert Path(one).read_bytes() != Path(two).read_bytes()
    assert digest({"file": one}) == digest({"file": two}) != digest({"file": other})


def test_quality_harness_tiny_run_reports_the_rmse_of_the_images_it_saved(tmp_path):
    """`bench quality` at 16 x 16, 0.02 s (one pass of 16 paths for clrender), 64 spp references in 2 parts (about 2 s
    with the kernels in PoCL's or Intel's binary cache; references no less converged than the images, so rmse_own is
    not 0): each row's rmse, rel_rmse, rmse_own and own_at_budget are the float64 formulas over the image it saved
    and the reference it cached; the ratio column is the ratio of the rows.  Mitsuba's side is measured where llvm_ad_rgb runs, else said and
    skipped.  (The cache's reuse: test_reference_cache_renders_once_per_key_and_digests_file_contents.)"""
    from tests.reference.mitsuba_scenes import unavailable

    have_mitsuba = unavailable("llvm_ad_rgb") is None
    cache, out = tmp_path / "cache", tmp_path / "out"
    args = ["--peer", "mitsuba", "--size", "16", "--budget", "0.02", "--ref-spp", "64", "--ref-parts", "2", "--runs", "1"]
    args += ["--scenes", "cornell_box", "--out", str(out), "--cache", str(cache)]
    proc = subprocess.run([sys.executable, "-m", "bench", "quality", *args], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.count("reference rendered in") == 1 + have_mitsuba
    rows = list(csv.DictReader(open(out / "quality.csv")))
    assert [r["renderer"] for r in rows] == ["clrender", "mitsuba llvm_ad_rgb"][: 1 + have_mitsuba]
    if not have_mitsuba:
        assert "not measured" in proc.stdout
    for row in rows:
        image = np.load(out / f"quality_cornell_box_{row['renderer'].split()[0]}.npy")
        (npz,) = cache.glob(f"cornell_box_{row['renderer'].split()[0]}_16x16_64spp_d8_*.npz")
        rmse, rel, own = numpy_errors(image, np.load(npz)["parts"])
        assert float(row["rmse"]) == pytest.approx(rmse, rel=1e-3)  # the table's 4 significant digits
        assert float(row["rel_rmse"]) == pytest.approx(rel, rel=1e-3)
        assert float(row["rmse_own"]) == pytest.approx(own, rel=1e-3, abs=1e-9)
        assert float(row["own_at_budget"]) == pytest.approx(own * np.sqrt(float(row["seconds"]) / 0.02), rel=1e-3, abs=1e-9)
        assert int(float(row["spp"])) >= 1 and float(row["seconds"]) > 0
    if have_mitsuba:
        ours, theirs = rows
        assert float(ours["rmse_ratio"]) == pytest.approx(float(ours["rmse"]) / float(theirs["rmse"]), rel=2e-3)
        assert "block z-test over 2 + 2 parts" in proc.stdout
