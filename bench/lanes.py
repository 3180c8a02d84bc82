"""What hand-written lanes give the path tracer's shading on this CPU: kernels/lanes_probe.cl at 1, 8 and 16 pixels
per work-item, the same arithmetic (render_path's vertex for a Lambert and a GGX conductor lobe: surface, Sobol pairs,
NEE with MIS, the lobe's sample, roulette) over given hits, so traversal is not timed; with lanes refilled by the
pixel's next sample, or not.  Prints kernel seconds (medians, compile apart), the speedup over one pixel a work-item,
the lanes' occupancy, and whether every variant gave the same bits.

    python -m bench lanes [--pixels 65536] [--spp 4] [--depth 8] [--runs 5] [--device D]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from bench.common import cpu_model

WIDTHS = (1, 8, 16)
MATTE, METAL = 0.0, 1.0


def room() -> tuple[np.ndarray, np.ndarray, tuple[int, int], float]:
    """A Cornell-like room: five walls, a ceiling light (two triangles), a matte box and a rough gold box, as (tris
    (N, 9), mats (N, 8): albedo or f0, emission, lobe, GGX alpha; the light's two triangle ids; one light triangle's
    area)."""
    white, red, green, gold = (0.73, 0.73, 0.73), (0.65, 0.05, 0.05), (0.12, 0.45, 0.15), (1.0, 0.78, 0.34)
    none = (0.0, 0.0, 0.0)
    quads = [  # corner, edge a, edge b, colour, emission, lobe, alpha
        ((-1, -1, -1), (2, 0, 0), (0, 0, 2), white, none, MATTE, 1.0),  # floor
        ((-1, 1, -1), (0, 0, 2), (2, 0, 0), white, none, MATTE, 1.0),  # ceiling
        ((-1, -1, -1), (0, 2, 0), (2, 0, 0), white, none, MATTE, 1.0),  # back
        ((-1, -1, -1), (0, 0, 2), (0, 2, 0), red, none, MATTE, 1.0),  # left
        ((1, -1, -1), (0, 2, 0), (0, 0, 2), green, none, MATTE, 1.0),  # right
    ]
    for (lo, hi), colour, lobe in ((((-0.6, -1, -0.6), (-0.1, 0.2, -0.1)), white, MATTE), (((0.1, -1, 0.0), (0.6, -0.4, 0.5)), gold, METAL)):
        lo, ex = np.array(lo, float), np.diag(np.subtract(hi, lo))
        for axis in range(3):
            a, b = ex[(axis + 1) % 3], ex[(axis + 2) % 3]
            quads += [(lo, a, b, colour, none, lobe, 0.3), (lo + ex[axis], b, a, colour, none, lobe, 0.3)]
    quads += [((-0.25, 0.999, -0.25), (0.5, 0, 0), (0, 0, 0.5), none, (17.0, 12.0, 4.0), MATTE, 1.0)]  # the light, last
    tris, mats = [], []
    for corner, a, b, colour, emission, lobe, alpha in quads:
        c, a, b = (np.array(v, float) for v in (corner, a, b))
        tris += [[c, c + a, c + a + b], [c, c + a + b, c + b]]
        mats += [[*colour, *emission, lobe, alpha]] * 2
    light = len(tris) - 2
    return np.asarray(tris, np.float32).reshape(-1, 9), np.asarray(mats, np.float32), (light, light + 1), 0.125


def hits(n_pixels: int, depth: int, n_surfaces: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Given hits, [depth][pixel]: a non-emitting triangle, and its barycentrics [2][depth][pixel]."""
    rng = np.random.default_rng(seed)
    prim = rng.integers(0, n_surfaces, (depth, n_pixels), dtype=np.int32)
    u, v = rng.random((2, depth, n_pixels), dtype=np.float32)
    outside = u + v > 1
    u[outside], v[outside] = 1 - u[outside], 1 - v[outside]
    return prim, np.stack([u, v])


def run(dev, lanes: int, refill: bool, n_pixels: int, spp: int, depth: int, runs: int, seed: int = 1):
    """Radiance [3][pixel] summed over the samples, the median kernel seconds (compile and first run apart) and the
    lanes' occupancy, at `lanes` pixels a work-item."""
    import pyopencl as cl
    import pyopencl.cltypes

    tris, mats, (e0, e1), area = room()
    prim, uv = hits(n_pixels, depth, len(tris) - 2, seed)
    knl = dev.program("lanes_probe.cl", {"LANES": lanes, "REFILL": int(refill)}).shade_probe
    items = n_pixels // lanes
    out = cl.Buffer(dev.context, cl.mem_flags.WRITE_ONLY, 3 * n_pixels * 4)
    steps = cl.Buffer(dev.context, cl.mem_flags.WRITE_ONLY, 8 * items)
    scene = [dev.to_device(a) for a in (tris, mats)]
    args = (
        np.int32(n_pixels),
        np.int32(spp),
        np.int32(depth),
        *scene,
        cl.cltypes.make_int2(e0, e1),
        np.float32(area),
        np.uint32(seed),
        dev.to_device(prim),
        dev.to_device(uv),
        out,
        steps,
    )
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
    radiance, counted = np.empty((3, n_pixels), np.float32), np.empty((items, 2), np.int32)
    cl.enqueue_copy(dev.queue, radiance, out)
    cl.enqueue_copy(dev.queue, counted, steps)
    occupancy = counted[:, 1].sum() / (lanes * counted[:, 0].sum())
    return radiance, statistics.median(times), float(occupancy)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench lanes", description=__doc__.split("\n\n")[0])
    ap.add_argument("--pixels", type=int, default=65536)
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--depth", type=int, default=8)
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--device", default=None)
    args = ap.parse_args(argv)
    for name, value, ok, allowed in (
        ("--pixels", args.pixels, args.pixels > 0 and args.pixels % 16 == 0, "a positive multiple of 16"),
        ("--spp", args.spp, args.spp > 0, "at least 1"),
        ("--depth", args.depth, args.depth > 0, "at least 1"),
        ("--runs", args.runs, args.runs > 0, "at least 1"),
    ):
        if not ok:
            sys.stderr.write(f"bench lanes: {name} {value}: {allowed}\n")
            return 2
    from clrender.device import get_device

    dev = get_device(args.device)
    print(f"{cpu_model()}; {dev.name}; {args.pixels} pixels, {args.spp} spp, depth {args.depth}, medians of {args.runs}")
    first, base = None, None
    for lanes in WIDTHS:
        for refill in (False, True) if lanes > 1 else (False,):
            image, seconds, occupancy = run(dev, lanes, refill, args.pixels, args.spp, args.depth, args.runs)
            first = image if first is None else first
            base = seconds if base is None else base
            same = np.array_equal(image.view(np.uint32), first.view(np.uint32))
            what = f"{lanes:2d} lanes" + (", refilled" if refill else "") if lanes > 1 else " 1 pixel a work-item"
            print(f"{what:22s} {seconds * 1e3:8.2f} ms  {base / seconds:5.2f}x  occupancy {occupancy:.2f}  same bits: {same}")
    return 0
