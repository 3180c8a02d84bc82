"""What hand-written lanes give the path tracer's shading on this CPU: kernels/lanes_probe.cl at 1, 8 and 16 paths
per work-item, the same arithmetic (a diffuse bounce of render_path: surface, Sobol pairs, NEE with MIS, the cosine
sample, roulette) over given hits, so traversal is not timed.  Prints kernel seconds (medians, compile apart), the
speedup over one path per work-item, and whether every width gave the same bits.

    python -m bench lanes [--paths 262144] [--bounces 8] [--runs 5] [--device D]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from bench.common import cpu_model

WIDTHS = (1, 8, 16)


def room() -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[int, int], float]:
    """A Cornell-like room: five walls, a ceiling light (two triangles) and two boxes, as (tris (N, 9), albedo (N, 3),
    emission (N, 3), the light's two triangle ids, one light triangle's area)."""
    quads = []  # (corner, edge a, edge b, albedo, emission)
    white, red, green = (0.73, 0.73, 0.73), (0.65, 0.05, 0.05), (0.12, 0.45, 0.15)
    quads += [((-1, -1, -1), (2, 0, 0), (0, 0, 2), white, (0, 0, 0))]  # floor
    quads += [((-1, 1, -1), (0, 0, 2), (2, 0, 0), white, (0, 0, 0))]  # ceiling
    quads += [((-1, -1, -1), (0, 2, 0), (2, 0, 0), white, (0, 0, 0))]  # back
    quads += [((-1, -1, -1), (0, 0, 2), (0, 2, 0), red, (0, 0, 0))]  # left
    quads += [((1, -1, -1), (0, 2, 0), (0, 0, 2), green, (0, 0, 0))]  # right
    for lo, hi in (((-0.6, -1, -0.6), (-0.1, 0.2, -0.1)), ((0.1, -1, 0.0), (0.6, -0.4, 0.5))):
        lo, hi = np.array(lo, float), np.array(hi, float)
        ex = np.diag(hi - lo)
        for axis in range(3):
            a, b = ex[(axis + 1) % 3], ex[(axis + 2) % 3]
            quads += [(lo, a, b, white, (0, 0, 0)), (lo + ex[axis], b, a, white, (0, 0, 0))]
    tris, albedo, emission = [], [], []
    for corner, a, b, alb, em in quads:
        c, a, b = (np.array(v, float) for v in (corner, a, b))
        tris += [[c, c + a, c + a + b], [c, c + a + b, c + b]]
        albedo += [alb, alb]
        emission += [em, em]
    light = len(tris)
    c, a, b = np.array([-0.25, 0.999, -0.25]), np.array([0.5, 0, 0]), np.array([0, 0, 0.5])
    tris += [[c, c + a, c + a + b], [c, c + a + b, c + b]]
    albedo += [(0.0, 0.0, 0.0)] * 2
    emission += [(17.0, 12.0, 4.0)] * 2
    return (np.asarray(tris, np.float32).reshape(-1, 9), np.asarray(albedo, np.float32), np.asarray(emission, np.float32), (light, light + 1), 0.125)


def hits(n_paths: int, bounces: int, n_surfaces: int, seed: int) -> tuple[np.ndarray, ...]:
    """Given hits, [bounce][path]: a non-emitting triangle and barycentrics; and the camera rays' directions, [3][path]."""
    rng = np.random.default_rng(seed)
    prim = rng.integers(0, n_surfaces, (bounces, n_paths), dtype=np.int32)
    u, v = rng.random((2, bounces, n_paths), dtype=np.float32)
    outside = u + v > 1
    u[outside], v[outside] = 1 - u[outside], 1 - v[outside]
    d = rng.normal(size=(3, n_paths)).astype(np.float32)
    d /= np.linalg.norm(d, axis=0)
    return prim, u, v, d


def run(dev, lanes: int, n_paths: int, bounces: int, runs: int, seed: int = 1) -> tuple[np.ndarray, float]:
    """Radiance [3][path] and the median kernel seconds at `lanes` paths per work-item (compile and first run apart)."""
    import pyopencl as cl
    import pyopencl.cltypes

    tris, albedo, emission, (e0, e1), area = room()
    prim, u, v, d = hits(n_paths, bounces, len(tris) - 2, seed)
    program = dev.program("lanes_probe.cl", {"LANES": lanes})
    knl = program.shade_probe
    bufs = [dev.to_device(a) for a in (tris, albedo, emission, prim, np.stack([u, v]), d)]
    out = cl.Buffer(dev.context, cl.mem_flags.WRITE_ONLY, 3 * n_paths * 4)
    args = (np.int32(n_paths), np.int32(bounces), *bufs[:3], cl.cltypes.make_int2(e0, e1), np.float32(area), np.uint32(seed), *bufs[3:], out)
    items = n_paths // lanes
    local = 8 if lanes == 1 else None  # render_path's 8-item groups on a CPU (work_layout.SCALAR_CPU)

    def once():
        knl(dev.queue, (items,), (local,) if local else None, *args)
        dev.queue.finish()

    once()
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        once()
        times.append(time.perf_counter() - start)
    result = np.empty((3, n_paths), np.float32)
    cl.enqueue_copy(dev.queue, result, out)
    return result, statistics.median(times)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench lanes", description=__doc__.split("\n\n")[0])
    ap.add_argument("--paths", type=int, default=262144)
    ap.add_argument("--bounces", type=int, default=8)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--device", default=None)
    args = ap.parse_args(argv)
    for name, value, ok, allowed in (
        ("--paths", args.paths, args.paths > 0 and args.paths % 16 == 0, "a positive multiple of 16"),
        ("--bounces", args.bounces, args.bounces > 0, "at least 1"),
        ("--runs", args.runs, args.runs > 0, "at least 1"),
    ):
        if not ok:
            sys.stderr.write(f"bench lanes: {name} {value}: {allowed}\n")
            return 2
    from clrender.device import get_device

    dev = get_device(args.device)
    print(f"{cpu_model()}; {dev.name}; {args.paths} paths, {args.bounces} bounces, medians of {args.runs}")
    first, base = None, None
    for lanes in WIDTHS:
        image, seconds = run(dev, lanes, args.paths, args.bounces, args.runs)
        first = image if first is None else first
        base = seconds if base is None else base
        same = np.array_equal(image.view(np.uint32), first.view(np.uint32))
        print(f"lanes {lanes:2d}: {seconds * 1e3:8.2f} ms  {base / seconds:5.2f}x  same bits as 1: {same}")
    return 0
