"""Image reading and writing through OpenImageIO.

Pixels travel as float32 arrays of shape (H, W, C).  Integer files are read
as values in [0, 1] (OpenImageIO's normalisation) and remember their stored
format so a filter can write the same bit depth back.  Writes are encoded in
memory, copied to a temporary file beside the target (where a full disk is
an error, which the encoders themselves do not report) and renamed into
place, so a failed write never leaves a half-written or empty image.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import OpenImageIO as oiio

from ..errors import RenderFailure, UsageError, first_line, library_messages, shown
from ..outputs import check_writable, write_file
from .tonemap import DisplaySettings, display_linear

# An image header may promise any size; more pixels than this are refused
# before a byte of them is allocated (the renderer's own limit, 8192 x 8192).
MAX_READ_PIXELS = 1 << 26
MAX_CHANNELS = 16

# Formats whose writers store floats; everything else is written as integers.
FLOAT_EXTENSIONS = {".exr", ".hdr", ".pfm"}


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


def _open_input(path: Path):
    """An open OpenImageIO ImageInput; UsageError if the file is missing, not an image or too large."""
    if not path.is_file():
        raise UsageError(f"input image {shown(path)} does not exist")
    with library_messages() as said:
        inp = oiio.ImageInput.open(_library_name(path))
    if inp is None:
        raise UsageError(f"cannot read {shown(path)} as an image ({first_line(_library_error(), said.text, 'unknown format')})")
    spec = inp.spec()
    pixels = spec.width * spec.height * max(spec.depth, 1)
    if pixels > MAX_READ_PIXELS or spec.nchannels > MAX_CHANNELS or pixels < 1 or spec.nchannels < 1:
        inp.close()
        raise UsageError(
            f"image {shown(path)} is {spec.width}x{spec.height} with {spec.nchannels} channels; "
            f"allowed: at most {MAX_READ_PIXELS} pixels and {MAX_CHANNELS} channels"
        )
    return inp


def read_image(path: str | os.PathLike) -> Image:
    """Read any image OpenImageIO understands; UsageError if it cannot."""
    path = Path(path)
    inp = _open_input(path)
    try:
        spec = inp.spec()
        with library_messages() as said:
            pixels = inp.read_image(0, 0, 0, spec.nchannels, "float")
    except (RuntimeError, UnicodeError) as exc:  # the bindings' own errors on a damaged file
        if isinstance(exc, RenderFailure):
            raise
        raise UsageError(f"cannot read {shown(path)}: the file is damaged ({first_line(str(exc), type(exc).__name__)})") from None
    finally:
        inp.close()
    if pixels is None:
        raise UsageError(f"cannot read the pixels of {shown(path)} ({first_line(_library_error(), said.text, 'the file is truncated or damaged')})")
    pixels = np.asarray(pixels, dtype=np.float32).reshape(spec.height, spec.width, spec.nchannels)
    return Image(pixels, str(spec.format), _channel_names(spec, path))


def _channel_names(spec, path) -> tuple:
    """The file's channel names; UsageError when the header's names are damaged (bytes that are not text)."""
    try:
        names = tuple(spec.channelnames)
    except (UnicodeDecodeError, RuntimeError):
        names = (None,)
    if not all(isinstance(n, str) and _is_utf8(n) for n in names):
        raise UsageError(f"cannot read {shown(path)}: its channel names are damaged (not UTF-8 text)")
    return names


def _is_utf8(text: str) -> bool:
    try:
        text.encode("utf-8")  # undecodable bytes come back as lone surrogates
        return True
    except UnicodeEncodeError:
        return False


def _library_error() -> str:
    """OpenImageIO's pending error text; a damaged file can put bytes in it that are not UTF-8."""
    try:
        return oiio.geterror()
    except UnicodeDecodeError:
        return "damaged header (unreadable text in the file)"


def _library_name(path) -> str:
    """The name as OpenImageIO takes it: UTF-8 text (a name with undecodable bytes is refused)."""
    name = str(path)
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        raise UsageError(f"file name {shown(name)} is not valid UTF-8; OpenImageIO cannot use it, rename the file") from None
    return name


# Channel types each writer stores, keyed by extension (OpenImageIO's plugins).
WRITER_FORMATS = {
    ".png": ("uint8", "uint16"),
    ".jpg": ("uint8",),
    ".jpeg": ("uint8",),
    ".tif": ("uint8", "uint16", "half", "float"),
    ".tiff": ("uint8", "uint16", "half", "float"),
    ".exr": ("half", "float"),
    ".hdr": ("float",),
    ".pfm": ("float",),
    ".bmp": ("uint8",),
    ".tga": ("uint8",),
    ".webp": ("uint8",),
}
FLOAT_FORMATS = ("half", "float", "double")

