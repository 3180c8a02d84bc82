"""clrender's own texture size limit, and only it (issue 38, defect 9): Pillow's decompression-bomb guard
(a warning past 89.5 M pixels, an error past 179 M) must neither leak warnings nor refuse a texture the docs
allow (MAX_TEXTURE_SIDE a side).  The PNGs here are headers only (signature, IHDR, an empty IDAT): Pillow
reads the size from the header, and `require` (memory's check, called before any texel is decoded) stops
each decode there, so nothing large is allocated."""

import struct
import warnings
import zlib

import pytest
from PIL import Image

from clrender.errors import UsageError
from clrender.memory import BASE_BYTES, TEXEL_BYTES
from clrender.scene.textures import MAX_TEXTURE_SIDE, decode


def png_header(width: int, height: int) -> bytes:
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8-bit RGB
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", b"")


class Reached(Exception):
    """The decode got past the header checks to memory's check."""


def reach_require(need, what):
    raise Reached(need)


@pytest.mark.parametrize("side", [10_000, 13_000, MAX_TEXTURE_SIDE])  # 100 M (Pillow warned), 169 M (warned), 268 M (refused)
def test_allowed_size_reaches_our_memory_check_without_pillow_warnings(side):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a DecompressionBombWarning fails the test
        with pytest.raises(Reached) as got:
            decode(png_header(side, side), srgb=True, what="big.png", require=reach_require)
    assert got.value.args[0] == BASE_BYTES + side * side * TEXEL_BYTES  # the header's size reached memory's check


def test_over_our_limit_is_refused_by_our_limit():
    with pytest.raises(UsageError, match=f"1 to {MAX_TEXTURE_SIDE} texels a side"):
        decode(png_header(MAX_TEXTURE_SIDE + 1, 8), srgb=True, what="wide.png", require=reach_require)


def test_pillow_limit_restored_after_decode():
    kept = Image.MAX_IMAGE_PIXELS
    with pytest.raises(Reached):
        decode(png_header(64, 64), srgb=False, what="small.png", require=reach_require)
    assert Image.MAX_IMAGE_PIXELS == kept
