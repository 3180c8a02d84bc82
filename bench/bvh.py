"""BVH on/off on the six bundled scenes: `python -m bench bvh [--quick] [--runs K] [--out DIR]`.

Renders each scene with the BVH and without it (every ray tests every
primitive) at identical settings; reports the median trace time of K runs
(compile excluded), BVH build time, node count, nodes visited per ray and
the speed-up, checks that both give the same object ids, and writes
DIR/bvh.csv, DIR/bvh.md and the bar chart DIR/bvh.png (the original report's Figure C).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from .common import write_table

SCENES = ("refract1", "bunny", "refract2", "wizard_tower", "wizard_hat", "wizard_cat")


def time_case(name: str, use_bvh: bool, camera: int, width: int, height: int, runs: int, light_samples: int) -> dict:
    """One scene x camera x {BVH on, off} case (a task on a cluster): timings and the object ids."""
    scene = Scene.load(name)
    tracer = Tracer(scene, use_bvh=use_bvh)
    renderer = Renderer(scene, tracer=tracer, width=width, height=height, camera=camera, bvh=use_bvh, light_samples=light_samples)
    times = []
    for _ in range(runs):
        result = renderer.run()
        times.append(result.timings["trace"])
    case = {
        "seconds": statistics.median(times),
        "visits_per_ray": result.node_visits / max(result.rays, 1),
        "primitives": tracer.n_prims,
        "path_ids": result.path_ids,
    }
    if use_bvh:
        # nodes of the tree the kernels traverse: 4-wide nodes (each visit tests four boxes) or binary ones
        nodes = tracer.wide.node_count if tracer.wide is not None else len(tracer.bvh.nodes)
        case.update(build_s=tracer.bvh_seconds, nodes=nodes, bvh_width=tracer.bvh_width)
    return case


def scene_row(name: str, camera: int, on: dict, off: dict) -> dict:
    """The table row of one scene and camera from its two cases; both must see the same objects."""
    if not np.array_equal(on["path_ids"], off["path_ids"]):
        differ = int((on["path_ids"] != off["path_ids"]).any(-1).sum())
        raise SystemExit(f"bench bvh: {name}: BVH on and off disagree on the object ids of {differ} pixels")
    return {
        "scene": name,
        "camera": camera,
        "primitives": on["primitives"],
        "on_s": on["seconds"],
        "on_visits_per_ray": on["visits_per_ray"],
        "build_s": on["build_s"],
        "bvh_width": on["bvh_width"],
        "nodes": on["nodes"],
        "off_s": off["seconds"],
        "off_visits_per_ray": off["visits_per_ray"],
        "speedup": off["seconds"] / on["seconds"],
    }


def time_scene(name: str, width: int, height: int, runs: int, light_samples: int, camera: int = 1) -> dict:
    on, off = (time_case(name, use_bvh, camera, width, height, runs, light_samples) for use_bvh in (True, False))
    return scene_row(name, camera, on, off)


def run_cases(args, cases: list) -> list:
    """Every (scene, camera, use_bvh) case here one after another, or as tasks on --scheduler / --workers."""
    common = (args.width, args.height, args.runs, args.light_samples)
    if args.scheduler is None and args.workers is None:
        return [time_case(name, use_bvh, camera, *common) for name, camera, use_bvh in cases]
    from clrender.distributed.cluster import connect

    with connect(args.scheduler, args.workers) as client:  # workers import bench.bvh: run from the checkout
        futures = [client.submit(time_case, name, use_bvh, camera, *common, pure=False) for name, camera, use_bvh in cases]
        try:
            return client.gather(futures)
        finally:
            client.cancel(futures)


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench bvh", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="32x24 pixels, one run: a smoke test (under a minute)")
    ap.add_argument("--runs", type=int, default=3, help="timed runs per scene and mode; the median is reported")
    # Without the BVH every ray tests all 120k primitives of refract2: the default
    # size keeps that baseline to about a minute per run on two cores.
    ap.add_argument("--width", type=int, default=80)
    ap.add_argument("--height", type=int, default=60)
    ap.add_argument("--light-samples", type=int, default=1, help="area-light samples per side, both modes")
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--out", default="bench/out", help="folder for bvh.csv, bvh.md and bvh.png")
    ap.add_argument("--cameras", default="1", help="camera number of every scene, or 'all'")
    ap.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run the scene x camera x {on, off} cases as tasks on this Dask scheduler (docs/distributed.md)",
    )
    ap.add_argument("--workers", type=int, default=None, metavar="N", help="... or on a LocalCluster of N workers")
    args = ap.parse_args(argv)
    if args.quick:
        args.width, args.height, args.runs = 32, 24, 1
    cameras = {name: (range(1, len(Scene.load(name).cameras) + 1) if args.cameras == "all" else [int(args.cameras)]) for name in args.scenes}
    cases = [(name, camera, use_bvh) for name in args.scenes for camera in cameras[name] for use_bvh in (True, False)]
    results = dict(zip(cases, run_cases(args, cases)))
    rows = [scene_row(name, camera, results[name, camera, True], results[name, camera, False]) for name in args.scenes for camera in cameras[name]]
    out = Path(args.out)
    title = (
        f"BVH on vs off, {args.width}x{args.height}, 1 sample per pixel, "
        f"{args.light_samples}x{args.light_samples} area-light samples, median of {args.runs}"
    )
    print(write_table(out, "bvh", rows, title))
    from clrender.image.plot import bar_chart

    bar_chart(
        out / "bvh.png",
        [r["scene"] if args.cameras == "1" else f"{r['scene']} {r['camera']}" for r in rows],
        {"without BVH": [r["off_s"] for r in rows], "with BVH": [r["on_s"] for r in rows]},
        title=title,
        ylabel="render time (s, log scale)",
        log=True,
    )
    print(f"wrote {out / 'bvh.csv'}, {out / 'bvh.md'}, {out / 'bvh.png'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
