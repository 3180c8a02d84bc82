"""Convolution filters by name, run by OpenCV on float32 pixels.

    apply(pixels, "box_blur_33")                 # one filter
    apply(pixels, "gauss_blur_5", "brighten_2")  # several, in order
    parse("gauss_blur_4")                        # UsageError before any work

Names, as the command line takes them:

  brighten_F     multiply by F (a finite number >= 0)
  box_blur_K     mean over a K x K square (K odd, 1..MAX_SIZE); cv2.blur, O(1) per pixel
  gauss_blur_K   K x K Gaussian, sigma = 0.3 * ((K - 1) / 2 - 1) + 0.8 (OpenCV's rule),
                 weights normalised to sum 1; separable (cv2.sepFilter2D) below
                 FFT_FROM_SIZE, FFT along rows then columns from there on
  edge_detect_1  4-neighbour Laplacian [[0,-1,0],[-1,4,-1],[0,-1,0]]
  edge_detect_2  8-neighbour Laplacian [[-1,-1,-1],[-1,8,-1],[-1,-1,-1]]

Borders are reflect-101 (OpenCV's BORDER_REFLECT_101: ... c b | a b c ... | ... b a),
repeated for kernels wider than the image.  The filters work on the values
they are given; the command line decides the colour space (see docs/filters.md).

Range: pixels must be finite (NaN or infinity: UsageError).  Every filter's result is clamped to
float32's finite range (|v| <= 3.4e38) instead of overflowing to infinity: brighten_1.5 of 3e38
gives 3.4e38, deterministically.  Blurs and edge detectors of values beyond 2^100 filter a copy
scaled by a power of two (exact), so their sums cannot overflow on the way.

Alpha: with `alpha_channel` set (or an `Image` whose file had alpha), blurs
treat the pixels as premultiplied (colour * alpha and alpha are blurred with
the same weights, colour is divided back), so hidden colours of transparent
pixels do not bleed in; brighten and edge_detect change colour only and copy
alpha.  Without it, every channel is filtered alike.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace

import numpy as np

from ..errors import UsageError, shown
from .files import Image

BORDER = 4  # cv2.BORDER_REFLECT_101 (tests/image check it): OpenCV is imported only when a filter runs


def _cv2():
    """OpenCV, imported on first use: the CLI imports this module for the filter names, and a render
    without --filter should not pay cv2's import (20 ms)."""
    import cv2

    return cv2


MAX_SIZE = 10001  # widest box or Gaussian accepted
FLOAT_MAX = float(np.finfo(np.float32).max)  # results are clamped to +-this (float32's largest finite value)
# Blurs and edge detectors scale inputs beyond 2^SAFE_EXPONENT down first: a sum of MAX_SIZE^2 (< 2^27)
# such values, or an edge kernel's 16 times one, stays below 2^127 < FLOAT_MAX.
SAFE_EXPONENT = 100
FFT_FROM_SIZE = 151  # Gaussians at least this wide go through the FFT (measured crossover, 4096^2 RGB)
EDGE_KERNELS = {
    1: np.array([[0, -1, 0], [-1, 4, -1], [0, -1, 0]], np.float32),
    2: np.array([[-1, -1, -1], [-1, 8, -1], [-1, -1, -1]], np.float32),
}
# (form, one-line description) for `clrender convolve --list` and error messages
FORMS = (
    ("brighten_{F}", "multiply colour by F, a finite number >= 0 (brighten_1.5; alpha is kept)"),
    ("box_blur_{K}", f"mean over a K x K square, K odd in 1..{MAX_SIZE} (box_blur_33)"),
    ("gauss_blur_{K}", f"K x K Gaussian, sigma = 0.3*((K-1)/2-1)+0.8, K odd in 1..{MAX_SIZE} (gauss_blur_5)"),
    ("edge_detect_1", "4-neighbour Laplacian [[0,-1,0],[-1,4,-1],[0,-1,0]] (signed result)"),
    ("edge_detect_2", "8-neighbour Laplacian [[-1,-1,-1],[-1,8,-1],[-1,-1,-1]] (signed result)"),
)
ALLOWED = "brighten_{F >= 0}, box_blur_{odd K}, gauss_blur_{odd K}, edge_detect_1, edge_detect_2"

