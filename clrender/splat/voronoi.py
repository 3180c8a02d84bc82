"""Nearest-site (Voronoi) splatting: each pixel takes the colour of its nearest site.

Sites are float positions in pixel units; pixel (x, y) has its centre at
(x + 0.5, y + 0.5).  Two exact methods give identical index maps:

    naive  every site for every pixel (the brute-force baseline), O(pixels x sites)
    grid   sites counting-sorted into square cells of a power-of-two side on
           the host; each pixel scans rings of cells outward and stops once no
           unscanned site can be closer.  Ties go to the lower site index.

Colours are `sample` (the image at the site) or `mean` (the
mean of the cell's pixels, the least-squares optimum, by np.bincount).
`lloyd_step` moves each site to its cell's centroid (centroidal Voronoi).
The trainable soft model is in voronoi_soft.py; the grid, the nearest-site search and the
colours in voronoi_cells.py; the numpy brute force and a synthetic photo in clrender/testing.py.

Any number of sites >= 1 works here, including more sites than pixels (then
some cells own no pixel and keep their sampled colour); the command line
refuses N > pixel count because such sites can never show.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import memory
from ..errors import UsageError, require
from . import INITS
from .pixels import check_pixels
from .voronoi_cells import (
    METHODS,
    NearestSite,
    SiteGrid,
    build_grid,
    cell_edges,
    cell_side,
    check_sites,
    mean_colors,
    nearest_site,
    pixel_of_site,
    render,
    sample_colors,
)
from .voronoi_soft import TrainSettings, train

# the grid, the nearest-site search and the cell colours live in voronoi_cells.py (shared with the soft model)
__all__ = [
    "COLOR_MODES",
    "INITS",
    "METHODS",
    "NearestSite",
    "SiteGrid",
    "VoronoiResult",
    "VoronoiSettings",
    "build_grid",
    "cell_edges",
    "cell_side",
    "check_sites",
    "init_sites",
    "lloyd",
    "lloyd_step",
    "mean_colors",
    "nearest_site",
    "pixel_of_site",
    "quantisation_energy",
    "render",
    "sample_colors",
    "splat",
]

COLOR_MODES = ("sample", "mean")
# Peak memory (clrender/memory.py), measured as peak RSS growth (PoCL CPU device) and rounded up:
# 2048^2 RGB pixels grew 71 B/pixel, and 633 with --train (8 neighbours a pixel).
BYTES_PER_PIXEL = 64  # index map, pixel centres and cell sums (Lloyd, mean colours), the written copy
BYTES_PER_PIXEL_CHANNEL = 12  # the float image, the rendered one and an output conversion
SOFT_BYTES_PER_NEIGHBOUR = 48  # --train, per pixel and neighbour: indices, weights, gradient pairs (device and host)
SOFT_BYTES_PER_NEIGHBOUR_CHANNEL = 12  # and the per-pair colour gradient terms, in float64 while summed
BYTES_PER_SITE = 64  # positions, colours, the grid's order, the optimiser's moments


# ------------------------------------------------------------------- Lloyd


def pixel_centres(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) float64 of every pixel centre, raveled in row-major order."""
    ys, xs = np.mgrid[0:height, 0:width]
    return xs.ravel() + 0.5, ys.ravel() + 0.5


def quantisation_energy(sites: np.ndarray, index: np.ndarray) -> float:
    """sum over pixels of |p - s(p)|^2 in float64 (the energy Lloyd's method lowers)."""
    h, w = index.shape
    px, py = pixel_centres(w, h)
    s = sites.astype(np.float64)[index.ravel()]
    return float(((px - s[:, 0]) ** 2 + (py - s[:, 1]) ** 2).sum())


