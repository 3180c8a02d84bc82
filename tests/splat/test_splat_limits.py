"""Hostile splat parameter files: refused in one line (exit 2) before anything large is allocated.

The red team's file: millions of splats, each covering every tile, made an int32 prefix sum of the
tile counts wrap and the binning kernel write past its buffer (a segfault).  Huge scales make every
splat cover the whole image, and compression keeps such a file a few KB.
"""

import subprocess
import sys

import numpy as np
import pytest

from clrender.layout import SPLAT_BOX_DTYPE
from clrender.splat import gauss
from clrender.splat.gauss import GaussParams, GaussRenderer

from tests.clitools import run_cli


def splat_file(path, n, width, height, *, blend="normalized", **overrides):
    """n identical splats (broadcast, so the compressed file stays small) at the image centre."""
    groups = {
        "xy": np.broadcast_to(np.float32([width / 2, height / 2]), (n, 2)),
        "log_scale": np.broadcast_to(np.float32([10.0, 10.0]), (n, 2)),  # sigma 22026 px: every tile
        "theta": np.zeros(n, np.float32),
        "color": np.broadcast_to(np.float32([0.5, 0.5, 0.5]), (n, 3)),
        "lum": np.ones(n, np.float32),
        "opacity": np.ones(n, np.float32),
    }
    groups.update(overrides)
    np.savez_compressed(path, **groups, width=width, height=height, blend=blend, background=np.zeros(3, np.float32))
    return path


def test_more_tile_pairs_than_the_kernels_can_index_are_refused_in_one_line(tmp_path):
    # 4096^2 pixels are 65536 tiles; 32769 splats covering all of them make 2^31 + 65536 pairs
    params = splat_file(tmp_path / "wide.npz", 32769, 4096, 4096)
    assert params.stat().st_size < 100_000
    out = tmp_path / "out.png"
    # a subprocess: the old code wrapped the count and wrote past a buffer (exit -11)
    run = subprocess.run(
        [sys.executable, "-m", "clrender", "splat", "render", str(params), "-o", str(out)], capture_output=True, text=True, timeout=300
    )
    assert run.returncode == 2, run.stderr
    lines = run.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("clrender: ") and "(tile, splat) pairs" in lines[0], run.stderr
    assert "2147549184" in lines[0]  # the exact count, in 64 bits
    assert not out.exists() and run.stdout == ""


def test_the_pair_bound_is_checked_when_memory_would_allow(device, monkeypatch):
    """The int32 bound itself, apart from the memory estimate (which refuses such counts first on most machines)."""
    monkeypatch.setattr(gauss, "MAX_PAIRS", 1000)
    n, side = 40, 64  # 16 tiles each: 640 pairs fit, 80 splats (1280 pairs) do not
    renderer = GaussRenderer(device, side, side)
    params = GaussParams.load(splat_file_in_memory(n, side))
    assert renderer.forward(params).binning.n_entries == n * 16
    with pytest.raises(gauss.UsageError, match=r"1280 \(tile, splat\) pairs.*at most 1000 pairs"):
        renderer.forward(params.select(np.arange(2 * n) % n))


def splat_file_in_memory(n, side):
    import io

    buffer = io.BytesIO()
    splat_file(buffer, n, side, side)
    buffer.seek(0)
    return buffer


def test_count_pairs_agrees_with_the_binning_kernel(device):
    rng = np.random.default_rng(7)
    n, width, height = 500, 200, 120
    params = GaussParams(
        xy=rng.uniform(-20, [width + 20, height + 20], (n, 2)),
        log_scale=rng.uniform(-1.5, 4.0, (n, 2)),
        theta=rng.uniform(0, np.pi, n),
        color=rng.random((n, 3)),
        lum=np.ones(n),
        opacity=rng.random(n),
        width=width,
        height=height,
    )
    renderer = GaussRenderer(device, width, height)
    frame = renderer.forward(params)
    # the kernels' own count, independent of count_pairs: the per-tile list lengths
    assert frame.binning.n_entries == int(np.diff(frame.binning.tile_start.astype(np.int64)).sum()) > n
    pairs_per_splat = np.bincount(frame.binning.entry_splat, minlength=n)
    boxes = np.zeros(n, SPLAT_BOX_DTYPE)
    import pyopencl as cl

    cl.enqueue_copy(device.queue, boxes, frame.packed.boxes)
    assert renderer.count_pairs(boxes) == pairs_per_splat.sum()


@pytest.mark.parametrize(
    ("name", "value", "allowed"),
    [
        ("opacity", 3e38, "0 to 1"),
        ("opacity", -0.5, "0 to 1"),
        ("log_scale", 50.0, "-10 to 10"),
        ("color", 3e38, "-1e+06 to 1e+06"),
        ("lum", -1.0, "0 to 1e+06"),
    ],
)
def test_values_outside_the_documented_ranges_are_refused(tmp_path, capsys, name, value, allowed):
    n = 3
    base = np.load(splat_file_in_memory(n, 8))
    bad = np.array(base[name], np.float64)
    bad.flat[1] = value
    path = splat_file(tmp_path / "bad.npz", n, 8, 8, blend="sum", **{name: bad})
    out = tmp_path / "out.exr"
    code, stdout, err = run_cli(capsys, "splat", "render", str(path), "-o", str(out))
    assert code == 2 and stdout == "" and not out.exists()
    assert err.count("\n") == 1 and f"{name} holds {value:g}" in err and f"allowed: {allowed}" in err, err


def test_the_range_ends_are_accepted_and_render_finite(tmp_path, capsys):
    n = 4
    path = splat_file(
        tmp_path / "edge.npz",
        n,
        16,
        16,
        blend="sum",
        log_scale=np.full((n, 2), 2.0, np.float32),
        color=np.full((n, 3), 1e6, np.float32),
        lum=np.full(n, 1e6, np.float32),
        opacity=np.float32([0, 1, 1, 1]),
    )
    out = tmp_path / "out.exr"
    code, _, err = run_cli(capsys, "splat", "render", str(path), "-o", str(out))
    assert code == 0, err
    from clrender.image.files import read_image

    pixels = read_image(out).pixels
    assert np.isfinite(pixels).all() and pixels.max() > 1e12
