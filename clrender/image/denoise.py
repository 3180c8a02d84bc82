"""Denoising a path-traced image with Intel Open Image Denoise (OIDN), through the `pyoidn` wheel.

OIDN is the production denoiser Blender, Mitsuba's tooling and most offline renderers use: a
trained U-Net that runs on the CPU, takes the noisy beauty together with the first hit's albedo and
normal (which keep edges and textures that a blur would smear) and gives the same result for the
same input on the same machine.  It is an optional dependency (setup.cfg extra `denoise`):
`require_oidn()` refuses `--denoise` with the install hint before anything is rendered.

The auxiliary images are the path tracer's `albedo` and `normal` AOVs (clrender/trace/aov.py): the
filtered mean of every path's first hit, as the beauty is, so free of Monte Carlo noise: OIDN is told
they are clean (`clean_aux=True`; measured in docs/display.md: it lowers the error, and with one-ray
AOVs it raised it).  The beauty is HDR (radiance above 1 is kept), so `hdr=True`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import RenderFailure, UsageError, real_array

INSTALL_HINT = "--denoise needs Intel Open Image Denoise: pip install 'clrender[denoise]' (the pyoidn wheel)"
AUX_AOVS = ("albedo", "normal")  # the AOVs OIDN takes beside the beauty


@dataclass(frozen=True)
class DenoiseSettings:
    quality: str = "high"  # OIDN's filter quality: "high" (offline rendering), "balanced" or "fast"
    use_aux: bool = True  # pass the albedo and normal AOVs (without them OIDN blurs across edges)


def require_oidn():
    """The pyoidn module; UsageError with the install hint when it is not installed."""
    try:
        import pyoidn
    except ImportError:
        raise UsageError(INSTALL_HINT) from None
    return pyoidn


def aux_images(aovs: dict) -> tuple[np.ndarray, np.ndarray]:
    """(albedo in [0, 1], normal in [-1, 1]) as contiguous float32 (H, W, 3), from the render's AOVs."""
    missing = [name for name in AUX_AOVS if name not in aovs]
    if missing:
        raise UsageError(f"denoising needs the {' and '.join(missing)} AOV(s) of the render; render with aovs={AUX_AOVS!r}")
    albedo = np.ascontiguousarray(np.clip(np.asarray(aovs["albedo"], np.float32), 0.0, 1.0))
    normal = np.ascontiguousarray(np.clip(np.asarray(aovs["normal"], np.float32), -1.0, 1.0))
    return albedo, normal


def denoise(image: np.ndarray, albedo=None, normal=None, settings: DenoiseSettings | None = None) -> np.ndarray:
    """The denoised (H, W, 3) float32 linear image; albedo and normal (H, W, 3) are the auxiliary images."""
    s = settings or DenoiseSettings()
    pyoidn = require_oidn()
    color = np.ascontiguousarray(np.maximum(np.nan_to_num(rgb_image(image, "the image to denoise")), 0.0))  # OIDN takes HDR >= 0
    if not s.use_aux:
        albedo = normal = None
    if normal is not None and albedo is None:
        raise UsageError("OIDN takes a normal image only together with an albedo image")
    for name, aux in (("albedo", albedo), ("normal", normal)):
        if aux is not None and np.shape(aux) != color.shape:
            raise UsageError(f"{name} image has shape {np.shape(aux)}; the image to denoise is {color.shape}")
    try:
        out = pyoidn.denoise(color, albedo, normal, hdr=True, clean_aux=True, quality=s.quality)
    except RuntimeError as exc:
        raise RenderFailure(f"Open Image Denoise failed: {exc}") from None
    return np.asarray(out, np.float32)


def rgb_image(image, name: str) -> np.ndarray:
    """`image` as float32 (H, W, 3) linear RGB; UsageError naming its shape or type otherwise."""
    a = real_array(image, name)
    if a.ndim != 3 or a.shape[2] != 3 or a.shape[0] < 1 or a.shape[1] < 1:
        raise UsageError(f"{name} has shape {a.shape}; allowed: (H, W, 3), linear RGB")
    return a.astype(np.float32, copy=False)


def denoise_result(result, settings: DenoiseSettings | None = None):
    """A copy of a path-traced RenderResult whose image is denoised with its albedo and normal AOVs
    (render with `aovs=("albedo", "normal")`): it shows, converts (`.srgb8()`) and saves (`.save(path)`)
    like any render result; its timings gain "denoise"."""
    from dataclasses import replace
    from time import perf_counter

    start = perf_counter()
    albedo, normal = aux_images(getattr(result, "aovs", None) or {})
    image = denoise(result.image, albedo, normal, settings)
    return replace(result, image=image, timings={**result.timings, "denoise": perf_counter() - start})
