"""The photo a Gaussian splat fit reproduces: its memory refused up front, its pixels read and checked.

Shared by one fit (`splat gauss IN`) and a batch of fits (a folder or glob), so neither imports the other.
"""

from __future__ import annotations


def check_fit_memory(path, config) -> None:
    """Refuse, from the image's header and before its pixels are read, a fit that memory cannot hold
    (clrender/memory.py, --max-memory); the splats' share is checked when they are first binned."""
    from .. import memory
    from ..image.files import probe_image
    from ..splat.gauss import peak_bytes

    info = probe_image(path)
    memory.require(peak_bytes(info.width, info.height, fit_loss=config.loss), f"a {info.width}x{info.height} splat fit ({config.loss} loss)")


def read_target(path):
    """The photo's pixels as linear RGB; NaN, inf or 3e38 in an EXR/HDR/PFM is refused, naming the file."""
    from ..errors import shown
    from ..image.files import read_image
    from ..splat.fit import as_rgb
    from ..splat.pixels import check_pixels

    pixels = read_image(path).pixels
    check_pixels(pixels, shown(path))
    return as_rgb(pixels)
