"""The path tracer's samplers, noise against time: `python -m bench sampler [--scenes cornell_box,assets] [--size PX]
[--ref-spp N] [--spp 4,16,64] [--budget S] [--runs K] [--out DIR]`.

RMSE against a converged image (--ref-spp paths a pixel, half by each sampler, seeds apart from the measured runs,
cached in DIR), for `--path-sampler independent` and `sobol` (docs/materials.md#the-sampler):
  equal spp   each --spp, K renders a sampler (seeds 1..K), the two samplers' runs interleaved: median RMSE and
              median wall time;
  equal time  --time-budget S with passes of the first --spp, K runs a sampler interleaved: median RMSE and the
              median paths a pixel reached.
Scenes at --size pixels wide, max depth 8: the Cornell box of tests/reference/path_scenes.py and bench/assets.py's
textured torus, gold sphere and checker floor under an HDR sky.  The CPU model is printed with the table.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

import numpy as np

from .common import cpu_model, write_table

SAMPLERS = ("independent", "sobol")


def scene_dict(name: str, size: int, out: Path) -> dict:
    if name == "cornell_box":
        from tests.reference import path_scenes

        return path_scenes.cornell_box(size)
    from .assets import picture_scenes

    folder = out / "sampler_assets"
    folder.mkdir(parents=True, exist_ok=True)
    return picture_scenes(folder, size, size * 3 // 4, 256)[0]


def measure(name: str, args, out: Path) -> list[dict]:
    from clrender.scene.scene import Scene
    from clrender.trace.renderer import Renderer
    from clrender.trace.tracer import Tracer

    scene = Scene.from_dict(scene_dict(name, args.size, out))
    tracer = Tracer(scene)

    def render(sampler, spp, seed, budget=None):
        start = time.perf_counter()
        r = Renderer(scene, tracer=tracer, integrator="path", path_sampler=sampler, spp=spp, max_depth=8, seed=seed, time_budget=budget).run()
        return r.image.astype(np.float64), time.perf_counter() - start, r.samples_per_pixel

    for sampler in SAMPLERS:  # compile both before timing
        render(sampler, 1, 0)
    cached = out / f"sampler_reference_{name}_{args.size}_{args.ref_spp}.npy"
    if cached.exists():
        reference = np.load(cached)
    else:
        reference = sum(render(s, args.ref_spp // 2, 1000 + i)[0] for i, s in enumerate(SAMPLERS)) / 2
        np.save(cached, reference)
    rmse = lambda image: float(np.sqrt(((image - reference) ** 2).mean()))  # noqa: E731
    rows = []
    for spp in args.spp:
        runs = [[render(s, spp, 1 + k) for s in SAMPLERS] for k in range(args.runs)]  # interleaved
        by = {s: [runs[k][i] for k in range(args.runs)] for i, s in enumerate(SAMPLERS)}
        for s in SAMPLERS:
            rmses, times = [rmse(r[0]) for r in by[s]], [r[1] for r in by[s]]
            rows.append(dict(scene=name, measure=f"{spp} spp", sampler=s, rmse=statistics.median(rmses), seconds=statistics.median(times), spp=spp))
    if args.budget > 0:
        timed = [[render(s, args.spp[0], 50 + k, args.budget) for s in SAMPLERS] for k in range(args.runs)]
        for i, s in enumerate(SAMPLERS):
            rmses, reached = [rmse(t[i][0]) for t in timed], [t[i][2] for t in timed]
            row = dict(scene=name, measure=f"{args.budget:g} s", sampler=s, rmse=statistics.median(rmses), seconds=args.budget)
            rows.append({**row, "spp": statistics.median(reached)})
    return rows


def main(argv):
    p = argparse.ArgumentParser(prog="python -m bench sampler", description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", default="cornell_box,assets", help="comma-separated: cornell_box, assets (default: both)")
    p.add_argument("--size", type=int, default=128, help="image width in pixels (default: 128)")
    p.add_argument("--ref-spp", type=int, default=4096, help="paths a pixel of the converged image (default: 4096)")
    p.add_argument("--spp", default="4,16,64", help="equal-spp counts; the first is the time budget's pass (default: 4,16,64)")
    p.add_argument("--budget", type=float, default=3.0, help="seconds of the equal-time renders; 0: none (default: 3)")
    p.add_argument("--runs", type=int, default=5, help="runs a sampler and count, interleaved (default: 5)")
    p.add_argument("--out", default="out/bench", help="folder of the table and the cached references (default: out/bench)")
    args = p.parse_args(argv)
    args.spp = [int(x) for x in args.spp.split(",")]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = [row for name in args.scenes.split(",") for row in measure(name, args, out)]
    print(write_table(out, "sampler", rows, f"Path samplers, RMSE against {args.ref_spp} spp ({cpu_model()})"))
    print(f"CPU: {cpu_model()}")
