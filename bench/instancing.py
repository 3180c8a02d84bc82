"""Instancing: memory and load time of N copies of one mesh vs one copy.

    python -m bench instancing [--copies 30] [--resolution 140] [--size 256] [--render 0] [--spp 4] [--rounds 3] [--out DIR]

Two ways of naming one mesh `copies` times, each with different translate / rotate / scale, against
the same scene with one object:

- `generator`: a scene dict of the built-in procedural bunny at `resolution` (about 3.5 * resolution^2
  triangles: 68,600 at 140);
- `file`: that bunny written once to a .ply in a temporary folder and a TOML scene file whose objects
  all name it (the issue's case: the file is read once, `file_reads` counts scene.load_mesh_file's calls).

Reported per scene: the fewest seconds of loading it (Scene.from_dict or Scene.from_file: mesh reading
and placing; the scenes loaded in turn, as their rays are traced, so that a busy machine slows all
alike), of Tracer(scene) (flatten, BVH build, upload), the peak Python-heap bytes of both steps
(tracemalloc, in a separate untimed run: numpy's arrays are counted; the Tracer's peak has the loaded
scene in it), the bytes of the Tracer's device buffers, whether any copy's world vertices were made
(`world_made`: Mesh.vertices is made on first read, which the instanced Tracer never does) and
primary-ray Mrays/s at size x size (Tracer.intersect); the copies flat and with Tracer(instancing=True)
(clrender/trace/instancing.py), then each copies row over its one-copy row and the flat copies' Mrays/s
over its own.  `file` is `generator`'s bunny rounded to float32 by the .ply.  With --render N, also
renders of the copies at N x N, Whitted (one ray a pixel, shadows) and path (--spp paths a pixel), flat
and instanced alternating in this one process: camera samples per second of Renderer.run, the median of
--rounds (instancing.csv/.md and instancing_ratios, then instancing_render.csv/.md).  Numbers are
reported, never asserted (docs/bvh.md, "Instancing").
"""

from __future__ import annotations

import argparse
import tempfile
import time
import tracemalloc
from pathlib import Path

import numpy as np

from .common import write_table

LOAD_RUNS = 15  # loads timed per scene, the scenes in turn (the fastest is reported: other work only adds time)
TRACE_RUNS = 15  # primary-ray passes timed per scene, likewise
BUILD_RUNS = 3  # Tracer builds timed per scene (the fastest is reported; the flat copies' takes seconds)