_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"


@dataclass(frozen=True)
class Filter:
    """One parsed filter name."""

    name: str
    kind: str  # "brighten", "box_blur", "gauss_blur" or "edge_detect"
    value: float  # the factor, the size K, or the edge kernel's number

    @property
    def averages(self) -> bool:
        """Weights are >= 0 and sum to 1, so alpha is filtered with the colour."""
        return self.kind in ("box_blur", "gauss_blur")

    def kernel(self) -> np.ndarray:
        """The 2-D weights this filter convolves with (float64; brighten is 1 x 1)."""
        if self.kind == "brighten":
            return np.array([[self.value]])
        if self.kind == "edge_detect":
            return EDGE_KERNELS[int(self.value)].astype(np.float64)
        size = int(self.value)
        if self.kind == "box_blur":
            return np.full((size, size), 1.0 / size**2)
        g = gaussian_weights(size)
        return np.outer(g, g)

    def __call__(self, pixels: np.ndarray) -> np.ndarray:
        """Filter every channel of float32 (H, W, C) finite pixels alike; results within +-FLOAT_MAX."""
        if self.kind == "brighten":
            return _brighten(pixels, self.value)
        peak = float(np.abs(pixels).max()) if pixels.size else 0.0
        if peak <= 2.0**SAFE_EXPONENT:
            return self._linear(pixels)
        # a power-of-two scale is exact both ways; only the way back can overflow, and is clamped
        shift = math.ceil(math.log2(peak)) - SAFE_EXPONENT
        out = self._linear(pixels * np.float32(2.0**-shift)).astype(np.float64) * 2.0**shift
        return np.clip(out, -FLOAT_MAX, FLOAT_MAX).astype(np.float32)

    def _linear(self, pixels: np.ndarray) -> np.ndarray:
        """The blur or edge detector itself (OpenCV), on values small enough not to overflow."""
        cv2 = _cv2()
        if self.kind == "edge_detect":
            return _per_planes(lambda x: cv2.filter2D(x, cv2.CV_32F, EDGE_KERNELS[int(self.value)], borderType=BORDER), pixels)
        size = int(self.value)
        if size == 1:
            return pixels.copy()
        if self.kind == "box_blur":
            return _per_planes(lambda x: cv2.blur(x, (size, size), borderType=BORDER), pixels)
        g = gaussian_weights(size).astype(np.float32)
        if size >= FFT_FROM_SIZE:
            return separable_fft(pixels, g)
        return _per_planes(lambda x: cv2.sepFilter2D(x, cv2.CV_32F, g, g, borderType=BORDER), pixels)


def _brighten(pixels: np.ndarray, factor: float) -> np.ndarray:
    """pixels * factor, clamped to +-FLOAT_MAX where it would overflow (float32 as before where it does not)."""
    peak = float(np.abs(pixels).max()) if pixels.size else 0.0
    if factor <= FLOAT_MAX and peak * factor <= FLOAT_MAX:  # (float32(factor) would be inf beyond)
        return pixels * np.float32(factor)
    return np.clip(pixels.astype(np.float64) * factor, -FLOAT_MAX, FLOAT_MAX).astype(np.float32)


def gaussian_sigma(size: int) -> float:
    """Sigma of gauss_blur_{size}: OpenCV's rule for a kernel of that width."""
    return 0.3 * ((size - 1) * 0.5 - 1) + 0.8


def gaussian_weights(size: int) -> np.ndarray:
    """1-D weights exp(-x^2 / 2 sigma^2) for x = -(size-1)/2 .. (size-1)/2, summing to 1 (float64)."""
    x = np.arange(size) - (size - 1) / 2
    g = np.exp(-(x**2) / (2 * gaussian_sigma(size) ** 2))
    return g / g.sum()


