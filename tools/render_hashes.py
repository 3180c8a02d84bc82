"""SHA-256 of renders, AOVs, edge masks and splats, one line per item, for checking that a refactor changed no pixel.

    python tools/render_hashes.py > before.txt                   # in the checkout before the refactor
    python tools/render_hashes.py > after.txt                    # ... and after it
    diff before.txt after.txt                                    # no output: bit for bit the same
    python tools/render_hashes.py --only 'splat*' 'voronoi*'     # some items (fnmatch patterns on the first column)
    python tools/render_hashes.py --list                         # the items' names

To compare two checkouts, run this same file in each: `(cd OLD && python /path/to/tools/render_hashes.py)`.
The clrender imported is the one of the current folder's checkout (run it from the repository root),
and only the public API is used, so the file also runs against older checkouts.

Each line is `ITEM VARIANT SHA256`; a hash covers the arrays' dtype, shape and bytes.  The items:
- `render:SCENE` for every bundled scene, in each AA mode: the image and the object ids;
- `aov:SCENE`: each AOV (depth, normal, albedo, id, edges) of an edge-detect render;
- `edges:SCENE`: the render's edge mask, and masks rebuilt from its path ids (thicker, with and
  without the shadow edges);
- `splat-gauss`: a Gaussian-splat render of 300 generated splats in both blends, and the gradients
  of a fixed loss;
- `path:SCENE`: path-traced renders (4 spp) of every bundled scene, with AOVs, and with the tent filter;
  `path:assets`: bench/assets.py's textured torus, gold sphere and checker floor under an HDR sky;
- `voronoi`: a Voronoi splat of a small generated photo (grid and naive search, with Lloyd steps and
  soft-Voronoi training), its nearest-site index and image.
"""

from __future__ import annotations

import argparse
import fnmatch
import hashlib
import os
import sys
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
sys.path.insert(0, str(Path.cwd()))  # the checkout being measured, not an installed clrender

SCENES = ("refract1", "refract2", "bunny", "wizard_cat", "wizard_hat", "wizard_tower")
AA_MODES = ("none", "full", "edge_detect")
AOV_SCENES = ("refract1", "bunny", "wizard_cat")  # spheres and glass, a smooth mesh, a many-object scene
AOVS = ("depth", "normal", "albedo", "id", "edges")
WIDTH, HEIGHT = 120, 90


