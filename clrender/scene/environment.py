"""The image-based environment light: an equirectangular (latitude-longitude) map read through OpenImageIO,
and the piecewise-constant distribution the path tracer samples it by (kernels/envmap.h).

Directions and the map (Mitsuba 3's `envmap` convention, so its scenes compare directly): a world direction
is first turned by -rotation about +y (the map turns by +rotation, as a mesh's `rotate = [0, rotation, 0]`
would), giving d, then
    u = atan2(d.x, -d.z) / (2 pi), wrapped into [0, 1);   v = acos(d.y) / pi
so v = 0 (the image's top row) is straight up (+y), and the left edge u = 0 looks along -z, u = 1/4 along +x,
u = 1/2 along +z.  Back: theta = pi v, phi = 2 pi u, d = (sin theta sin phi, cos theta, -sin theta cos phi).
The radiance (times `intensity`) is bilinear between texel centres, at Mitsuba's envmap sample positions:
texel (row i, column j) of a W x H map sits at u = (j + 1/2) / W (wrapping around: the column right of the
last is the first) and v = i / (H - 1) (the first row straight up, the last straight down; a one-row map is
read as two equal rows).  A solid angle is d omega = 2 pi^2 sin(theta) du dv.

Sampling is piecewise constant over the (H - 1) x W cells between four texel centres: cell (i, j) spans
u in [(j + 1/2) / W, (j + 3/2) / W) (wrapping) and v in [i / (H - 1), (i + 1) / (H - 1)), with weight
w = mean luminance of its four texels x sin(theta at the cell's middle row), so a cell is picked wherever
any of its texels is bright (the density is positive wherever the radiance is).  A row by the marginal CDF
over rows, a column by that row's conditional CDF (each searched from its guide: guide()), a uniform point inside
the cell.  The density over
(u, v) is p = w / mean(w) (constant over a cell), and over solid angle p / (2 pi^2 sin theta): the
evaluated radiance is bilinear while the density is not, and the kernels weigh NEE and BSDF rays by this
density, the one they sample by.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UsageError
from .checks import RADIANCE_LIMIT, Checks, TypeReader, show

LUMINANCE = (0.2126, 0.7152, 0.0722)  # Rec. 709 / sRGB primaries, as kernels/material.h's luminance()
CHANNELS = (1, 3, 4)  # grey (copied to R, G, B), RGB, RGBA (alpha ignored)
ROTATION_LIMIT = 360.0  # degrees either way
# Peak bytes per texel while a map is read and prepared: the file's float32 channels (counted apart), its
# RGB copy (12), the float64 weights, CDFs and densities (~64), the float4 texels and CDF (20) and their
# device copies (20), the guides (up to 8, 16 with the device copy) and the int64 counts that build them (up to
# 32); rounded up.  Measured: 89 B/texel peak RSS growth for a 2048 x 1024 RGB EXR, read and uploaded (PoCL CPU),
# before the guides, against the 140 then estimated.
BYTES_PER_TEXEL = 176


@dataclass
class EnvironmentMap:
    """An environment map as the scene holds it (shipped to Dask workers as it is: payload.py)."""

    texels: np.ndarray  # (H, W, 3) float32 linear RGB radiance as the file holds it; row 0 is straight up
    intensity: float = 1.0  # radiance scale
    rotation: float = 0.0  # degrees about +y
    source: str = ""  # the file it came from, for messages

    @property
    def width(self) -> int:
        return self.texels.shape[1]

    @property
    def height(self) -> int:
        return self.texels.shape[0]


@dataclass
class Distribution:
    """What the kernels read of a map (trace/envmap.py uploads it)."""

    texels: np.ndarray  # (H * W, 4) float32: RGB radiance times intensity, and the density over (u, v) of the cell
    # whose top-left texel it is (0 on the last row)
    marginal: np.ndarray  # (H,) float32 running sum of the H - 1 cell rows' probabilities, 0 ... 1
    conditional: np.ndarray  # (H - 1, W + 1) float32 running sums of each cell row's probabilities, 0 ... 1
    sampled: bool  # False for a black map: nothing to sample, nothing to see
    width: int  # of the texels as uploaded: a one-row map is uploaded as two equal rows
    height: int
    row_buckets: int  # the marginal CDF's guide buckets (guide()), a power of two
    column_buckets: int  # each conditional CDF's
    guides: np.ndarray  # int32: the marginal's guide (row_buckets + 1), then each cell row's (column_buckets + 1)


def buckets(n: int) -> int:
    """A guide's buckets for a CDF over n intervals: the smallest power of two >= n."""
    return 1 << max(0, int(n - 1).bit_length())


def guide(cdf: np.ndarray, b: int) -> np.ndarray:
    """The guide table of running sums cdf (..., n + 1), for kernels/envmap.h's cdf_search: entry k of b + 1 is
    the largest i < n with cdf[i] <= k / b, so the interval holding any u in [k / b, (k + 1) / b) lies between
    entries k and k + 1 (the sums never decrease).  b is a power of two: the kernel's bucket floor(u b) is exact.
    Counted per row as a histogram of ceil(cdf[i] b), the first bucket each i <= k satisfies: exact in float64."""
    rows = cdf.reshape(-1, cdf.shape[-1])[:, :-1].astype(np.float64)
    first = np.clip(np.ceil(rows * b), 0, b).astype(np.int64) + (b + 1) * np.arange(len(rows))[:, None]
    hist = np.bincount(first.ravel(), minlength=len(rows) * (b + 1)).reshape(len(rows), b + 1)
    return (np.cumsum(hist, axis=1) - 1).astype(np.int32)


