"""`clrender splat gauss|render|sweep`: fit Gaussian splats to an image, re-render saved splats, sweep settings."""

from __future__ import annotations

import itertools
import sys
from dataclasses import replace

import numpy as np

from ..errors import UsageError
from . import add_device_argument
from .splat_target import check_fit_memory, read_target

GAUSS_EXAMPLE = """example:
  clrender splat gauss photo.jpg -o splats.png --splats 5000 --time-budget 120 \\
      --save-params splats.npz --log fit.csv
  (writes splats.png, splats.npz, fit.csv and the loss/PSNR curve splats.curve.png)
  clrender splat gauss photo.jpg -o plain.png --learn scale-lum --blend sum --optimizer sgd --init uniform
  (the simplest fit: a uniform grid, only scales and luminance learned, added up, plain SGD)"""

RENDER_EXAMPLE = """example:
  clrender splat render splats.npz -o big.png --width 2048"""

SWEEP_EXAMPLE = """example:
  clrender splat sweep photo.jpg --splats 2000 --lrs 0.5 1 2 --batches 0 65536 --time-budget 10"""


def add_parser(group):
    from ..splat.fit import INITS, LEARN, LEARN_ALIASES, FitConfig
    from ..splat.gauss import BLENDS
    from ..splat.losses import LOSSES
    from ..splat.optim import OPTIMIZERS

    d = FitConfig()

    def fit_options(p):
        p.add_argument("--splats", type=int, default=d.splats, metavar="N", help="number of splats to start with")
        p.add_argument("--epochs", type=int, default=None, metavar="E", help="passes over the image (default: 1000, or unlimited with --time-budget)")
        p.add_argument("--init", choices=INITS, default=d.init, help="initial centres")
        p.add_argument(
            "--learn",
            choices=LEARN,
            type=lambda text: LEARN_ALIASES.get(text, text),
            default=d.learn,
            help="scale-lum: log-scales and a per-splat luminance factor only (old name: seed); all: every parameter",
        )
        p.add_argument("--blend", choices=BLENDS, default=d.blend, help="sum: background + sum of w c; normalized: sum of w c / sum of w")
        p.add_argument(
            "--optimizer",
            choices=OPTIMIZERS,
            default=d.optimizer,
            help="host-side update rule; sgd with --learn scale-lum --blend sum --init uniform is the simplest fit",
        )
        p.add_argument(
            "--loss",
            choices=LOSSES,
            default=d.loss,
            help="l2: mean squared error; l1: mean absolute error; l1-ssim: l1 + 0.2 (1 - SSIM)",
        )
        p.add_argument("--seed", type=int, default=d.seed, help="seed of every random choice")
        p.add_argument("--max-splats", type=int, default=None, metavar="M", help="densification keeps N <= M (default: the same as --splats)")
        p.add_argument("--batch", type=int, default=d.batch, metavar="B", help="pixels per step, rounded to whole 16x16 tiles; 0 = the full image")
        add_device_argument(p)

    p = group.add_parser(
        "gauss",
        help="fit Gaussian splats to an image",
        epilog=GAUSS_EXAMPLE,
        description="Fit 2D Gaussian splats to IN with OpenCL forward/backward kernels and a host-side optimiser; write the rendered fit to OUT.",
    )
    p.add_argument("input", metavar="IN", help="image to fit (anything OpenImageIO reads)")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="rendered fit (.png, .exr, ...); required")
    fit_options(p)
    p.add_argument("--lr", type=float, default=d.lr, help="multiplier of every group's default learning rate")
    p.add_argument("--time-budget", type=float, default=None, metavar="SECONDS", help="stop fitting after this long (default: no limit)")
    p.add_argument("--save-params", metavar="P.npz", help="save the fitted splats, to re-render with 'splat render' (default: not saved)")
    p.add_argument("--log", metavar="CSV", help="write step, epoch, seconds, splats, loss, psnr rows (default: no log)")
    p.add_argument("--curve", metavar="PNG", help="loss/PSNR curve picture (default: OUT's name + .curve.png)")
    p.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    from .cluster import add_cluster_arguments  # IN a folder or glob: one fit per photo, on Dask if asked

    add_cluster_arguments(p, tiles=False)
    p.set_defaults(run=run_gauss)

    p = group.add_parser("render", help="render saved Gaussian splats at another resolution", epilog=RENDER_EXAMPLE)
    p.add_argument("params", metavar="P.npz", help="parameters saved by 'splat gauss --save-params'")
    p.add_argument("-o", "--output", required=True, metavar="OUT", help="image to write (.png, .exr, ...); required")
    p.add_argument("--width", type=int, default=None, help="output width; the height keeps the aspect ratio (default: the fitted image's)")
    p.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    add_device_argument(p)
    p.set_defaults(run=run_render)

    p = group.add_parser("sweep", help="try a grid of learning rates and batch sizes, report the best", epilog=SWEEP_EXAMPLE)
    p.add_argument("input", metavar="IN", help="image to fit (anything OpenImageIO reads)")
    fit_options(p)
    p.set_defaults(splats=2000)
    p.add_argument("--lrs", type=float, nargs="+", default=[0.3, 1.0, 3.0], help="--lr values to try")
    p.add_argument("--batches", type=int, nargs="+", default=[0, 65536], help="--batch values to try")
    p.add_argument("--time-budget", type=float, default=10.0, metavar="SECONDS", help="seconds per run")
    p.add_argument("--csv", metavar="CSV", help="also write the results table here (default: stdout only)")
    p.add_argument("--overwrite", action="store_true", help="replace the --csv file if it exists")
    add_cluster_arguments(p, tiles=False)  # one fit per combination on Dask
    p.set_defaults(run=run_sweep)