def lloyd_step(sites: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Sites moved to the centroids of their cells' pixel centres; sites owning no pixel stay."""
    h, w = index.shape
    n = len(sites)
    px, py = pixel_centres(w, h)
    flat = index.ravel()
    count = np.bincount(flat, minlength=n).astype(np.float64)
    owned = count > 0
    moved = sites.astype(np.float64).copy()
    moved[owned, 0] = np.bincount(flat, weights=px, minlength=n)[owned] / count[owned]
    moved[owned, 1] = np.bincount(flat, weights=py, minlength=n)[owned] / count[owned]
    return moved.astype(np.float32)


def lloyd(device, sites: np.ndarray, width: int, height: int, steps: int, method: str = "grid"):
    """`steps` Lloyd iterations; returns (sites, index map of the final sites, energies per step)."""
    index = nearest_site(device, sites, width, height, method)
    energies = [quantisation_energy(sites, index)]
    for _ in range(steps):
        sites = lloyd_step(sites, index)
        index = nearest_site(device, sites, width, height, method)
        energies.append(quantisation_energy(sites, index))
    return sites, index, energies


# ---------------------------------------------------------- initial sites


def init_sites(image: np.ndarray, n: int, method: str = "uniform", seed: int = 0) -> np.ndarray:
    """N starting sites (float32 (N, 2), pixel units) for an (H, W, C) image.

    uniform   rows of evenly spaced sites, N exactly, about square spacing
    random    uniform random positions
    gradient  pixels drawn with probability ~ (gradient magnitude + its mean),
              jittered within the pixel: more sites where the image has detail
    """
    h, w = image.shape[:2]
    if n < 1:
        raise UsageError(f"number of sites {n} must be at least 1")
    if method not in INITS:
        raise UsageError(f"site initialisation {method!r} is unknown; allowed: {', '.join(INITS)}")
    rng = np.random.default_rng(seed)
    if method == "uniform":
        rows = min(n, max(1, round(math.sqrt(n * h / w))))
        bounds = np.round(np.linspace(0, n, rows + 1)).astype(np.int64)  # sites [bounds[r], bounds[r+1]) in row r
        i = np.arange(n)
        row = np.searchsorted(bounds, i, side="right") - 1
        per_row = bounds[row + 1] - bounds[row]
        x = (i - bounds[row] + 0.5) / per_row * w
        y = (row + 0.5) / rows * h
        return np.stack([x, y], axis=1).astype(np.float32)
    if method == "random":
        return (rng.random((n, 2)) * [w, h]).astype(np.float32)
    luma = image[..., :3].mean(axis=2) if image.shape[2] >= 3 else image[..., 0]
    luma = luma.astype(np.float64)
    # np.gradient needs two samples along an axis: a one-pixel row or column has no slope
    gy = np.gradient(luma, axis=0) if h > 1 else np.zeros_like(luma)
    gx = np.gradient(luma, axis=1) if w > 1 else np.zeros_like(luma)
    mag = np.hypot(gx, gy).ravel()
    weight = mag + (mag.mean() if mag.mean() > 0 else 1.0)
    pick = rng.choice(h * w, size=n, replace=n > h * w, p=weight / weight.sum())
    jitter = rng.random((n, 2))
    return np.stack([pick % w + jitter[:, 0], pick // w + jitter[:, 1]], axis=1).astype(np.float32)


# --------------------------------------------------------- one-call driver


@dataclass(frozen=True)
class VoronoiSettings:
    """Settings of one Voronoi splatting, each with its default; change one with dataclasses.replace."""

    n: int = 5000  # number of sites
    method: str = "grid"  # nearest-site search: grid | naive
    init: str = "gradient"  # starting sites: gradient (denser where the image has detail) | random | uniform (a square grid: looks like pixelation)
    colors: str = "mean"  # sample (image at the site) | mean (cell mean)
    lloyd: int = 0  # Lloyd (centroidal) iterations before colouring
    train: int = 0  # soft-Voronoi training steps (Adam) after Lloyd
    seed: int = 0  # random seed for random/gradient initialisation

    def validate(self, width: int, height: int) -> None:
        """UsageError naming the first setting that is out of range for a width x height image."""
        require(self.n >= 1, f"--splats {self.n} must be at least 1")
        require(
            self.n <= width * height,
            f"--splats {self.n} is more than the {width}x{height} image's {width * height} pixels; allowed: 1 to {width * height}",
        )
        require(self.method in METHODS, f"method {self.method!r} is unknown; allowed: {', '.join(METHODS)}")
        require(self.colors in COLOR_MODES, f"colors {self.colors!r} is unknown; allowed: {', '.join(COLOR_MODES)}")
        require(self.lloyd >= 0, f"--lloyd {self.lloyd} must be >= 0")
        require(0 <= self.seed < 2**32, f"--seed {self.seed} must be from 0 to 2**32-1")
        require(self.train >= 0, f"--train {self.train} must be >= 0")


@dataclass
class VoronoiResult:
    sites: np.ndarray  # float32 (N, 2)
    colors: np.ndarray  # float32 (N, C)
    index: np.ndarray  # int32 (H, W)
    image: np.ndarray  # float32 (H, W, C)

    def _repr_png_(self) -> bytes:
        """The cells inline in Jupyter (the input's stored values, as written to files)."""
        from ..image.display import png_bytes

        return png_bytes(self.image, linear=False)


def peak_bytes(width: int, height: int, channels: int, settings: VoronoiSettings) -> int:
    """Estimated peak memory of `splat` on a width x height image with `channels` channels."""
    per_pixel = BYTES_PER_PIXEL + BYTES_PER_PIXEL_CHANNEL * channels
    if settings.train:
        k = min(TrainSettings().k, settings.n)
        per_pixel += k * (SOFT_BYTES_PER_NEIGHBOUR + SOFT_BYTES_PER_NEIGHBOUR_CHANNEL * channels)
    return memory.BASE_BYTES + width * height * per_pixel + settings.n * BYTES_PER_SITE


def require_memory(width: int, height: int, channels: int, settings: VoronoiSettings) -> None:
    """UsageError with the figure when the splatting would need more memory than allowed (--max-memory)."""
    need = peak_bytes(width, height, channels, settings)
    memory.require(
        need, f"a {width}x{height} Voronoi splatting of {settings.n} sites" + (f" with --train {settings.train}" if settings.train else "")
    )


def splat(device, image: np.ndarray, settings: VoronoiSettings) -> VoronoiResult:
    """Initialise sites, optionally relax (Lloyd) and train (soft Voronoi), colour, render."""
    h, w = image.shape[:2]
    settings.validate(w, h)
    require_memory(w, h, image.shape[2] if image.ndim == 3 else 1, settings)
    image = np.ascontiguousarray(image, dtype=np.float32)
    check_pixels(image, "the image")
    sites = init_sites(image, settings.n, settings.init, settings.seed)
    if settings.lloyd:
        sites, _, _ = lloyd(device, sites, w, h, settings.lloyd, settings.method)
    if settings.train:
        sites = train(device, image, sites, steps=settings.train).sites
    index = nearest_site(device, sites, w, h, settings.method)
    colors = sample_colors(image, sites)
    if settings.colors == "mean":
        colors = mean_colors(image, index, len(sites), fallback=colors)
    return VoronoiResult(sites, colors, index, render(index, colors))
