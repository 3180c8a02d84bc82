"""Instancing: memory and load time of N copies of one mesh vs one copy.

    python -m bench instancing [--copies 30] [--resolution 140] [--size 256] [--render 0] [--spp 4] [--rounds 3] [--out DIR]

A scene dict of `copies` objects naming the same built-in mesh (the procedural bunny at
`resolution`, about 3.5 * resolution^2 triangles: 68,600 at 140) with different translate /
rotate / scale, against the same scene with one object.  Reported per scene: the seconds of
Scene.from_dict (mesh loading and transforms), of Tracer(scene) (flatten, BVH build, upload),
the bytes of the Tracer's device buffers, the peak Python-heap bytes of both steps (tracemalloc:
numpy's arrays are counted), and primary-ray Mrays/s at size x size (Tracer.intersect); the copies
flat and with Tracer(instancing=True) (clrender/trace/instancing.py).  With --render N, also renders of
the copies at N x N, Whitted (one ray a pixel, shadows) and path (--spp paths a pixel), flat and
instanced alternating in this one process: camera samples per second of Renderer.run, the median of
--rounds (instancing.csv/.md, then instancing_render.csv/.md).  Numbers are reported, never asserted
(docs/bvh.md, "Instancing").
"""

from __future__ import annotations

import argparse
import time
import tracemalloc
from pathlib import Path

import numpy as np

from .common import median_seconds, write_table


def bunnies_scene(copies: int, resolution: int) -> dict:
    """A scene dict of `copies` bunnies on a grid, each turned, scaled and moved differently."""
    rng = np.random.default_rng(7)
    side = int(np.ceil(np.sqrt(copies)))
    objects = []
    for i in range(copies):
        x, z = i % side, i // side
        objects.append(
            {
                "type": "mesh",
                "generator": "bunny",
                "params": {"resolution": resolution},
                "translate": [2.0 * x - side, 0.0, -2.0 * z],
                "rotate": [0.0, float(rng.uniform(0, 360)), 0.0],
                "scale": float(rng.uniform(0.6, 1.2)),
            }
        )
    return {
        "cameras": [{"position": [0.0, 6.0, 8.0], "look_at": [0.0, 0.0, -side], "fov": 60}],
        "lights": [{"type": "point", "position": [0, 20, 10]}],
        "objects": objects,
    }


def measure(copies: int, resolution: int, size: int, instancing: bool) -> dict:
    from clrender.scene.scene import Scene
    from clrender.trace.tracer import Tracer

    data = bunnies_scene(copies, resolution)
    # the bunny built and cached on disk, the BVH builder's kernels compiled, before any timing
    Tracer(Scene.from_dict(bunnies_scene(1, resolution)))
    tracemalloc.start()
    start = time.perf_counter()
    scene = Scene.from_dict(data)
    load_s = time.perf_counter() - start
    _, load_peak = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    start = time.perf_counter()
    tracer = Tracer(scene, instancing=instancing)
    build_s = time.perf_counter() - start
    _, build_peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    names = ("nodes", "prims", "prim_object", "normals", "objects", "materials", "instance_buffer")
    device_bytes = sum(getattr(tracer, k).size for k in names)
    o, d = primary_rays(scene, size)
    tracer.intersect(o, d)  # compile and warm up
    seconds = median_seconds(lambda: tracer.intersect(o, d), 3)
    return {
        "copies": copies,
        "instancing": instancing,
        "triangles": scene.triangle_count,
        "stored_triangles": tracer.primitives.count + sum(len(s.faces) for s in (tracer.instances.shapes if tracer.instances else [])),
        "load_s": load_s,
        "tracer_s": build_s,
        "load_peak_MB": load_peak / 1e6,
        "tracer_peak_MB": build_peak / 1e6,
        "device_MB": device_bytes / 1e6,
        "primary_Mrays_s": len(d) / seconds / 1e6,
    }


