"""Ray throughput and BVH build: `python -m bench rays [--mesh PATH] [--runs K] [--out DIR]`.

Primary rays: a 512x512 pinhole camera framing the mesh; shadow (any-hit) rays:
from each primary hit towards a point light; incoherent rays: from each primary
hit in a random direction of the hit face's hemisphere.  Kernel time only (rays
already on the device, compile and warm-up excluded), median of K runs, also per
CPU-second of this process (steadier than wall time on a shared CPU), with nodes
and primitives tested per ray, for each layout (builder, BVH width, eight coherent
rays walked as one packet or each ray alone).  --peer embree traces the same rays
with Embree in the same run (embreex, which calls rtcIntersect1 / rtcOccluded1 once
per ray on one thread) and reports the ratios.

--peer embree,open3d also measures what a user gets, end to end on host arrays
(issue 27): `Tracer.intersect` / `Tracer.occluded` against Embree on as many threads
as clrender's device has compute units (embreex in that many Python threads, each
on its share of the rays: embreex releases the GIL) and Open3D's RaycastingScene
(`cast_rays`, `test_occlusions`, with the same thread count), median of K runs, and
Mrays/s against the batch size (host overhead per call) for primary rays.
Also the BVH build time for a 1,000,000-triangle mesh and the SAH cost of both builders.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from clrender.device import get_device
from clrender.scene.camera import Camera
from clrender.scene.scene import load_mesh_file
from clrender.trace.tracer import Tracer

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


def warm_up(launch, calls: int = 5, seconds: float = 0.2) -> None:
    """Calls before timing: the first finishes PoCL's compile, and the next few launches on this VM
    often run on one core (second worker not yet busy; measured: cpu/wall 1.0-1.7 for up to four
    launches after the first, 2.0 after), for the peer alike."""
    start = time.perf_counter()
    for i in range(1000):
        if i >= calls and time.perf_counter() - start >= seconds:
            break
        launch()


# (builder, BVH width, ray packets); the first is the default, the second the same tree walked one ray
# at a time (the single-ray walk packets fall back to).  The median tree traces 20-50x slower (457
# nodes per primary ray on the generated mesh): only its build is timed.
LAYOUTS = (("sah", 8, True), ("sah", 8, False), ("sah", 4, True), ("sah", 2, False))


def ray_sets(mesh, size: int, seed: int = 0):
    """The three ray kinds, as float32 (origins, directions, t_max) on the host:
    primary: a size x size pinhole camera framing the mesh; shadow: from each primary hit toward a
    point light (t_max = the light's distance); incoherent: from each primary hit, a uniformly random
    direction in the hemisphere of the hit face (a diffuse bounce).  Secondary origins are moved off
    the surface by 1e-4 of the mesh's coordinate scale, for clrender and Embree alike."""
    cam = framing_camera(np.asarray(mesh.vertices))
    o, d = cam.rays(size, size)
    o, d = o.reshape(-1, 3).astype(np.float32), d.reshape(-1, 3).astype(np.float32)
    from clrender.trace.tracer import Tracer as _T  # closest hits from the exact (binary, SAH) tracer

    t, prim, _ = _T(mesh, bvh_width=2).intersect(o, d)
    hit = np.isfinite(t)
    p = o[hit].astype(np.float64) + t[hit, None] * d[hit].astype(np.float64)
    n = np.asarray(mesh.face_normals, np.float64)[prim[hit]]
    eps = 1e-4 * (1 + np.abs(np.asarray(mesh.vertices)).max())
    light = np.asarray(cam.position) + np.array([2.0, 3.0, 0.0]) * np.ptp(mesh.vertices, axis=0).max()
    to_light = light - p
    dist = np.linalg.norm(to_light, axis=1)
    to_light /= dist[:, None]
    side = np.sign(np.einsum("ij,ij->i", n, to_light))[:, None]
    shadow = (p + side * n * eps, to_light, dist)
    rng = np.random.default_rng(seed)
    r = rng.normal(size=p.shape)
    r /= np.linalg.norm(r, axis=1, keepdims=True)
    facing = -np.sign(np.einsum("ij,ij->i", n, d[hit]))[:, None]  # the side the camera sees
    r *= np.where(np.einsum("ij,ij->i", r, n * facing) < 0, -1, 1)[:, None]
    bounce = (p + facing * n * eps, r, np.full(len(p), np.inf))
    f32 = lambda a: tuple(np.ascontiguousarray(x, np.float32) for x in a)
    return {"primary": (o, d, np.full(len(o), np.inf, np.float32)), "shadow": f32(shadow), "incoherent": f32(bounce)}, float(hit.mean())


def clrender_rates(mesh, rays: dict, runs: int, builder: str, width: int, packets: bool = True):
    """Mrays/s (wall) and Mrays per CPU-second of this process for each ray kind, with nodes and
    primitives tested per ray; kernel time only (rays on the device, compile and warm-up excluded)."""
    dev = get_device()
    tracer = Tracer(mesh, builder=builder, bvh_width=width, device=dev, ray_packets=packets)
    counter = Tracer(mesh, builder=builder, bvh_width=width, device=dev, ray_packets=packets, count_prim_tests=True)
    row = dict(bvh_build_s=tracer.bvh_seconds)
    for kind, (o, d, t_max) in rays.items():
        n, o_buf, d_buf = len(o), dev.to_device(o), dev.to_device(d)  # float32 (n, 3) rays (ray_sets)
        zeros = dev.to_device(np.zeros(n, np.float32))  # t_min
        if kind == "shadow":
            t_buf, outs = dev.to_device(t_max), (dev.empty(4 * n), dev.empty(4 * n))
            launch = lambda: tracer.launch_occluded(n, o_buf, d_buf, zeros, t_buf, outs).wait()
            query = lambda tr: tr.occluded(o, d, t_max)
        else:
            outs = tuple(dev.empty(4 * n) for _ in range(4))
            launch = lambda: tracer.launch_intersect(n, o_buf, d_buf, zeros, outs).wait()
            query = lambda tr: tr.intersect(o, d)
        warm_up(launch)
        row[f"{kind}_mrays"] = n / median_seconds(launch, runs) / 1e6
        row[f"{kind}_mrays_per_cpu_s"] = n / median_cpu_seconds(launch, runs) / 1e6
        query(tracer)
        row[f"{kind}_nodes_per_ray"] = float(tracer.last_visits.mean())
        query(counter)
        row[f"{kind}_prims_per_ray"] = float(counter.last_visits.mean())
    return row


def embree_rates(mesh, rays: dict, runs: int):
    """The same rays through Embree (embreex): rtcIntersect1 / rtcOccluded1 once per ray in
    embreex's Cython loop, on this one thread (Embree's build may use more)."""
    from embreex import rtcore_scene
    from embreex.mesh_construction import TriangleMesh

    scene = rtcore_scene.EmbreeScene()
    TriangleMesh(scene, np.asarray(mesh.vertices, np.float32)[np.asarray(mesh.faces)])
    row = {}
    for kind, (o, d, t_max) in rays.items():
        if kind == "shadow":
            launch = lambda: scene.run(o, d, dists=t_max.copy(), query="OCCLUDED")
        else:
            launch = lambda: scene.run(o, d)
        warm_up(launch)
        row[f"{kind}_mrays"] = len(o) / median_seconds(launch, runs) / 1e6
        row[f"{kind}_mrays_per_cpu_s"] = len(o) / median_cpu_seconds(launch, runs) / 1e6
    return row


PEERS = ("embree", "open3d")
BATCHES = (256, 1024, 4096, 16384, 65536, 262144)  # rays per call, for the host overhead per call


def user_queries(mesh, threads: int):
    """Each tool's end-to-end query on host float32 arrays, as its user calls it: name -> (closest(o, d),
    occluded(o, d, t_max)).  Every tool gets `threads` threads (clrender: its device's compute units)."""
    from concurrent.futures import ThreadPoolExecutor

    tracer = Tracer(mesh)
    tools = {"clrender": (lambda o, d: tracer.intersect(o, d), lambda o, d, t: tracer.occluded(o, d, t))}
    tri = np.ascontiguousarray(np.asarray(mesh.vertices, np.float32)[np.asarray(mesh.faces)])
    try:
        from embreex import rtcore_scene
        from embreex.mesh_construction import TriangleMesh
    except ImportError:
        pass
    else:
        scene = rtcore_scene.EmbreeScene()
        TriangleMesh(scene, tri)
        pool = ThreadPoolExecutor(threads)

        def split(fn, *arrays):  # each thread a contiguous share of the rays
            parts = [np.array_split(a, threads) for a in arrays]
            return list(pool.map(fn, *parts))

        tools["embree"] = (
            lambda o, d: split(lambda oo, dd: scene.run(oo, dd, output=True), o, d),
            lambda o, d, t: split(lambda oo, dd, tt: scene.run(oo, dd, dists=tt.copy(), query="OCCLUDED"), o, d, t),
        )
    try:
        import open3d as o3d
    except ImportError:
        pass
    else:
        rc = o3d.t.geometry.RaycastingScene()
        vertices = o3d.core.Tensor(np.asarray(mesh.vertices, np.float32))
        rc.add_triangles(vertices, o3d.core.Tensor(np.asarray(mesh.faces, np.uint32)))
        rays = lambda o, d: o3d.core.Tensor(np.concatenate([o, d], axis=1))
        # test_occlusions takes one t_far for all rays: each direction is scaled to its segment, t_far = 1
        tools["open3d"] = (
            lambda o, d: rc.cast_rays(rays(o, d), nthreads=threads),
            lambda o, d, t: rc.test_occlusions(rays(o, d * np.minimum(t, 3e38)[:, None]), tfar=1.0, nthreads=threads),
        )
    return tools


def interleaved_seconds(calls: list, runs: int) -> list[float]:
    """Median wall time of each call over `runs` rounds, the calls taking turns within a round (in an
    order rotated from round to round), so that load from other jobs on the machine falls on all alike."""
    for call in calls:
        warm_up(call, calls=2)
    times = [[] for _ in calls]
    for r in range(runs):
        for i in (r + k for k in range(len(calls))):
            i %= len(calls)
            start = time.perf_counter()
            calls[i]()
            times[i].append(time.perf_counter() - start)
    return [float(np.median(t)) for t in times]


def end_to_end(mesh, rays: dict, runs: int, peers: list[str], threads: int):
    """Mrays/s of each tool's user query for each ray kind, and clrender's ratio to each peer, measured
    in this run; then Mrays/s against the batch size for primary rays."""
    tools = user_queries(mesh, threads)
    missing = [p for p in peers if p not in tools]
    if missing:
        sys.exit(f"bench rays: --peer {','.join(missing)} needs its package: pip install 'clrender[bench]'")
    names = ["clrender", *peers]
    rows = [dict(tool=name, threads=threads) for name in names]
    for kind, (o, d, t_max) in rays.items():
        calls = [(lambda q=tools[name][1]: q(o, d, t_max)) if kind == "shadow" else (lambda q=tools[name][0]: q(o, d)) for name in names]
        for row, seconds in zip(rows, interleaved_seconds(calls, runs)):
            row[f"{kind}_mrays"] = len(o) / seconds / 1e6
    for peer_row in rows[1:]:
        for kind in KINDS:
            rows[0][f"{kind}_vs_{peer_row['tool']}"] = rows[0][f"{kind}_mrays"] / peer_row[f"{kind}_mrays"]
    rows = [{k: r.get(k, float("nan")) for k in rows[0]} for r in rows]  # one table: the peers' ratio columns empty
    o, d, _ = rays["primary"]
    batches = []
    for n in (b for b in BATCHES if b <= len(o)):
        calls = [lambda q=tools[name][0], n=n: q(o[:n], d[:n]) for name in names]
        batches.append(dict(batch=n, **{f"{name}_mrays": n / s / 1e6 for name, s in zip(names, interleaved_seconds(calls, runs))}))
    return rows, batches


def end_to_end_summary(rows: list[dict]) -> str:
    peers = [r["tool"] for r in rows[1:]]
    head = "| rays | " + " | ".join(f"{r['tool']} Mrays/s" for r in rows) + "".join(f" | clrender / {p}" for p in peers) + " |"
    lines = [head, "|" + "---|" * (1 + len(rows) + len(peers))]
    for k in KINDS:
        cells = [f"{r[f'{k}_mrays']:.3g}" for r in rows] + [f"{rows[0][f'{k}_vs_{p}']:.2f}" for p in peers]
        lines.append(f"| {k} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def build_times(n_triangles: int, runs: int):
    """Build time (wall and CPU) and SAH cost of each builder with its default leaves, and of the tree
    the Tracer builds for its default width (leaves of DEFAULT_KNOBS.leaf_size(width), then the collapse)."""
    from clrender.scene.meshes import dense_mesh
    from clrender.trace.bvh import build_bvh
    from clrender.trace.bvh_wide import collapse
    from clrender.trace.knobs import DEFAULT_KNOBS
    from clrender.trace.tracer import DEFAULT_BVH_WIDTH

    mesh = dense_mesh(n_triangles, seed=1)
    tri = np.asarray(mesh.vertices, np.float32)[np.asarray(mesh.faces)]
    lo, hi = tri.min(1), tri.max(1)
    build_bvh(lo[:64], hi[:64])  # the SAH build's kernels are compiled once per process: not timed
    w = DEFAULT_BVH_WIDTH
    rows = []
    for builder, leaf in (("sah", 4), ("median", 4), ("sah", DEFAULT_KNOBS.leaf_size(w))):
        build = lambda: build_bvh(lo, hi, builder=builder, max_leaf_size=leaf)
        seconds, cpu_seconds = median_seconds(build, runs), median_cpu_seconds(build, runs)
        bvh = build()
        collapse_s = median_seconds(lambda: collapse(bvh, w), runs)
        wide = collapse(bvh, w)
        rows.append(
            dict(
                builder=builder,
                max_leaf=leaf,
                triangles=len(tri),
                build_s=seconds,
                build_cpu_s=cpu_seconds,
                nodes=len(bvh.nodes),
                sah_cost=float(bvh.sah_cost()),
                width=w,
                collapse_s=collapse_s,
                wide_nodes=wide.node_count,
                wide_sah_cost=wide.sah_cost(),
            )
        )
    return rows


KINDS = ("primary", "shadow", "incoherent")


def layout_name(r: dict) -> str:
    walk = "packets" if r["packets"] and r["width"] >= 4 else "one ray"
    return f"{r['builder']}, width {r['width']}, {walk}"


def summary(rows: list[dict]) -> str:
    """One line per layout and ray kind: Mrays/s, per CPU-second, ratios to Embree, work per ray."""
    lines = [
        "| layout | rays | Mrays/s | Mrays/CPU-s | vs Embree (wall) | vs Embree (per CPU-s) | nodes/ray | prims/ray |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        layout = "embree (1 thread)" if r["builder"] == "embree" else layout_name(r)
        for k in KINDS:
            g = lambda key: r.get(f"{k}_{key}", float("nan"))
            lines.append(
                f"| {layout} | {k} | {g('mrays'):.3g} | {g('mrays_per_cpu_s'):.3g} | {g('vs_embree'):.3g} | "
                f"{g('vs_embree_per_cpu_s'):.3g} | {g('nodes_per_ray'):.3g} | {g('prims_per_ray'):.3g} |"
            )
    return "\n".join(lines)


def chart(path: Path, rows: list[dict], title: str) -> None:
    """Bars of Mrays/s (wall) and Mrays per CPU-second for each ray kind, one series per layout."""
    from clrender.image.plot import bar_chart

    name = lambda r: "Embree, 1 thread" if r["builder"] == "embree" else f"clrender {layout_name(r)}"
    labels = [f"{k}\n{unit}" for k in KINDS for unit in ("Mrays/s", "per CPU-s")]
    series = {name(r): [r[f"{k}_{m}"] for k in KINDS for m in ("mrays", "mrays_per_cpu_s")] for r in rows}
    bar_chart(path, labels, series, title=title, ylabel="million rays")


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench rays", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mesh", help="mesh file to trace (default: a generated ~100k-triangle mesh)")
    ap.add_argument("--size", type=int, default=512, help="image side in pixels (rays = size^2)")
    ap.add_argument("--runs", type=int, default=5, help="timed runs; the median is reported")
    ap.add_argument("--build-triangles", type=int, default=1_000_000, help="triangles for the build benchmark")
    ap.add_argument("--out", default="bench/out", help="folder for rays.csv / rays.md")
    ap.add_argument(
        "--peer",
        help="embree: also trace the same rays with Embree (embreex, one thread) and report kernel-time ratios; "
        "a comma list of embree, open3d: also the end-to-end user queries at equal threads, and Mrays/s against batch size",
    )
    ap.add_argument("--threads", type=int, default=0, help="threads of the end-to-end peers (default: the device's compute units)")
    ap.add_argument("--no-build", action="store_true", help="skip the 1M-triangle build benchmark")
    args = ap.parse_args(argv)
    peers = [p for p in (args.peer or "").split(",") if p]
    if any(p not in PEERS for p in peers):
        ap.error(f"--peer {args.peer!r}; allowed: a comma list of {', '.join(PEERS)}")
    if args.mesh:
        mesh = load_mesh_file(Path(args.mesh), "--mesh")
        label = args.mesh
    else:
        from clrender.scene.meshes import dense_mesh

        mesh = dense_mesh(100_000, seed=0)
        label = "generated"
    rays, hit_fraction = ray_sets(mesh, args.size)
    out = Path(args.out)
    if peers:
        threads = args.threads or get_device().device.max_compute_units
        rows, batches = end_to_end(mesh, rays, args.runs, peers, threads)
        write_table(out, "rays_end_to_end", rows, f"End-to-end ray queries on host arrays, {threads} threads each")
        table = end_to_end_summary(rows)
        print(f"{label}: {len(mesh.faces)} triangles, {args.size}x{args.size} rays, {threads} threads each, median of {args.runs}")
        print(table)
        print(write_table(out, "rays_batches", batches, "Primary-ray Mrays/s against rays per call"))
        (out / "rays_end_to_end_summary.md").write_text(table + "\n")
    peer = embree_rates(mesh, rays, args.runs) if "embree" in peers else None
    rows = []
    for builder, width, packets in LAYOUTS:
        r = clrender_rates(mesh, rays, args.runs, builder, width, packets)
        row = dict(mesh=label, triangles=len(mesh.faces), builder=builder, width=width, packets=packets, hit_fraction=hit_fraction, **r)
        if peer:
            for kind in KINDS:
                row[f"{kind}_vs_embree"] = r[f"{kind}_mrays"] / peer[f"{kind}_mrays"]
                row[f"{kind}_vs_embree_per_cpu_s"] = r[f"{kind}_mrays_per_cpu_s"] / peer[f"{kind}_mrays_per_cpu_s"]
        rows.append(row)
    if peer:
        base = dict(mesh=label, triangles=len(mesh.faces), builder="embree", width=0, packets=False, hit_fraction=hit_fraction, **peer)
        rows.append({k: base.get(k, float("nan")) for k in rows[0]})
    write_table(out, "rays", rows, f"Ray throughput at {args.size}x{args.size} (median of {args.runs})")
    table = summary(rows)
    (out / "rays_summary.md").write_text(table + "\n")
    chart(out / "rays.png", rows, f"{label} ({len(mesh.faces)} triangles), {args.size}x{args.size}")
    print(
        f"{label}: {len(mesh.faces)} triangles, {args.size}x{args.size} primary rays, {hit_fraction:.1%} hit; "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    )
    print(table)
    if args.no_build:
        return 0
    build = build_times(args.build_triangles, max(1, min(args.runs, 3)))
    print()
    print(write_table(out, "bvh_build", build, "BVH build time"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
