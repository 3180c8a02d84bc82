"""The path tracer's reconstruction filters (kernels/film.h, Mitsuba 3's film): which there are, the kernel variant
each needs, and the gather of the per-pixel splats into an image.

With `box` (the default) a pixel is the mean of its own samples, as always.  With `tent` or `gaussian` every
sample also counts towards its neighbours: the kernel gives each pixel (2R + 1)^2 slots, slot (dy, dx) holding
the sums (sum f w L, sum f w) of the pixel's own samples weighed by the filter about the centre of the pixel
(dy, dx) away, and `gather` adds each pixel's slots into those neighbours in one fixed order (rows of slots,
then columns) in float64.  Each slot comes from one work-item's fixed sequence of samples, so the image has
the same bits on any tiling, work-group size or device that computes the same samples.
"""

from __future__ import annotations

import numpy as np

FILTERS = {"box": 0, "tent": 1, "gaussian": 2}  # RenderSettings.rfilter and --rfilter; codes of kernels/film.h
RADIUS = {"tent": 1.0, "gaussian": 2.0}  # pixels: Mitsuba's tent (radius 1) and gaussian (stddev 0.5, 4 stddev)
GAUSSIAN_STDDEV = 0.5


def reach(name: str) -> int:
    """R: the footprint's half width in whole pixels (0 for box)."""
    return int(np.ceil(RADIUS[name])) if name in RADIUS else 0


def slots(name: str) -> int:
    """Splat slots per pixel: (2R + 1)^2, 1 for box."""
    return (2 * reach(name) + 1) ** 2


def defines(name: str) -> dict:
    """The kernel's -D variant for filter `name`: none for box (its kernel is the one without filters)."""
    return {"SPLAT_FILTER": FILTERS[name], "SPLAT_RADIUS": reach(name)} if name in RADIUS else {}


def gather(splats: np.ndarray, width: int, height: int, name: str) -> np.ndarray:
    """(H, W, 4) float64 sums (sum f L RGB, sum f) per pixel from the kernel's splats (H * W, slots, 4) in image
    order, each pixel's slots added into the neighbours they belong to, in a fixed order."""
    r = reach(name)
    n = 2 * r + 1
    s = splats.reshape(height, width, n * n, 4)
    out = np.zeros((height + 2 * r, width + 2 * r, 4))
    for dy in range(n):
        for dx in range(n):
            out[dy : dy + height, dx : dx + width] += s[:, :, dy * n + dx]
    return out[r : r + height, r : r + width]  # what lands outside the image is dropped, as Mitsuba's film crops it