def parse(name: str) -> Filter:
    """The filter a name stands for; UsageError naming the allowed forms if it is not one."""
    text = str(name)
    m = re.fullmatch(r"brighten_(.*)", text)
    if m:
        if not re.fullmatch(_NUMBER, m.group(1)):
            raise UsageError(f"filter {shown(text)}: {shown(m.group(1))} is not a number; use brighten_F with F >= 0, e.g. brighten_1.5")
        factor = float(m.group(1))
        if not math.isfinite(factor) or factor < 0:
            raise UsageError(f"filter {shown(text)}: the factor must be a finite number >= 0, e.g. brighten_1.5")
        return Filter(text, "brighten", factor)
    m = re.fullmatch(r"(box_blur|gauss_blur)_(.*)", text)
    if m:
        kind, size = m.groups()
        if not re.fullmatch(r"[+-]?\d+", size):
            raise UsageError(
                f"filter {shown(text)}: size {shown(size)} is not a whole number; use {kind}_K with K odd in 1..{MAX_SIZE}, e.g. {kind}_5"
            )
        digits = size.lstrip("+-").lstrip("0")
        if len(digits) > len(str(MAX_SIZE)):  # int() refuses over 4300 digits; no such size is allowed anyway
            raise UsageError(
                f"filter {shown(text)}: size is {len(digits)} digits long; use {kind}_K with K odd in 1..{MAX_SIZE}, e.g. {kind}_{MAX_SIZE}"
            )
        size = int(size)
        if size < 1 or size % 2 == 0 or size > MAX_SIZE:
            raise UsageError(
                f"filter {shown(text)}: size {size} is not allowed; use {kind}_K with K odd in 1..{MAX_SIZE}, e.g. {kind}_{_nearest_allowed(size)}"
            )
        return Filter(text, kind, size)
    m = re.fullmatch(r"edge_detect_([12])", text)
    if m:
        return Filter(text, "edge_detect", int(m.group(1)))
    raise UsageError(f"unknown filter {shown(text)}; allowed: {ALLOWED}")


def _nearest_allowed(size: int) -> int:
    if size > MAX_SIZE:
        return MAX_SIZE
    return size + 1 if size >= 2 else 3


def parse_all(names) -> list[Filter]:
    """Parse every name first, so a bad one is reported before any work."""
    if isinstance(names, str):
        names = [names]
    filters = [n if isinstance(n, Filter) else parse(n) for n in names]
    if not filters:
        raise UsageError(f"no filter given; allowed: {ALLOWED}")
    return filters


def apply(image, *names, alpha_channel: int | None = None):
    """Apply the named filters in order to an (H, W[, C]) array or an `Image`.

    Returns float32 pixels of the same shape (an `Image` for an `Image`, with
    its alpha channel found from the file's channel names unless given).
    """
    filters = parse_all(names)
    if isinstance(image, Image):
        if alpha_channel is None:
            alpha_channel = image.alpha_channel
        return replace(image, pixels=apply(image.pixels, *filters, alpha_channel=alpha_channel))
    pixels = np.asarray(image, dtype=np.float32)
    flat = pixels.ndim == 2
    if flat:
        pixels = pixels[:, :, None]
    if pixels.ndim != 3 or pixels.shape[0] < 1 or pixels.shape[1] < 1:
        raise UsageError(f"pixels of shape {pixels.shape} cannot be filtered; expected (H, W) or (H, W, C)")
    if alpha_channel is not None and not 0 <= alpha_channel < pixels.shape[2]:
        raise UsageError(f"alpha channel {alpha_channel} is not one of the {pixels.shape[2]} channels")
    check_finite(pixels, "the pixels")
    for f in filters:
        pixels = f(pixels) if alpha_channel is None else _with_alpha(f, pixels, alpha_channel)
    return pixels[:, :, 0] if flat else pixels


def check_finite(pixels: np.ndarray, where: str) -> None:
    """UsageError naming `where` when a pixel value is NaN or infinite: filters would spread it."""
    bad = np.count_nonzero(~np.isfinite(pixels))
    if bad:
        raise UsageError(f"{where}: {bad} pixel values are NaN or infinite; allowed: finite numbers")


