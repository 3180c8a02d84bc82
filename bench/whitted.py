"""Whitted against Mitsuba 3's `direct` integrator at equal work: `python -m bench whitted [--quick] [--runs K] [--out DIR]`.

The report's render (wizard_cat, camera 3, 400x400, full AA N = 6: 36 stratified samples per pixel, the area
light's own 5 x 5 = 25 samples per shading point) by clrender's Whitted tracer, and the same scene, converted
by bench/path.py's rule (`wizard_cat_dict`: lights made physical for BOTH renderers, Phong materials to Lambert
+ GGX conductor), by Mitsuba 3 `llvm_ad_rgb` with the `direct` integrator, 36 spp (`independent` sampler).
Two variants, one row each:
  opaque  the glass sphere's transparency set to 0 in both scenes (a Blinn-Phong / Lambert + GGX ball): no
          refracted or reflected rays, so both renderers do the same kind of work, camera rays and shadow rays;
  glass   the scene's glass sphere (transparency 0.75, ior 1.5): clrender follows the refracted and reflected rays
          (max depth 8); `direct` does not (it has no recursion), so its rays are spent on shadow rays instead.

Rays, counted on both sides:
  clrender: RenderResult.rays, the kernel's own count of every ray it traces:
      rays = P + sum over shading points x of  sum_lights  n_light x #(samples with n . l > 0 at x)
             + the reflected and refracted rays (glass only)
    with P = width x height x 36 camera rays and n_light = 25 (area light) or 1 (directional): a shading point
    sends no shadow ray towards a light sample behind its surface (kernels/shade.h).
  Mitsuba `direct` (src/integrators/direct.cpp, src/render/scene.cpp): per camera ray one closest-hit ray; at
    each hit whose BSDF has a smooth component, `emitter_samples` times: an emitter drawn uniformly (the area
    rectangle or the directional light), and a shadow ray where the sampled direction's pdf is not 0 (one-sided
    rectangle: not from above it); then `bsdf_samples` closest-hit rays where the BSDF sample's weight is not 0:
      rays = P + e x #(smooth hits) x p_e + b x #(hits with a BSDF sample of weight != 0)
    p_e and the hit counts are counted, with those masks, by Mitsuba itself on a pass of `--count-spp` camera
    samples per pixel (count_mitsuba_rays), scaled to 36.  `--bsdf-samples` defaults to 0 (all extra rays shadow
    rays, like Whitted's; the estimate stays unbiased: MIS weight 1) and e is solved so that Mitsuba's rays equal
    clrender's counted rays of the warm-up render (nearest whole e), per variant.

Equal threads: Mitsuba's (Dr.Jit's pool, `dr.set_thread_count`) = clrender's OpenCL device compute units.
Timing: each renderer's first render apart (clrender: BVH build and kernel compile; Mitsuba: Dr.Jit tracing and
LLVM compiling the kernel, or its disk cache), then K renders each, alternating (ABBA order, fresh seeds),
in this one process; wall and CPU seconds (process time: every thread of the process) are medians of the K.
Speedups are Mitsuba / clrender (> 1: clrender faster): wall time, CPU time, and Mrays/s (the equal-work
measure where the ray counts differ).  Results: whitted.csv / .md and whitted_<variant>_pair.png (clrender left,
Mitsuba right; Whitted also draws `background` and `ambient`, Mitsuba does not).
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
from tests.reference import mitsuba_scenes

VARIANTS = ("opaque", "glass")
CAMERA = 3  # wizard_cat's default view
SPHERE_MATERIAL = "glass"


def scenes(variant: str):
    """(clrender Scene, Mitsuba scene dict) of wizard_cat with physical lights; the sphere made opaque in both for "opaque"."""
    from dataclasses import replace

    from .path import wizard_cat_dict, wizard_cat_scene

    scene, scene_dict = wizard_cat_scene(CAMERA), wizard_cat_dict(CAMERA)
    if variant == "opaque":
        scene.materials[SPHERE_MATERIAL] = replace(scene.materials[SPHERE_MATERIAL], transparency=0.0)
        scene_dict["materials"][SPHERE_MATERIAL]["transparency"] = 0.0
    return scene, scene_dict


def delta_light_weight(mi, emitter_samples: int) -> float:
    """How many times its due a delta light's (directional, point) sample counts in Mitsuba's `direct` with this
    many emitter samples: Mitsuba 3.9's direct.cpp weights such samples by 1 instead of 1 / emitter_samples
    (the MIS weight of a delta direction is 1 and the 1 / emitter_samples is applied inside the other branch),
    so a directional light comes out emitter_samples times too bright.  Measured, not assumed from the version:
    a Lambert square lit straight from above by a directional light of irradiance 1 seen by a 2x2 film, whose
    radiance is reflectance / pi exactly (no sample falls anywhere else), rendered with emitter_samples 1 and
    with this many."""
    if emitter_samples == 1:
        return 1.0
    means = []
    for e in (1, emitter_samples):
        scene = {
            "type": "scene",
            "integrator": {"type": "direct", "emitter_samples": e, "bsdf_samples": 0},
            "sensor": {
                "type": "orthographic",
                "to_world": mi.ScalarTransform4f().look_at(origin=[0, 0, 2], target=[0, 0, 0], up=[0, 1, 0]),
                "film": {"type": "hdrfilm", "width": 2, "height": 2, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                "sampler": {"type": "independent", "sample_count": 1},
            },
            "square": {"type": "rectangle", "to_world": mi.ScalarTransform4f().scale([4, 4, 1]), "bsdf": {"type": "diffuse"}},
            "light": {"type": "directional", "direction": [0, 0, -1], "irradiance": mitsuba_scenes.rgb((1.0, 1.0, 1.0))},
        }
        means.append(float(np.mean(mitsuba_scenes.render_loaded(mi, mi.load_dict(scene), spp=1))))
    return means[1] / means[0]


def mitsuba_scene(mi, scene_dict: dict, size: int, spp: int, emitter_samples: int, bsdf_samples: int, delta_weight: float = 1.0):
    """The loaded Mitsuba scene with the `direct` integrator; delta lights dimmed by `delta_weight` (see
    delta_light_weight: the same work, one multiplication, and the picture as bright as the scene)."""
    d = mitsuba_scenes.to_mitsuba(scene_dict, spp=spp, camera=1, width=size, height=size, exact=False)
    d["integrator"] = {"type": "direct", "emitter_samples": int(emitter_samples), "bsdf_samples": int(bsdf_samples)}
    for light in d.values():
        if isinstance(light, dict) and light.get("type") in ("directional", "point"):
            key = "irradiance" if light["type"] == "directional" else "intensity"
            light[key] = mitsuba_scenes.rgb(np.asarray(light[key]["value"]) / delta_weight)
    return mi.load_dict(d)


def count_mitsuba_rays(mi, mi_scene, spp: int, seed: int = 12345) -> dict:
    """Per camera sample, with direct.cpp's masks, on `spp` samples per pixel: `emitter` shadow rays per emitter
    sample (smooth-BSDF hits whose sampled emitter direction has pdf != 0) and `bsdf` rays per BSDF sample
    (hits whose BSDF sample has a weight != 0); `hits` the fraction of camera rays that hit."""
    import drjit as dr

    sensor = mi_scene.sensors()[0]
    width, height = (int(v) for v in sensor.film().crop_size())
    n = width * height * spp
    sampler = sensor.sampler().clone()
    sampler.seed(seed, n)
    pixel = dr.arange(mi.UInt32, n) // spp
    film_pos = (mi.Vector2f(mi.Float(pixel % width), mi.Float(pixel // width)) + sampler.next_2d()) / mi.ScalarVector2f(width, height)
    ray, _ = sensor.sample_ray(0.0, sampler.next_1d(), film_pos, sampler.next_2d())
    si = mi_scene.ray_intersect(ray)
    hit = si.is_valid()
    bsdf = si.bsdf()
    smooth = hit & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
    ds, _ = mi_scene.sample_emitter_direction(si, sampler.next_2d(), False, smooth)
    _, weight = bsdf.sample(mi.BSDFContext(), si, sampler.next_1d(), sampler.next_2d(), hit)
    count = lambda mask: int(dr.count(mask)[0])
    return dict(hits=count(hit) / n, emitter=count(smooth & (ds.pdf != 0)) / n, bsdf=count(hit & dr.any(weight != 0)) / n)


def mitsuba_rays(camera_rays: int, rates: dict, emitter_samples: int, bsdf_samples: int) -> float:
    """Mitsuba direct's rays for `camera_rays` camera samples (the formula in the module docstring)."""
    return camera_rays * (1.0 + emitter_samples * rates["emitter"] + bsdf_samples * rates["bsdf"])


