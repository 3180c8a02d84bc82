"""Gaussian splat fitting: `python -m bench splat [--image PATH] [--quick] [--runs K] [--out DIR]`.

Measures, for 5,000 splats on a 512x512 image (the original report: one forward pass in
0.05 s), the median (and minimum) wall time of one forward pass and of one
forward + backward + optimiser step, and the CPU time per call of all our
threads (kernel compile excluded and reported apart), and the PSNR reached after 30 s and 120 s of fitting (5 s and 15 s
with --quick), for both blend modes.  Writes DIR/splat.csv, DIR/splat.md,
DIR/splat.png (PSNR against time) and the fitted images.

Without --image it fits `test_image()`: a deterministic 512x512 landscape
made of smooth gradients, soft-edged shapes and band-limited noise texture
(none of our dependencies ships a photograph).
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import cv2
import numpy as np

from clrender.device import get_device
from clrender.image.files import read_image, write_image
from clrender.splat.fit import FitConfig, Fitter, as_rgb, initial_params
from clrender.splat.gauss import GaussRenderer
from clrender.splat.losses import loss_and_grad
from clrender.splat.optim import Optimizer

from .common import write_table


def band_noise(rng, shape, sigma):
    """White noise low-passed by a Gaussian of `sigma` pixels, scaled to unit std."""
    n = cv2.GaussianBlur(rng.normal(size=shape).astype(np.float32), (0, 0), sigma)
    return n / (n.std() + 1e-12)


def test_image(size: int = 512, seed: int = 0) -> np.ndarray:
    """A deterministic natural-looking RGB image in [0, 1]: sky, sun, hills, a lake, a house, grass texture."""
    rng = np.random.default_rng(seed)
    ys, xs = (np.mgrid[0:size, 0:size] + 0.5) / size
    img = np.zeros((size, size, 3), np.float32)
    # sky: vertical gradient with soft clouds
    sky = np.array([0.35, 0.55, 0.9]) * (1 - ys[..., None]) + np.array([0.85, 0.8, 0.75]) * ys[..., None]
    clouds = np.clip(band_noise(rng, (size, size), size / 24) * 0.5 + 0.1, 0, 1)[..., None]
    img[:] = sky * (1 - 0.6 * clouds) + 0.6 * clouds
    # sun: a soft disc
    r = np.hypot(xs - 0.75, ys - 0.2)
    img += (np.clip((0.07 - r) / 0.01, 0, 1) * 0.8 + np.exp(-((r / 0.12) ** 2)) * 0.25)[..., None] * [1.0, 0.9, 0.6]
    # two hill ranges with wiggly ridges, shaded by height and textured
    for level, amp, col, sig in ((0.45, 0.08, (0.3, 0.4, 0.35), 30), (0.6, 0.06, (0.25, 0.5, 0.2), 20)):
        ridge = level + amp * np.sin(xs * (7 + 5 * level) + level * 10) + 0.02 * band_noise(rng, (size, size), sig)
        inside = np.clip((ys - ridge) * size / 1.5, 0, 1)[..., None]
        tex = band_noise(rng, (size, size), 2.0)[..., None] * 0.04
        shade = np.array(col) * (0.8 + 0.6 * (ys[..., None] - level)) + tex
        img = img * (1 - inside) + shade * inside
    # a lake reflecting the sky, with ripples
    lake = np.clip((0.09 - np.hypot((xs - 0.3) / 2.2, ys - 0.82)) * size / 2, 0, 1)[..., None]
    ripples = 0.05 * np.sin(ys * 160 + band_noise(rng, (size, size), 6) * 0.8)[..., None]
    img = img * (1 - lake) + (np.array([0.3, 0.45, 0.7]) + ripples) * lake
    # a house: wall, roof, window (edges blurred like a camera's)
    house = np.zeros((size, size, 4), np.float32)
    wall = (np.abs(xs - 0.62) < 0.07) & (np.abs(ys - 0.66) < 0.05)
    roof = (ys < 0.61) & (ys > 0.61 - 0.07 * (1 - np.abs(xs - 0.62) / 0.09))
    window = (np.abs(xs - 0.6) < 0.015) & (np.abs(ys - 0.66) < 0.02)
    for mask, col in ((wall, (0.8, 0.7, 0.55)), (roof, (0.55, 0.15, 0.1)), (window, (0.15, 0.2, 0.3))):
        house[mask] = [*col, 1.0]
    house = cv2.GaussianBlur(house, (0, 0), 0.8)
    img = img * (1 - house[..., 3:]) + house[..., :3]
    # fine grass texture at the bottom, and a little sensor noise everywhere
    grass = np.clip((ys - 0.9) * 20, 0, 1)[..., None] * band_noise(rng, (size, size), 1.2)[..., None] * 0.06
    img += grass * [0.5, 1.0, 0.3] + rng.normal(0, 0.005, img.shape)
    return np.clip(img, 0, 1).astype(np.float32)


def time_steps(device, target, blend, splats, runs):
    """Median forward and forward+backward+step times (after one warm-up call that compiles)."""
    cfg = FitConfig(splats=splats, blend=blend, init="gradient")
    compile_before = device.compile_seconds
    fitter = Fitter(device, target, cfg)
    renderer: GaussRenderer = fitter.renderer
    params = initial_params(target, splats, cfg.init, blend, np.random.default_rng(0), renderer)
    opt = Optimizer("adam", fitter.base_lr)

    def forward():
        renderer.forward(params)

    def step():
        frame = renderer.forward(params)
        _, d_image = loss_and_grad("l2", frame.image, target)
        grads = renderer.backward(frame, d_image)
        opt.step(params.groups(), grads)
        fitter._project(params)

    forward(), step()  # warm-up: builds the kernels
    compile_s = device.compile_seconds - compile_before
    times = {}
    for name, fn in (("forward", forward), ("step", step)):
        samples = []
        cpu = time.process_time()
        for _ in range(runs):
            t = time.perf_counter()
            fn()
            samples.append(time.perf_counter() - t)
        # CPU seconds of all our threads per call: less sensitive to other users of the cores
        times[name + "_cpu"] = (time.process_time() - cpu) / runs
        times[name] = statistics.median(samples)
        times[name + "_min"] = min(samples)
    frame = renderer.forward(params)
    times["entries"] = frame.binning.n_entries
    times["compile"] = compile_s
    return times


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench splat", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--image", help="fit this image (its centre square resized to --size x --size) instead of the built-in test image")
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--splats", type=int, default=5000)
    ap.add_argument("--runs", type=int, default=20, help="timed runs; the median is reported")
    ap.add_argument("--budgets", type=float, nargs="*", default=None, help="fitting time budgets in seconds")
    ap.add_argument("--blends", nargs="*", default=["normalized", "sum"])
    ap.add_argument("--quick", action="store_true", help="budgets of 5 s and 15 s, 5 timed runs")
    ap.add_argument("--timing-only", action="store_true", help="no fitting, only the step timings")
    ap.add_argument("--out", type=Path, default=Path("bench/out"))
    args = ap.parse_args(argv)
    budgets = args.budgets or ([5.0, 15.0] if args.quick else [30.0, 120.0])
    if args.timing_only:
        budgets = []
    runs = 5 if args.quick else args.runs
    if args.image:
        target = as_rgb(read_image(args.image).pixels)
        h, w = target.shape[:2]
        side = min(h, w)  # the centre square, resized
        target = target[(h - side) // 2 : (h - side) // 2 + side, (w - side) // 2 : (w - side) // 2 + side]
        target = cv2.resize(target, (args.size, args.size), interpolation=cv2.INTER_AREA if side > args.size else cv2.INTER_CUBIC)
        target = np.clip(target, 0, 1)
        source = args.image
    else:
        target = test_image(args.size)
        source = "test_image()"
    args.out.mkdir(parents=True, exist_ok=True)
    write_image(args.out / "splat_target.png", target)
    device = get_device()
    rows, curves = [], {}
    for blend in args.blends:
        t = time_steps(device, target, blend, args.splats, runs)
        row = {
            "blend": blend,
            "splats": args.splats,
            "size": args.size,
            "tile_entries": t["entries"],
            "forward_ms": t["forward"] * 1e3,
            "forward_min_ms": t["forward_min"] * 1e3,
            "forward_cpu_ms": t["forward_cpu"] * 1e3,
            "step_ms": t["step"] * 1e3,
            "step_min_ms": t["step_min"] * 1e3,
            "step_cpu_ms": t["step_cpu"] * 1e3,
            "compile_s": t["compile"],
        }
        for budget in budgets:
            cfg = FitConfig(splats=args.splats, blend=blend, time_budget=budget, seed=0)
            result = Fitter(device, target, cfg).run(show_progress=False)
            row[f"psnr_{budget:g}s"] = result.psnr
            row[f"steps_{budget:g}s"] = result.steps
            write_image(args.out / f"splat_{blend}_{budget:g}s.png", np.clip(result.image, 0, 1))
            if budget == budgets[-1]:
                curves[blend] = result.log
        rows.append(row)
        print({k: (round(v, 3) if isinstance(v, float) else v) for k, v in row.items()}, flush=True)
    table = write_table(args.out, "splat", rows, f"Gaussian splats, {args.splats} splats, {args.size}x{args.size}, image: {source}")
    print(table)
    if not curves:
        return 0
    try:
        from clrender.image.plot import line_chart
    except ImportError:
        print("clrender.image.plot is not available: no curve picture")
        return 0
    # PSNR against time, each blend resampled on a common time axis
    end = max(budgets)
    t = np.linspace(0, end, 121)
    series = {f"{b} PSNR (dB)": list(np.interp(t, [r["seconds"] for r in log], [r["psnr"] for r in log])) for b, log in curves.items()}
    line_chart(args.out / "splat.png", list(t), series, title=f"PSNR while fitting {args.splats} splats", xlabel="seconds", ylabel="PSNR (dB)")
    return 0
