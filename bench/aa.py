"""Full vs edge-only anti-aliasing: `python -m bench aa [--quick] [--out DIR]`.

The wizard_cat setting (a triangle mesh, a refractive Blinn-Phong
sphere and an area light) at 400x400, stratified N=6, edge thickness 1.0:
time (wall, and CPU seconds of this process) of `full` and `edge_detect`, the fraction of pixels resampled, and the
RMSE of each (sRGB values in [0, 1]) against a high-sample reference.
The original report's renderer took 3700 s (full) and 1129 s (edge) for this render.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from clrender.image.files import linear_to_srgb, write_display_image
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from .common import write_table


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m bench aa", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="wizard_cat")
    ap.add_argument("--camera", type=int, default=3, help="wizard_cat's default view")
    ap.add_argument("--size", type=int, default=400)
    ap.add_argument("--samples", type=int, default=6, help="N: N x N stratified samples per pixel")
    ap.add_argument("--reference-samples", type=int, default=12, help="N of the reference render")
    ap.add_argument("--thickness", type=float, default=1.0)
    ap.add_argument("--quick", action="store_true", help="100x100, N=3, reference N=6")
    ap.add_argument("--out", default="bench/out")
    ap.add_argument("--no-reference", action="store_true", help="skip the reference render (and the RMSE column)")
    ap.add_argument("--bvh-width", type=int, default=None, help="BVH width (2 or 4; default: the Tracer's)")
    ap.add_argument("--no-shadow-shafts", action="store_true", help="trace every area-light shadow ray through the tree (kernels/shaft.h off)")
    args = ap.parse_args(argv)
    if args.quick:
        args.size, args.samples, args.reference_samples = 100, 3, 6
    scene = Scene.load(args.scene)
    width = {} if args.bvh_width is None else {"bvh_width": args.bvh_width}
    tracer = Tracer(scene, shadow_shafts=not args.no_shadow_shafts, **width)
    common = dict(tracer=tracer, width=args.size, height=args.size, camera=args.camera, sampler="stratified")
    runs = {}
    modes = {
        "none": dict(aa="none"),
        "full": dict(aa="full", samples=args.samples),
        "edge_detect (ids only)": dict(aa="edge_detect", contrast=0.0, samples=args.samples, thickness=args.thickness),
        "edge_detect": dict(aa="edge_detect", samples=args.samples, thickness=args.thickness),
    }
    cpu = {}
    for mode, settings in modes.items():
        renderer = Renderer(scene, seed=1, **settings, **common)  # samples and thickness only where they act
        start = time.process_time()
        runs[mode] = renderer.run()
        cpu[mode] = time.process_time() - start  # this process, PoCL's threads included (the host is shared)
    if args.no_reference:
        ref = None
    else:
        ref = linear_to_srgb(Renderer(scene, aa="full", samples=args.reference_samples, seed=2, **common).run().image)
    rows = []
    for mode, result in runs.items():
        t = result.timings
        total = t["trace"] + t.get("edges", 0.0) + t.get("resample", 0.0)
        rmse = float("nan") if ref is None else float(np.sqrt(np.mean((linear_to_srgb(result.image) - ref) ** 2)))
        rows.append(
            dict(
                mode=mode,
                seconds=total,
                cpu_s=cpu[mode],
                pass1_s=t["trace"],
                pass2_s=t.get("resample", 0.0),
                resampled=result.resampled_fraction if mode.startswith("edge") else float(mode == "full"),
                rmse=rmse,
                compile_s=t["compile"],
            )
        )
    out = Path(args.out)
    title = (
        f"{args.scene} camera {args.camera}, {args.size}x{args.size}, stratified N={args.samples}, "
        f"thickness {args.thickness}; reference N={args.reference_samples}; BVH width {tracer.bvh_width}; "
        f"shadow shafts {'on' if tracer.shadow_shafts else 'off'}; "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs"
    )
    print(write_table(out, "aa", rows, title))
    write_display_image(out / "aa_edge.png", runs["edge_detect"].image)
    from clrender.trace.edges import overlay_edges

    write_display_image(out / "aa_mask.png", overlay_edges(runs["none"].image, runs["edge_detect"].edge_mask))
    full, edge = rows[1], rows[3]
    print(
        f"edge-AA: {edge['seconds']:.2f}s vs full {full['seconds']:.2f}s ({full['seconds'] / edge['seconds']:.1f}x), "
        f"{100 * edge['resampled']:.1f}% of pixels resampled, RMSE {edge['rmse']:.4f} vs {full['rmse']:.4f} "
        f"({100 * (edge['rmse'] / full['rmse'] - 1):+.1f}%)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