# Channel counts each writer can store, where it cannot store any (OpenImageIO refuses the others;
# JPEG, TIFF and EXR take any count: JPEG keeps the first three).
WRITER_CHANNELS = {
    ".png": (1, 2, 3, 4),
    ".hdr": (3,),
    ".pfm": (1, 3),
    ".bmp": (1, 3, 4),
    ".tga": (1, 2, 3, 4),
    ".webp": (3, 4),
}


def check_output_channels(path: str | os.PathLike, nchannels: int) -> None:
    """UsageError when the writer for `path`'s extension cannot store `nchannels` channels."""
    suffix = Path(path).suffix.lower()
    allowed = WRITER_CHANNELS.get(suffix)
    if allowed is not None and nchannels not in allowed:
        counts = ", ".join(map(str, allowed[:-1])) + (" or " if len(allowed) > 1 else "") + str(allowed[-1])
        raise UsageError(
            f"output {shown(path)} cannot hold {nchannels} channels: {suffix[1:].upper()} allows {counts} (.exr or .tif take any number)"
        )


@dataclass
class ImageInfo:
    """What a file's header says, read without its pixels."""

    height: int
    width: int
    nchannels: int
    format: str
    channel_names: tuple

    @property
    def nbytes(self) -> int:
        """Size of the pixels as float32."""
        return self.height * self.width * self.nchannels * 4


def probe_image(path: str | os.PathLike) -> ImageInfo:
    """Read only the header; UsageError if the file is missing or not an image."""
    inp = _open_input(Path(path))
    try:
        spec = inp.spec()
        return ImageInfo(spec.height, spec.width, spec.nchannels, str(spec.format), _channel_names(spec, path))
    finally:
        inp.close()


def output_format(path: str | os.PathLike, stored: str) -> str:
    """The channel type to write `path` with, for pixels that were stored as `stored`.

    The same type where the writer has it (8-bit PNG stays 8-bit, 16-bit
    TIFF stays 16-bit, half EXR stays half); otherwise floats go to the
    widest float or integer the writer has, integers to the deepest integer
    no deeper than needed, or to float for float-only formats.
    """
    allowed = WRITER_FORMATS.get(Path(path).suffix.lower())
    if allowed is None or stored in allowed:
        return stored
    if stored in FLOAT_FORMATS:
        order = ("float", "half", "uint16", "uint8")
    elif stored in ("uint8", "int8"):
        order = ("uint8", "uint16", "float")
    else:
        order = ("uint16", "uint8", "float")
    return next(f for f in order if f in allowed)


def writer_supports_alpha(path: str | os.PathLike) -> bool:
    """Whether the writer for this extension can store an alpha channel (JPEG, HDR cannot)."""
    out = oiio.ImageOutput.create(_library_name(path))
    if out is None:
        _library_error()
        return False
    return bool(out.supports("alpha"))


def check_output_path(path: str | os.PathLike, *, overwrite: bool = False, inputs=()) -> Path:
    """Refuse an output we could not write, before any work is done.

    This is the early, friendly check; the final no-clobber check happens
    atomically when the finished file is put in place (clrender/outputs.py).
    """
    path = Path(path)
    if path.is_dir():
        raise UsageError(f"output {shown(path)} is a folder; name an image file (e.g. {shown(path / 'out.png')})")
    if not path.suffix:
        raise UsageError(f"output {shown(path)} has no extension; use .png, .jpg, .tif, .exr or .hdr")
    probe = oiio.ImageOutput.create(_library_name(path))
    if probe is None:
        _library_error()  # clear it, or OpenImageIO prints it again at exit
        raise UsageError(f"no image writer for extension {shown(path.suffix)} of {shown(path)}; use .png, .jpg, .tif, .exr or .hdr")
    for other in inputs:
        if Path(other).resolve() == path.resolve() and not overwrite:
            raise UsageError(f"output {shown(path)} is the input; pass --overwrite to replace it")
    return check_writable(path, overwrite=overwrite)


