"""`splat gauss` / `splat voronoi` over a folder or glob of photos, and `splat sweep`, optionally on Dask.

IN may be a folder (every image file in it) or a glob ('photos/*.jpg'); then
-o names a folder and each photo's result goes there under the photo's own
file name.  With --scheduler / --workers each fit is one task
(clrender.distributed.fits); without, the fits run one after another here.
All results are written together at the end, or none (clrender/outputs.py).
"""

from __future__ import annotations

import glob
import sys
from pathlib import Path

from ..errors import UsageError

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".exr", ".hdr", ".bmp", ".webp", ".pfm")


def is_batch(text: str) -> bool:
    """A folder or a glob pattern rather than one image file."""
    return Path(text).is_dir() or any(c in text for c in "*?[")


def photos(text: str) -> list[Path]:
    if Path(text).is_dir():
        found = sorted(p for p in Path(text).iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file())
    else:
        found = sorted(Path(p) for p in glob.glob(text) if Path(p).is_file())
    if not found:
        raise UsageError(f"no images in {text!r}; give a folder of images or a glob such as 'photos/*.jpg'")
    return found


def batch_outputs(args, inputs: list[Path], refused: dict) -> list[Path]:
    """OUT/<photo name> for each photo, checked before any work."""
    from ..image.files import check_output_path

    for option, value in refused.items():
        if value:
            raise UsageError(f"{option} names one file; with a folder or glob of photos only the images are written")
    folder = Path(args.output)
    if folder.suffix and not folder.is_dir():
        raise UsageError(f"with a folder or glob of photos, -o names a folder (got {args.output!r})")
    folder.mkdir(parents=True, exist_ok=True)
    outs = [folder / p.name for p in inputs]
    if len({o.name for o in outs}) != len(outs):
        raise UsageError("two photos have the same file name; their outputs would collide in the -o folder")
    for out, photo in zip(outs, inputs):
        check_output_path(out, overwrite=args.overwrite, inputs=[photo])
    return outs


def run_gauss_batch(args, config_of) -> int:
    """One Gaussian fit per photo; config_of(args) is the FitConfig a single fit would use."""
    from ..image.files import write_image
    from ..outputs import output_set
    from .cluster import cluster_client
    from .splat_target import check_fit_memory, read_target

    inputs = photos(args.input)
    outs = batch_outputs(args, inputs, {"--save-params": args.save_params, "--log": args.log, "--curve": args.curve})
    config = config_of(args)
    for p in inputs:  # each photo's fit within memory, from its header (run locally, the fits take turns)
        check_fit_memory(p, config)
    targets = [read_target(p) for p in inputs]  # each checked (splat/pixels.py), naming its file
    for t in targets:
        config.validate(t.shape[1], t.shape[0])
    with cluster_client(args) as client:
        if client is None:
            import copy

            from ..device import get_device
            from ..splat.fit import fit

            results = [fit(get_device(args.device), t, copy.copy(config)) for t in targets]
        else:
            from ..distributed.fits import fit_gauss

            results = fit_gauss(targets, config, client, device=args.device)
    with output_set(overwrite=args.overwrite):
        for out, result in zip(outs, results):
            write_image(out, result.image, format=None)
    for out, result in zip(outs, results):
        print(out)
        if not args.quiet:
            sys.stderr.write(f"{out.name}: {result.params.n} splats, {result.steps} steps, PSNR {result.psnr:.2f} dB\n")
    return 0


def run_voronoi_batch(args, settings_of) -> int:
    """One Voronoi splatting per photo; settings_of(args) is the VoronoiSettings a single run would use."""
    from ..errors import shown
    from ..image.files import probe_image, read_image, write_image
    from ..outputs import output_set
    from ..splat.pixels import check_pixels
    from ..splat.voronoi import cell_edges, require_memory
    from .cluster import cluster_client

    inputs = photos(args.input)
    outs = batch_outputs(args, inputs, {"--save-sites": args.save_sites})
    settings = settings_of(args)
    for path in inputs:  # each photo's splatting within memory, from its header (run locally, they take turns)
        info = probe_image(path)
        settings.validate(info.width, info.height)
        require_memory(info.width, info.height, info.nchannels, settings)
    images = [read_image(p) for p in inputs]
    for path, image in zip(inputs, images):
        check_pixels(image.pixels, shown(path))
    with cluster_client(args) as client:
        if client is None:
            from ..device import get_device
            from ..splat.voronoi import splat

            results = [splat(get_device(args.device), img.pixels, settings) for img in images]
        else:
            from ..distributed.fits import splat_voronoi

            results = splat_voronoi([img.pixels for img in images], settings, client, device=args.device)
    with output_set(overwrite=args.overwrite):
        for out, img, result in zip(outs, images, results):
            pixels = result.image
            if args.edges:
                pixels = pixels.copy()
                pixels[cell_edges(result.index)] = 0.0
            fmt = "float" if out.suffix.lower() in (".exr", ".hdr", ".pfm") else (img.format if img.format in ("uint8", "uint16") else None)
            write_image(out, pixels, format=fmt, channel_names=img.channel_names or None)
    for out in outs:
        print(out)
    return 0


def sweep_results(args, target, configs):
    """Yield each config's FitResult in order: here one by one, or all as tasks on the cluster."""
    from .cluster import cluster_client

    with cluster_client(args) as client:
        if client is None:
            from ..device import get_device
            from ..splat.fit import Fitter

            device = get_device(args.device)
            for config in configs:
                yield Fitter(device, target, config).run(show_progress=False)
        else:
            from ..distributed.fits import sweep_gauss

            yield from sweep_gauss(target, configs, client, device=args.device)