def primary_rays(scene, size: int):
    """size x size pinhole rays from the scene's camera 1 (60 degrees across)."""
    cam = scene.camera(1)
    ys, xs = np.mgrid[0:size, 0:size]
    u, v = (xs + 0.5) / size * 2 - 1, 1 - (ys + 0.5) / size * 2
    forward = np.asarray(cam.look_at, float) - np.asarray(cam.position, float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0, 1, 0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = forward + 0.6 * (u[..., None] * right + v[..., None] * up)
    d = (d / np.linalg.norm(d, axis=-1, keepdims=True)).reshape(-1, 3).astype(np.float32)
    return np.broadcast_to(np.asarray(cam.position, np.float32), d.shape).copy(), d


def render_rates(copies: int, resolution: int, size: int, spp: int, rounds: int) -> list:
    """Camera samples per second of Renderer.run over the copies, Whitted and path, flat and instanced: the two
    Renderers of each integrator built first, then timed alternately, `rounds` times each (median)."""
    import warnings

    from clrender.scene.scene import Scene
    from clrender.trace.renderer import Renderer

    data = bunnies_scene(copies, resolution)
    # closer than the ray benchmark's view, over a floor: every ray meets something and shadows cross the bunnies
    data["cameras"] = [{"position": [-1.0, 3.0, 3.0], "look_at": [-1.0, 0.0, -4.5], "fov": 60}]
    data["objects"].append({"type": "quad", "corner": [-9, 0, 3], "edge_a": [16, 0, 0], "edge_b": [0, 0, -16]})
    scene = Scene.from_dict(data)
    rows = []
    for integrator, extra in (("whitted", {}), ("path", {"spp": spp, "max_depth": 4})):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # a scene without lights for the path tracer's emission: said once is enough
            renderers = {inst: Renderer(scene, width=size, height=size, integrator=integrator, instancing=inst, **extra) for inst in (False, True)}
        for r in renderers.values():
            r.run()  # warm-up
        times = {False: [], True: []}
        for _ in range(rounds):
            for inst, r in renderers.items():
                start = time.perf_counter()
                r.run()
                times[inst].append(time.perf_counter() - start)
        samples = size * size * (spp if integrator == "path" else 1)
        for inst in (False, True):
            seconds = float(np.median(times[inst]))
            rows.append(
                {
                    "integrator": integrator,
                    "instancing": inst,
                    "size": size,
                    "samples": samples,
                    "run_s": seconds,
                    "Msamples_s": samples / seconds / 1e6,
                }
            )
    return rows


def main(argv):
    parser = argparse.ArgumentParser(prog="python -m bench instancing", description=__doc__.splitlines()[0])
    parser.add_argument("--copies", type=int, default=30, help="objects naming the same mesh (default 30)")
    parser.add_argument("--resolution", type=int, default=140, help="bunny resolution: 3.5 r^2 triangles (default 140: 68,600)")
    parser.add_argument("--size", type=int, default=256, help="primary rays: size x size (default 256)")
    parser.add_argument("--render", type=int, default=0, help="also time renders of the copies at this size, flat vs instanced (default 0: none)")
    parser.add_argument("--spp", type=int, default=4, help="--render: paths per pixel of the path renders (default 4)")
    parser.add_argument("--rounds", type=int, default=3, help="--render: timed runs of each, alternating (default 3)")
    parser.add_argument("--out", type=Path, default=Path("bench_out"), help="folder for instancing.csv/.md (default bench_out)")
    args = parser.parse_args(argv)
    rows = [measure(n, args.resolution, args.size, inst) for n, inst in ((1, False), (args.copies, False), (args.copies, True))]
    print(write_table(args.out, "instancing", rows, f"Instancing: 1 vs {args.copies} bunnies"))
    if args.render > 0:
        rates = render_rates(args.copies, args.resolution, args.render, args.spp, args.rounds)
        print(write_table(args.out, "instancing_render", rates, f"Instancing: renders of {args.copies} bunnies, flat vs instanced"))
    return 0
