"""BVH on/off on the seed's six scenes: `python -m bench bvh [--quick] [--runs K] [--out DIR]`.

Renders each scene with the BVH and without it (every ray tests every
primitive) at identical settings; reports the median trace time of K runs
(compile excluded), BVH build time, node count, nodes visited per ray and
the speed-up, checks that both give the same object ids, and writes
DIR/bvh.csv, DIR/bvh.md and the bar chart DIR/bvh.png (the seed's Figure C).
"""
from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

from clrender.renderer import Renderer
from clrender.scene import Scene
from clrender.tracer import Tracer

from .common import write_table

SCENES = ("refract1", "bunny", "refract2", "wizard_tower", "wizard_hat", "wizard_cat")


def time_scene(name: str, width: int, height: int, runs: int, light_samples: int) -> dict:
    scene = Scene.load(name)
    row = {"scene": name, "primitives": None}
    results = {}
    for use_bvh in (True, False):
        tracer = Tracer(scene, use_bvh=use_bvh)
        renderer = Renderer(scene, tracer=tracer, width=width, height=height, bvh=use_bvh, light_samples=light_samples)
        times = []
        for _ in range(runs):
            result = renderer.run()
            times.append(result.timings["trace"])
        results[use_bvh] = result
        key = "on" if use_bvh else "off"
        row["primitives"] = tracer.n_prims
        row[f"{key}_s"] = statistics.median(times)
        row[f"{key}_visits_per_ray"] = result.node_visits / max(result.rays, 1)
        if use_bvh:
            row["build_s"] = tracer.bvh_seconds
            row["nodes"] = len(tracer.bvh.nodes)
    if not np.array_equal(results[True].path_ids, results[False].path_ids):
        differ = int((results[True].path_ids != results[False].path_ids).any(-1).sum())
        raise SystemExit(f"bench bvh: {name}: BVH on and off disagree on the object ids of {differ} pixels")
    row["speedup"] = row["off_s"] / row["on_s"]
    return row


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench bvh", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="32x24 pixels, one run: a smoke test (under a minute)")
    ap.add_argument("--runs", type=int, default=3, help="timed runs per scene and mode; the median is reported")
    # Without the BVH every ray tests all 120k primitives of refract2: the default
    # size keeps that baseline to about a minute per run on two cores.
    ap.add_argument("--width", type=int, default=80)
    ap.add_argument("--height", type=int, default=60)
    ap.add_argument("--light-samples", type=int, default=1, help="area-light samples per side, both modes")
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--out", default="bench/out", help="folder for bvh.csv, bvh.md and bvh.png")
    args = ap.parse_args(argv)
    if args.quick:
        args.width, args.height, args.runs = 32, 24, 1
    rows = [time_scene(name, args.width, args.height, args.runs, args.light_samples) for name in args.scenes]
    out = Path(args.out)
    title = (f"BVH on vs off, {args.width}x{args.height}, 1 sample per pixel, "
             f"{args.light_samples}x{args.light_samples} area-light samples, median of {args.runs}")
    print(write_table(out, "bvh", rows, title))
    from clrender.plot import bar_chart

    bar_chart(out / "bvh.png", [r["scene"] for r in rows],
              {"without BVH": [r["off_s"] for r in rows], "with BVH": [r["on_s"] for r in rows]},
              title=title, ylabel="render time (s, log scale)", log=True)
    print(f"wrote {out / 'bvh.csv'}, {out / 'bvh.md'}, {out / 'bvh.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
