"""`clrender` command line: subcommands render, convolve, splat {gauss,render,sweep,voronoi}, devices.

Errors are one line on stderr, `clrender: <what was wrong and what is
allowed>`, exit 2 for bad input and 1 for a failure at run time.  Each
subcommand lives in clrender/commands/<name>.py and registers itself with
`add_parser(subparsers)`, setting `run` to the function that does the work.
"""
from __future__ import annotations

import argparse
import sys

from . import progress
from .errors import RenderFailure, UsageError


class ArgumentParser(argparse.ArgumentParser):
    """argparse with one-line errors (exit 2) and defaults shown in --help."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message):  # argparse calls this for bad arguments
        sys.stderr.write(f"clrender: {message} (see '{self.prog} --help')\n")
        sys.exit(2)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Shows each option's default and keeps worked examples laid out as written."""


def build_parser() -> ArgumentParser:
    from .commands import convolve, devices, render, splat

    parser = ArgumentParser(
        prog="clrender",
        description="Ray tracing, convolution filters and image splatting on OpenCL (PoCL by default).",
        epilog="example:\n  clrender render refract1 -o refract1.png\n  clrender convolve in.jpg out.jpg box_blur_33",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars or timings")
    parser.add_argument("-v", "--verbose", action="store_true", help="progress bars even off a terminal")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=ArgumentParser)
    sub.required = True
    for module in (render, convolve, splat, devices):
        module.add_parser(sub)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.quiet:
        progress.SHOW = False
    elif args.verbose:
        progress.SHOW = True
    try:
        result = args.run(args)
    except UsageError as exc:
        sys.stderr.write(f"clrender: {exc}\n")
        return 2
    except RenderFailure as exc:
        sys.stderr.write(f"clrender: {exc}\n")
        return 1
    except KeyboardInterrupt:
        sys.stderr.write("clrender: interrupted\n")
        return 130
    return int(result or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
