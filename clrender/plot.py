"""Small charts for benchmarks, drawn with OpenCV into a PNG (no matplotlib).

    bar_chart(path, labels, {"numpy": [...], "OpenCV": [...]}, title=..., ylabel=...)
    line_chart(path, x, {"loss": [...]}, title=..., xlabel=..., ylabel=...)

Both draw grouped series in a fixed palette with a legend, "nice" axis ticks
and an optional log scale (`log=True`, for timings that span decades).
Values that are None or not finite are left out (a missing bar, a gap in a
line).  The file is written atomically; the chart's parent folder is created.
"""
from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np

# BGR colours, chosen to stay distinct for the colour-blind (Okabe-Ito).
PALETTE = [
    (178, 114, 0),  # blue
    (0, 159, 230),  # orange
    (115, 158, 0),  # bluish green
    (167, 121, 204),  # reddish purple
    (233, 180, 86),  # sky blue
    (0, 94, 213),  # vermillion
    (66, 228, 240),  # yellow
    (0, 0, 0),  # black
]
WIDTH, HEIGHT = 960, 560
MARGIN = dict(left=90, right=30, top=60, bottom=90)
FONT = cv2.FONT_HERSHEY_SIMPLEX
INK = (40, 40, 40)
GRID = (225, 225, 225)


def bar_chart(path, labels, series: dict, title: str = "", ylabel: str = "", *, log: bool = False) -> Path:
    """Grouped bars: one group per label, one bar per series in each group."""
    labels = [str(s) for s in labels]
    series = _check_series(series, len(labels), "labels")
    canvas, plot = _canvas(title)
    values = [v for vals in series.values() for v in vals if v is not None]
    lo, hi = _range(values + ([] if log else [0.0]), log)
    to_y = _axis_y(canvas, plot, lo, hi, log, ylabel)
    x0, y0, x1, y1 = plot
    group = (x1 - x0) / max(len(labels), 1)
    bar = group * 0.8 / max(len(series), 1)
    base = to_y(lo if log else max(lo, 0.0))
    for g, label in enumerate(labels):
        left = x0 + g * group + group * 0.1
        for s, vals in enumerate(series.values()):
            v = vals[g]
            if v is None:
                continue
            bx = int(round(left + s * bar))
            cv2.rectangle(canvas, (bx, int(round(to_y(v)))), (int(round(left + (s + 1) * bar)) - 2, int(round(base))),
                          PALETTE[s % len(PALETTE)], thickness=-1)
        _text(canvas, label, (x0 + g * group + group / 2, y1 + 22), scale=0.45, centre=True, max_width=group * 0.9)
    _legend(canvas, plot, list(series))
    return _save(path, canvas)


def line_chart(path, x, series: dict, title: str = "", xlabel: str = "", ylabel: str = "", *,
               log: bool = False) -> Path:
    """Lines of y against shared x values, one per series."""
    x = [float(v) for v in x]
    series = _check_series(series, len(x), "x")
    if not x or not all(math.isfinite(v) for v in x):
        raise ValueError("line_chart needs finite x values")
    canvas, plot = _canvas(title)
    x0, y0, x1, y1 = plot
    values = [v for vals in series.values() for v in vals if v is not None]
    lo, hi = _range(values, log)
    to_y = _axis_y(canvas, plot, lo, hi, log, ylabel)
    xlo, xhi = min(x), max(x)
    if xhi == xlo:
        xlo, xhi = xlo - 0.5, xhi + 0.5
    to_x = lambda v: x0 + (v - xlo) / (xhi - xlo) * (x1 - x0)  # noqa: E731
    for t in _ticks(xlo, xhi):
        px = to_x(t)
        cv2.line(canvas, (int(px), y1), (int(px), y1 + 5), INK, 1)
        _text(canvas, _fmt(t), (px, y1 + 22), scale=0.45, centre=True)
    _text(canvas, xlabel, ((x0 + x1) / 2, y1 + 47), scale=0.55, centre=True)
    for s, vals in enumerate(series.values()):
        colour = PALETTE[s % len(PALETTE)]
        run = []  # the current stretch of points without a gap
        for xv, v in list(zip(x, vals)) + [(None, None)]:
            if v is None:
                if len(run) == 1:
                    cv2.circle(canvas, run[0], 3, colour, -1, cv2.LINE_AA)
                elif run:
                    cv2.polylines(canvas, [np.array(run, np.int32)], False, colour, 2, cv2.LINE_AA)
                run = []
            else:
                run.append((int(round(to_x(xv))), int(round(to_y(v)))))
    _legend(canvas, plot, list(series))
    return _save(path, canvas)


def _check_series(series: dict, n: int, what: str) -> dict:
    """Series as lists of float-or-None; ValueError on a length mismatch."""
    if not series:
        raise ValueError("a chart needs at least one series")
    out = {}
    for name, vals in series.items():
        vals = list(vals)
        if len(vals) != n:
            raise ValueError(f"series {name!r} has {len(vals)} values but there are {n} {what}")
        out[str(name)] = [float(v) if v is not None and math.isfinite(float(v)) else None for v in vals]
    return out


