"""Image files a scene names, judged from their headers before any pixel is decoded: the texture size limit,
and Pillow's own decompression-bomb guard turned off while clrender decodes (its limits are ours alone).
Used by textures.py (textures), confine.py (an OBJ's map_Kd as trimesh asks for it) and obj_mtl.py."""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

from ..errors import UsageError

MAX_TEXTURE_SIDE = 16384  # texels along either side of one texture


@contextmanager
def own_size_limit(Image):
    """Pillow's decompression-bomb guard off while clrender decodes (MAX_TEXTURE_SIDE and memory.require are the
    limits, checked on the header's size before any texel is decoded): Pillow would warn past 89.5 M texels and
    refuse past 179 M, under the 16384^2 the docs allow.  Scoped: Image.MAX_IMAGE_PIXELS is restored after."""
    import warnings

    kept = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", Image.DecompressionBombWarning)
            yield
    finally:
        Image.MAX_IMAGE_PIXELS = kept


def image_header(path: Path, what: str) -> tuple[int, int]:
    """(width, height) of an image file from its header alone (Pillow reads no pixels to open it), refused
    when it is not an image Pillow reads or is past MAX_TEXTURE_SIDE."""
    from PIL import Image, UnidentifiedImageError

    with own_size_limit(Image):
        try:
            with Image.open(path) as image:
                width, height = image.size
        except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as exc:
            raise UsageError(f"{what}: not an image clrender reads ({type(exc).__name__}); allowed: PNG, JPEG or any image Pillow decodes") from None
    if not (1 <= width <= MAX_TEXTURE_SIDE and 1 <= height <= MAX_TEXTURE_SIDE):
        raise UsageError(f"{what}: image is {width} x {height}; allowed: 1 to {MAX_TEXTURE_SIDE} texels a side")
    return width, height