def _check_side_output(path: str | None, overwrite: bool, suffixes: tuple[str, ...]) -> None:
    from ..outputs import check_file_output

    if path is not None:
        check_file_output(path, overwrite=overwrite, suffixes=suffixes)


def _config(args, **extra):
    from ..splat.fit import FitConfig

    return FitConfig(
        splats=args.splats,
        epochs=args.epochs,
        init=args.init,
        learn=args.learn,
        blend=args.blend,
        optimizer=args.optimizer,
        loss=args.loss,
        seed=args.seed,
        max_splats=args.max_splats,
        batch=args.batch,
        **extra,
    )


def write_log(path, log: list[dict], overwrite: bool = True) -> None:
    """The rows as CSV, through a temp file (or as part of the current output set)."""
    from ..outputs import write_csv

    write_csv(path, log, overwrite=overwrite)


def write_curve(path, log: list[dict], title: str) -> bool:
    """The loss (log scale) above the PSNR against step, in two panels: for the L2 loss PSNR is
    -10 log10(loss) exactly, so on one shared axis one line would hide the other."""
    from ..image.plot import training_curve

    training_curve(path, [r["step"] for r in log], [r["loss"] for r in log], [r["psnr"] for r in log], title=title)
    return True


def run_gauss(args):
    from ..device import get_device
    from ..errors import RenderFailure
    from ..image.files import check_distinct_outputs, check_output_path, write_image
    from ..outputs import output_set
    from ..splat.fit import Fitter
    from .splat_batch import is_batch, run_gauss_batch

    if is_batch(args.input):  # a folder or glob of photos (commands/splat_batch.py)
        return run_gauss_batch(args, lambda a: _config(a, lr=a.lr, time_budget=a.time_budget))
    out = check_output_path(args.output, overwrite=args.overwrite, inputs=[args.input])
    curve = args.curve or str(out.with_suffix("")) + ".curve.png"
    check_output_path(curve, overwrite=args.overwrite, inputs=[args.input])
    _check_side_output(args.save_params, args.overwrite, (".npz",))
    _check_side_output(args.log, args.overwrite, (".csv",))
    check_distinct_outputs(**{"-o": out, "--curve": curve, "--save-params": args.save_params, "--log": args.log, "IN": args.input})
    config = _config(args, lr=args.lr, time_budget=args.time_budget)
    check_fit_memory(args.input, config)
    target = read_target(args.input)
    fitter = Fitter(get_device(args.device), target, config)  # validates the settings and the image size
    result = fitter.run()
    if not np.isfinite(result.image).all():
        raise RenderFailure(f"the fit diverged (NaN or infinite pixels) with --lr {args.lr:g}; use a smaller --lr")
    with output_set(overwrite=args.overwrite):  # image, parameters, log and curve: all of them or none
        write_image(out, result.image, format=None)
        if args.save_params:
            result.params.save(args.save_params)
        if args.log:
            write_log(args.log, result.log)
        write_curve(curve, result.log, f"splat gauss: {result.params.n} splats, {config.blend}, {config.loss}")
    for path in (out, args.save_params, args.log, curve):  # stdout: the written paths, for scripts
        if path:
            print(path)
    if not args.quiet:
        sys.stderr.write(f"{result.params.n} splats, {result.steps} steps in {result.seconds:.1f} s, PSNR {result.psnr:.2f} dB\n")
    return 0


