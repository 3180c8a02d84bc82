"""Nearest-site (Voronoi) splatting: each pixel takes the colour of its nearest site.

Sites are float positions in pixel units; pixel (x, y) has its centre at
(x + 0.5, y + 0.5).  Two exact methods give identical index maps:

    naive  every site for every pixel (the seed's baseline), O(pixels x sites)
    grid   sites counting-sorted into square cells of a power-of-two side on
           the host; each pixel scans rings of cells outward and stops once no
           unscanned site can be closer.  Ties go to the lower site index.

Colours are `sample` (the image at the site, as the seed did) or `mean` (the
mean of the cell's pixels, the least-squares optimum, by np.bincount).
`lloyd_step` moves each site to its cell's centroid (centroidal Voronoi).
The trainable soft model is in voronoi_soft.py.

Any number of sites >= 1 works here, including more sites than pixels (then
some cells own no pixel and keep their sampled colour); the command line
refuses N > pixel count because such sites can never show.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError

METHODS = ("grid", "naive")
INITS = ("uniform", "random", "gradient")
COLOR_MODES = ("sample", "mean")
SITES_PER_CELL = 1.0
STRIP = 8  # pixels per work-item in the grid kernel (one float8)  # target grid density; the cell side is rounded to a power of two


# ----------------------------------------------------------------- site grid

@dataclass
class SiteGrid:
    """Sites counting-sorted into gw x gh square cells of side `cell` (a power of two)."""

    cell: float
    gw: int
    gh: int
    cell_start: np.ndarray  # int32 (gw*gh + 1,): cell c holds order[cell_start[c]:cell_start[c+1]]
    order: np.ndarray       # int32 (N,): site indices in cell order (stable: ascending within a cell)


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

    def __init__(self, device, sites, width: int, height: int, method: str = "grid",
                 local_size=None):
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
            self.args = (device.to_device(self.sites), np.int32(len(self.sites)),
                         np.int32(width), np.int32(height), self.out)
        else:
            self.grid = grid = build_grid(self.sites, width, height)
            self.knl = device.kernel("splat_voronoi.cl", "nearest_grid")
            self.args = (device.to_device(self.sites[grid.order]), device.to_device(grid.order),
                         device.to_device(grid.cell_start), np.int32(grid.gw), np.int32(grid.gh),
                         np.float32(grid.cell),
                         np.int32(width), np.int32(height), self.out)
        self._cl = cl

    def enqueue(self):
        """Launch the kernel (asynchronous); returns its event."""
        gsize = (self.width if self.method == "naive" else -(-self.width // STRIP), self.height)
        if self.local_size is not None:
            lx, ly = self.local_size
            gsize = (-(-gsize[0] // lx) * lx, -(-gsize[1] // ly) * ly)
        return self.knl(self.dev.queue, gsize, self.local_size, *self.args)

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


def nearest_site_reference(sites, width: int, height: int) -> np.ndarray:
    """numpy brute force in float32, the same arithmetic as the kernels (for tests; small sizes)."""
    sites = np.asarray(sites, dtype=np.float32)
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float32) + np.float32(0.5)
    dx = xs.reshape(-1, 1) - sites[None, :, 0]
    dy = ys.reshape(-1, 1) - sites[None, :, 1]
    d2 = dx * dx + dy * dy
    return np.argmin(d2, axis=1).astype(np.int32).reshape(height, width)  # argmin: first (lowest) on ties


# ----------------------------------------------------------------- colours

def pixel_of_site(sites: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """(row, column) of the pixel containing each site, clamped into the image."""
    col = np.clip(np.floor(sites[:, 0]), 0, width - 1).astype(np.int64)
    row = np.clip(np.floor(sites[:, 1]), 0, height - 1).astype(np.int64)
    return row, col


def sample_colors(image: np.ndarray, sites: np.ndarray) -> np.ndarray:
    """The image's colour at each site (the seed's choice); (N, C) float32."""
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


def psnr(a: np.ndarray, b: np.ndarray, peak: float = 1.0) -> float:
    """Peak signal-to-noise ratio in dB of `a` against reference `b`."""
    mse = float(np.mean((np.asarray(a, np.float64) - np.asarray(b, np.float64)) ** 2))
    return float("inf") if mse == 0 else 10.0 * math.log10(peak * peak / mse)


# --------------------------------------------------------- one-call driver

@dataclass
class VoronoiSettings:
    n: int = 5000            # number of sites
    method: str = "grid"     # nearest-site search: grid | naive
    init: str = "gradient"   # starting sites: gradient (denser where the image has detail) | random | uniform (a square grid: looks like pixelation)
    colors: str = "mean"     # sample (image at the site) | mean (cell mean)
    lloyd: int = 0           # Lloyd (centroidal) iterations before colouring
    train: int = 0           # soft-Voronoi training steps (Adam) after Lloyd
    seed: int = 0            # random seed for random/gradient initialisation

    def validate(self, width: int, height: int) -> None:
        if self.n < 1:
            raise UsageError(f"--splats {self.n} must be at least 1")
        if self.n > width * height:
            raise UsageError(f"--splats {self.n} is more than the {width}x{height} image's "
                             f"{width * height} pixels; allowed: 1 to {width * height}")
        if self.method not in METHODS:
            raise UsageError(f"method {self.method!r} is unknown; allowed: {', '.join(METHODS)}")
        if self.colors not in COLOR_MODES:
            raise UsageError(f"colors {self.colors!r} is unknown; allowed: {', '.join(COLOR_MODES)}")
        if self.lloyd < 0:
            raise UsageError(f"--lloyd {self.lloyd} must be >= 0")
        if not 0 <= self.seed < 2**32:
            raise UsageError(f"--seed {self.seed} must be from 0 to 2**32-1")
        if self.train < 0:
            raise UsageError(f"--train {self.train} must be >= 0")


@dataclass
class VoronoiResult:
    sites: np.ndarray   # float32 (N, 2)
    colors: np.ndarray  # float32 (N, C)
    index: np.ndarray   # int32 (H, W)
    image: np.ndarray   # float32 (H, W, C)

    def _repr_png_(self) -> bytes:
        """The cells inline in Jupyter (the input's stored values, as written to files)."""
        from ..display import png_bytes

        return png_bytes(self.image, linear=False)


def splat(device, image: np.ndarray, settings: VoronoiSettings) -> VoronoiResult:
    """Initialise sites, optionally relax (Lloyd) and train (soft Voronoi), colour, render."""
    h, w = image.shape[:2]
    settings.validate(w, h)
    image = np.ascontiguousarray(image, dtype=np.float32)
    sites = init_sites(image, settings.n, settings.init, settings.seed)
    if settings.lloyd:
        sites, _, _ = lloyd(device, sites, w, h, settings.lloyd, settings.method)
    if settings.train:
        from .voronoi_soft import train

        sites = train(device, image, sites, steps=settings.train).sites
    index = nearest_site(device, sites, w, h, settings.method)
    colors = sample_colors(image, sites)
    if settings.colors == "mean":
        colors = mean_colors(image, index, len(sites), fallback=colors)
    return VoronoiResult(sites, colors, index, render(index, colors))


def synthetic_photo(width: int = 512, height: int = 512, seed: int = 0) -> np.ndarray:
    """A deterministic photo-like linear RGB image (H, W, 3) in [0, 1]: sky gradient,
    rolling hills, soft discs, hard-edged shapes and multi-octave value-noise texture."""
    import cv2

    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float32)
    u, v = (xs + 0.5) / width, (ys + 0.5) / height
    img = np.empty((height, width, 3), np.float32)
    img[...] = np.stack([0.35 + 0.3 * v, 0.5 + 0.25 * v, 0.85 - 0.2 * v], axis=2)  # sky
    texture = np.zeros((height, width), np.float32)
    for octave in range(1, 9):  # value noise: coarse-to-fine random grids, smoothly upsampled
        cells = 2 ** octave
        grid = rng.random((cells + 1, cells + 1)).astype(np.float32)
        texture += cv2.resize(grid, (width, height), interpolation=cv2.INTER_CUBIC) / 1.35 ** octave
    texture = (texture - texture.min()) / max(float(np.ptp(texture)), 1e-6)
    for k in range(3):  # hills, farther ones paler
        phase, amp, base = rng.random() * 6.3, 0.04 + 0.05 * rng.random(), 0.45 + 0.15 * k
        ridge = base + amp * np.sin(u * (3 + 4 * rng.random()) * np.pi + phase)
        ground = v > ridge
        colour = np.array([0.15 + 0.2 * rng.random(), 0.3 + 0.3 * rng.random(), 0.1 + 0.1 * k], np.float32)
        img[ground] = colour * (0.6 + 0.8 * texture[ground, None])
    for _ in range(6):  # soft discs (foliage, sun)
        cx, cy, r = rng.random() * width, rng.random() * height * 0.7, (0.04 + 0.08 * rng.random()) * width
        a = np.clip(1.0 - np.hypot(xs - cx, ys - cy) / r, 0.0, 1.0) ** 0.5
        img += a[..., None] * (rng.random(3).astype(np.float32) - img) * 0.8
    for _ in range(4):  # hard-edged rectangles (buildings), textured
        x0, y0 = int(rng.random() * width * 0.8), int(height * (0.4 + 0.4 * rng.random()))
        x1, y1 = x0 + int(width * (0.05 + 0.15 * rng.random())), height
        img[y0:y1, x0:x1] = rng.random(3).astype(np.float32) * (0.7 + 0.6 * texture[y0:y1, x0:x1, None])
    return np.clip(img, 0.0, 1.0).astype(np.float32)
