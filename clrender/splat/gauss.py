"""2D Gaussian splats: the model and the packing, binning, forward and backward kernels.

A splat has a centre (x, y) in pixels, log-scales (log sx, log sy), a rotation
theta, a base colour (r, g, b), a luminance factor and an opacity in [0, 1].
Its weight at pixel centre p is

    w(p) = opacity * exp(-q / 2),  q = d^T Sigma^-1 d,  d = p - centre,
    Sigma = R(theta) diag(sx^2, sy^2) R(theta)^T,

cut to zero outside the 3-sigma ellipse (q >= 9); its effective colour is
luminance * colour.  Blend modes (see kernels/splat_gauss.cl):

    sum:        I = background + sum_i w_i c_i          (additive)
    normalized: I = (sum_i w_i c_i + eps * background) / (sum_i w_i + eps)

The forward kernel renders 16x16 tiles, each pixel visiting only the splats
binned to its tile by their 3-sigma boxes (packed and binned by kernels too, in
splat order, so the sums are deterministic; the host only adds up tile counts).  The
backward kernel writes one SplatGrad record per (tile, splat) entry;
`np.bincount` sums each field per splat in entry order, so the result has no
races and is deterministic.  The chain rule from the kernel's (A, B2, C) quadratic form to
(log sx, log sy, theta) is done here, vectorised.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import memory
from ..errors import UsageError, shown
from ..layout import (
    GAUSS_SPLAT_DTYPE,
    SPLAT_BOX_DTYPE,
    SPLAT_COLOR_DTYPE,
    SPLAT_EPS,
    SPLAT_GRAD_DTYPE,
    SPLAT_PARAMS_DTYPE,
    SPLAT_TILE,
)

TILE = SPLAT_TILE  # pixels per tile side (shared with the kernels: clrender/layout.py)
# the per-splat sums of the entries, in float64 (np.bincount's), with the entries' field names
_GRAD_SUMS = np.dtype([(name, "<f8", SPLAT_GRAD_DTYPE[name].shape) for name in SPLAT_GRAD_DTYPE.names])
EPS = SPLAT_EPS  # normalized blend: weight of the background colour
BACKWARD_GROUP = 64  # work-items per work-group of the backward kernel
PREPARE_GROUP = 64  # and of the packing kernel
BLENDS = ("sum", "normalized")
GROUPS = ("xy", "log_scale", "theta", "color", "lum", "opacity")
MIN_LOG_SCALE = float(np.log(0.25))  # sigma below a quarter pixel only aliases
# The kernels index the splat-tile pairs with int: more pairs than this cannot be binned.
MAX_PAIRS = 2**31 - 1
# Peak memory (clrender/memory.py), measured as peak RSS growth on the PoCL CPU device and rounded up:
# a fit of 2048^2 pixels grew 118 B/pixel with the l2 loss and about 290 with l1-ssim (its SSIM maps).
RENDER_BYTES_PER_PIXEL = 48  # padded image and weight planes, their device views and the written copy
FIT_BYTES_PER_PIXEL = 160  # + target, loss, dL/dI and the adjoint planes (l2, l1)
SSIM_BYTES_PER_PIXEL = 340  # the same with l1-ssim's blurred moment maps
BYTES_PER_SPLAT = 256  # loaded and scaled parameters, packed rows, device buffers, boxes
RENDER_BYTES_PER_PAIR = 16  # tile lists on the device and the host, each pair's tile
# + gradient rows (device and host) and their float64 bincount weights; measured when one bincount also took int64 keys
FIT_BYTES_PER_PAIR = 400


@dataclass
class GaussParams:
    """N splats fitted to a width x height image (arrays are float32, one row per splat)."""

    xy: np.ndarray  # (N, 2) centre in pixels, pixel (i, j) has its centre at (i + 0.5, j + 0.5)
    log_scale: np.ndarray  # (N, 2) log sigma along the rotated axes
    theta: np.ndarray  # (N,) rotation, radians
    color: np.ndarray  # (N, 3) base colour
    lum: np.ndarray  # (N,) luminance factor (what `--learn scale-lum` fits); colour = lum * color
    opacity: np.ndarray  # (N,) in [0, 1]
    width: int = 0
    height: int = 0
    blend: str = "normalized"
    background: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))

    def __post_init__(self):
        for name in GROUPS:
            setattr(self, name, np.ascontiguousarray(getattr(self, name), dtype=np.float32))
        self.background = np.asarray(self.background, dtype=np.float32).reshape(3)
        if self.blend not in BLENDS:
            raise UsageError(f"blend {self.blend!r} is unknown; allowed: {', '.join(BLENDS)}")

    @property
    def n(self) -> int:
        return len(self.xy)

    def groups(self) -> dict[str, np.ndarray]:
        """The learnable arrays by group name (views: the optimiser updates them in place)."""
        return {name: getattr(self, name) for name in GROUPS}

    def select(self, index: np.ndarray) -> GaussParams:
        """A new model made of the splats at `index` (repeats allowed)."""
        return GaussParams(
            **{name: getattr(self, name)[index] for name in GROUPS},
            width=self.width,
            height=self.height,
            blend=self.blend,
            background=self.background,
        )

    def copy(self) -> GaussParams:
        return self.select(np.arange(self.n))

    def scaled(self, factor: float, width: int, height: int) -> GaussParams:
        """The same picture for a (factor x) larger image: centres and scales grow, colours stay."""
        out = self.copy()
        out.xy *= factor
        out.log_scale += np.float32(np.log(factor))
        out.width, out.height = int(width), int(height)
        return out

    def save(self, path, *, overwrite: bool = True) -> None:
        """Write the splats as .npz through a temp file (clrender/outputs.py)."""
        from ..outputs import save_npz

        save_npz(path, overwrite=overwrite, **self.groups(), width=self.width, height=self.height, blend=self.blend, background=self.background)

    @classmethod
    def load(cls, path) -> GaussParams:
        """Splats saved by `save`; UsageError (one line) for a file that is damaged or not a splat file."""
        where = shown(path)
        try:
            with np.load(path, allow_pickle=False) as f:
                if not isinstance(f, np.lib.npyio.NpzFile):
                    raise ValueError("a single .npy array, not an .npz archive")
                data = {k: f[k] for k in f.files}
        except UsageError:
            raise
        except Exception as exc:  # BadZipFile, EOFError, zlib.error, ...: every damaged file is bad input
            reason = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
            raise UsageError(f"cannot read splat parameters from {where} ({type(exc).__name__}: {reason})") from None
        missing = [k for k in (*GROUPS, "width", "height", "blend") if k not in data]
        if missing:
            raise UsageError(f"{where} is not a splat parameter file (missing {', '.join(missing)})")
        return cls(
            **_checked_groups(data, where),
            width=_checked_size(data, "width", where),
            height=_checked_size(data, "height", where),
            blend=_checked_blend(data, where),
            background=_checked_array(data.get("background", np.zeros(3)), "background", (3,), where, (-MAX_COLOR, MAX_COLOR)),
        )


GROUP_SHAPES = {"xy": (2,), "log_scale": (2,), "theta": (), "color": (3,), "lum": (), "opacity": ()}  # per splat
# What a loaded file may hold (docs/splat-gauss.md).  Beyond these the kernels' float32 arithmetic
# overflows (exp(2 log sx) in splat_prepare, a sum of 10 M colours) and images come out inf or NaN.
MAX_COLOR = 1e6  # |colour|, |background| and luminance: HDR headroom, while 10 M sums stay finite
GROUP_RANGES = {
    "xy": (-(2.0**20), 2.0**20),  # pixels; far outside any image, finite after scaling by 32768
    "log_scale": (-10.0, 10.0),  # sigma from 5e-5 to 22026 pixels; exp(4 log s) stays finite after scaling
    "theta": (-1e6, 1e6),  # radians
    "color": (-MAX_COLOR, MAX_COLOR),
    "lum": (0.0, MAX_COLOR),
    "opacity": (0.0, 1.0),
}
MAX_LOADED_SPLATS = 10_000_000
MAX_SIDE = 32768


def _checked_array(value, name: str, shape: tuple, where: str, bounds: tuple[float, float] | None = None) -> np.ndarray:
    """A finite float array of exactly `shape` within `bounds`; UsageError naming the file and the array otherwise."""
    value = np.asarray(value)
    if value.dtype.kind not in "fiu":
        raise UsageError(f"{where}: {name} holds {value.dtype} values; allowed: numbers")
    if value.shape != shape:
        raise UsageError(f"{where}: {name} has shape {value.shape}; allowed: {shape}")
    with np.errstate(over="ignore"):
        value = value.astype(np.float32)
    if not np.isfinite(value).all():
        raise UsageError(f"{where}: {name} holds NaN or infinite values (or beyond float32); allowed: finite numbers")
    if bounds is not None and value.size:
        low, high = bounds
        outside = (value < low) | (value > high)
        if outside.any():
            bad = value[outside].flat[0]
            raise UsageError(f"{where}: {name} holds {bad:g} ({int(outside.sum())} values out of range); allowed: {low:g} to {high:g}")
    return value


def _checked_groups(data: dict, where: str) -> dict:
    n = np.shape(data["xy"])[0] if np.ndim(data["xy"]) >= 1 else -1
    if not 0 <= n <= MAX_LOADED_SPLATS:
        raise UsageError(f"{where}: xy has shape {np.shape(data['xy'])}; allowed: (N, 2) with N up to {MAX_LOADED_SPLATS}")
    return {name: _checked_array(data[name], name, (n, *GROUP_SHAPES[name]), where, GROUP_RANGES[name]) for name in GROUPS}


def _checked_size(data: dict, name: str, where: str) -> int:
    value = np.asarray(data[name])
    if value.shape != () or value.dtype.kind not in "iu" or not 1 <= int(value) <= MAX_SIDE:
        raise UsageError(f"{where}: {name} is {shown(value)}; allowed: a whole number from 1 to {MAX_SIDE}")
    return int(value)


def _checked_blend(data: dict, where: str) -> str:
    value = np.asarray(data["blend"])
    if value.shape != () or value.dtype.kind != "U" or str(value) not in BLENDS:
        raise UsageError(f"{where}: blend is {shown(value)}; allowed: {', '.join(BLENDS)}")
    return str(value)


# ----------------------------------------------------------------------------- geometry


@dataclass
class Binning:
    """Splats sorted into 16x16 tiles (all arrays int32)."""

    tiles_x: int
    tiles_y: int
    tile_start: np.ndarray  # (tiles + 1,) entries of tile t: [tile_start[t], tile_start[t+1])
    entry_splat: np.ndarray  # (entries,) splat of each entry, sorted by tile then splat
    entry_tile: np.ndarray  # (entries,) tile of each entry

    @property
    def n_entries(self) -> int:
        return len(self.entry_splat)


# ----------------------------------------------------------------------------- kernels


@dataclass
class PreparedSplats:
    """The device buffers splat_prepare fills, one record per splat (clrender/layout.py)."""

    splats: object  # GAUSS_SPLAT_DTYPE: centre, inverse covariance, opacity, row parabolas
    colors: object  # SPLAT_COLOR_DTYPE: luminance * colour
    boxes: object  # SPLAT_BOX_DTYPE: pixel range of the 3-sigma ellipse


@dataclass
class Frame:
    """What one forward pass leaves for the backward pass."""

    image: np.ndarray  # (H, W, 3) rendered colour (pixels of unrendered tiles are 0)
    weight: np.ndarray  # (H, W) sum of splat weights
    tiles: np.ndarray  # int32 tiles rendered
    binning: Binning
    packed: PreparedSplats
    params: GaussParams


class GaussRenderer:
    """Renders GaussParams with the OpenCL kernels and back-propagates image gradients."""

    def __init__(self, device, width: int, height: int, blend: str = "normalized", background=(0, 0, 0), *, fit_loss: str | None = None):
        """`fit_loss`: the loss of the fit this renderer serves (None: rendering only); it sets the memory estimate."""
        import pyopencl as cl

        if blend not in BLENDS:
            raise UsageError(f"blend {blend!r} is unknown; allowed: {', '.join(BLENDS)}")
        if width < 1 or height < 1:
            raise UsageError(f"image size {width}x{height} is empty; both sides must be >= 1")
        self._cl = cl
        self.dev = device
        self.width, self.height, self.blend = int(width), int(height), blend
        self.background = np.zeros(4, np.float32)
        self.background[:3] = np.asarray(background, np.float32).reshape(3)
        self.tiles_x, self.tiles_y = -(-width // TILE), -(-height // TILE)
        defines = {"BLEND_NORMALIZED": int(blend == "normalized")}
        self._forward = device.kernel("splat_gauss.cl", "splat_forward", defines)
        self._prepare = device.kernel("splat_gauss.cl", "splat_prepare", defines)
        self._bin_count = device.kernel("splat_gauss.cl", "splat_bin_count", defines)
        self._bin_fill = device.kernel("splat_gauss.cl", "splat_bin_fill", defines)
        self._backward = device.kernel("splat_gauss.cl", "splat_backward", defines)
        # images are padded to whole tiles (layouts in kernels/splat_gauss.cl)
        self.pitch, self.rows = self.tiles_x * TILE, self.tiles_y * TILE
        self.plane = self.pitch * self.rows
        self.fit_loss, self.what = fit_loss, "render" if fit_loss is None else "fit"
        memory.require(self.peak_bytes(0, 0), f"a {width}x{height} splat {self.what}")
        self._memory_checked = False  # the splats' share is checked at the first binning (see _pack_and_bin)
        device.check_fits(self.plane * 16, f"a {width}x{height} splat image")
        self._dimg_host = np.zeros((4, self.rows, self.pitch), np.float32)  # the padding stays 0
        self._partial = None
        self._partial_bytes = 0
        self.all_tiles = np.arange(self.tiles_x * self.tiles_y, dtype=np.int32)

    def peak_bytes(self, n: int, pairs: int) -> int:
        """Estimated peak memory of this renderer's job with n splats covering `pairs` (tile, splat) pairs."""
        return peak_bytes(self.pitch, self.rows, n, pairs, fit_loss=self.fit_loss)

    def count_pairs(self, boxes: np.ndarray) -> int:
        """(tile, splat) pairs of these pixel boxes [x0, x1) x [y0, y1) (SPLAT_BOX_DTYPE), in 64 bits: the
        kernels' int32 prefix sums would wrap (box_in_tile_row's rule, vectorised)."""
        x0, y0, x1, y1 = (boxes[name].astype(np.int64) for name in ("x0", "y0", "x1", "y1"))
        cols = (x1 - 1) // TILE - x0 // TILE + 1
        rows = (y1 - 1) // TILE - y0 // TILE + 1
        empty = (x1 <= x0) | (y1 <= y0)
        return int(np.where(empty, 0, cols * rows).sum(dtype=np.int64))

    def _check_pairs(self, n: int, pairs: int) -> None:
        """Refuse, before the tile lists are allocated, a binning the kernels cannot index or memory cannot hold."""
        what = f"{n} splats covering {pairs} (tile, splat) pairs of a {self.width}x{self.height} image"
        if not self._memory_checked:
            # once: later checks would count this job's own memory as taken (MemAvailable already excludes it)
            memory.require(self.peak_bytes(n, pairs), f"a splat {self.what} of {what}")
            self._memory_checked = True
        if pairs > MAX_PAIRS:
            raise UsageError(f"{what}: too many; allowed: at most {MAX_PAIRS} pairs (fewer or smaller splats, or a smaller image)")

    def forward(self, params: GaussParams, tiles: np.ndarray | None = None) -> Frame:
        """Render all tiles (or only `tiles`, the rest left 0); returns a Frame for `backward`."""
        dev = self.dev
        if (params.width, params.height) != (self.width, self.height):
            raise UsageError(f"parameters are for {params.width}x{params.height}, renderer is {self.width}x{self.height}")
        tiles = self.all_tiles if tiles is None else np.ascontiguousarray(tiles, np.int32)
        buffers, tile_splats, binning = self._pack_and_bin(params)
        # fresh arrays, so a Frame stays valid after the next forward pass; the kernel writes
        # into them directly on a CPU device (no copy, no interleaving pass on the host)
        zero = len(tiles) < len(self.all_tiles)
        image, weight = aligned_array((self.rows, self.pitch, 3), zero), aligned_array((self.rows, self.pitch), zero)
        image_buf, weight_buf = dev.host_buffer(image), dev.host_buffer(weight)
        if len(tiles):
            self._forward(
                dev.queue,
                (len(tiles),),
                (1,),
                splats=buffers.splats,
                colors=buffers.colors,
                bbox=buffers.boxes,
                tile_start=dev.to_device(binning.tile_start),
                tile_splats=tile_splats,
                tiles=dev.to_device(tiles),
                tiles_x=self.tiles_x,
                background=self.background,
                image=image_buf,
                weight=weight_buf,
            )
        dev.sync_to_host(image_buf, image)
        dev.sync_to_host(weight_buf, weight)
        return Frame(image[: self.height, : self.width], weight[: self.height, : self.width], tiles, binning, buffers, params)

    def _pack_and_bin(self, params: GaussParams):
        """Pack the splats and bin them into tiles on the device.

        Returns the PreparedSplats buffers, the tile lists' buffer and the
        Binning, whose entry_splat is filled by a copy still queued (the in-order
        queue finishes it before anything read back later).
        """
        cl, dev = self._cl, self.dev
        n, tiles = params.n, len(self.all_tiles)
        packed = np.empty(n, SPLAT_PARAMS_DTYPE)
        for name in GROUPS:
            packed[name] = getattr(params, name)
        buffers = PreparedSplats(
            dev.empty(n * GAUSS_SPLAT_DTYPE.itemsize), dev.empty(n * SPLAT_COLOR_DTYPE.itemsize), dev.empty(n * SPLAT_BOX_DTYPE.itemsize)
        )
        count = np.zeros(tiles, np.int32)
        if n:
            # fixed local sizes: PoCL builds a kernel binary per local size
            self._prepare(
                dev.queue,
                (-(-n // PREPARE_GROUP) * PREPARE_GROUP,),
                (PREPARE_GROUP,),
                params=dev.to_device(packed),
                n=n,
                width=self.width,
                height=self.height,
                splats=buffers.splats,
                colors=buffers.colors,
                bbox=buffers.boxes,
            )
            boxes = np.empty(n, SPLAT_BOX_DTYPE)
            cl.enqueue_copy(dev.queue, boxes, buffers.boxes)
            self._check_pairs(n, self.count_pairs(boxes))
            del boxes
            count_buf = dev.empty(count.nbytes)
            self._bin_count(dev.queue, (self.tiles_y,), (1,), bbox=buffers.boxes, n=n, tiles_x=self.tiles_x, count=count_buf)
            cl.enqueue_copy(dev.queue, count, count_buf)
        # summed in 64 bits; _check_pairs has bounded the total, so the int32 starts the kernels read hold it
        total = np.zeros(tiles + 1, np.int64)
        np.cumsum(count, out=total[1:])
        if total[-1] > MAX_PAIRS:  # the kernel counted what count_pairs did: this is a bug if it happens
            raise RuntimeError(f"splat binning counted {int(total[-1])} pairs; the boxes allow at most {MAX_PAIRS}")
        tile_start = total.astype(np.int32)
        n_entries = int(tile_start[-1])
        dev.check_fits(n_entries * 4, f"{n_entries} splat-tile entries")
        entry_splat = np.empty(n_entries, np.int32)
        tile_splats = dev.empty(n_entries * 4)
        if n_entries:
            self._bin_fill(
                dev.queue,
                (self.tiles_y,),
                (1,),
                bbox=buffers.boxes,
                n=n,
                tiles_x=self.tiles_x,
                cursor=dev.to_device(tile_start[:-1], writable=True),
                tile_splats=tile_splats,
            )
            cl.enqueue_copy(dev.queue, entry_splat, tile_splats, is_blocking=False)
        entry_tile = np.repeat(self.all_tiles, count)
        return buffers, tile_splats, Binning(self.tiles_x, self.tiles_y, tile_start, entry_splat, entry_tile)

    def backward(self, frame: Frame, d_image: np.ndarray) -> dict[str, np.ndarray]:
        """Gradients of the loss for every parameter group, from dL/dI (H, W, 3).

        Also returns "weight": each splat's summed weight over the rendered
        pixels (how much it contributes; used for pruning).
        """
        cl, dev = self._cl, self.dev
        binning, params = frame.binning, frame.params
        dimg = self._dimg_host
        pixel_adjoint(d_image, frame.image, frame.weight, self.blend, dimg[:, : self.height, : self.width])
        if len(frame.tiles) == len(self.all_tiles):
            entries = slice(None)
        else:
            selected = np.zeros(len(self.all_tiles), bool)
            selected[frame.tiles] = True
            entries = np.nonzero(selected[binning.entry_tile])[0]
        entry_splat = np.ascontiguousarray(binning.entry_splat[entries])
        entry_tile = np.ascontiguousarray(binning.entry_tile[entries])
        n_entries = len(entry_splat)
        nbytes = n_entries * SPLAT_GRAD_DTYPE.itemsize
        dev.check_fits(nbytes, f"{n_entries} splat-tile gradient rows")
        if nbytes > self._partial_bytes:
            self._partial_bytes = max(nbytes, int(self._partial_bytes * 1.5))
            self._partial = dev.empty(self._partial_bytes)
        partial = np.empty(n_entries, SPLAT_GRAD_DTYPE)
        if n_entries:
            # a fixed work-group size: PoCL builds a kernel binary per local size, so letting the
            # driver choose one from the (changing) entry count would rebuild it every few steps
            groups = -(-n_entries // BACKWARD_GROUP)
            self._backward(
                dev.queue,
                (groups * BACKWARD_GROUP,),
                (BACKWARD_GROUP,),
                splats=frame.packed.splats,
                colors=frame.packed.colors,
                bbox=frame.packed.boxes,
                entry_splat=dev.to_device(entry_splat),
                entry_tile=dev.to_device(entry_tile),
                n_entries=n_entries,
                tiles_x=self.tiles_x,
                plane=self.plane,
                dimg=dev.to_device(dimg),
                partial=self._partial,
            )
            cl.enqueue_copy(dev.queue, partial, self._partial)
        return chain_rule(params, sum_per_splat(partial, entry_splat, params.n))


def sum_per_splat(partial: np.ndarray, entry_splat: np.ndarray, n: int) -> np.ndarray:
    """Each splat's sum of its entries' gradients (SPLAT_GRAD_DTYPE rows, entry order), field by field, in float64."""
    sums = np.zeros(n, _GRAD_SUMS)
    for name in SPLAT_GRAD_DTYPE.names:
        values, total = partial[name], sums[name]
        if values.ndim == 1:
            total[:] = np.bincount(entry_splat, weights=values, minlength=n)
        else:
            for k in range(values.shape[1]):
                total[:, k] = np.bincount(entry_splat, weights=values[:, k], minlength=n)
    return sums


def peak_bytes(width: int, height: int, n: int = 0, pairs: int = 0, *, fit_loss: str | None = None) -> int:
    """Estimated peak memory of a render (fit_loss None) or a fit with that loss of n splats covering
    `pairs` (tile, splat) pairs of a width x height image (see the constants at the top)."""
    if fit_loss is None:
        per_pixel, per_pair = RENDER_BYTES_PER_PIXEL, RENDER_BYTES_PER_PAIR
    else:
        per_pixel, per_pair = (SSIM_BYTES_PER_PIXEL if fit_loss == "l1-ssim" else FIT_BYTES_PER_PIXEL), FIT_BYTES_PER_PAIR
    return memory.BASE_BYTES + width * height * per_pixel + n * BYTES_PER_SPLAT + pairs * per_pair


def aligned_array(shape, zero: bool) -> np.ndarray:
    """A float32 array (zeroed or not) whose data starts on a 64-byte boundary: kernels store
    aligned float8 vectors into it through a host buffer."""
    n = int(np.prod(shape))
    raw = (np.zeros if zero else np.empty)(n + 16, np.float32)
    start = (-raw.ctypes.data % 64) // 4
    return raw[start : start + n].reshape(shape)


def pixel_adjoint(d_image: np.ndarray, image: np.ndarray, weight: np.ndarray, blend: str, out: np.ndarray) -> np.ndarray:
    """Fill `out` (4, H, W) with planes (g.rgb, k): dL/dc_i = g w_i and dL/dw_i = g . c_i - k.

    sum:        I = bg + S          -> g = dL/dI, k = 0
    normalized: I = (S + eps bg) / (W + eps)
                dI/dw_i = (c_i - I) / (W + eps) -> g = dL/dI / (W + eps), k = g . I
    """
    g = d_image.transpose(2, 0, 1)
    if blend == "normalized":
        g = g * (1.0 / (weight + EPS))[None]
        out[:3] = g
        out[3] = g[0] * image[..., 0] + g[1] * image[..., 1] + g[2] * image[..., 2]
    else:
        out[:3] = g
        out[3] = 0.0
    return out


def chain_rule(params: GaussParams, raw: np.ndarray) -> dict[str, np.ndarray]:
    """From the kernel's gradients per splat (mean, A, B2, C, colour, opacity; fields of
    layout.SPLAT_GRAD_DTYPE) to every parameter group."""
    ls = params.log_scale.astype(np.float64)
    a, b = np.exp(-2.0 * ls[:, 0]), np.exp(-2.0 * ls[:, 1])
    c, s = np.cos(params.theta.astype(np.float64)), np.sin(params.theta.astype(np.float64))
    gA, gB, gC = raw["A"], raw["B2"], raw["C"]
    # A = c^2 a + s^2 b, B2 = 2cs (a - b), C = s^2 a + c^2 b;  da/dlog sx = -2a
    g_a = gA * c * c + gB * 2 * c * s + gC * s * s
    g_b = gA * s * s - gB * 2 * c * s + gC * c * c
    g_theta = gA * 2 * c * s * (b - a) + gB * 2 * (c * c - s * s) * (a - b) + gC * 2 * c * s * (a - b)
    g_color_eff = raw["color"]
    return {
        "xy": raw["mean"].astype(np.float32),
        "log_scale": np.stack([-2 * a * g_a, -2 * b * g_b], axis=1).astype(np.float32),
        "theta": g_theta.astype(np.float32),
        "color": (g_color_eff * params.lum[:, None]).astype(np.float32),
        "lum": np.einsum("ij,ij->i", g_color_eff, params.color).astype(np.float32),
        "opacity": raw["opacity"].astype(np.float32),
        "weight": raw["weight"].astype(np.float32),
    }


def render(device, params: GaussParams) -> np.ndarray:
    """(H, W, 3) float32 image of `params` at its own size."""
    renderer = GaussRenderer(device, params.width, params.height, params.blend, params.background)
    return renderer.forward(params).image
