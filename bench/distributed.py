"""Scaling a render over Dask workers: `python -m bench distributed [--quick] [--out DIR]`.

Renders one scene split into >= 64 tiles on a LocalCluster of 1 worker and
of 2 workers, every worker a single-thread process whose PoCL device is
pinned to one thread (POCL_MAX_PTHREAD_COUNT=1).  Reports, per cluster size:

- wall: median seconds of a warm render (scene cached on the workers),
  and the speed-up of 2 workers over 1;
- compute: the summed wall seconds the tasks spent tracing (measured on the
  workers), the CPU seconds of the same (what they would take on an idle
  core; under load the wall time grows, the CPU time does not), per task;
- overhead per task: (wall x workers - compute) / tasks, i.e. the time a
  worker's slot was not tracing: scheduling, (de)serialising, shipping the
  tile back, assembling on the client;
- first pixel: from `run()` on a fresh cluster to the first tile back
  (shipping the scene, building its BVH and compiling the kernels on the worker);
- tasks per worker: how Dask shared the tiles out;
- the same render in this process on one PoCL thread, for comparison.

Every distributed image is checked byte for byte against the local one.
Numbers depend on what else the machine runs; the table says how loaded it was.

Linux autogroups: with kernel.sched_autogroup_enabled=1 the scheduler shares
the CPU fairly between sessions, not processes, so on a busy machine all the
workers of a LocalCluster (children of this session) together get one
session's share however many there are, and adding a worker cannot speed
anything up.  Workers started by hand (`dask worker` in its own shell, or on
other machines) each have their own session; the benchmark gives each worker
its own session (setsid) to measure that case, unless --same-session.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

# this process's own PoCL device (the local baseline) gets one thread, like each worker
os.environ.setdefault("POCL_MAX_PTHREAD_COUNT", "1")
os.environ.setdefault("POCL_CPU_MAX_CU_NUM", "1")

from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer, RenderSettings

from .common import write_table


def load_average() -> str:
    try:
        return "/".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "n/a"


def parse_args(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench distributed", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="wizard_cat")
    ap.add_argument("--camera", type=int, default=3)
    ap.add_argument("--size", type=int, default=384, help="square image side")
    ap.add_argument("--tile", type=int, default=48, help="tile side: (size / tile)^2 tiles")
    ap.add_argument("--samples", type=int, default=2, help="N: full AA with N x N stratified samples")
    ap.add_argument("--runs", type=int, default=3, help="warm renders per cluster size (median)")
    ap.add_argument("--workers", default="1,2", help="cluster sizes to compare")
    ap.add_argument("--same-session", action="store_true", help="leave the workers in this process's session (see 'Linux autogroups' above)")
    ap.add_argument("--quick", action="store_true", help="128x128, 16-pixel tiles, N=1, 1 run")
    ap.add_argument("--out", default="bench/out")
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.tile, args.samples, args.runs = 128, 16, 1, 1
    return args


def main(argv=None):
    args = parse_args(argv)
    scene = Scene.load(args.scene)
    settings = RenderSettings(width=args.size, height=args.size, camera=args.camera, aa="full", samples=args.samples, tile_size=args.tile, seed=1)
    n_tiles = (-(-args.size // args.tile)) ** 2
    load_before = load_average()
    print(
        f"{args.scene} camera {args.camera}, {args.size}x{args.size}, full AA N={args.samples}, "
        f"{n_tiles} tiles of {args.tile}x{args.tile}; load average {load_before}",
        file=sys.stderr,
    )

    reference, row = local_row(scene, settings, args.runs, n_tiles)
    rows = [row]
    walls = {}
    for workers in [int(w) for w in args.workers.split(",")]:
        times, logs, identical, first_pixel, cluster_start = cluster_runs(scene, settings, workers, args, reference)
        wall = statistics.median(times)
        log = logs[times.index(min(times, key=lambda t: abs(t - wall)))]
        walls[workers] = wall
        rows.append(cluster_row(workers, wall, walls[min(walls)] / wall if walls else 1.0, log, identical, first_pixel, cluster_start))
        print(f"{workers} worker(s): {wall:.2f} s, {len({t['pid'] for t in log})} process(es) ran tasks", file=sys.stderr)

    title = (
        f"{args.scene} camera {args.camera}, {args.size}x{args.size}, full AA N={args.samples}, {n_tiles} tiles; "
        f"one PoCL thread per worker{', workers in this session' if args.same_session else ', one session per worker'}; "
        f"{os.cpu_count()} CPUs, load average (1/5/15 min) before {load_before}, "
        f"after {load_average()}"
    )
    table = write_table(Path(args.out), "distributed", rows, title)
    print(table)
    if not all(r["identical"] for r in rows):
        print("distributed images differ from the local one", file=sys.stderr)
        return 1
    return 0


def local_row(scene, settings, runs: int, n_tiles: int):
    """The same render in this process: (its image, the table's row), the median of `runs` warm renders."""
    local = Renderer(scene, settings)
    local.run()  # warm: kernels built
    local_times = []
    for _ in range(runs):
        start = time.perf_counter()
        reference = local.run()
        local_times.append(time.perf_counter() - start)
    row = dict(
        workers="local (this process)",
        wall_s=statistics.median(local_times),
        speedup=1.0,
        tasks=n_tiles,
        compute_s=float("nan"),
        compute_cpu_s=float("nan"),
        compute_per_task_ms=float("nan"),
        overhead_per_task_ms=float("nan"),
        tasks_per_worker="",
        first_pixel_s=float("nan"),
        cluster_start_s=float("nan"),
        identical=True,
    )
    return reference, row


def cluster_runs(scene, settings, workers: int, args, reference):
    """A cold render, then `args.runs` warm ones, on a fresh LocalCluster of `workers` workers: (wall times, task
    logs, whether every image is byte for byte the local one, seconds to the first tile, seconds to start)."""
    import logging

    import distributed

    import clrender.distributed as crd
    from clrender.distributed.cluster import pocl_env

    start = time.perf_counter()
    with (
        distributed.LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=logging.ERROR, env=pocl_env(1)
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        client.wait_for_workers(workers)
        if not args.same_session:
            client.run(os.setsid)  # each worker its own autogroup, as workers started by hand are
        cluster_start = time.perf_counter() - start
        cold = crd.DistributedRenderer(scene, settings, client)
        cold.run()
        first_pixel = cold.first_result_seconds
        times, logs, identical = [], [], True
        for _ in range(args.runs):
            renderer = crd.DistributedRenderer(scene, settings, client)
            start = time.perf_counter()
            result = renderer.run()
            times.append(time.perf_counter() - start)
            logs.append(renderer.task_log)
            identical &= result.image.tobytes() == reference.image.tobytes()
    return times, logs, identical, first_pixel, cluster_start


def cluster_row(workers: int, wall: float, speedup: float, log: list, identical: bool, first_pixel: float, cluster_start: float) -> dict:
    """The table's row of one cluster size, from the task log of its median run."""
    compute = sum(t["compute"] for t in log)
    compute_cpu = sum(t["compute_cpu"] for t in log)
    per_worker = {}
    for t in log:
        per_worker[t["pid"]] = per_worker.get(t["pid"], 0) + 1
    return dict(
        workers=workers,
        wall_s=wall,
        speedup=speedup,
        tasks=len(log),
        compute_s=compute,
        compute_cpu_s=compute_cpu,
        compute_per_task_ms=1e3 * compute / len(log),
        overhead_per_task_ms=1e3 * (wall * workers - compute) / len(log),
        tasks_per_worker="/".join(map(str, sorted(per_worker.values(), reverse=True))),
        first_pixel_s=first_pixel,
        cluster_start_s=cluster_start,
        identical=identical,
    )
