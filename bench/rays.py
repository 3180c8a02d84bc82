"""Ray throughput and BVH build: `python -m bench rays [--mesh PATH] [--runs K] [--out DIR]`.

Primary rays: a 512x512 pinhole camera framing the mesh; shadow rays: from
each primary hit towards a point light.  Kernel time only (rays already on
the device, compile and warm-up excluded), median of K runs; for primary rays
also per CPU-second of this process (steadier than wall time on a shared CPU).  Also the BVH
build time for a 1,000,000-triangle mesh and the SAH cost of both builders.
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from clrender.camera import Camera
from clrender.device import get_device
from clrender.scene import load_mesh_file
from clrender.tracer import Tracer

from .common import median_seconds, write_table


def framing_camera(vertices) -> Camera:
    """A camera whose view the mesh's bounding sphere just fills (most rays hit)."""
    centre = (vertices.min(0) + vertices.max(0)) / 2
    radius = np.linalg.norm(vertices - centre, axis=1).max()
    fov = 50.0
    direction = np.array([0.3, 0.4, 1.0]) / np.linalg.norm([0.3, 0.4, 1.0])
    eye = centre + direction * radius / np.sin(np.radians(fov / 2))
    return Camera(tuple(eye), tuple(centre), (0, 1, 0), fov)


def median_cpu_seconds(fn, runs: int) -> float:
    """Median CPU time of this process (all its threads: PoCL's workers included) per call of fn().
    On a CPU device shared with other jobs this varies far less than wall time."""
    times = []
    for _ in range(runs):
        start = time.process_time()
        fn()
        times.append(time.process_time() - start)
    return float(np.median(times))


def ray_throughput(mesh, size: int, runs: int, builder: str):
    dev = get_device()
    tracer = Tracer(mesh, builder=builder, device=dev)
    cam = framing_camera(np.asarray(mesh.vertices))
    o, d = cam.rays(size, size)
    n, o_buf, d_buf = tracer._rays(o.reshape(-1, 3), d.reshape(-1, 3))
    outs = tuple(dev.empty(4 * n) for _ in range(4))
    zeros = dev.to_device(np.zeros(n, np.float32))  # t_min
    tracer.launch_intersect(n, o_buf, d_buf, zeros, outs).wait()  # warm-up: PoCL finishes compiling here
    primary = median_seconds(lambda: tracer.launch_intersect(n, o_buf, d_buf, zeros, outs).wait(), runs)
    primary_cpu = median_cpu_seconds(lambda: tracer.launch_intersect(n, o_buf, d_buf, zeros, outs).wait(), runs)
    t, prim, _ = tracer.intersect(o.reshape(-1, 3), d.reshape(-1, 3))
    visits = tracer.last_visits.mean()
    hit = np.isfinite(t)
    p = o.reshape(-1, 3)[hit] + t[hit, None] * d.reshape(-1, 3)[hit]
    light = np.asarray(cam.position) + np.array([2.0, 3.0, 0.0]) * np.ptp(mesh.vertices, axis=0).max()
    to_light = light - p
    dist = np.linalg.norm(to_light, axis=1)
    to_light /= dist[:, None]
    origins = p + to_light * 1e-4 * (1 + np.abs(p).max(1, keepdims=True))
    m, so, sd = tracer._rays(origins, to_light)
    t_max = dev.to_device(dist.astype(np.float32))
    s_zeros = dev.to_device(np.zeros(m, np.float32))  # t_min
    souts = (dev.empty(4 * m), dev.empty(4 * m))
    tracer.launch_occluded(m, so, sd, s_zeros, t_max, souts).wait()
    shadow = median_seconds(lambda: tracer.launch_occluded(m, so, sd, s_zeros, t_max, souts).wait(), runs)
    return dict(primary_mrays=n / primary / 1e6, primary_mrays_per_cpu_s=n / primary_cpu / 1e6,
                shadow_mrays=m / shadow / 1e6, hit_fraction=float(hit.mean()),
                nodes_per_primary_ray=float(visits), compile_s=dev.compile_seconds, bvh_build_s=tracer.bvh_seconds)


def build_times(n_triangles: int, runs: int):
    from clrender.bvh import build_bvh
    from clrender.meshes import dense_mesh

    mesh = dense_mesh(n_triangles, seed=1)
    tri = np.asarray(mesh.vertices, np.float32)[np.asarray(mesh.faces)]
    lo, hi = tri.min(1), tri.max(1)
    rows = []
    for builder in ("sah", "median"):
        seconds = median_seconds(lambda: build_bvh(lo, hi, builder=builder), runs)
        bvh = build_bvh(lo, hi, builder=builder)
        rows.append(dict(builder=builder, triangles=len(tri), build_s=seconds, nodes=len(bvh.nodes),
                         sah_cost=float(bvh.sah_cost())))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench rays", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", help="mesh file to trace (default: a generated ~100k-triangle mesh)")
    ap.add_argument("--size", type=int, default=512, help="image side in pixels (rays = size^2)")
    ap.add_argument("--runs", type=int, default=5, help="timed runs; the median is reported")
    ap.add_argument("--build-triangles", type=int, default=1_000_000, help="triangles for the build benchmark")
    ap.add_argument("--out", default="bench/out", help="folder for rays.csv / rays.md")
    args = ap.parse_args(argv)
    if args.mesh:
        mesh = load_mesh_file(Path(args.mesh), "--mesh")
        label = args.mesh
    else:
        from clrender.meshes import dense_mesh

        mesh = dense_mesh(100_000, seed=0)
        label = "generated"
    rows = []
    for builder in ("sah", "median"):
        r = ray_throughput(mesh, args.size, args.runs, builder)
        rows.append(dict(mesh=label, triangles=len(mesh.faces), builder=builder, **r))
    out = Path(args.out)
    print(write_table(out, "rays", rows, f"Ray throughput at {args.size}x{args.size} (median of {args.runs})"))
    build = build_times(args.build_triangles, max(1, min(args.runs, 3)))
    print()
    print(write_table(out, "bvh_build", build, "BVH build time"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