def cell_sin_theta(height: int) -> np.ndarray:
    """sin(theta) at the middle of each of the height - 1 cell rows, float64."""
    return np.sin(np.pi * (np.arange(height - 1) + 0.5) / (height - 1))


def distribution(env: EnvironmentMap) -> Distribution:
    """The map's texels and its sampling CDFs over the cells between texel centres (module docstring), built in
    float64 and stored in float32."""
    rgb = env.texels if env.height > 1 else np.repeat(env.texels, 2, axis=0)
    h, w = rgb.shape[:2]
    radiance = rgb.astype(np.float64) * env.intensity
    lum = radiance @ np.array(LUMINANCE)  # (H, W)
    corners = lum[:-1] + lum[1:]
    weight = 0.25 * (corners + np.roll(corners, -1, axis=1)) * cell_sin_theta(h)[:, None]  # (H - 1, W)
    total = weight.sum()
    texels = np.zeros((h * w, 4), np.float32)
    texels[:, :3] = radiance.reshape(-1, 3)
    marginal = np.zeros(h, np.float64)
    conditional = np.zeros((h - 1, w + 1), np.float64)
    if total > 0:
        texels[: (h - 1) * w, 3] = (weight / weight.mean()).ravel()
        rows = weight.sum(axis=1)
        marginal[1:] = np.cumsum(rows) / total
        nonzero = rows > 0
        conditional[nonzero, 1:] = np.cumsum(weight[nonzero], axis=1) / rows[nonzero, None]
        conditional[~nonzero, 1:] = np.arange(1, w + 1) / w  # never picked; a uniform row keeps the CDF valid
        marginal[-1] = 1.0  # the searches never run past the end
        conditional[:, -1] = 1.0
    marginal, conditional = marginal.astype(np.float32), conditional.astype(np.float32)
    rb, cb = buckets(h - 1), buckets(w)
    guides = np.concatenate([guide(marginal, rb).ravel(), guide(conditional, cb).ravel()])
    return Distribution(texels, marginal, conditional, bool(total > 0), w, h, rb, cb, guides)


def map_bytes(width: int, height: int, channels: int) -> int:
    """Peak bytes of reading and preparing a map of this size (BYTES_PER_TEXEL, the file's own channels)."""
    return width * height * (BYTES_PER_TEXEL + 4 * channels)


# ---------------------------------------------------------------------- the [environment] table
def _read(checks: Checks, table: dict, path: str):
    """The constant colour (a tuple), or an EnvironmentMap when the table names a `file`."""
    if "file" not in table:
        for key in ("intensity", "rotation"):
            if key in table:
                checks.fail(f"{path}.{key}", "needs 'file' (an environment map image)")
        return checks.vec3(table, "color", path, (0.0, 0.0, 0.0), kind="colour")
    if "color" in table:
        checks.fail(f"{path}.color", "give either 'color' (a constant environment) or 'file' (an image), not both")
    intensity = checks.number(table, "intensity", path, 1.0, low=0.0, high=RADIANCE_LIMIT)
    rotation = checks.number(table, "rotation", path, 0.0, low=-ROTATION_LIMIT, high=ROTATION_LIMIT)
    file = table["file"]
    if not isinstance(file, str) or not file or "\x00" in file:
        checks.fail(f"{path}.file", f"expected a path to a .hdr or .exr image, got {show(file)}")
    from .confine import scene_file

    where = f"{checks.where}: {path}.file"
    texels = load_texels(scene_file(checks.base_dir, file, checks.root, where), where)
    return EnvironmentMap(texels, float(intensity), float(rotation), file)


ENVIRONMENT_READER = TypeReader(("color", "file", "intensity", "rotation"), _read)


def load_texels(path: Path, what: str) -> np.ndarray:
    """(H, W, 3) float32 radiance of an image file (Radiance HDR, OpenEXR, any format OpenImageIO reads):
    its header checked and the memory it needs estimated before its pixels are read; UsageError naming
    `what` for a missing, damaged or unsuitable file."""
    from .. import memory
    from ..image.files import probe_image, read_image
    from .confine import regular_file

    try:
        info = probe_image(regular_file(path, "environment map"))  # a FIFO would block the read forever
        if info.nchannels not in CHANNELS:
            raise UsageError(f"image {str(path)!r} has {info.nchannels} channels; allowed: 1 (grey), 3 (RGB) or 4 (RGBA, alpha ignored)")
        memory.require(memory.BASE_BYTES + map_bytes(info.width, info.height, info.nchannels), f"environment map {info.width}x{info.height}")
        pixels = read_image(path).pixels
    except UsageError as exc:
        raise UsageError(f"{what}: {exc}") from None
    rgb = np.repeat(pixels, 3, axis=2) if pixels.shape[2] == 1 else pixels[..., :3]
    finite = np.isfinite(rgb)
    if not finite.all() or (rgb < 0).any() or rgb.max(initial=0.0) > RADIANCE_LIMIT:
        bad = rgb[~finite][0] if not finite.all() else (rgb.min() if (rgb < 0).any() else rgb.max())
        raise UsageError(f"{what}: image {str(path)!r} holds the value {bad:g}; allowed: radiance from 0 to {RADIANCE_LIMIT:g}")
    return np.ascontiguousarray(rgb, np.float32)
