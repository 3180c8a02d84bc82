"""`clrender splat ...`: the splatting subcommands, gathered under one group."""

from __future__ import annotations

from . import splat_gauss, splat_voronoi


def add_parser(sub):
    p = sub.add_parser("splat", help="fit Gaussian or Voronoi splats to an image")
    group = p.add_subparsers(dest="splat_command", metavar="KIND", parser_class=type(p))
    group.required = True
    splat_gauss.add_parser(group)
    splat_voronoi.add_parser(group)