def equal_work_emitter_samples(target_rays: int, camera_rays: int, rates: dict, bsdf_samples: int) -> int:
    """The whole emitter_samples >= 1 whose Mitsuba ray count is nearest `target_rays`."""
    per_sample = camera_rays * rates["emitter"]
    rest = target_rays - mitsuba_rays(camera_rays, rates, 0, bsdf_samples)
    return max(1, round(rest / per_sample)) if per_sample > 0 else 1


def timed(fn):
    """(result, wall s, CPU s of this process) of fn()."""
    wall, cpu = time.perf_counter(), time.process_time()
    result = fn()
    return result, time.perf_counter() - wall, time.process_time() - cpu


def clrender_settings(size: int, samples: int) -> dict:
    """clrender's Whitted settings: the report's full AA, stratified samples x samples a pixel, from CAMERA."""
    return dict(width=size, height=size, camera=CAMERA, aa="full", sampler="stratified", samples=samples)


def measure(variant: str, args, threads: int, out: Path) -> dict:
    """One row: both renderers' warm-up render, then args.runs timed renders each, alternating."""
    import drjit as dr

    from clrender.image.files import write_display_image
    from clrender.trace.renderer import Renderer

    scene, scene_dict = scenes(variant)
    spp = args.samples**2
    settings = clrender_settings(args.size, args.samples)
    start = time.perf_counter()
    renderer = Renderer(scene, seed=0, **settings)
    first = renderer.run()
    clrender_first = time.perf_counter() - start
    tracer = renderer.tracer
    camera_rays = args.size * args.size * spp

    mi = mitsuba_scenes.load_mitsuba("llvm_ad_rgb")
    dr.set_thread_count(threads)
    bsdf_samples = args.bsdf_samples
    probe = mitsuba_scene(mi, scene_dict, args.size, spp, 1, bsdf_samples)
    rates = count_mitsuba_rays(mi, probe, args.count_spp)
    e = args.emitter_samples or equal_work_emitter_samples(first.rays, camera_rays, rates, bsdf_samples)
    delta_weight = delta_light_weight(mi, e)
    loaded = mitsuba_scene(mi, scene_dict, args.size, spp, e, bsdf_samples, delta_weight)
    theirs, mitsuba_first, _ = timed(lambda: mitsuba_scenes.render_loaded(mi, loaded, spp=spp, seed=0))

    walls = {"clrender": [], "mitsuba": []}
    cpus = {"clrender": [], "mitsuba": []}
    clrender_rays = []

    def run_clrender(seed):
        result, wall, cpu = timed(lambda: Renderer(scene, seed=seed, tracer=tracer, **settings).run())
        walls["clrender"].append(wall)
        cpus["clrender"].append(cpu)
        clrender_rays.append(result.rays)

    def run_mitsuba(seed):
        _, wall, cpu = timed(lambda: mitsuba_scenes.render_loaded(mi, loaded, spp=spp, seed=seed))
        walls["mitsuba"].append(wall)
        cpus["mitsuba"].append(cpu)

    for k in range(args.runs):  # ABBA: neither renderer always runs second
        order = (run_clrender, run_mitsuba) if k % 2 == 0 else (run_mitsuba, run_clrender)
        for fn in order:
            fn(k + 1)
    write_display_image(out / f"whitted_{variant}_pair.png", np.concatenate([first.image, theirs], axis=1))
    print(
        f"{variant}: mean RGB clrender {np.round(first.image.mean(axis=(0, 1)), 4).tolist()}, "
        f"Mitsuba {np.round(theirs.mean(axis=(0, 1)), 4).tolist()}; Mitsuba ray rates per camera sample {rates}; "
        f"Mitsuba's directional-light weight with {e} emitter samples: {delta_weight:.3f} (divided out)"
    )

    ours_rays = int(statistics.median(clrender_rays or [first.rays]))
    theirs_rays = mitsuba_rays(camera_rays, rates, e, bsdf_samples)
    med = {who: statistics.median(v) if v else float("nan") for who, v in walls.items()}
    cpu = {who: statistics.median(v) if v else float("nan") for who, v in cpus.items()}
    ours_rate, theirs_rate = ours_rays / med["clrender"] / 1e6, theirs_rays / med["mitsuba"] / 1e6
    return dict(
        variant=variant,
        threads=threads,
        spp=spp,
        emitter_samples=e,
        bsdf_samples=bsdf_samples,
        clrender_mrays=ours_rays / 1e6,
        mitsuba_mrays=theirs_rays / 1e6,
        clrender_first_s=clrender_first,
        mitsuba_first_s=mitsuba_first,
        clrender_s=med["clrender"],
        mitsuba_s=med["mitsuba"],
        clrender_cpu_s=cpu["clrender"],
        mitsuba_cpu_s=cpu["mitsuba"],
        clrender_mrays_per_s=ours_rate,
        mitsuba_mrays_per_s=theirs_rate,
        speedup_wall=med["mitsuba"] / med["clrender"],
        speedup_cpu=cpu["mitsuba"] / cpu["clrender"],
        speedup_mrays_per_s=ours_rate / theirs_rate,
    )


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench whitted", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", type=int, default=400, help="image side in pixels (default 400)")
    ap.add_argument("--samples", type=int, default=6, help="N: N x N samples per pixel in both renderers (default 6: 36 spp)")
    ap.add_argument("--runs", type=int, default=3, help="timed renders per renderer after the first; medians reported (default 3)")
    ap.add_argument("--bsdf-samples", type=int, default=0, help="Mitsuba direct's bsdf_samples (default 0: shadow rays only, as Whitted)")
    ap.add_argument("--emitter-samples", type=int, default=0, help="Mitsuba direct's emitter_samples; 0 (default): solved for clrender's ray count")
    ap.add_argument("--count-spp", type=int, default=4, help="samples per pixel of the pass that counts Mitsuba's rays (default 4)")
    ap.add_argument("--threads", type=int, default=0, help="Mitsuba's threads (default 0: as many as clrender's OpenCL device has compute units)")
    ap.add_argument("--variants", nargs="+", choices=VARIANTS, default=list(VARIANTS))
    ap.add_argument("--quick", action="store_true", help="64x64, N = 2, one timed run each, counted at 1 spp")
    ap.add_argument("--out", default="bench/out", help="folder for whitted.csv / whitted.md and the pair images (default bench/out)")
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.samples, args.runs, args.count_spp = 64, 2, 1, 1
    reason = mitsuba_scenes.unavailable("llvm_ad_rgb")
    if reason:
        sys.stderr.write(f"bench whitted needs Mitsuba 3 llvm_ad_rgb: {reason}\n")
        return 2
    from clrender.device import get_device

    threads = args.threads or get_device().device.max_compute_units
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = [measure(variant, args, threads, out) for variant in args.variants]
    title = (
        f"wizard_cat camera {CAMERA}, {args.size}x{args.size}, {args.samples**2} spp: clrender Whitted vs Mitsuba llvm_ad_rgb direct, "
        f"{threads} threads each (median of {args.runs})"
    )
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
    print(write_table(out, "whitted", rows, title))
    return 0


if __name__ == "__main__":
    sys.exit(main())
