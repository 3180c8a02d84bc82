"""Voronoi splatting: `python -m bench voronoi [--image PATH] [--splats N] [--size S] [--runs K] [--out DIR]`.

Timing: one nearest-site pass (every pixel's nearest site) at SxS with N
sites, for the naive kernel, the grid kernel and, when scipy is importable,
scipy.spatial.cKDTree (build + query, all cores) as an outside reference.
Kernel times are enqueue-to-finish with buffers already on the device,
compile and a warm-up run excluded; "grid end-to-end" adds the host binning,
uploads and the read-back.  Medians of K runs (naive: at most 3).

Quality: PSNR against the image of sampled colours (point sampling), cell-mean
colours, mean colours after Lloyd steps, and after soft-Voronoi training
(the soft image itself and the hard image of the trained sites).

Writes DIR/voronoi.csv/.md, voronoi_quality.csv/.md, voronoi_scaling.csv/.md,
voronoi.png (original and the four reconstructions) and voronoi_times.png.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from clrender.device import get_device
from clrender.splat import voronoi as V
from clrender.splat.losses import psnr
from clrender.splat.voronoi_soft import SoftVoronoi, TrainSettings, train
from clrender.testing import synthetic_photo

from .common import median_seconds, write_table


def kdtree_seconds(sites, w, h, runs):
    """cKDTree build + nearest query for every pixel centre, or None without scipy."""
    try:
        from scipy.spatial import cKDTree
    except ImportError:
        return None, None
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32) + np.float32(0.5)
    pts = np.stack([xs.ravel(), ys.ravel()], axis=1)

    def once():
        return cKDTree(sites).query(pts, k=1, workers=-1)[1]

    return median_seconds(once, runs), once().reshape(h, w)


def timings(dev, sites, w, h, runs):
    rows, index = [], {}
    for method in ("naive", "grid"):
        ns = V.NearestSite(dev, sites, w, h, method)
        ns.enqueue()
        dev.queue.finish()  # warm-up: PoCL finishes compiling here
        k = runs if method == "grid" else min(runs, 3)
        seconds = median_seconds(lambda: (ns.enqueue(), dev.queue.finish()), k)
        index[method] = ns.read()
        rows.append(dict(method=f"{method} kernel", sites=len(sites), pixels=w * h, ms=1e3 * seconds))
    e2e = median_seconds(lambda: V.nearest_site(dev, sites, w, h, "grid"), runs)
    rows.append(dict(method="grid end-to-end", sites=len(sites), pixels=w * h, ms=1e3 * e2e))
    kd, kd_index = kdtree_seconds(sites, w, h, runs)
    if kd is not None:
        rows.append(dict(method="scipy cKDTree (all cores)", sites=len(sites), pixels=w * h, ms=1e3 * kd))
    same = np.array_equal(index["grid"], index["naive"])
    # cKDTree breaks exact ties its own way: count disagreements that are not ties
    kd_diff = None
    if kd_index is not None:
        kd_diff = int((kd_index != index["grid"]).sum())
    return rows, same, kd_diff


def scaling(dev, w, h, runs, counts):
    rows = []
    for n in counts:
        sites = V.init_sites(np.zeros((h, w, 1), np.float32), n, "random", seed=1)
        ns = V.NearestSite(dev, sites, w, h, "grid")
        ns.enqueue()
        dev.queue.finish()
        grid = median_seconds(lambda: (ns.enqueue(), dev.queue.finish()), runs)
        kd, _ = kdtree_seconds(sites, w, h, max(1, runs // 2))
        rows.append(dict(sites=n, grid_ms=1e3 * grid, ckdtree_ms=None if kd is None else 1e3 * kd))
    return rows


def quality(dev, image, n, lloyd_steps, train_steps, seed):
    """PSNR of the reconstructions; random starting sites for the seed-like rows, as the seed."""
    h, w = image.shape[:2]
    rows, pictures = [], {}

    def hard(label, sites, colors_mode="mean", seconds=0.0, show=False):
        index = V.nearest_site(dev, sites, w, h)
        colors = V.sample_colors(image, sites)
        if colors_mode == "mean":
            colors = V.mean_colors(image, index, n, fallback=colors)
        pic = V.render(index, colors)
        rows.append(dict(config=label, psnr_db=psnr(pic, image), seconds=seconds))
        if show:
            pictures[label] = pic

    random_sites = V.init_sites(image, n, "random", seed)
    hard("random sites, sample colours (seed)", random_sites, "sample", show=True)
    hard("random sites, mean colours", random_sites, show=True)
    start = time.perf_counter()
    sites_l, _, energies = V.lloyd(dev, random_sites, w, h, lloyd_steps)
    hard(f"random + Lloyd x{lloyd_steps}, mean colours", sites_l, seconds=time.perf_counter() - start, show=True)
    uniform = V.init_sites(image, n, "uniform", seed)
    hard("uniform sites, mean colours", uniform)
    hard("gradient sites, mean colours", V.init_sites(image, n, "gradient", seed))
    st = TrainSettings(steps=train_steps)
    start = time.perf_counter()
    result = train(dev, image, uniform, settings=st)
    seconds = time.perf_counter() - start
    _, _, _, soft = SoftVoronoi(dev, w, h, st.k).loss_and_grads(result.sites, result.colors, image, w * h / n * st.t_end)
    rows.append(dict(config=f"soft Voronoi x{train_steps} from uniform (soft image)", psnr_db=psnr(soft, image), seconds=seconds))
    hard("soft-trained sites, hard, mean colours", result.sites, seconds=seconds, show=True)
    return rows, pictures, energies, result.losses


def montage(path, image, pictures):
    """Original and reconstructions side by side, labelled, as one PNG (stored values, no transform)."""
    import cv2

    from clrender.image.files import write_image

    tiles = [("original", image)] + list(pictures.items())
    out = []
    for label, pic in tiles:
        tile = np.ascontiguousarray(np.clip(pic[..., :3], 0, 1) * 255).astype(np.uint8)
        bar = np.full((28, tile.shape[1], 3), 255, np.uint8)
        cv2.putText(bar, label, (6, 19), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
        out.append(np.concatenate([bar, tile], axis=0))
        out.append(np.full((tile.shape[0] + 28, 6, 3), 255, np.uint8))
    write_image(path, np.concatenate(out[:-1], axis=1).astype(np.float32) / 255.0)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench voronoi", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--image", help="image to splat (default: a generated photo-like image)")
    ap.add_argument("--size", type=int, default=512, help="side of the generated image")
    ap.add_argument("--splats", type=int, default=5000, help="number of sites")
    ap.add_argument("--runs", type=int, default=20, help="timed runs; the median is reported")
    ap.add_argument("--lloyd", type=int, default=10, help="Lloyd steps for the quality table")
    ap.add_argument("--train", type=int, default=100, help="soft-Voronoi training steps for the quality table")
    ap.add_argument("--seed", type=int, default=0, help="seed of the generated image and of the sites")
    ap.add_argument("--out", default="bench/out", help="output folder")
    args = ap.parse_args(argv)
    if args.image:
        from clrender.image.files import read_image

        image = read_image(args.image).pixels
        label = args.image
    else:
        image = synthetic_photo(args.size, args.size, args.seed)
        label = f"synthetic {args.size}x{args.size}"
    h, w = image.shape[:2]
    dev = get_device()
    out = Path(args.out)

    sites = V.init_sites(image, args.splats, "random", args.seed)
    rows, same, kd_diff = timings(dev, sites, w, h, args.runs)
    for r in rows:
        r["image"] = label
    print(write_table(out, "voronoi", rows, f"One nearest-site pass, {args.splats} sites at {w}x{h} (median of {args.runs}; {dev.name})"))
    print(f"grid == naive exactly: {same}; pixels where cKDTree differs: {kd_diff}; compile {dev.compile_seconds:.2f}s (excluded)")
    by = {r["method"]: r["ms"] for r in rows}
    if "scipy cKDTree (all cores)" in by:
        print(
            f"grid kernel is {by['scipy cKDTree (all cores)'] / by['grid kernel']:.1f}x faster than cKDTree, "
            f"{by['naive kernel'] / by['grid kernel']:.0f}x faster than naive"
        )

    scale = scaling(dev, w, h, max(3, args.runs // 2), [1000, 5000, 20000, 100000])
    print()
    print(write_table(out, "voronoi_scaling", scale, f"Grid kernel vs cKDTree by site count at {w}x{h}"))

    q, pictures, energies, losses = quality(dev, image, args.splats, args.lloyd, args.train, args.seed)
    print()
    print(write_table(out, "voronoi_quality", q, f"PSNR with {args.splats} sites, {label}"))
    print(f"Lloyd energy per step: {', '.join(f'{e:.4g}' for e in energies)}")
    montage(out / "voronoi.png", image, pictures)
    try:
        from clrender.image.plot import bar_chart, line_chart

        bar_chart(
            out / "voronoi_times.png",
            [r["method"] for r in rows],
            {"ms": [r["ms"] for r in rows]},
            title=f"Nearest-site pass, {args.splats} sites, {w}x{h}",
            ylabel="ms (log)",
            log=True,
        )
        line_chart(
            out / "voronoi_training.png", list(range(len(losses))), {"MSE": losses}, title="Soft-Voronoi training", xlabel="step", ylabel="MSE"
        )
    except ImportError:  # pragma: no cover - plot.py lands separately
        pass
    print(f"wrote {out}/voronoi.csv/.md, voronoi_quality.*, voronoi_scaling.*, voronoi.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
