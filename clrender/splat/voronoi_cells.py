"""Voronoi cells on the device: sites binned in a grid, each pixel's nearest site, the cells' colours.

Shared by the hard splats (voronoi.py) and the trainable soft model (voronoi_soft.py).
Sites are float positions in pixel units; pixel (x, y) has its centre at (x + 0.5, y + 0.5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from ..layout import VORONOI_STRIP

METHODS = ("grid", "naive")
SITES_PER_CELL = 1.0  # target grid density; the cell side is rounded to a power of two
STRIP = VORONOI_STRIP  # pixels per work-item in the grid kernel (one float8; clrender/layout.py)


# ----------------------------------------------------------------- site grid


@dataclass
class SiteGrid:
    """Sites counting-sorted into gw x gh square cells of side `cell` (a power of two)."""

    cell: float
    gw: int
    gh: int
    cell_start: np.ndarray  # int32 (gw*gh + 1,): cell c holds order[cell_start[c]:cell_start[c+1]]
    order: np.ndarray  # int32 (N,): site indices in cell order (stable: ascending within a cell)


def cell_side(n: int, width: int, height: int, sites_per_cell: float | None = None) -> float:
    """Power-of-two cell side giving about `sites_per_cell` sites per cell."""
    sites_per_cell = sites_per_cell or SITES_PER_CELL
    ideal = math.sqrt(width * height * sites_per_cell / max(n, 1))
    return float(2.0 ** round(math.log2(ideal)))


def build_grid(sites: np.ndarray, width: int, height: int, sites_per_cell: float | None = None) -> SiteGrid:
    """Bin the sites into a uniform grid covering the image (counting sort, numpy only)."""
    cell = cell_side(len(sites), width, height, sites_per_cell)
    gw, gh = max(1, math.ceil(width / cell)), max(1, math.ceil(height / cell))
    # float32 position times a power of two is exact, so floor() matches the kernel's cell borders
    s = sites.astype(np.float64)
    cx = np.clip(np.floor(s[:, 0] / cell), 0, gw - 1).astype(np.int64)
    cy = np.clip(np.floor(s[:, 1] / cell), 0, gh - 1).astype(np.int64)
    cell_of = cy * gw + cx
    order = np.argsort(cell_of, kind="stable").astype(np.int32)
    counts = np.bincount(cell_of, minlength=gw * gh)
    cell_start = np.zeros(gw * gh + 1, dtype=np.int32)
    np.cumsum(counts, out=cell_start[1:])
    return SiteGrid(cell, gw, gh, cell_start, order)


def check_sites(sites, width: int, height: int) -> np.ndarray:
    """Sites as a contiguous float32 (N, 2) array; UsageError for anything unusable."""
    sites = np.ascontiguousarray(sites, dtype=np.float32)
    if sites.ndim != 2 or sites.shape[1] != 2:
        raise UsageError(f"sites must have shape (N, 2), got {sites.shape}")
    if len(sites) < 1:
        raise UsageError("need at least 1 site")
    if not np.isfinite(sites).all():
        raise UsageError("site positions must be finite")
    if width < 1 or height < 1:
        raise UsageError(f"image size {width}x{height} must be at least 1x1")
    return sites


# ------------------------------------------------------------ nearest site


class NearestSite:
    """Index map of the nearest site per pixel, `prepare` once and `enqueue` as often as wanted."""

    def __init__(self, device, sites, width: int, height: int, method: str = "grid", local_size=None):
        import pyopencl as cl

        if method not in METHODS:
            raise UsageError(f"method {method!r} is unknown; allowed: {', '.join(METHODS)}")
        self.sites = check_sites(sites, width, height)
        self.dev, self.width, self.height, self.method = device, width, height, method
        self.local_size = local_size
        npix = width * height
        device.check_fits(npix * 4, f"the {width}x{height} index map")
        self.out = device.empty(npix * 4)
        if method == "naive":
            self.knl = device.kernel("splat_voronoi.cl", "nearest_naive")
            self.args = dict(sites=device.to_device(self.sites), n=len(self.sites), width=width, height=height, nearest=self.out)
        else:
            self.grid = grid = build_grid(self.sites, width, height)
            self.knl = device.kernel("splat_voronoi.cl", "nearest_grid")
            self.args = dict(
                sorted_pos=device.to_device(self.sites[grid.order]),
                sorted_idx=device.to_device(grid.order),
                cell_start=device.to_device(grid.cell_start),
                gw=grid.gw,
                gh=grid.gh,
                cell=grid.cell,
                width=width,
                height=height,
                nearest=self.out,
            )
        self._cl = cl

    def enqueue(self):
        """Launch the kernel (asynchronous); returns its event."""
        gsize = (self.width if self.method == "naive" else -(-self.width // STRIP), self.height)
        if self.local_size is not None:
            lx, ly = self.local_size
            gsize = (-(-gsize[0] // lx) * lx, -(-gsize[1] // ly) * ly)
        return self.knl(self.dev.queue, gsize, self.local_size, **self.args)

    def read(self) -> np.ndarray:
        index = np.empty((self.height, self.width), dtype=np.int32)
        self._cl.enqueue_copy(self.dev.queue, index, self.out)
        return index

    def run(self) -> np.ndarray:
        self.enqueue()
        return self.read()


def nearest_site(device, sites, width: int, height: int, method: str = "grid") -> np.ndarray:
    """int32 (height, width): index of each pixel's nearest site (lowest index on ties)."""
    return NearestSite(device, sites, width, height, method).run()


# ----------------------------------------------------------------- colours


def pixel_of_site(sites: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(row, column) of the pixel containing each site, clamped into the image."""
    col = np.clip(np.floor(sites[:, 0]), 0, width - 1).astype(np.int64)
    row = np.clip(np.floor(sites[:, 1]), 0, height - 1).astype(np.int64)
    return row, col


def sample_colors(image: np.ndarray, sites: np.ndarray) -> np.ndarray:
    """The image's colour at each site (point sampling); (N, C) float32."""
    h, w = image.shape[:2]
    row, col = pixel_of_site(sites, w, h)
    return image[row, col].astype(np.float32)


def mean_colors(image: np.ndarray, index: np.ndarray, n: int, fallback: np.ndarray | None = None) -> np.ndarray:
    """Mean colour of each site's cell (least-squares optimum); empty cells take `fallback` (or 0)."""
    c = image.shape[2]
    flat = index.ravel()
    count = np.bincount(flat, minlength=n).astype(np.float64)
    sums = np.stack([np.bincount(flat, weights=image[..., k].ravel(), minlength=n) for k in range(c)], axis=1)
    empty = count == 0
    colors = sums / np.where(empty, 1.0, count)[:, None]
    if fallback is not None:
        colors[empty] = fallback[empty]
    return colors.astype(np.float32)


def render(index: np.ndarray, colors: np.ndarray) -> np.ndarray:
    """(H, W, C) image: each pixel the colour of its site."""
    return colors[index]


def cell_edges(index: np.ndarray) -> np.ndarray:
    """bool (H, W): pixels whose right or lower neighbour belongs to another site."""
    edge = np.zeros(index.shape, dtype=bool)
    edge[:, :-1] |= index[:, :-1] != index[:, 1:]
    edge[:-1, :] |= index[:-1, :] != index[1:, :]
    return edge
