"""Image losses and their gradients with respect to the rendered image (numpy + OpenCV on the host).

Every loss takes the rendered image x and the target y, both (H, W, 3), and an
optional pixel mask (H, W) of the pixels that count (a mini-batch); it returns
(loss, dL/dx).  Means are over the counted pixels and the three channels.

    l2:      mean (x - y)^2                                  (mean squared error)
    l1:      mean |x - y|           (subgradient 0 where x = y)
    l1-ssim: l1 + lambda * (1 - SSIM(x, y)), lambda = 0.2, SSIM with an 11x11
             Gaussian window (sigma 1.5), zero padding, C1 = 0.01^2, C2 = 0.03^2
             (the usual constants for values in [0, 1]); the SSIM map is averaged
             over the whole image, its gradient is then masked.
"""

from __future__ import annotations

import cv2
import numpy as np

from ..errors import UsageError

LOSSES = ("l2", "l1", "l1-ssim")
SSIM_LAMBDA = 0.2
SSIM_C1, SSIM_C2 = 0.01**2, 0.03**2
_WINDOW = cv2.getGaussianKernel(11, 1.5)


def _blur(a: np.ndarray) -> np.ndarray:
    """Gaussian window, zero padding: a symmetric linear map, so it is its own adjoint."""
    return cv2.sepFilter2D(a, -1, _WINDOW.astype(a.dtype), _WINDOW.astype(a.dtype), borderType=cv2.BORDER_CONSTANT)


def ssim(x: np.ndarray, y: np.ndarray, *, with_grad: bool = False):
    """Mean SSIM over pixels and channels, and optionally d(mean SSIM)/dx."""
    mx, my = _blur(x), _blur(y)
    exx, eyy, exy = _blur(x * x), _blur(y * y), _blur(x * y)
    a1 = 2 * mx * my + SSIM_C1
    a2 = 2 * (exy - mx * my) + SSIM_C2
    b1 = mx * mx + my * my + SSIM_C1
    b2 = (exx - mx * mx) + (eyy - my * my) + SSIM_C2
    s = a1 * a2 / (b1 * b2)
    value = float(s.mean())
    if not with_grad:
        return value
    # s as a function of (mx, exx, exy) per pixel, then through the blurs back to x
    d_exx = -s / b2
    d_exy = 2 * a1 / (b1 * b2)
    d_mx = 2 * my * (a2 - a1) / (b1 * b2) - 2 * mx * s / b1 + 2 * mx * s / b2
    grad = (_blur(d_mx) + 2 * x * _blur(d_exx) + y * _blur(d_exy)) / s.size
    return value, grad


def loss_and_grad(name: str, x: np.ndarray, y: np.ndarray, mask: np.ndarray | None = None):
    """(loss, dL/dx) for loss `name`; dtype follows x (float32 in training, float64 in tests)."""
    if name not in LOSSES:
        raise UsageError(f"loss {name!r} is unknown; allowed: {', '.join(LOSSES)}")
    diff = x - y
    if mask is not None:
        m = mask[..., None].astype(x.dtype)
        diff = diff * m
        count = max(float(mask.sum()) * x.shape[2], 1.0)
    else:
        count = float(diff.size)
    if name == "l2":
        return float(np.dot(diff.ravel(), diff.ravel())) / count, (2.0 / count) * diff
    l1 = float(np.abs(diff).sum()) / count
    grad = np.sign(diff) / count
    if name == "l1":
        return l1, grad.astype(x.dtype)
    value, d_ssim = ssim(x, y, with_grad=True)
    if mask is not None:
        d_ssim = d_ssim * m
    return l1 + SSIM_LAMBDA * (1.0 - value), (grad - SSIM_LAMBDA * d_ssim).astype(x.dtype)


def psnr(x: np.ndarray, y: np.ndarray) -> float:
    """Peak signal-to-noise ratio in dB for values in [0, 1] (x is clipped, as when saved)."""
    mse = float(np.mean((np.clip(x, 0.0, 1.0) - y) ** 2, dtype=np.float64))
    return float("inf") if mse == 0 else float(10.0 * np.log10(1.0 / mse))
