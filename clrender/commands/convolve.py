"""`clrender convolve IN OUT FILTER [FILTER ...]`: named convolution filters on an image file."""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from .. import progress
from ..errors import UsageError, shown
from ..image import files as image_files
from ..image import filters

EPILOG = f"""\
filters (applied left to right; `--list` prints this table):
{filters.describe()}

Borders are reflect-101 (... c b | a b c ... | ... b a), repeated for kernels
wider than the image.  Gaussians of width >= {filters.FFT_FROM_SIZE} run through the FFT, so
sizes up to {filters.MAX_SIZE} stay fast; box blurs cost the same at any size.

Colour space (--space stored, the default): the stored numbers are filtered
as they are, as OpenCV, oiiotool and ImageMagick do, so
brighten_1.5 multiplies every stored value by 1.5.  --space linear first
decodes integer files (8/16-bit PNG, JPEG, TIFF) from sRGB to linear light
and encodes the result again; float files (EXR, HDR, float TIFF) are linear
already.  Pick linear for physically meaningful results on photographs:
blurs then mix light as a lens does (no dark fringes between bright and
dark areas) and brighten_2 doubles the light, not the code values.
Bit depth: the input's channel type is kept where the output format has
it (8-bit stays 8-bit, 16-bit stays 16-bit, EXR stays float); values are
clamped to [0, 1] only when an integer format is written.
Range: input pixels must be finite (NaN or infinity: refused).  Results
are clamped to the output type's finite range instead of overflowing:
+-3.4e38 for float, +-65504 for half (brighten_2 of a 65504 half pixel
writes 65504).
Alpha: blurs filter premultiplied colour and alpha together (transparent
pixels do not bleed); brighten and edge_detect leave alpha as it was.
Alpha is dropped (with a note) for formats without it (JPEG, HDR).

examples:
  clrender convolve treebranch.jpg treebranch_blur.jpg box_blur_33
  clrender convolve render.exr soft.exr gauss_blur_5 brighten_1.5
  clrender convolve photo.jpg soft.jpg gauss_blur_15 --space linear   # blur as a lens would
"""

HALF_MAX = 65504.0  # the largest finite half float: what brighten_2 of a 65504 half EXR pixel is written as
# working copies held at once while filtering: input, colour-space copy, blur input and output, FFT transposes
WORKING_COPIES = 6


def add_parser(sub):
    p = sub.add_parser(
        "convolve",
        help="apply convolution filters (blur, edge detect, brighten) to an image",
        description="Apply named convolution filters, in order, to an image file (OpenCV on float32).",
        epilog=EPILOG,
    )
    # SUPPRESS: no "(default: None)" in --help for the positionals (run() reads them with getattr)
    p.add_argument("input", nargs="?", default=argparse.SUPPRESS, metavar="IN", help="image to read (PNG, JPEG, TIFF, EXR, HDR, ...)")
    p.add_argument("output", nargs="?", default=argparse.SUPPRESS, metavar="OUT", help="image to write; its extension picks the format")
    p.add_argument("filters", nargs="*", default=argparse.SUPPRESS, metavar="FILTER", help="filter names, applied left to right")
    p.add_argument(
        "--space",
        choices=("stored", "linear"),
        default="stored",
        help="filter the stored values (as OpenCV) or linear light (integer files are sRGB-decoded first; see below)",
    )
    p.add_argument("--overwrite", action="store_true", help="replace OUT if it exists (or is IN)")
    p.add_argument("--list", action="store_true", help="print the filter names with a line each, and exit")
    p.set_defaults(run=run)
    return p


def run(args) -> int:
    if args.list:
        print(filters.describe())
        return 0
    for name in ("input", "output", "filters"):
        if not hasattr(args, name):
            setattr(args, name, None)
    if not args.input or not args.output or not args.filters:
        raise UsageError("convolve needs IN OUT FILTER [FILTER ...], e.g. 'clrender convolve in.jpg out.jpg box_blur_33'; see --list for the filters")
    # everything that can be refused is refused before the image is read
    chain = filters.parse_all(args.filters)
    info = image_files.probe_image(args.input)
    out_path = image_files.check_output_path(args.output, overwrite=args.overwrite, inputs=[args.input])
    check_memory(info)

    start = time.perf_counter()
    image = image_files.read_image(args.input)
    pixels, names = image.pixels, image.channel_names
    filters.check_finite(pixels, shown(args.input))  # a NaN or an infinity would spread over the kernel's width
    alpha = image.alpha_channel
    colour = [c for c in range(pixels.shape[2]) if c != alpha]
    out_format = image_files.output_format(out_path, image.format)
    # integer files hold sRGB codes, float files linear light; --space picks where the filters run,
    # and a change of kind between IN and OUT (EXR to PNG, say) is converted either way
    in_linear = image.format in image_files.FLOAT_FORMATS
    out_linear = out_format in image_files.FLOAT_FORMATS
    filter_linear = in_linear if args.space == "stored" else True
    if filter_linear and not in_linear:
        pixels = pixels.copy()
        pixels[:, :, colour] = image_files.srgb_to_linear(pixels[:, :, colour])

    for f in progress.progress(chain, total=len(chain), desc="convolve"):
        pixels = filters.apply(pixels, f, alpha_channel=alpha)

    if filter_linear and not out_linear:
        pixels[:, :, colour] = image_files.linear_to_srgb(pixels[:, :, colour])
    elif not filter_linear and out_linear:
        pixels[:, :, colour] = image_files.srgb_to_linear(pixels[:, :, colour])
    if out_format == "half":  # the filters clamp to float32's range; a half file holds +-65504 at most
        np.clip(pixels, -HALF_MAX, HALF_MAX, out=pixels)
    if alpha is not None and not image_files.writer_supports_alpha(out_path):
        note(args, f"warning: {out_path.suffix} has no alpha channel: alpha dropped")
        pixels = np.ascontiguousarray(pixels[:, :, colour])
        names = tuple(n for i, n in enumerate(names) if i != alpha)
    image_files.write_image(out_path, pixels, format=out_format, channel_names=names, overwrite=args.overwrite)
    print(out_path)  # stdout: the written path, for scripts
    note(args, f"{pixels.shape[1]}x{pixels.shape[0]}, {out_format}, {len(chain)} filters in {time.perf_counter() - start:.2f} s")
    return 0


def check_memory(info: image_files.ImageInfo) -> None:
    """Refuse an image whose working copies would not fit (clrender/memory.py: what is available now,
    --max-memory or CLRENDER_MAX_MEMORY), before its pixels are read."""
    from .. import memory

    memory.require(info.nbytes * WORKING_COPIES, f"filtering the {info.width}x{info.height}x{info.nchannels} image")


def note(args, message: str) -> None:
    """Timings and warnings on stderr; 'clrender:' is kept for errors."""
    if not getattr(args, "quiet", False):
        sys.stderr.write(f"{message}\n")
