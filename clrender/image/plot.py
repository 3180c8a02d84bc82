"""Charts for benchmarks and fits, drawn by matplotlib into PNG files.

    bar_chart(path, labels, {"numpy": [...], "OpenCV": [...]}, title=..., ylabel=..., log=False)
    line_chart(path, x, {"loss": [...]}, title=..., xlabel=..., ylabel=..., log=False)
    training_curve(path, steps, loss, psnr, title=...)

Figures are built with matplotlib's object API (a Figure on the Agg canvas), never pyplot, so
nothing here changes a notebook's backend or its current figure.  Values that are None or not
finite are left out (a missing bar, a gap in a line).  Each `*_figure` function returns the
Figure (to show in a notebook or restyle); the functions without it also write the PNG,
atomically through image.files.write_image, creating the parent folder.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

# Okabe-Ito: distinct for the colour-blind, in the order series take them
PALETTE = ["#0072B2", "#E69F00", "#009E73", "#CC79A7", "#56B4E9", "#D55E00", "#F0E442", "#000000"]
SIZE = (9.6, 5.6)  # inches at DPI: 960 x 560 pixels
DPI = 100


def bar_chart(path, labels, series: dict, title: str = "", ylabel: str = "", *, log: bool = False) -> Path:
    """Grouped bars: one group per label, one bar per series in each group."""
    return save(path, bar_figure(labels, series, title, ylabel, log=log))


def line_chart(path, x, series: dict, title: str = "", xlabel: str = "", ylabel: str = "", *, log: bool = False) -> Path:
    """Lines of y against shared x values, one per series."""
    return save(path, line_figure(x, series, title, xlabel, ylabel, log=log))


def training_curve(path, steps, loss, psnr, title: str = "") -> Path:
    """Loss (log scale) above PSNR (dB) against step: two panels, so neither line hides the other
    (for the L2 loss PSNR is exactly -10 log10(loss), and on one axis the lines coincide)."""
    return save(path, training_figure(steps, loss, psnr, title))


def bar_figure(labels, series: dict, title: str = "", ylabel: str = "", *, log: bool = False) -> Figure:
    labels = [str(s) for s in labels]
    series = _check_series(series, len(labels), "labels")
    fig, ax = _figure(title)
    width = 0.8 / len(series)
    x = np.arange(len(labels))
    for s, (name, values) in enumerate(series.items()):
        ax.bar(x - 0.4 + (s + 0.5) * width, values, width * 0.95, label=name, color=PALETTE[s % len(PALETTE)])
    ax.set_xticks(x, labels)
    ax.set_ylabel(ylabel)
    if log:
        ax.set_yscale("log")
    ax.grid(axis="y", color="#dddddd")
    ax.set_axisbelow(True)
    _legend(ax, series)
    return fig


def line_figure(x, series: dict, title: str = "", xlabel: str = "", ylabel: str = "", *, log: bool = False) -> Figure:
    x = np.array([float(v) for v in x])
    series = _check_series(series, len(x), "x")
    if not len(x) or not np.isfinite(x).all():
        raise ValueError("line_chart needs finite x values")
    fig, ax = _figure(title)
    for s, (name, values) in enumerate(series.items()):
        ax.plot(x, values, label=name, color=PALETTE[s % len(PALETTE)], linewidth=2)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if log:
        ax.set_yscale("log")
    ax.grid(color="#dddddd")
    _legend(ax, series)
    return fig


def training_figure(steps, loss, psnr, title: str = "") -> Figure:
    steps = np.array([float(v) for v in steps])
    curves = _check_series({"loss": loss, "PSNR (dB)": psnr}, len(steps), "steps")
    fig = Figure(figsize=SIZE, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.plot(steps, curves["loss"], color=PALETTE[0], linewidth=2)
    top.set_yscale("log")
    top.set_ylabel("loss")
    bottom.plot(steps, curves["PSNR (dB)"], color=PALETTE[1], linewidth=2)
    bottom.set_ylabel("PSNR (dB)")
    bottom.set_xlabel("step")
    for ax in (top, bottom):
        ax.grid(color="#dddddd")
    if title:
        fig.suptitle(title)
    return fig


def figure_pixels(fig: Figure) -> np.ndarray:
    """The figure rendered as (H, W, 3) uint8 RGB."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def save(path, fig: Figure) -> Path:
    """Write the figure as an 8-bit PNG (atomically, through write_image); returns the path."""
    from .files import write_image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    pixels = figure_pixels(fig).astype(np.float32) / 255.0
    return write_image(path, pixels, format="uint8")


def _figure(title: str):
    fig = Figure(figsize=SIZE, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    if title:
        ax.set_title(title)
    return fig, ax


def _legend(ax, series: dict) -> None:
    if len(series) > 1 or any(series):
        ax.legend(frameon=False)


def _check_series(series: dict, n: int, what: str) -> dict:
    """Series as float arrays of length n, None and non-finite values as NaN (left out when drawn)."""
    if not series:
        raise ValueError("a chart needs at least one series")
    out = {}
    for name, values in series.items():
        values = list(values)
        if len(values) != n:
            raise ValueError(f"series {name!r} has {len(values)} values for {n} {what}")
        out[str(name)] = np.array([float(v) if v is not None and math.isfinite(float(v)) else np.nan for v in values])
    return out
