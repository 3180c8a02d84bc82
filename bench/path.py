"""Path tracing speed, against Mitsuba 3: `python -m bench path [--peer mitsuba] [--schedule megakernel wavefront] [--quick]
[--runs K] [--out DIR]`.

Two scenes at 512x512, 64 samples per pixel, max depth 8 (bounces after the primary hit; Mitsuba's
max_depth 10): the Cornell box of tests/reference/path_scenes.py (Lambert walls and block, a rough metal
sphere, a glass sphere, an emissive quad) and the bundled wizard_cat from camera 3.

clrender: `Renderer(scene, integrator="path", spp=64, max_depth=8)`; the first image (BVH build, kernel
compile, PoCL's first launches) is reported apart from the median of K later ones, with the kernel compile
time the renderer measures (RenderResult.timings["compile"]).  --peer mitsuba renders
the same scenes, converted by tests/reference/mitsuba_scenes.py, with Russian roulette from clrender's bounce
(clrender/trace/path.py RR_DEPTH: equal work a sample), in the same run:
  llvm_ad_rgb   the first render (Dr.Jit tracing and LLVM compiling its kernels, or reading them from its
                disk cache, said in the table) apart from the median of K later renders;
  scalar_rgb    --scalar-spp samples per pixel (default 16: a 64 spp render takes minutes on two cores),
                the time scaled by 64 / spp (the independent sampler's cost is linear in spp), one run.
`--schedule` times each of clrender's path schedules named (docs/lanes.md), a row each, and prints the
wavefront's lane occupancy.  Both use every core (Mitsuba's thread pool, PoCL's device).  Samples per second are camera paths (pixels x
spp) per wall second; the ratios are wall times against Mitsuba llvm.  `--quick`: 128x128, 16 spp, one run.
With both clrender and llvm: path_<scene>_pair.png (clrender left, Mitsuba right, the seed-0 renders) and a
line per scene, the two renderers' mean brightness and a block-mean z-test over all their renders (agreement_line).

wizard_cat is a Whitted scene, converted by this rule (the path tracer reads Phong materials the same way):
`diffuse` kd -> Lambert; `specular` ks with `shininess` s -> ks times a GGX conductor of reflectance 1 with
alpha = sqrt(2 / (s + 2)), added to the Lambert lobe; `mirror` -> a smooth conductor of that weight;
`transparency` with `ior` -> a smooth dielectric of that weight.  Lights (docs/shading.md's units): an area
light's colour x intensity is a radiance (falloff inverse_square) -> a one-sided rectangle emitter; a point
light's is a radiant intensity (W/sr) -> a point emitter.  wizard_cat's lights use the unnormalised falloff "none"
(pi I c cos(theta) at every distance: no physical light does that), so the bench makes them physical for BOTH
renderers (`physical_lights`, a bench-only mapping): the directional light's irradiance pi c I, the area
light's radiance chosen so that its irradiance at camera 3's look-at point (the cat) is what falloff "none"
gives there; both renderers then draw the same physical scene.  `ambient` is Whitted's and not drawn; `background`
is the path tracer's constant environment (wizard_cat has no [environment]), given to both.  The metal of the
Cornell box is Mitsuba's native `principled` here (metallic 1: the same D, F and
alpha, separable Smith G instead of the height-correlated G2: the same cost, not the same function; the
reference tests use the exact lobe).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from .common import write_table
from tests.reference import mitsuba_scenes, path_scenes

SCENES = ("cornell_box", "wizard_cat")
WHITTED_KEYS = ("diffuse", "specular", "shininess", "mirror", "transparency", "ior")


def physical_lights(scene, focus) -> list:
    """The scene's falloff-"none" lights as inverse-square ones as bright at the point `focus` (bench only):
    a directional light's irradiance pi c I stays; an area light's radiance L is set so that its
    irradiance there, L A cos(theta_l) / d^2 (A, cos(theta_l) and d from the light's centre), is the
    pi c I cos(theta) of falloff "none"."""
    import math
    from dataclasses import replace

    import numpy as np

    lights = []
    for light in scene.lights:
        if light.falloff != "none":
            lights.append(light)
        elif light.type == "area":
            a, b = np.asarray(light.edge_a, float), np.asarray(light.edge_b, float)
            normal = np.cross(a, b)
            area = float(np.linalg.norm(normal))
            d = np.asarray(focus, float) - (np.asarray(light.position, float) + (a + b) / 2)
            cos_l = abs(float(normal @ d)) / (area * float(np.linalg.norm(d)))
            lights.append(replace(light, falloff="inverse_square", intensity=light.intensity * math.pi * float(d @ d) / (area * cos_l)))
        else:  # directional: pi c I at every distance already; a point light: pi c I at unit distance
            lights.append(replace(light, falloff="inverse_square", intensity=light.intensity * math.pi))
    return lights


def wizard_cat_scene(camera: int = 3):
    """The bundled wizard_cat with physical_lights as bright at the camera's look-at point."""
    from clrender.scene.scene import Scene

    scene = Scene.load("wizard_cat")
    scene.lights = physical_lights(scene, scene.camera(camera).look_at)
    return scene


def wizard_cat_dict(camera: int = 3) -> dict:
    """wizard_cat_scene as the scene dict mitsuba_scenes reads: meshes as world-space triangles."""
    from dataclasses import asdict

    scene = wizard_cat_scene(camera)
    cam = scene.camera(camera)
    lights = []
    for light in scene.lights:
        entry = {"type": light.type, "color": light.color, "intensity": light.intensity, "falloff": light.falloff}
        if light.type == "area":
            entry.update(corner=light.position, edge_a=light.edge_a, edge_b=light.edge_b)
        elif light.type == "point":
            entry["position"] = light.position
        else:
            entry["direction"] = light.direction
        lights.append(entry)
    objects = []
    for obj in scene.objects:
        if hasattr(obj, "radius"):
            objects.append({"type": "sphere", "center": obj.center, "radius": obj.radius, "material": obj.material})
        else:
            normals = obj.vertex_normals if obj.smooth else None
            objects.append({"type": "mesh", "vertices": obj.vertices, "faces": obj.faces, "normals": normals, "material": obj.material})
    return {
        "cameras": [{"position": cam.position, "look_at": cam.look_at, "up": cam.up, "fov": cam.fov}],
        # the Whitted keys of wizard_cat's materials (its scene file gives no metallic-roughness ones)
        "materials": {name: {k: v for k, v in asdict(m).items() if k in WHITTED_KEYS} for name, m in scene.materials.items()},
        "lights": lights,
        "objects": objects,
    }


def wizard_cat_path_dict(camera: int = 3) -> dict:
    """wizard_cat_dict with its background as the constant environment, as clrender's path tracer sees a scene
    without [environment] (bench whitted keeps wizard_cat_dict: Mitsuba's `direct` would be lit by it)."""
    return {**wizard_cat_dict(camera), "environment": {"color": list(wizard_cat_scene(camera).environment)}}


def agreement_line(ours: list, theirs: list, block: int = 16) -> str:
    """Mean brightness of both renderers' images and a block-mean z-test: each image's means over
    block x block pixel blocks, averaged over the renders (independent seeds), the difference's z from
    the renders' spread (a t statistic with renders - 1 degrees of freedom each side)."""
    a, b = np.stack(ours).astype(np.float64), np.stack(theirs).astype(np.float64)  # (K, H, W, 3)
    k, h, w, _ = a.shape
    blocks = lambda x: x[:, : h // block * block, : w // block * block].reshape(x.shape[0], h // block, block, w // block, block, 3).mean(axis=(2, 4))
    ba, bb = blocks(a), blocks(b)
    se2 = ba.var(axis=0, ddof=1) / len(ba) + bb.var(axis=0, ddof=1) / len(bb)
    z = (ba.mean(0) - bb.mean(0)) / np.sqrt(np.maximum(se2, 1e-30))
    ma, mb = a.mean(axis=(0, 1, 2)), b.mean(axis=(0, 1, 2))
    return (
        f"mean RGB clrender {np.round(ma, 4).tolist()} vs Mitsuba {np.round(mb, 4).tolist()} (ratio {np.round(ma / mb, 3).tolist()}); "
        f"{block}x{block} block means over {len(ba)} + {len(bb)} renders: |z| > 3 in {np.mean(np.abs(z) > 3):.1%} of {z.size} block channels, "
        f"median |z| {np.median(np.abs(z)):.2f}"
    )


def clrender_has_path_tracer() -> bool:
    from clrender.trace.renderer import RenderSettings

    return "integrator" in RenderSettings.__dataclass_fields__


def clrender_setup(name: str, size: int, spp: int, depth: int):
    """(clrender scene, Renderer settings) of bench scene `name` path-traced at size x size: the Cornell box, or wizard_cat
    from camera 3."""
    scene, camera = (path_scenes.cornell_box(size), 1) if name == "cornell_box" else (wizard_cat_scene(3), 3)
    return scene, dict(integrator="path", spp=spp, max_depth=depth, width=size, height=size, camera=camera)


def time_clrender(name: str, size: int, spp: int, depth: int, runs: int, schedule: str = "megakernel"):
    """(first image s, its kernel compile s, median s, median CPU s, images: the first and each timed one) of clrender's path
    tracer under `schedule` (RenderSettings.path_schedule)."""
    from clrender.trace.renderer import Renderer

    scene, settings = clrender_setup(name, size, spp, depth)
    settings["path_schedule"] = schedule
    start = time.perf_counter()
    renderer = Renderer(scene, seed=0, **settings)
    result = renderer.run()
    first, images = time.perf_counter() - start, [result.image]
    compile_s = result.timings.get("compile", float("nan"))
    walls, cpus = [], []
    for run in range(runs):
        renderer = Renderer(scene, seed=run + 1, tracer=renderer.tracer, **settings)
        wall, cpu = time.perf_counter(), time.process_time()
        images.append(renderer.run().image)
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    occupancy = getattr(renderer.kernel, "occupancy", None)  # the wavefront's lanes: live paths / slots over its bounces
    if occupancy:
        busy = sum(sum(o.live) for o in occupancy) / sum(len(o.live) * o.slots for o in occupancy)
        print(f"{name} {schedule}: lane occupancy {busy:.3f} over {sum(len(o.live) for o in occupancy)} bounces of the last render")
    return first, compile_s, statistics.median(walls), statistics.median(cpus), images


def time_mitsuba(scene: dict, variant: str, size: int, spp: int, depth: int, runs: int):
    """(load s, first render s, JIT s, kernels from the disk cache, median s, median CPU s, images: the first and each timed one)."""
    import drjit as dr

    from clrender.trace.path import RR_DEPTH

    start = time.perf_counter()
    # Russian roulette from the same bounce as clrender's (its default): equal work a sample, the same estimator
    mi, loaded = mitsuba_scenes.load(scene, variant=variant, spp=spp, max_depth=depth, width=size, height=size, exact=False, rr_depth=RR_DEPTH)
    load_s = time.perf_counter() - start
    jit = variant.startswith("llvm")
    if jit:
        dr.set_flag(dr.JitFlag.KernelHistory, True)
    start = time.perf_counter()
    images = [mitsuba_scenes.render_loaded(mi, loaded, spp=spp, seed=0)]
    first = time.perf_counter() - start
    compile_s, cached = float("nan"), ""
    if jit:
        kernels = [k for k in dr.kernel_history() if k.get("cache_hit") is not None]
        compile_s = sum(k.get("codegen_time", 0.0) + k.get("backend_time", 0.0) for k in kernels) / 1000.0  # ms -> s
        cached = "yes" if kernels and all(k.get("cache_hit") for k in kernels) else "no"
        dr.set_flag(dr.JitFlag.KernelHistory, False)
    walls, cpus = [], []
    for run in range(runs):
        wall, cpu = time.perf_counter(), time.process_time()
        images.append(mitsuba_scenes.render_loaded(mi, loaded, spp=spp, seed=run + 1))
        walls.append(time.perf_counter() - wall)
        cpus.append(time.process_time() - cpu)
    return load_s, first, compile_s, cached, statistics.median(walls), statistics.median(cpus), images


def parse_args(argv=None):
    from clrender.layout import PATH_SCHEDULES

    ap = argparse.ArgumentParser(prog="python -m bench path", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=512, help="image side in pixels")
    ap.add_argument("--spp", type=int, default=64, help="samples per pixel")
    ap.add_argument("--max-depth", type=int, default=8, help="bounces after the primary hit (Mitsuba's max_depth is this + 2)")
    ap.add_argument("--runs", type=int, default=3, help="timed renders after the first; the median is reported")
    ap.add_argument("--scalar-spp", type=int, default=16, help="spp of Mitsuba's scalar_rgb render (its time is scaled to --spp); 0 skips it")
    ap.add_argument("--scenes", nargs="+", choices=SCENES, default=list(SCENES))
    ap.add_argument(
        "--schedule",
        nargs="+",
        choices=PATH_SCHEDULES,
        default=["megakernel"],
        help="clrender's path schedules to time, each a row (RenderSettings.path_schedule; docs/lanes.md)",
    )
    ap.add_argument("--peer", choices=("mitsuba",), help="also render with Mitsuba 3 (llvm_ad_rgb and scalar_rgb) in the same run")
    ap.add_argument("--quick", action="store_true", help="128x128, 16 spp, one timed run, scalar at 4 spp")
    ap.add_argument("--out", default="bench/out", help="folder for path.csv / path.md / path.png and the images")
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.spp, args.runs, args.scalar_spp = 128, 16, 1, min(args.scalar_spp, 4)
    return args


def main(argv=None):
    args = parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    have_clrender = clrender_has_path_tracer()
    if not have_clrender:
        print("clrender's path integrator is not available yet (RenderSettings has no `integrator`, issue 25): clrender not measured")
        if not args.peer:
            return 1
    from clrender.image.files import write_display_image

    pixels = args.size * args.size
    rows, agreement = [], []
    for name in args.scenes:
        scene = path_scenes.cornell_box(args.size) if name == "cornell_box" else wizard_cat_path_dict(3)
        measured, renders = {}, {}
        for schedule in args.schedule if have_clrender else ():
            first, compile_s, wall, cpu, images = time_clrender(name, args.size, args.spp, args.max_depth, args.runs, schedule)
            label = "clrender" if args.schedule == ["megakernel"] else f"clrender {schedule}"
            measured[label] = dict(spp_run=args.spp, load_s=float("nan"), first_s=first, compile_s=compile_s, cached="", seconds=wall, cpu_s=cpu)
            renders.setdefault("clrender", images)  # the schedules' images are the same bits
            write_display_image(out / f"path_{name}_clrender.png", images[0])
        if args.peer == "mitsuba":
            measure_mitsuba(args, name, scene, out, measured, renders)
        if "clrender" in renders and "llvm_ad_rgb" in renders:
            ours, theirs = renders["clrender"], renders["llvm_ad_rgb"]
            write_display_image(out / f"path_{name}_pair.png", np.concatenate([ours[0], theirs[0]], axis=1))
            agreement.append(f"{name}: {agreement_line(ours, theirs)}")
        llvm = measured.get("mitsuba llvm_ad_rgb", {}).get("seconds", float("nan"))
        for renderer, m in measured.items():
            rows.append(
                dict(
                    scene=name,
                    renderer=renderer,
                    size=args.size,
                    spp=args.spp,
                    max_depth=args.max_depth,
                    **m,
                    msamples_per_s=pixels * args.spp / m["seconds"] / 1e6,
                    time_vs_mitsuba_llvm=m["seconds"] / llvm,
                )
            )
    if not rows:
        print("nothing measured")
        return 1
    title = f"Path tracing, {args.size}x{args.size}, {args.spp} spp, max depth {args.max_depth} (median of {args.runs})"
    table = write_table(out, "path", rows, title)
    from clrender.image.plot import bar_chart

    renderers = list(dict.fromkeys(r["renderer"] for r in rows))
    series = {
        who: [next((r["msamples_per_s"] for r in rows if r["scene"] == s and r["renderer"] == who), 0.0) for s in args.scenes] for who in renderers
    }
    bar_chart(out / "path.png", args.scenes, series, title=title, ylabel="million samples (camera paths) per second")
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs; seconds: median per image at {args.spp} spp")
    print(table)
    print("\n".join(agreement))
    return 0


def measure_mitsuba(args, name: str, scene, out: Path, measured: dict, renders: dict) -> None:
    """Mitsuba 3's llvm_ad_rgb render of one scene, and its scalar_rgb one (at --scalar-spp, its time scaled to
    --spp), each added to `measured` (its row's timings) and `renders` (its images) unless the variant is missing."""
    from clrender.image.files import write_display_image

    variants = [("mitsuba llvm_ad_rgb", "llvm_ad_rgb", args.spp, args.runs)]
    if args.scalar_spp > 0:
        variants.append(("mitsuba scalar_rgb", "scalar_rgb", args.scalar_spp, 1))
    for label, variant, spp, runs in variants:
        reason = mitsuba_scenes.unavailable(variant)
        if reason:
            print(f"{label}: not measured: {reason}")
            continue
        load_s, first, compile_s, cached, wall, cpu, images = time_mitsuba(scene, variant, args.size, spp, args.max_depth, runs)
        scale = args.spp / spp  # the scalar render's time at --spp
        measured[label] = dict(spp_run=spp, load_s=load_s, first_s=first, compile_s=compile_s, cached=cached, seconds=wall * scale, cpu_s=cpu * scale)
        renders[variant] = images
        write_display_image(out / f"path_{name}_{variant}.png", images[0])


if __name__ == "__main__":
    sys.exit(main())
