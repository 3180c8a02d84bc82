"""Images in notebooks and on screen.

`png_bytes(image, linear=...)` encodes an array as an 8-bit PNG: linear renders are sRGB-encoded
first, masks (bool) become black and white, stored values (what splat fits and filters hold) are
written as they are.  Results carry `_repr_png_` built on it, so a `RenderResult` or a splat
result shows itself as the last expression of a Jupyter cell.  `show(x)` shows an array or a
result: inline under IPython, in a matplotlib window elsewhere, or (with no display at all) as a
PNG file whose path it prints and returns.
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np


def png_bytes(image, *, linear: bool = True) -> bytes:
    """8-bit PNG of a (H, W) or (H, W, 1..4) array; float values in [0, 1] (clipped).
    linear=True: the colour channels are linear light and are sRGB-encoded (alpha is not)."""
    import cv2

    from .files import linear_to_srgb

    pixels = np.asarray(image)
    if pixels.dtype == bool:
        pixels, linear = pixels.astype(np.float32), False
    if pixels.ndim == 2:
        pixels = pixels[..., None]
    if pixels.ndim == 3 and pixels.shape[2] == 2:  # grey + alpha: the grey
        pixels = pixels[..., :1]
    if pixels.ndim != 3 or pixels.shape[2] not in (1, 3, 4) or pixels.size == 0:  # 2 became 1 above
        raise ValueError(f"cannot show an array of shape {np.shape(image)}; expected (H, W) or (H, W, 1 to 4)")
    pixels = np.nan_to_num(pixels.astype(np.float32), nan=0.0, posinf=1.0, neginf=0.0)
    if linear:
        pixels = pixels.copy()
        colour = min(pixels.shape[2], 3)
        pixels[..., :colour] = linear_to_srgb(pixels[..., :colour])
    codes = np.round(np.clip(pixels, 0, 1) * 255).astype(np.uint8)
    if codes.shape[2] >= 3:  # OpenCV writes BGR(A)
        codes = np.concatenate([codes[..., 2::-1], codes[..., 3:]], axis=2)
    ok, data = cv2.imencode(".png", codes)
    if not ok:  # pragma: no cover - cv2 encodes any uint8 array of these shapes
        raise RuntimeError("PNG encoding failed")
    return data.tobytes()


def show(image, *, linear: bool = True, title: str | None = None):
    """Show an image array (linear RGB by default; linear=False for stored values, masks need
    neither) or anything with `_repr_png_` (RenderResult, splat results).  Under Jupyter it displays the
    picture and returns None (so `show(x)` as a cell's last line shows it once); elsewhere it returns
    the matplotlib Figure, or the Path of the PNG it wrote."""
    png = image._repr_png_() if hasattr(image, "_repr_png_") else png_bytes(image, linear=linear)
    ipython = _ipython()
    if ipython is not None:
        from IPython.display import Image, display

        display(Image(data=png))
        return None
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "pdf", "ps", "svg", "cairo", "template"):
        return _window(png, title)
    with tempfile.NamedTemporaryFile("wb", suffix=".png", prefix="clrender-show-", delete=False) as f:
        f.write(png)
    warnings.warn(f"no display available: wrote {f.name}", stacklevel=2)
    return Path(f.name)


def _ipython():
    """The running IPython shell with a rich display (Jupyter, VS Code...), else None."""
    shell = sys.modules.get("IPython")
    if shell is None:
        return None
    try:
        ip = shell.get_ipython()
    except Exception:  # pragma: no cover
        return None
    return ip if ip is not None and getattr(ip, "kernel", None) is not None else None


def _window(png: bytes, title: str | None):  # pragma: no cover - needs a GUI
    import cv2
    import matplotlib.pyplot as plt

    rgb = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_UNCHANGED)
    rgb = rgb[..., 2::-1] if rgb.ndim == 3 else rgb
    fig, ax = plt.subplots()
    ax.imshow(rgb, cmap="gray" if rgb.ndim == 2 else None, interpolation="nearest")
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    plt.show()
    return fig
