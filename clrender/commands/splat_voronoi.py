"""`clrender splat voronoi`: colour each pixel by its nearest site (Voronoi splatting)."""

from __future__ import annotations

import sys
import time

EXAMPLES = """examples:
  clrender splat voronoi photo.jpg -o cells.png
  clrender splat voronoi photo.jpg -o cells.png --splats 20000 --init gradient --colors mean --lloyd 5
  clrender splat voronoi photo.jpg -o cells.png --colors sample --method naive --splats 500   # brute force, point-sampled
  clrender splat voronoi photo.jpg -o soft.png --train 100 --edges --save-sites sites.npz
"""


def add_parser(group):
    from ..splat.voronoi import COLOR_MODES, INITS, METHODS, VoronoiSettings
    from . import add_device_argument

    d = VoronoiSettings()
    p = group.add_parser(
        "voronoi",
        help="nearest-site (Voronoi) splatting of an image",
        epilog=EXAMPLES,
        description="Approximate IN by N sites, each pixel taking the colour of its nearest site (exact; ties go to the lower site index).",
    )
    p.add_argument("input", metavar="IN", help="input image (anything OpenImageIO reads)")
    p.add_argument("-o", "--output", required=True, help="output image; same stored values as the input (no colour transform); required")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output file")
    p.add_argument("--splats", "-n", type=int, default=d.n, metavar="N", help="number of sites, 1 to the pixel count")
    p.add_argument("--method", choices=METHODS, default=d.method, help="nearest-site search (identical results)")
    p.add_argument(
        "--init",
        choices=INITS,
        default=d.init,
        help="starting sites: gradient puts more where the image has detail, random anywhere, uniform on a square grid (cells look like pixelation)",
    )
    p.add_argument(
        "--colors", choices=COLOR_MODES, default=d.colors, help="sample: image at the site (point sampling); mean: mean of the cell (least squares)"
    )
    p.add_argument("--lloyd", type=int, default=d.lloyd, metavar="K", help="Lloyd (centroidal Voronoi) iterations")
    p.add_argument("--train", type=int, default=d.train, metavar="STEPS", help="soft-Voronoi training steps (Adam, annealed temperature) after Lloyd")
    p.add_argument("--seed", type=int, default=d.seed, help="random seed for --init random|gradient")
    p.add_argument("--edges", action="store_true", help="draw cell borders in black")
    p.add_argument(
        "--save-sites", default=None, metavar="P.npz", help="also save sites (N,2 pixel units), colors (N,C) and the image size (default: not saved)"
    )
    add_device_argument(p)
    from .cluster import add_cluster_arguments  # IN a folder or glob: one splatting per photo, on Dask if asked

    add_cluster_arguments(p, tiles=False)
    p.set_defaults(run=run)


def run(args):
    from ..device import get_device
    from ..errors import shown
    from ..image.files import check_distinct_outputs, check_output_path, probe_image, read_image, write_image
    from ..outputs import output_set, save_npz
    from ..splat.pixels import check_pixels
    from ..splat.voronoi import VoronoiSettings, cell_edges, require_memory, splat
    from .splat_batch import is_batch, run_voronoi_batch

    if is_batch(args.input):  # a folder or glob of photos (commands/splat_batch.py)
        return run_voronoi_batch(
            args, lambda a: VoronoiSettings(n=a.splats, method=a.method, init=a.init, colors=a.colors, lloyd=a.lloyd, train=a.train, seed=a.seed)
        )
    output = check_output_path(args.output, overwrite=args.overwrite, inputs=[args.input])
    sites_path = None
    if args.save_sites:
        from ..outputs import check_file_output

        sites_path = check_file_output(args.save_sites, overwrite=args.overwrite, suffixes=(".npz",), option="--save-sites")
        check_distinct_outputs(**{"IN": args.input, "-o": output, "--save-sites": sites_path})
    settings = VoronoiSettings(
        n=args.splats, method=args.method, init=args.init, colors=args.colors, lloyd=args.lloyd, train=args.train, seed=args.seed
    )
    info = probe_image(args.input)  # refused from the header, before the pixels are read
    settings.validate(info.width, info.height)
    require_memory(info.width, info.height, info.nchannels, settings)
    img = read_image(args.input)
    check_pixels(img.pixels, shown(args.input))  # NaN, inf or 3e38 in an EXR/HDR/PFM: refused naming the file
    h, w = img.pixels.shape[:2]
    dev = get_device(args.device)
    start = time.perf_counter()
    result = splat(dev, img.pixels, settings)
    seconds = time.perf_counter() - start
    pixels = result.image
    if args.edges:
        pixels = pixels.copy()
        pixels[cell_edges(result.index)] = 0.0
    fmt = img.format if img.format in ("uint8", "uint16", "half", "float") else None
    if output.suffix.lower() in (".exr", ".hdr", ".pfm"):
        fmt = "float"
    elif fmt in ("half", "float"):
        fmt = None  # integer-only writers pick their own
    with output_set(overwrite=args.overwrite):  # the image and the sites: both or neither
        write_image(output, pixels, format=fmt, channel_names=img.channel_names or None)
        if sites_path is not None:
            save_npz(sites_path, sites=result.sites, colors=result.colors, width=w, height=h)
    print(output)
    if not args.quiet:
        from ..splat.losses import psnr

        sys.stderr.write(
            f"voronoi: {w}x{h}, {settings.n} sites ({settings.method}, {settings.init}, "
            f"{settings.colors}, lloyd {settings.lloyd}, train {settings.train}); "
            f"PSNR {psnr(result.image, img.pixels):.2f} dB; {seconds:.2f}s "
            f"(compile {dev.compile_seconds:.2f}s)\n"
        )
    return 0