def _canvas(title: str):
    canvas = np.full((HEIGHT, WIDTH, 3), 255, np.uint8)
    _text(canvas, title, (WIDTH / 2, 32), scale=0.6, centre=True, max_width=WIDTH - 20)
    plot = (MARGIN["left"], MARGIN["top"], WIDTH - MARGIN["right"], HEIGHT - MARGIN["bottom"])
    return canvas, plot


def _range(values, log: bool):
    """Data range of the y axis (log: positive values only, whole decades)."""
    if log:
        values = [v for v in values if v > 0]
        if not values:
            return 0.1, 1.0
        return 10.0 ** math.floor(math.log10(min(values)) + 1e-9), 10.0 ** math.ceil(math.log10(max(values)) - 1e-9)
    if not values:
        return 0.0, 1.0
    lo, hi = min(values), max(values)
    if hi == lo:
        hi = lo + (abs(lo) or 1.0)
    ticks = _ticks(lo, hi)
    return min(lo, ticks[0]), max(hi, ticks[-1])


def _axis_y(canvas, plot, lo, hi, log, ylabel):
    """Draw grid, ticks and label of the y axis; return value -> pixel row."""
    x0, y0, x1, y1 = plot
    if log:
        llo, lhi = math.log10(lo), math.log10(hi)
        to_y = lambda v: y1 - (math.log10(max(v, lo)) - llo) / (lhi - llo) * (y1 - y0)  # noqa: E731
        ticks = [10.0 ** e for e in range(int(round(llo)), int(round(lhi)) + 1)]
    else:
        to_y = lambda v: y1 - (v - lo) / (hi - lo) * (y1 - y0)  # noqa: E731
        ticks = _ticks(lo, hi)
    for t in ticks:
        py = int(round(to_y(t)))
        cv2.line(canvas, (x0, py), (x1, py), GRID, 1)
        _text(canvas, _fmt(t), (x0 - 8, py + 5), scale=0.45, right=True)
    cv2.rectangle(canvas, (x0, y0), (x1, y1), INK, 1)
    if ylabel:
        # written horizontally, then turned a quarter to run up the left side
        (w, h), _ = cv2.getTextSize(ylabel, FONT, 0.55, 1)
        strip = np.full((h + 10, w + 4, 3), 255, np.uint8)
        cv2.putText(strip, ylabel, (2, h + 3), FONT, 0.55, INK, 1, cv2.LINE_AA)
        strip = cv2.rotate(strip, cv2.ROTATE_90_COUNTERCLOCKWISE)[: y1 - y0]
        top = y0 + (y1 - y0 - strip.shape[0]) // 2
        canvas[top : top + strip.shape[0], 8 : 8 + strip.shape[1]] = strip
    return to_y


def _ticks(lo: float, hi: float, count: int = 6) -> list[float]:
    """Round tick values (1, 2, 5 x 10^n steps) covering [lo, hi]."""
    raw = (hi - lo) / count
    step = 10.0 ** math.floor(math.log10(raw))
    for m in (1, 2, 5, 10):
        if m * step >= raw:
            step *= m
            break
    first = math.floor(lo / step + 1e-9) * step
    last = math.ceil(hi / step - 1e-9) * step
    return [first + i * step for i in range(int(round((last - first) / step)) + 1)]


def _fmt(v: float) -> str:
    if v == int(v) and abs(v) < 1e6:
        return str(int(v))
    return f"{v:.3g}"


def _text(canvas, text, at, *, scale=0.5, centre=False, right=False, max_width=None):
    if not text:
        return
    (w, h), _ = cv2.getTextSize(text, FONT, scale, 1)
    if max_width is not None and w > max_width:  # shrink long labels to fit their slot
        scale *= max(max_width, 10) / w
        (w, h), _ = cv2.getTextSize(text, FONT, scale, 1)
    x, y = at
    if centre:
        x -= w / 2
    elif right:
        x -= w
    cv2.putText(canvas, text, (int(round(x)), int(round(y))), FONT, scale, INK, 1, cv2.LINE_AA)


def _legend(canvas, plot, names):
    x0, y0, x1, y1 = plot
    y = y1 + 72
    x = x0
    for s, name in enumerate(names):
        (w, _), _ = cv2.getTextSize(name, FONT, 0.45, 1)
        if x + 22 + w > WIDTH - 10 and x > x0:  # wrap to a second row
            x, y = x0, y + 20
        cv2.rectangle(canvas, (x, y - 10), (x + 14, y + 2), PALETTE[s % len(PALETTE)], -1)
        _text(canvas, name, (x + 20, y + 1), scale=0.45)
        x += 20 + w + 24


def _save(path, canvas) -> Path:
    """Write the BGR uint8 canvas as an 8-bit PNG (atomically, through write_image)."""
    from .imageio import write_image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_image(path, canvas[..., ::-1].astype(np.float32) / 255.0, format="uint8")
