"""Synthetic test images and numpy references, apart from the library so that it never imports its own oracle.

Used by the tests and the benchmarks: each reference is brute force in numpy, written independently
of the kernels it checks (small sizes only).
"""

from __future__ import annotations

import numpy as np


def synthetic_photo(width: int = 512, height: int = 512, seed: int = 0) -> np.ndarray:
    """A deterministic photo-like linear RGB image (H, W, 3) in [0, 1]: sky gradient,
    rolling hills, soft discs, hard-edged shapes and multi-octave value-noise texture."""
    import cv2  # only here: the references need numpy alone

    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float32)
    u, v = (xs + 0.5) / width, (ys + 0.5) / height
    img = np.empty((height, width, 3), np.float32)
    img[...] = np.stack([0.35 + 0.3 * v, 0.5 + 0.25 * v, 0.85 - 0.2 * v], axis=2)  # sky
    texture = np.zeros((height, width), np.float32)
    for octave in range(1, 9):  # value noise: coarse-to-fine random grids, smoothly upsampled
        cells = 2**octave
        grid = rng.random((cells + 1, cells + 1)).astype(np.float32)
        texture += cv2.resize(grid, (width, height), interpolation=cv2.INTER_CUBIC) / 1.35**octave
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


def nearest_site_reference(sites, width: int, height: int) -> np.ndarray:
    """numpy brute force in float32, the same arithmetic as the kernels (for tests; small sizes)."""
    sites = np.asarray(sites, dtype=np.float32)
    ys, xs = np.mgrid[0:height, 0:width].astype(np.float32) + np.float32(0.5)
    dx = xs.reshape(-1, 1) - sites[None, :, 0]
    dy = ys.reshape(-1, 1) - sites[None, :, 1]
    d2 = dx * dx + dy * dy
    return np.argmin(d2, axis=1).astype(np.int32).reshape(height, width)  # argmin: first (lowest) on ties


def soft_loss_reference(sites, colors, target, temperature: float, k: int) -> float:
    """The same loss in float64 numpy, brute force (for finite-difference tests; small sizes)."""
    h, w, c = target.shape
    ys, xs = np.mgrid[0:h, 0:w]
    p = np.stack([xs.ravel() + 0.5, ys.ravel() + 0.5], axis=1)
    s = np.asarray(sites, np.float64)
    d2 = ((p[:, None, :] - s[None, :, :]) ** 2).sum(axis=2)
    k = min(k, len(s))
    order = np.lexsort((np.broadcast_to(np.arange(len(s)), d2.shape), d2), axis=1)[:, :k]
    dk = np.take_along_axis(d2, order, axis=1)
    a = -(dk - dk[:, :1]) / temperature
    wts = np.exp(a)
    wts /= wts.sum(axis=1, keepdims=True)
    out = (wts[:, :, None] * np.asarray(colors, np.float64)[order]).sum(axis=1)
    return float(np.mean((out - target.reshape(-1, c)) ** 2))
