"""Image reading and writing through OpenImageIO.

Pixels travel as float32 arrays of shape (H, W, C).  Integer files are read
as values in [0, 1] (OpenImageIO's normalisation) and remember their stored
format so a filter can write the same bit depth back.  Writes go to a
temporary file beside the target and are renamed into place, so a failed
write never leaves a half-written image.
"""
from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from .errors import UsageError

# Formats whose writers store floats; everything else is written as integers.
FLOAT_EXTENSIONS = {".exr", ".hdr", ".pfm"}
# Extensions that are conventionally sRGB-encoded 8/16-bit images.
DISPLAY_EXTENSIONS = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp", ".tga", ".webp"}


@dataclass
class Image:
    """Pixels plus the facts about the file they came from."""

    pixels: np.ndarray  # float32 (H, W, C)
    format: str = "float"  # stored channel type: "uint8", "uint16", "half", "float"
    channel_names: tuple = ()  # e.g. ("R", "G", "B", "A")

    @property
    def alpha_channel(self) -> int | None:
        """Index of the alpha channel, if the file had one."""
        for i, name in enumerate(self.channel_names):
            if name.upper() == "A":
                return i
        return None


def read_image(path: str | os.PathLike) -> Image:
    """Read any image OpenImageIO understands; UsageError if it cannot."""
    path = Path(path)
    if not path.is_file():
        raise UsageError(f"input image {str(path)!r} does not exist")
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        raise UsageError(f"cannot read {str(path)!r} as an image ({oiio.geterror().strip() or 'unknown format'})")
    try:
        spec = inp.spec()
        pixels = inp.read_image(0, 0, 0, spec.nchannels, "float")
    finally:
        inp.close()
    if pixels is None:
        raise UsageError(f"cannot read the pixels of {str(path)!r} ({oiio.geterror().strip()})")
    pixels = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    return Image(pixels, str(spec.format), tuple(spec.channelnames))


def check_output_path(path: str | os.PathLike, *, overwrite: bool = False, inputs=()) -> Path:
    """Refuse an output we could not write, before any work is done."""
    path = Path(path)
    if not path.suffix:
        raise UsageError(f"output {str(path)!r} has no extension; use .png, .jpg, .tif, .exr or .hdr")
    probe = oiio.ImageOutput.create(str(path))
    if probe is None:
        raise UsageError(
            f"no image writer for extension {path.suffix!r} of {str(path)!r}; use .png, .jpg, .tif, .exr or .hdr"
        )
    for other in inputs:
        if Path(other).resolve() == path.resolve() and not overwrite:
            raise UsageError(f"output {str(path)!r} is the input; pass --overwrite to replace it")
    if path.exists() and not overwrite:
        raise UsageError(f"output {str(path)!r} already exists; pass --overwrite to replace it")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"output folder {str(parent)!r} does not exist")
    if not os.access(parent, os.W_OK):
        raise UsageError(f"output folder {str(parent)!r} is not writable")
    return path


def linear_to_srgb(x: np.ndarray) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1), for linear values in [0, 1]."""
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055).astype(np.float32)


def srgb_to_linear(x: np.ndarray) -> np.ndarray:
    """Inverse of linear_to_srgb."""
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.04045, x / 12.92, np.power((x + 0.055) / 1.055, 2.4)).astype(np.float32)


def write_image(
    path: str | os.PathLike,
    pixels: np.ndarray,
    *,
    format: str | None = None,
    channel_names=None,
) -> Path:
    """Write pixels (H, W[, C]) atomically.

    `format` is the stored channel type; by default float for EXR/HDR and
    uint8 otherwise.  Values are clamped to [0, 1] only for integer formats
    (OpenImageIO does that when it converts).  No colour transform happens
    here: callers encode sRGB themselves (see `write_display_image`).
    """
    path = Path(path)
    pixels = np.asarray(pixels, dtype=np.float32)
    if pixels.ndim == 2:
        pixels = pixels[:, :, None]
    height, width, nchannels = pixels.shape
    if format is None:
        format = "float" if path.suffix.lower() in FLOAT_EXTENSIONS else "uint8"
    spec = oiio.ImageSpec(width, height, nchannels, format)
    if channel_names:
        spec.channelnames = tuple(channel_names)
    if nchannels == 4:
        spec.alpha_channel = 3
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=f".tmp{path.suffix}", dir=path.parent or ".")
    os.close(fd)
    try:
        out = oiio.ImageOutput.create(tmp)
        if out is None or not out.open(tmp, spec):
            raise UsageError(f"cannot write {str(path)!r}: {oiio.geterror().strip()}")
        ok = out.write_image(np.ascontiguousarray(pixels))
        out.close()
        if not ok:
            raise UsageError(f"cannot write {str(path)!r}: {oiio.geterror().strip()}")
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return path


def write_display_image(path: str | os.PathLike, linear_rgb: np.ndarray) -> Path:
    """Write a linear render: float formats stay linear, others are sRGB-encoded 8-bit."""
    path = Path(path)
    if path.suffix.lower() in FLOAT_EXTENSIONS:
        return write_image(path, linear_rgb, format="float")
    return write_image(path, linear_to_srgb(linear_rgb), format="uint8")
