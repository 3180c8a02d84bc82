"""`clrender warmup`: compile every kernel variant a render can build, ahead of time (clrender/warmup.py)."""

from __future__ import annotations

from ..errors import UsageError
from . import add_device_argument
from .render import positive_int

EXAMPLES = """examples:
  clrender warmup                       # every variant (minutes: 10-60 s each on a CPU runtime; cached afterwards)
  clrender warmup --list                # the variants, without compiling
  clrender warmup --only "path, bvh, flat"   # the variants whose description contains the text
  clrender warmup --jobs 8              # eight compiles at once (each driver's compiler uses one core)
"""


def add_parser(sub):
    p = sub.add_parser(
        "warmup",
        help="compile every kernel variant ahead of time (for CI images and clusters)",
        epilog=EXAMPLES,
        description="Build every -D variant of the kernels a render can use, so pyopencl's cache holds them "
        "and no render waits for the compiler. Prints each variant's build seconds on stdout.",
    )
    add_device_argument(p)
    p.add_argument("--list", action="store_true", help="print the variants and compile nothing")
    p.add_argument("--only", metavar="TEXT", default=None, help="only the variants whose description contains TEXT (default: every variant)")
    p.add_argument("--jobs", type=positive_int, default=1, metavar="N", help="compile N variants at once, in N processes (default: 1)")
    p.set_defaults(run=run)


def run(args):
    from ..device import get_device
    from ..warmup import variants, warm

    device = get_device(args.device)
    chosen = [v for v in variants(device) if args.only is None or args.only in v.label]
    if not chosen:
        raise UsageError(f"--only {args.only!r} matches no variant; `clrender warmup --list` names them")
    if args.list:
        for variant in chosen:
            print(variant.label)
        return 0
    seconds = warm(device, chosen, jobs=args.jobs, spec=args.device)
    if not args.quiet:
        slowest = max(seconds, key=lambda pair: pair[1])
        import sys

        sys.stderr.write(
            f"{len(seconds)} variants for {device.name} in {sum(s for _, s in seconds):.1f}s; slowest {slowest[1]:.1f}s ({slowest[0].label})\n"
        )
    return 0
