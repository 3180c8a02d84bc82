"""Dispatch `python -m bench NAME ...` to bench/NAME.py's main(argv)."""

import importlib
import os
import sys

# OpenBLAS's worker threads spin for a while after any numpy/scipy BLAS call, on the same two cores
# as PoCL's kernel threads (perf showed them at ~7% of a ray benchmark): one BLAS thread, set before
# numpy is imported.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

NAMES = ("rays", "bvh", "aa", "filters", "splat", "voronoi", "distributed", "path", "instancing", "assets", "whitted", "sampler", "quality", "lanes")
MOVED = {"mutants": "python -m tools.mutants", "render_hashes": "python tools/render_hashes.py"}  # tools, not benchmarks


def main(argv):
    if argv and argv[0] in MOVED:
        sys.stderr.write(f"{argv[0]} is a tool, not a benchmark: {MOVED[argv[0]]} (docs/testing.md)\n")
        return 2
    if not argv or argv[0] not in NAMES:
        sys.stderr.write(f"usage: python -m bench {{{'|'.join(NAMES)}}} [options]\n")
        return 2
    module = importlib.import_module(f"bench.{argv[0]}")
    return module.main(argv[1:]) or 0


sys.exit(main(sys.argv[1:]))