def digest(*arrays) -> str:
    import numpy as np

    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(f"{a.dtype.str}{a.shape}".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def renders(chosen):
    from clrender import Renderer

    for scene in (s for s in SCENES if f"render:{s}" in chosen):
        for aa in AA_MODES:
            result = Renderer(scene, width=WIDTH, height=HEIGHT, aa=aa, samples=1 if aa == "none" else 2, seed=7).run()
            yield f"render:{scene}", aa, digest(result.image, result.ids)


def aovs(chosen):
    from clrender import Renderer
    from clrender.trace.edges import edge_mask

    for scene in (s for s in AOV_SCENES if f"aov:{s}" in chosen or f"edges:{s}" in chosen):
        result = Renderer(scene, width=WIDTH, height=HEIGHT, aa="edge_detect", samples=2, seed=7, aovs=AOVS).run()
        for name in AOVS:
            yield f"aov:{scene}", name, digest(result.aovs[name])
        yield f"edges:{scene}", "render", digest(result.edge_mask)
        yield f"edges:{scene}", "thick-2.5", digest(edge_mask(result.path_ids, thickness=2.5, shadow=result.shadow))
        yield f"edges:{scene}", "no-shadow-edges", digest(edge_mask(result.path_ids, thickness=1.0, shadow=result.shadow, shadow_edges=False))
        yield f"edges:{scene}", "ids-only", digest(edge_mask(result.path_ids, thickness=0.0))


def paths(chosen):
    from clrender import Renderer

    for scene in (s for s in SCENES if f"path:{s}" in chosen):
        for name, extra in (("box", {}), ("aovs", {"aovs": ("depth", "normal", "albedo")}), ("tent", {"rfilter": "tent"})):
            result = Renderer(scene, width=64, height=48, integrator="path", spp=4, seed=7, **extra).run()
            yield f"path:{scene}", name, digest(result.image, *(result.aovs[k] for k in sorted(result.aovs)))
    if "path:assets" in chosen:
        import tempfile

        from bench.assets import clrender_settings, picture_scenes
        from clrender.scene.scene import Scene

        with tempfile.TemporaryDirectory() as folder:
            scene = Scene.from_dict(picture_scenes(Path(folder), 64, 48, 256)[0])
            result = Renderer(scene, seed=7, **clrender_settings(4)).run()
        yield "path:assets", "box", digest(result.image)


def gauss_params(n: int, width: int, height: int, blend: str):
    import numpy as np

    from clrender.splat.gauss import GaussParams

    rng = np.random.default_rng(11)
    return GaussParams(
        xy=rng.uniform((0, 0), (width, height), (n, 2)),
        log_scale=rng.uniform(0.0, 2.0, (n, 2)),
        theta=rng.uniform(-np.pi, np.pi, n),
        color=rng.uniform(0.0, 1.0, (n, 3)),
        lum=rng.uniform(0.5, 1.5, n),
        opacity=rng.uniform(0.2, 1.0, n),
        width=width,
        height=height,
        blend=blend,
        background=(0.1, 0.2, 0.3),
    )


def splat_gauss(chosen):
    import numpy as np

    from clrender import get_device
    from clrender.splat.gauss import GaussRenderer

    width, height = 96, 64
    for blend in ("normalized", "sum"):
        params = gauss_params(300, width, height, blend)
        renderer = GaussRenderer(get_device(), width, height, blend, params.background)
        frame = renderer.forward(params)
        yield "splat-gauss", f"{blend}-image", digest(frame.image)
        d_image = np.random.default_rng(12).standard_normal((height, width, 3)).astype(np.float32)
        grads = renderer.backward(frame, d_image)
        yield "splat-gauss", f"{blend}-grads", digest(*(grads[k] for k in sorted(grads)))


def voronoi(chosen):
    from dataclasses import replace

    from clrender import get_device
    from clrender.splat import voronoi as V
    from clrender.testing import synthetic_photo

    image = synthetic_photo(96, 64, seed=3)
    base = V.VoronoiSettings(n=200, seed=5)
    for name, settings in (
        ("grid", base),
        ("naive", replace(base, method="naive")),
        ("lloyd-2", replace(base, lloyd=2)),
        ("train-5", replace(base, init="random", colors="sample", train=5)),
    ):
        result = V.splat(get_device(), image, settings)
        yield "voronoi", name, digest(result.index, result.image)


GROUPS = {"render": renders, "path": paths, "aov": aovs, "edges": aovs, "splat-gauss": splat_gauss, "voronoi": voronoi}
ITEMS = (
    [f"render:{s}" for s in SCENES]
    + [f"path:{s}" for s in (*SCENES, "assets")]
    + [f"{k}:{s}" for s in AOV_SCENES for k in ("aov", "edges")]
    + ["splat-gauss", "voronoi"]
)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python tools/render_hashes.py", description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", nargs="+", metavar="ITEM", help="only the items matching these fnmatch patterns")
    parser.add_argument("--list", action="store_true", help="list the items, then exit")
    args = parser.parse_args(argv)
    chosen = [i for i in ITEMS if not args.only or any(fnmatch.fnmatchcase(i, p) for p in args.only)]
    if args.list:
        print("\n".join(ITEMS))
        return 0
    if not chosen:
        parser.error(f"no item matches {' '.join(args.only)} (see --list)")
    import clrender

    print(f"# clrender from {Path(clrender.__file__).parent}", file=sys.stderr)
    for group in dict.fromkeys(GROUPS[i.split(":")[0]] for i in chosen):
        for item, variant, h in group(chosen):
            if item in chosen:
                print(f"{item:22s} {variant:16s} {h}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
