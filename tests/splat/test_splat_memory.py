"""`splat gauss` and `splat voronoi` estimate their peak memory and refuse beyond --max-memory, before reading pixels.

The red team saw 6.7 GB (gauss) and 8.1 GB (voronoi) peaks under `--max-memory 500M`.
"""

import subprocess
import sys

import numpy as np
import pytest

from clrender import memory
from clrender.errors import UsageError
from clrender.image.files import write_image
from clrender.splat import gauss, voronoi
from clrender.splat.fit import FitConfig, Fitter

from tests.clitools import run_cli


@pytest.fixture(scope="module")
def big_photo(tmp_path_factory):
    """2048^2 pixels: every splat command needs more than 500 MiB for it (a flat grey compresses to a few KB)."""
    path = tmp_path_factory.mktemp("big") / "big.png"
    write_image(path, np.full((2048, 2048, 3), 0.5, np.float32))
    return path


@pytest.mark.parametrize(
    "command",
    [
        ["splat", "gauss", "--epochs", "1", "--splats", "50"],
        ["splat", "gauss", "--epochs", "1", "--splats", "50", "--loss", "l1-ssim"],
        ["splat", "voronoi", "--splats", "50"],
        ["splat", "voronoi", "--splats", "50", "--train", "1"],
    ],
    ids=["gauss", "gauss-ssim", "voronoi", "voronoi-train"],
)
def test_max_memory_is_obeyed(tmp_path, capsys, big_photo, command):
    out = tmp_path / "out.png"
    code, stdout, err = run_cli(capsys, "--max-memory", "500M", *command[:2], str(big_photo), "-o", str(out), *command[2:])
    assert code == 2 and stdout == "" and not out.exists(), err
    assert err.count("\n") == 1 and "2048x2048" in err and "--max-memory is 500 MiB" in err, err


def test_the_estimates_grow_with_the_work():
    fit = [gauss.peak_bytes(2048, 2048, fit_loss=loss) for loss in ("l2", "l1-ssim")]
    assert gauss.peak_bytes(2048, 2048) < fit[0] < fit[1]  # a render holds less than a fit; SSIM holds its maps
    plain = voronoi.peak_bytes(2048, 2048, 3, voronoi.VoronoiSettings(n=100))
    trained = voronoi.peak_bytes(2048, 2048, 3, voronoi.VoronoiSettings(n=100, train=5))
    assert 500 << 20 < plain < trained


def test_the_python_api_refuses_too(device, monkeypatch):
    monkeypatch.setattr(memory, "MAX_MEMORY", 300 << 20)
    image = np.full((1024, 1024, 3), 0.5, np.float32)
    with pytest.raises(UsageError, match=r"1024x1024 splat fit needs about .* --max-memory is 300 MiB"):
        Fitter(device, image, FitConfig(splats=10, epochs=1))
    with pytest.raises(UsageError, match=r"1024x1024 Voronoi splatting of 10 sites needs about .* --max-memory is 300 MiB"):
        voronoi.splat(device, image, voronoi.VoronoiSettings(n=10))


# The peak resident memory of this process's own address space (VmHWM): getrusage's ru_maxrss would
# also count the parent's peak, which Linux carries over the fork and exec (pytest's, over 1 GB late
# in the suite).
PEAK = """
import sys
from clrender.cli import main
code = main(sys.argv[1:])
hwm = next(line for line in open("/proc/self/status") if line.startswith("VmHWM:"))
print(code, int(hwm.split()[1]) * 1024)
"""


@pytest.mark.slow
@pytest.mark.parametrize(
    ("command", "estimate"),
    [
        (["splat", "gauss", "--epochs", "2", "--splats", "2000"], lambda w, h: gauss.peak_bytes(w, h, fit_loss="l2")),
        (
            ["splat", "voronoi", "--splats", "2000", "--train", "2"],
            lambda w, h: voronoi.peak_bytes(w, h, 3, voronoi.VoronoiSettings(n=2000, train=2)),
        ),
    ],
    ids=["gauss", "voronoi-train"],
)
def test_the_estimate_is_above_the_measured_peak(tmp_path, command, estimate):
    side = 1024
    rng = np.random.default_rng(3)
    photo = tmp_path / "photo.png"
    write_image(photo, rng.random((side, side, 3)).astype(np.float32))
    argv = ["-q", *command[:2], str(photo), "-o", str(tmp_path / "out.png"), *command[2:]]
    run = subprocess.run([sys.executable, "-c", PEAK, *argv], capture_output=True, text=True, timeout=300)
    code, peak = map(int, run.stdout.splitlines()[-1].split())
    assert code == 0, run.stderr
    assert peak < estimate(side, side)