def run_render(args):
    from ..device import get_device
    from ..image.files import check_output_path, write_image
    from ..splat.gauss import BYTES_PER_SPLAT, RENDER_BYTES_PER_PIXEL, GaussParams, render

    out = check_output_path(args.output, overwrite=args.overwrite)
    params = GaussParams.load(args.params)
    width = args.width or params.width
    if width < 1 or width > 32768:
        raise UsageError(f"--width {width} is out of range; allowed: 1 to 32768")
    factor = width / params.width
    height = max(1, int(round(params.height * factor)))
    if height > 32768:
        raise UsageError(f"--width {width} makes the image {height} pixels high; allowed: at most 32768")
    from .. import memory

    # the image, its tile buffers and the scaled splats (see clrender/memory.py); the (tile, splat)
    # pairs are counted and checked once the splats' boxes are known (GaussRenderer._pack_and_bin)
    memory.require(memory.BASE_BYTES + width * height * RENDER_BYTES_PER_PIXEL + params.n * BYTES_PER_SPLAT, f"a {width}x{height} splat render")
    image = render(get_device(args.device), params.scaled(factor, width, height))
    write_image(out, image, overwrite=args.overwrite)
    print(out)
    return 0


def run_sweep(args):
    _check_side_output(args.csv, args.overwrite, (".csv",))
    if args.csv:
        from ..image.files import check_distinct_outputs

        check_distinct_outputs(**{"IN": args.input, "--csv": args.csv})
    for lr in args.lrs:
        if not 0 < lr < float("inf"):
            raise UsageError(f"--lrs value {lr} must be a number > 0")
    target = read_target(args.input)
    rows = []
    combos = list(itertools.product(args.lrs, args.batches))
    configs = []
    for lr, batch in combos:
        configs.append(replace(_config(args, lr=lr, time_budget=args.time_budget), batch=batch))
    from .splat_batch import sweep_results  # here one by one, or one task each under --scheduler / --workers

    for (lr, batch), result in zip(combos, sweep_results(args, target, configs)):
        rows.append({"lr": lr, "batch": batch, "steps": result.steps, "seconds": round(result.seconds, 2), "psnr": round(result.psnr, 3)})
        sys.stdout.write(f"lr {lr:g}  batch {batch:>7d}  steps {result.steps:>6d}  PSNR {result.psnr:6.2f} dB\n")
        sys.stdout.flush()
    best = max(rows, key=lambda r: r["psnr"])
    sys.stdout.write(f"best: --lr {best['lr']:g} --batch {best['batch']} (PSNR {best['psnr']:.2f} dB)\n")
    if args.csv:
        write_log(args.csv, rows, overwrite=args.overwrite)
    return 0
