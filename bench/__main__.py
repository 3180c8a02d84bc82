"""Dispatch `python -m bench NAME ...` to bench/NAME.py's main(argv)."""

import importlib
import sys

NAMES = ("rays", "bvh", "aa", "filters", "splat", "voronoi", "mutants", "distributed")


def main(argv):
    if not argv or argv[0] not in NAMES:
        sys.stderr.write(f"usage: python -m bench {{{'|'.join(NAMES)}}} [options]\n")
        return 2
    module = importlib.import_module(f"bench.{argv[0]}")
    return module.main(argv[1:]) or 0


sys.exit(main(sys.argv[1:]))
