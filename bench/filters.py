"""Convolution filters, OpenCV vs plain numpy: `python -m bench filters [--size N] [--runs K] [--out DIR]`.

Each filter family at sizes 3, 33, 101 on an N x N RGB float32 image
(default 4096): the median of K runs of `clrender.image.filters.apply` (OpenCV)
after one untimed warm-up call,
and the same operation in plain numpy with the same reflect-101 border --
brighten by one multiply, box blur by running sums along rows then columns,
Gaussian by separable shift-and-add (one pass per tap), the 3 x 3 edge
kernels by nine shifted adds.  The largest difference between the two is
reported as a check.  Wider sizes (--wide, default 301 and 1001) are timed
for OpenCV only, to show that time does not grow with the square of the
size: box blurs cost the same at any size, Gaussians grow linearly up to
FFT_FROM_SIZE and are then convolved by FFT.  There are no OpenCL kernels
here, so there is no compile time to report.

Writes DIR/filters.csv, DIR/filters.md, DIR/filters.png (bars, log scale)
and DIR/filters_growth.png (time against size); with --crossover also
DIR/filters_crossover.{csv,md}, the Gaussian timed both ways, which is how
FFT_FROM_SIZE was chosen.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from clrender.image import filters
from clrender.image.plot import bar_chart, line_chart

from .common import write_table


def numpy_pad(img: np.ndarray, r: int, axis: int) -> np.ndarray:
    """numpy's 'reflect' is reflect-101 (the edge pixel is not repeated)."""
    widths = [(0, 0)] * img.ndim
    widths[axis] = (r, r)
    return np.pad(img, widths, mode="reflect")


def numpy_box(img: np.ndarray, k: int) -> np.ndarray:
    """Mean over k x k by running sums (float64), rows then columns: O(1) per pixel."""
    out = img.astype(np.float64)
    r = k // 2
    for axis in (0, 1):
        padded = numpy_pad(out, r, axis)
        csum = np.cumsum(padded, axis=axis)
        csum = np.concatenate([np.zeros_like(np.take(csum, [0], axis=axis)), csum], axis=axis)
        n = out.shape[axis]
        out = (np.take(csum, np.arange(k, k + n), axis=axis) - np.take(csum, np.arange(n), axis=axis)) / k
    return out.astype(np.float32)