def placements(copies: int):
    """(translate, rotate, scale) of `copies` bunnies on a grid, each turned, scaled and moved differently."""
    rng = np.random.default_rng(7)
    side = int(np.ceil(np.sqrt(copies)))
    return [
        ([2.0 * (i % side) - side, 0.0, -2.0 * (i // side)], [0.0, float(rng.uniform(0, 360)), 0.0], float(rng.uniform(0.6, 1.2)))
        for i in range(copies)
    ]


def bunnies_scene(copies: int, resolution: int) -> dict:
    """A scene dict of `copies` generated bunnies (placements)."""
    objects = [
        {"type": "mesh", "generator": "bunny", "params": {"resolution": resolution}, "translate": t, "rotate": r, "scale": s}
        for t, r, s in placements(copies)
    ]
    return {**_view(copies), "objects": objects}


def _view(copies: int) -> dict:
    side = int(np.ceil(np.sqrt(copies)))
    return {
        "cameras": [{"position": [0.0, 6.0, 8.0], "look_at": [0.0, 0.0, -side], "fov": 60}],
        "lights": [{"type": "point", "position": [0, 20, 10]}],
    }


def bunnies_file_scene(folder: Path, copies: int, resolution: int) -> Path:
    """A TOML scene file in `folder` whose `copies` objects all name bunny.ply (written there once)."""
    from clrender.scene.meshes import bunny

    mesh_file = folder / "bunny.ply"
    if not mesh_file.exists():
        bunny(resolution).export(mesh_file)
    view = _view(copies)
    camera, light = view["cameras"][0], view["lights"][0]
    lines = ["[[cameras]]", f"position = {camera['position']}", f"look_at = {camera['look_at']}", f"fov = {camera['fov']}"]
    lines += ["[[lights]]", 'type = "point"', f"position = {light['position']}"]
    for t, r, s in placements(copies):
        lines += ["[[objects]]", 'type = "mesh"', 'file = "bunny.ply"', f"translate = {t}", f"rotate = {r}", f"scale = {s}"]
    path = folder / f"bunnies-{copies}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def prepare(kind: str, copies: int, resolution: int, size: int, instancing: bool, folder: Path) -> dict:
    """One scene's untimed numbers (row, with load_s and primary_Mrays_s left to `alternate`), its loader
    and its traced rays."""
    from clrender.scene import scene as scene_module
    from clrender.scene.scene import Mesh, Scene
    from clrender.trace.tracer import Tracer

    if kind == "file":
        path = bunnies_file_scene(folder, copies, resolution)
        load = lambda: Scene.from_file(path)
    else:
        data = bunnies_scene(copies, resolution)
        load = lambda: Scene.from_dict(data)
    # the bunny built and cached on disk, the BVH builder's kernels compiled, before any timing
    Tracer(Scene.from_dict(bunnies_scene(1, resolution)))
    reads, read = [], scene_module.load_mesh_file
    scene_module.load_mesh_file = lambda *a, **k: reads.append(a[0]) or read(*a, **k)
    try:
        load()
    finally:
        scene_module.load_mesh_file = read
    loaded, build_s = load(), float("inf")
    for _ in range(BUILD_RUNS):
        start = time.perf_counter()
        tracer = Tracer(loaded, instancing=instancing)
        build_s = min(build_s, time.perf_counter() - start)
        del tracer
    del loaded
    tracemalloc.start()  # an untimed run: tracemalloc slows every allocation
    scene = load()
    _, load_peak = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    tracer = Tracer(scene, instancing=instancing)
    _, build_peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    names = ("nodes", "prims", "prim_object", "normals")
    device_bytes = sum(getattr(tracer, k).size for k in names) + tracer.tables.buffer.size  # objects, materials, instances
    world_made = sum(bool(o.world_made) for o in scene.objects if isinstance(o, Mesh))
    o, d = primary_rays(scene, size)
    oc, dc = close_up_rays(scene, size)
    tracer.intersect(o, d)  # compile and warm up
    t_close = tracer.intersect(oc, dc)[0]
    row = {
        "scene": kind,
        "copies": copies,
        "instancing": instancing,
        "file_reads": len(reads),
        "triangles": scene.triangle_count,
        "stored_triangles": tracer.primitives.count + sum(len(s.faces) for s in (tracer.instances.shapes if tracer.instances else [])),
        "load_s": None,
        "tracer_s": build_s,
        "load_peak_MB": load_peak / 1e6,
        "tracer_peak_MB": build_peak / 1e6,
        "device_MB": device_bytes / 1e6,
        "world_made": world_made,
        "primary_Mrays_s": None,
        "close_up_hits": float(np.isfinite(t_close).mean()),
        "close_up_Mrays_s": None,
    }
    trace = (lambda: tracer.intersect(o, d)), (lambda: tracer.intersect(oc, dc))
    return {"row": row, "load": load, "trace": trace, "rays": len(d)}


def alternate(fns, rounds: int) -> list[float]:
    """The fewest seconds of each fn, all called in turn `rounds` times: the machine's load falls on all alike,
    and on a busy machine (other helpers' work on 2 cores) it only ever adds time, by 1.5x from run to run."""
    times = [[] for _ in fns]
    for _ in range(rounds):
        for spent, fn in zip(times, fns):
            start = time.perf_counter()
            fn()
            spent.append(time.perf_counter() - start)
    return [min(t) for t in times]


def ratios(rows: list[dict]) -> list[dict]:
    """Each row of copies over its scene kind's one-copy row (the issue's targets: load and memory <= 1.5x
    one copy's, traversal within 1.3x: the close-up rays, the same picture in both), and the flat copies'
    primary Mrays/s over the row's on the same rays (camera 1's: 30 bunnies, where one copy's sees one)."""
    out = []
    for row in rows:
        one = next(r for r in rows if r["scene"] == row["scene"] and r["copies"] == 1)
        if row is one:
            continue
        flat = [r for r in rows if r["copies"] == row["copies"] and not r["instancing"]]  # the same scene either way
        flat = next((r for r in flat if r["scene"] == row["scene"]), flat[0] if flat else None)
        out.append(
            {
                "scene": row["scene"],
                "copies": row["copies"],
                "instancing": row["instancing"],
                **{f"{k} / one": row[k] / one[k] for k in ("load_s", "load_peak_MB", "tracer_s", "tracer_peak_MB", "device_MB")},
                "one / close_up_Mrays_s": one["close_up_Mrays_s"] / row["close_up_Mrays_s"],
                "flat / primary_Mrays_s": flat["primary_Mrays_s"] / row["primary_Mrays_s"] if flat else float("nan"),
            }
        )
    return out


def primary_rays(scene, size: int):
    """size x size pinhole rays from the scene's camera 1 (60 degrees across)."""
    cam = scene.camera(1)
    return pinhole_rays(cam.position, cam.look_at, (0.0, 1.0, 0.0), 0.6, size)


def close_up_rays(scene, size: int):
    """size x size rays from above onto the first object, which fills the view: those that miss it fall
    past the others (the bunnies stand on no floor), so one copy and the copies trace the same picture and
    the difference is the instanced walk's (its top-level tree and object-space rays)."""
    mesh = scene.objects[0]
    lo, hi = mesh.local_vertices.min(axis=0), mesh.local_vertices.max(axis=0)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    world = corners @ mesh.to_world[:3, :3].T + mesh.to_world[:3, 3]  # its world box, its vertices left unmade
    w_lo, w_hi = world.min(axis=0), world.max(axis=0)
    centre, across = (w_lo + w_hi) / 2, (w_hi - w_lo)[[0, 2]].max()
    eye = centre + [0.0, 3 * across, 0.0]
    return pinhole_rays(eye, centre, (0.0, 0.0, -1.0), 0.5 * across / np.linalg.norm(eye - centre), size)


def pinhole_rays(position, look_at, up_hint, spread: float, size: int):
    """size x size unit rays from `position` toward `look_at`, the image plane `spread` x the distance across each half."""
    ys, xs = np.mgrid[0:size, 0:size]
    u, v = (xs + 0.5) / size * 2 - 1, 1 - (ys + 0.5) / size * 2
    forward = np.asarray(look_at, float) - np.asarray(position, float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, up_hint)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    d = forward + spread * (u[..., None] * right + v[..., None] * up)
    d = (d / np.linalg.norm(d, axis=-1, keepdims=True)).reshape(-1, 3).astype(np.float32)
    return np.broadcast_to(np.asarray(position, np.float32), d.shape).copy(), d


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
    runs = [("generator", 1, False), ("generator", args.copies, False), ("generator", args.copies, True)]
    runs += [("file", 1, False), ("file", args.copies, True)]
    with tempfile.TemporaryDirectory() as folder:
        parts = [prepare(kind, n, args.resolution, args.size, inst, Path(folder)) for kind, n, inst in runs]
        for part, seconds in zip(parts, alternate([p["load"] for p in parts], LOAD_RUNS)):
            part["row"]["load_s"] = seconds
        for k, column in enumerate(("primary_Mrays_s", "close_up_Mrays_s")):
            for part, seconds in zip(parts, alternate([p["trace"][k] for p in parts], TRACE_RUNS)):
                part["row"][column] = part["rays"] / seconds / 1e6
    rows = [p["row"] for p in parts]
    print(write_table(args.out, "instancing", rows, f"Instancing: 1 vs {args.copies} bunnies"))
    print()
    print(write_table(args.out, "instancing_ratios", ratios(rows), f"Instancing: {args.copies} bunnies over one"))
    if args.render > 0:
        rates = render_rates(args.copies, args.resolution, args.render, args.spp, args.rounds)
        print()
        print(write_table(args.out, "instancing_render", rates, f"Instancing: renders of {args.copies} bunnies, flat vs instanced"))
    return 0
