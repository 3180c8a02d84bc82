"""Soft Voronoi: a differentiable stand-in for "colour of the nearest site".

Each pixel p blends the colours of its K nearest sites with softmax weights

    w_i(p) = exp(-|p - s_i|^2 / T) / sum_j exp(-|p - s_j|^2 / T)     (j over the K nearest)
    out(p) = sum_i w_i(p) c_i

which tends to the hard nearest-site image as the temperature T -> 0.  The
loss is the mean squared error over pixels and channels.  With g = dL/dout:

    dL/dc_i = sum_p w_i(p) g(p)
    dL/ds_i = sum_p (g(p) . (c_i - out(p))) w_i(p) 2 (p - s_i) / T

The kernels (kernels/splat_voronoi.cl: soft_forward, soft_backward) find the
K nearest sites through the same uniform grid as the hard search and write
one gradient term per (pixel, neighbour) pair; the host sums them per site
with np.bincount (race-free, deterministic).  The K-nearest set is held
fixed when differentiating: it changes only where a (K+1)-th site ties the
K-th, where its weight is already tiny.  Training anneals T geometrically
and steps sites and colours with Adam; position steps shrink with sqrt(T),
the width of the soft borders, or training diverges as T falls.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..errors import UsageError
from ..progress import progress
from .optim import Optimizer
from .voronoi_cells import build_grid, check_sites, mean_colors, nearest_site, sample_colors

MAX_K = 16


def _pad4(colors: np.ndarray) -> np.ndarray:
    out = np.zeros((len(colors), 4), dtype=np.float32)
    out[:, : colors.shape[1]] = colors
    return out


class SoftVoronoi:
    """Forward and backward passes of the soft model for one image size and K."""

    def __init__(self, device, width: int, height: int, k: int = 8):
        if not 1 <= k <= MAX_K:
            raise UsageError(f"k {k} must be between 1 and {MAX_K}")
        self.dev, self.width, self.height, self.k = device, width, height, k
        npix = width * height
        device.check_fits(npix * k * 8, f"the soft-Voronoi buffers for {width}x{height} with k={k}")
        self.knn_idx = device.empty(npix * k * 4)
        self.knn_w = device.empty(npix * k * 4)
        self.grad_pairs = device.empty(npix * k * 8)
        self.out = device.empty(npix * 16)

    def _kernels(self, k: int):
        defines = {"K": k}
        return (self.dev.kernel("splat_voronoi.cl", "soft_forward", defines), self.dev.kernel("splat_voronoi.cl", "soft_backward", defines))

    def loss_and_grads(self, sites, colors, target, temperature: float):
        """(loss, dL/dsites (N, 2), dL/dcolors (N, C), blended image (H, W, C)) for the MSE loss."""
        import pyopencl as cl

        w, h = self.width, self.height
        sites = check_sites(sites, w, h)
        n, c = len(sites), target.shape[2]
        if c > 4:
            raise UsageError(f"soft Voronoi handles at most 4 channels, got {c}")
        k = min(self.k, n)
        forward, backward = self._kernels(k)
        q = self.dev.queue
        grid = build_grid(sites, w, h)
        colors4 = self.dev.to_device(_pad4(colors))
        sites_buf = self.dev.to_device(sites)
        inv_temp = np.float32(1.0 / temperature)
        forward(
            q,
            (w, h),
            None,
            sorted_pos=self.dev.to_device(sites[grid.order]),
            sorted_idx=self.dev.to_device(grid.order),
            cell_start=self.dev.to_device(grid.cell_start),
            grid_cells=(grid.gw, grid.gh),
            cell=grid.cell,
            width=w,
            height=h,
            colors=colors4,
            inv_temp=inv_temp,
            knn_idx=self.knn_idx,
            knn_w=self.knn_w,
            out=self.out,
        )
        out4 = np.empty((h * w, 4), dtype=np.float32)
        cl.enqueue_copy(q, out4, self.out)
        residual = out4[:, :c] - target.reshape(-1, c)
        loss = float(np.mean(residual.astype(np.float64) ** 2))
        g4 = np.zeros((h * w, 4), dtype=np.float32)
        g4[:, :c] = residual * np.float32(2.0 / residual.size)
        backward(
            q,
            (w, h),
            None,
            sites=sites_buf,
            colors=colors4,
            knn_idx=self.knn_idx,
            knn_w=self.knn_w,
            out=self.out,
            grad_out=self.dev.to_device(g4),
            inv_temp=inv_temp,
            width=w,
            height=h,
            grad_pos=self.grad_pairs,
        )
        idx = np.empty(h * w * k, dtype=np.int32)
        wts = np.empty(h * w * k, dtype=np.float32)
        pairs = np.empty((h * w * k, 2), dtype=np.float32)
        cl.enqueue_copy(q, idx, self.knn_idx)
        cl.enqueue_copy(q, wts, self.knn_w)
        cl.enqueue_copy(q, pairs, self.grad_pairs)
        grad_sites = np.stack([np.bincount(idx, weights=pairs[:, a], minlength=n) for a in range(2)], axis=1)
        g_rep = np.repeat(g4[:, :c], k, axis=0)  # g of the pixel of each (pixel, neighbour) pair
        grad_colors = np.stack([np.bincount(idx, weights=wts * g_rep[:, a], minlength=n) for a in range(c)], axis=1)
        return loss, grad_sites, grad_colors, out4[:, :c].reshape(h, w, c)


@dataclass(frozen=True)
class TrainSettings:
    """Settings of the soft-Voronoi training, each with its default; change one with dataclasses.replace."""

    steps: int = 100  # Adam steps
    k: int = 8  # sites blended per pixel
    t_start: float = 0.25  # starting temperature, in units of the mean site spacing squared
    t_end: float = 0.01  # final temperature, same units (geometric schedule)
    lr_sites: float = 0.1  # Adam rate for positions at t_start, in units of the mean site spacing;
    # it shrinks with sqrt(T) as the temperature falls
    lr_colors: float = 0.01  # Adam rate for colours


@dataclass
class TrainResult:
    sites: np.ndarray
    colors: np.ndarray
    losses: list = field(default_factory=list)


def train(device, image, sites, *, steps: int | None = None, settings: TrainSettings | None = None, colors=None, callback=None) -> TrainResult:
    """Fit sites and colours of the soft model to `image`; returns the trained sites and colours."""
    st = settings or TrainSettings()
    if steps is not None:
        st = replace(st, steps=steps)  # the caller's settings stay as they were
    image = np.ascontiguousarray(image, dtype=np.float32)
    h, w, c = image.shape
    sites = check_sites(sites, w, h).copy()
    n = len(sites)
    if colors is None:
        index = nearest_site(device, sites, w, h)
        colors = mean_colors(image, index, n, fallback=sample_colors(image, sites))
    colors = np.array(colors, dtype=np.float32)
    spacing = math.sqrt(w * h / n)
    model = SoftVoronoi(device, w, h, st.k)
    opt = Optimizer("adam", {"sites": st.lr_sites * spacing, "colors": st.lr_colors})
    params = {"sites": sites, "colors": colors}
    losses = []
    for step in progress(range(st.steps), total=st.steps, desc="soft voronoi"):
        frac = step / max(st.steps - 1, 1)
        temperature = spacing * spacing * st.t_start * (st.t_end / st.t_start) ** frac
        # position steps shrink with the blending width sqrt(T): a step wider than
        # the soft border overshoots once T is small
        opt.lrs["sites"] = st.lr_sites * math.sqrt(temperature / st.t_start)
        loss, g_sites, g_colors, _ = model.loss_and_grads(sites, colors, image, temperature)
        opt.step(params, {"sites": g_sites, "colors": g_colors})
        np.clip(sites[:, 0], 0.0, w, out=sites[:, 0])
        np.clip(sites[:, 1], 0.0, h, out=sites[:, 1])
        losses.append(loss)
        if callback is not None:
            callback(step, loss)
    return TrainResult(sites, colors, losses)