def check_distinct_outputs(**outputs) -> None:
    """Refuse two outputs of one command that name the same file (one would silently replace the other)."""
    seen: dict[str, str] = {}
    for option, path in outputs.items():
        if path is None:
            continue
        key = os.path.normcase(os.path.abspath(os.fspath(path)))
        if key in seen:
            raise UsageError(f"{seen[key]} and {option} both name {shown(path)}; give each output its own file")
        seen[key] = option


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
    overwrite: bool = True,
) -> Path:
    """Write pixels (H, W[, C]) atomically (clrender/outputs.py; inside an output set it joins the set).

    `format` is the stored channel type; by default float for EXR/HDR and
    uint8 otherwise.  Values are clamped to [0, 1] only for integer formats
    (OpenImageIO does that when it converts).  No colour transform happens
    here: callers encode sRGB themselves (see `write_display_image`).
    Without `overwrite` an existing file is never replaced.
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
    names = [n.upper() for n in (channel_names or ())]
    if "A" in names:
        spec.alpha_channel = names.index("A")
    elif nchannels == 4:
        spec.alpha_channel = 3

    check_output_channels(path, nchannels)

    def write_pixels(temp: str) -> None:
        out = oiio.ImageOutput.create(_library_name(path))  # the writer is chosen by the final name's extension
        if out is None:
            raise UsageError(f"no image writer for {shown(path)}: {first_line(_library_error())}")
        # The encoders do not report a failed write: libpng leaves a 0-byte file and says it worked,
        # libjpeg calls exit(1).  So they write into memory (a memfd never fills up) and Python copies
        # the bytes into the file, where a full disk is an OSError like any other write's.
        with _memory_file() as (encoded, name):
            with library_messages() as said:
                ok = out.open(name, spec) and out.write_image(np.ascontiguousarray(pixels))
                ok = out.close() and ok
            size = os.fstat(encoded).st_size
            if not ok or size == 0:
                reason = first_line(out.geterror(), _library_error(), said.text, "the image writer wrote nothing")
                raise RenderFailure(f"cannot write {shown(path)}: {reason}")
            _copy_into(encoded, temp, size, path)

    return write_file(path, write_pixels, overwrite=overwrite)


@contextlib.contextmanager
def _memory_file():
    """(fd, name) of a file in memory for an encoder (Linux memfd); elsewhere a temp file that is removed after."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("clrender-image")
        try:
            yield fd, f"/proc/self/fd/{fd}"
        finally:
            os.close(fd)
        return
    fd, name = tempfile.mkstemp(prefix="clrender-image-")
    try:
        yield fd, name
    finally:
        os.close(fd)
        os.unlink(name)


def _copy_into(source_fd: int, temp: str, size: int, path: Path) -> None:
    """The encoded bytes from `source_fd` into the file `temp`, all of them or a RenderFailure naming `path`."""
    with open(temp, "wb") as target:
        copied = 0
        while copied < size:
            chunk = os.pread(source_fd, min(size - copied, 1 << 22), copied)
            if not chunk:
                break
            target.write(chunk)  # a full disk raises OSError(ENOSPC) here or at the flush on close
            copied += len(chunk)
    if os.stat(temp).st_size != size:
        raise RenderFailure(f"cannot write {shown(path)}: only {os.stat(temp).st_size} of its {size} bytes were written (is the disk full?)")


def display_srgb(linear_rgb: np.ndarray, display: DisplaySettings | None = None) -> np.ndarray:
    """The display transform (clrender/image/tonemap.py: exposure, tone curve), then the sRGB encoding:
    float32 in [0, 1], ready for an 8-bit writer (the default clamp: exactly linear_to_srgb(linear_rgb))."""
    return linear_to_srgb(display_linear(linear_rgb, display))


def srgb8(linear_rgb: np.ndarray, display: DisplaySettings | None = None) -> np.ndarray:
    """(H, W, 3) uint8 sRGB codes of a linear render after the display transform, as a PNG of it stores them."""
    return np.round(display_srgb(linear_rgb, display) * 255.0).astype(np.uint8)


def write_display_image(path: str | os.PathLike, linear_rgb: np.ndarray, *, overwrite: bool = True, display: DisplaySettings | None = None) -> Path:
    """Write a linear render: float formats stay scene-linear, others get the display transform
    (`display`: exposure and tone curve, default clamp) and are sRGB-encoded 8-bit."""
    path = Path(path)
    if path.suffix.lower() in FLOAT_EXTENSIONS:
        return write_image(path, linear_rgb, format="float", overwrite=overwrite)
    linear_rgb = display_linear(linear_rgb, display)  # clamp: the values as they are (the encoding clips)
    return write_image(path, linear_to_srgb(linear_rgb), format="uint8", overwrite=overwrite)