def numpy_separable(img: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Rows then columns, one multiply-add of a shifted copy per tap (float32)."""
    out = img
    r = len(weights) // 2
    for axis in (1, 0):
        padded = numpy_pad(out, r, axis)
        n = out.shape[axis]
        acc = np.zeros_like(out)
        for i, w in enumerate(weights.astype(np.float32)):
            acc += w * (padded[:, i : i + n] if axis == 1 else padded[i : i + n])
        out = acc
    return out


def numpy_direct(img: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Direct 2-D convolution: one multiply-add of a shifted copy per kernel entry."""
    r = kernel.shape[0] // 2
    padded = numpy_pad(numpy_pad(img, r, 0), r, 1)
    h, w = img.shape[:2]
    acc = np.zeros_like(img)
    for dy in range(kernel.shape[0]):
        for dx in range(kernel.shape[1]):
            if kernel[dy, dx] != 0:
                acc += np.float32(kernel[dy, dx]) * padded[dy : dy + h, dx : dx + w]
    return acc


def numpy_version(name: str):
    f = filters.parse(name)
    if f.kind == "brighten":
        return lambda img: img * np.float32(f.value)
    if f.kind == "box_blur":
        return lambda img: numpy_box(img, int(f.value))
    if f.kind == "gauss_blur":
        return lambda img: numpy_separable(img, filters.gaussian_weights(int(f.value)))
    return lambda img: numpy_direct(img, f.kernel())


def timed(fn, runs: int, warm_up: bool = False):
    """(median seconds, last result); warm_up: one untimed call first."""
    result = fn() if warm_up else None
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def parse_args(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench filters", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=4096, help="image is SIZE x SIZE x 3 float32")
    ap.add_argument("--runs", type=int, default=3, help="timed OpenCV runs per filter; the median is reported")
    ap.add_argument("--numpy-runs", type=int, default=1, help="timed numpy runs per filter (slow at size 101)")
    ap.add_argument("--sizes", default="3,33,101", help="kernel sizes timed with both implementations")
    ap.add_argument("--wide", default="301,1001", help="wider sizes timed with OpenCV only ('' for none)")
    ap.add_argument(
        "--crossover", default="", metavar="SIZES", help="also time the Gaussian both ways (separable and FFT) at these sizes, e.g. 75,101,151,201"
    )
    ap.add_argument("--quick", action="store_true", help="512 x 512, one run each: a smoke test")
    ap.add_argument("--out", default="bench/out", help="folder for filters.csv/.md/.png")
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.runs, args.numpy_runs = 512, 1, 1
    return args


def main(argv=None):
    args = parse_args(argv)
    sizes = [int(s) for s in args.sizes.split(",") if s]
    wide = [int(s) for s in args.wide.split(",") if s]

    img = np.random.default_rng(0).random((args.size, args.size, 3), dtype=np.float32)
    names = ["brighten_1.5"]
    names += [f"{family}_{k}" for family in ("box_blur", "gauss_blur") for k in sizes + wide]
    names += ["edge_detect_1", "edge_detect_2"]
    print(
        f"{args.size}x{args.size} RGB float32, OpenCV {cv2.__version__} with {cv2.getNumThreads()} threads, "
        f"median of {args.runs} (numpy: {args.numpy_runs})",
        flush=True,
    )
    rows = [time_filter(name, img, sizes, args) for name in names]

    out = Path(args.out)
    crossover = [int(k) for k in args.crossover.split(",") if k]
    if crossover:
        time_crossover(crossover, img, out, args)
    title = f"Filters on {args.size}x{args.size} RGB float32, median of {args.runs} (numpy {args.numpy_runs}), {cv2.getNumThreads()} OpenCV threads"
    print(write_table(out, "filters", rows, title))
    both = [r for r in rows if r["numpy_s"] != ""]
    bar_chart(
        out / "filters.png",
        [r["filter"] for r in both],
        {"OpenCV (clrender.image.filters)": [r["opencv_s"] for r in both], "plain numpy": [r["numpy_s"] for r in both]},
        title=title,
        ylabel="seconds (log scale)",
        log=True,
    )
    grown = sorted({r["size"] for r in rows if r["filter"].startswith(("box", "gauss"))})
    by_size = lambda family: [next((r["opencv_s"] for r in rows if r["filter"] == f"{family}_{k}"), None) for k in grown]
    line_chart(
        out / "filters_growth.png",
        grown,
        {"box_blur": by_size("box_blur"), "gauss_blur": by_size("gauss_blur")},
        title=f"OpenCV time against kernel size, {args.size}x{args.size} RGB",
        xlabel="kernel size K",
        ylabel="seconds",
    )
    print(f"wrote {out / 'filters.csv'}, {out / 'filters.md'}, {out / 'filters.png'}, {out / 'filters_growth.png'}")
    return 0


def time_filter(name: str, img, sizes: list, args) -> dict:
    """One filter's row: clrender's (OpenCV) time, and for the sizes timed both ways numpy's and the largest difference."""
    f = filters.parse(name)
    size = 1 if f.kind == "brighten" else (3 if f.kind == "edge_detect" else int(f.value))
    path = {
        "brighten": "multiply",
        "box_blur": "running sums",
        "edge_detect": "3x3 direct",
        "gauss_blur": "FFT" if size >= filters.FFT_FROM_SIZE else "separable",
    }[f.kind]
    opencv_s, ours = timed(lambda: filters.apply(img, name), args.runs, warm_up=True)
    row = {"filter": name, "size": size, "path": path, "opencv_s": opencv_s, "numpy_s": "", "numpy_over_opencv": "", "max_abs_diff": ""}
    if f.kind in ("brighten", "edge_detect") or size in sizes:
        numpy_s, theirs = timed(lambda: numpy_version(name)(img), args.numpy_runs)
        row.update(numpy_s=numpy_s, numpy_over_opencv=numpy_s / opencv_s, max_abs_diff=float(np.abs(ours - theirs).max()))
        del theirs
    del ours
    print(f"  {name:<16} opencv {opencv_s:8.3f} s   numpy {row['numpy_s'] or float('nan'):8.3f} s", flush=True)
    return row


def time_crossover(crossover: list, img, out: Path, args) -> None:
    """The Gaussian both ways (separable and FFT) at each size of `crossover`: filters_crossover.csv/.md."""
    both_ways = []
    for k in crossover:
        g = filters.gaussian_weights(k).astype(np.float32)
        sep_s, _ = timed(lambda: cv2.sepFilter2D(img, cv2.CV_32F, g, g, borderType=filters.BORDER), args.runs)
        fft_s, _ = timed(lambda: filters.separable_fft(img, g), args.runs)
        both_ways.append({"size": k, "separable_s": sep_s, "fft_s": fft_s, "separable_over_fft": sep_s / fft_s})
        print(f"  gauss {k:<5} separable {sep_s:7.3f} s   FFT {fft_s:7.3f} s", flush=True)
    print(
        write_table(
            out,
            "filters_crossover",
            both_ways,
            f"Gaussian, separable vs FFT, {args.size}x{args.size} RGB, median of {args.runs} (clrender switches at {filters.FFT_FROM_SIZE})",
        )
    )


if __name__ == "__main__":
    sys.exit(main())