def _with_alpha(f: Filter, pixels: np.ndarray, a: int) -> np.ndarray:
    """One filter on pixels with an alpha channel (see the module docstring)."""
    colour = [c for c in range(pixels.shape[2]) if c != a]
    out = pixels.copy()
    if not f.averages:
        out[:, :, colour] = f(np.ascontiguousarray(pixels[:, :, colour]))
        return out
    alpha = pixels[:, :, a : a + 1]
    with np.errstate(over="ignore"):  # huge colour times alpha, or divided by a small alpha: clamped
        premultiplied = np.clip(pixels[:, :, colour] * alpha, -FLOAT_MAX, FLOAT_MAX)
        blurred = f(np.concatenate([premultiplied, alpha], axis=2))
        new_alpha = blurred[:, :, -1:]
        covered = new_alpha > 1e-6  # elsewhere nothing is left to see: colour 0
        colour_out = np.where(covered, blurred[:, :, :-1] / np.where(covered, new_alpha, 1), 0)
    out[:, :, colour] = np.clip(colour_out, -FLOAT_MAX, FLOAT_MAX)
    out[:, :, a] = new_alpha[:, :, 0]
    return out


def _per_planes(fn, pixels: np.ndarray) -> np.ndarray:
    """Run an OpenCV filter on (H, W, C) float32, four channels at a time (OpenCV's limit for some paths)."""
    pixels = np.ascontiguousarray(pixels, dtype=np.float32)
    channels = pixels.shape[2]
    if channels <= 4:
        return fn(pixels).reshape(pixels.shape)
    parts = [fn(np.ascontiguousarray(pixels[:, :, c : c + 4])).reshape(pixels.shape[:2] + (-1,)) for c in range(0, channels, 4)]
    return np.concatenate(parts, axis=2)


def separable_fft(pixels: np.ndarray, weights: np.ndarray, rows_per_block: int = 256) -> np.ndarray:
    """Convolve (H, W, C) with outer(weights, weights) by FFT, rows then columns, reflect-101 borders.

    Time grows with log K instead of K, so a 1001-wide Gaussian costs about
    what a 101-wide one does.  `weights` must be symmetric and of odd length.
    """
    pixels = np.ascontiguousarray(pixels, dtype=np.float32)
    height, width, channels = pixels.shape
    # rows: (C*H, W); then columns: (C*W, H) -- each pass filters along contiguous lines
    planes = pixels.transpose(2, 0, 1).reshape(channels * height, width)
    planes = _fft_lines(planes, weights, rows_per_block).reshape(channels, height, width)
    lines = np.ascontiguousarray(planes.transpose(0, 2, 1)).reshape(channels * width, height)
    lines = _fft_lines(lines, weights, rows_per_block).reshape(channels, width, height)
    return np.ascontiguousarray(lines.transpose(2, 1, 0))


def _fft_lines(lines: np.ndarray, weights: np.ndarray, block: int) -> np.ndarray:
    """Filter each row of a 2-D float32 array with a symmetric 1-D kernel by FFT (cv2.dft, rows at a time)."""
    cv2 = _cv2()
    lines = np.ascontiguousarray(lines)
    count, n = lines.shape
    r = len(weights) // 2
    size = cv2.getOptimalDFTSize(n + 2 * r)  # no wrap-around reaches the n outputs we keep
    kernel = np.zeros((1, size), np.float32)
    kernel[0, : len(weights)] = weights
    spectrum = np.repeat(cv2.dft(kernel, flags=cv2.DFT_ROWS), min(block, count), axis=0)
    out = np.empty_like(lines)
    for start in range(0, count, block):
        chunk = lines[start : start + block]
        # reflect-101 on both sides; what lies past n + 2r never reaches a kept output
        padded = cv2.copyMakeBorder(chunk, 0, 0, r, size - n - r, BORDER)
        f = cv2.mulSpectrums(cv2.dft(padded, flags=cv2.DFT_ROWS), spectrum[: len(chunk)], cv2.DFT_ROWS)
        full = cv2.idft(f, flags=cv2.DFT_ROWS | cv2.DFT_SCALE | cv2.DFT_REAL_OUTPUT)
        # circular convolution: output x of the padded line sits at x + 2r
        out[start : start + block] = full[:, 2 * r : 2 * r + n]
    return out


def describe() -> str:
    """The allowed forms, one per line, for `--list`."""
    width = max(len(form) for form, _ in FORMS)
    return "\n".join(f"{form:<{width}}  {text}" for form, text in FORMS)
