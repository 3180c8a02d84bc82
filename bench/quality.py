"""Equal-time quality against Mitsuba 3: `python -m bench quality [--peer mitsuba] [--budget S] [--size PX]
[--ref-spp N] [--runs K] [--seed S] [--threads N] [--scenes ...] [--out DIR] [--cache DIR]`.

Each renderer renders each scene for a fixed wall time (--budget, default 10 s) on the same threads, and its
image's error is measured against ITS OWN converged image (--ref-spp paths a pixel, default 4096): the two
converged images agree within noise (the line under the table says how well), so this error is noise alone, and
the lower error after equal time is the better renderer of that scene.

  clrender   `Renderer(..., integrator="path", spp=--pass-spp, time_budget=--budget)`: whole-image passes while
             the budget lasts (it stops before a pass that would overrun it), the passes averaged.
  Mitsuba    `llvm_ad_rgb`, `path` integrator, `independent` sampler, ONE render whose spp is chosen by a timed
             calibration (renders of 1, 4, 16, ... spp until one takes an eighth of the budget, and one at twice
             that spp if it was the first; the line through the last two gives the spp that fills the budget:
             spp_for_budget).  Mitsuba has no
             time budget, and a user picks its spp; one render a budget is its fastest way (each mi.render call
             re-traces its megakernel, so passes of a few spp would charge it an overhead the one render does not
             pay).  Dr.Jit's LLVM compile of a new kernel (a new spp can need one) is subtracted from its time.
             Russian roulette from its own default bounce (rr_depth 5), or with --mitsuba-rr same from clrender's
             (clrender/trace/path.py RR_DEPTH; the converged image, its reference, is the same either way).

Error: RMSE over pixels and channels against the reference (float64), relative RMSE (RMSE / the reference's
mean), and rmse_own: the RMSE with the reference's own noise taken out, sqrt(max(MSE - mean(s^2 / P), 0)) with s^2
each pixel's sample variance over the reference's P parts (the reference is the mean of P renders of ref_spp / P
paths, seeds apart from the measured ones): E[MSE] = the image's variance + the reference's.  own_at_budget
scales rmse_own by sqrt(seconds / budget) (variance falls as 1 / time), so a render that took longer or shorter than
the budget compares at exactly the budget: the image's own noise after exactly the budget.  The ratios are
clrender / Mitsuba (< 1: clrender less noisy).  Medians of --runs renders a side (seeds --seed, --seed + 1, ...), the
two alternating (ABBA).

References are cached (--cache, default ~/.cache/clrender/bench) as <scene>_<renderer>_<W>x<H>_<spp>spp_d<depth>
_<digest>.npz, the digest over the scene's content (files it names included), the parts, the renderer's code
(clrender: kernels/, clrender/trace, clrender/scene, clrender/layout.py and the OpenCL device's name; Mitsuba:
its and Dr.Jit's versions and tests/reference/mitsuba_scenes.py): a re-run renders none of them again.

Scenes (max depth --max-depth after the primary hit; Mitsuba's max_depth that + 2): the Cornell box of
tests/reference/path_scenes.py at --size square; `bench assets`'s textured torus, gold sphere and checker floor
under an HDR sky (bench/assets.py picture_scenes, textures 1024^2) at --size x 5/8 --size; and wizard_cat from
camera 3 with bench/path.py's physical lights at --size square.  Mitsuba's metal is its native `principled`
(exact=False, as `bench path`: its fastest form; the references then differ on the metal by that lobe's G term).
Threads: --threads N pins this process to N CPUs (sched_setaffinity) and sets Dr.Jit's pool to N; default all CPUs.
Results: quality.csv / quality.md (the table and the agreement lines), quality_<scene>_<renderer>.npy (the last
equal-time image) and quality_<scene>.png (clrender | Mitsuba, equal time, then their references).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import statistics
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .common import cpu_model, write_table

ROOT = Path(__file__).resolve().parents[1]
SCENES = ("cornell_box", "assets", "wizard_cat")
CLRENDER_CODE = ("kernels", "clrender/trace", "clrender/scene", "clrender/layout.py")
MITSUBA_CODE = ("tests/reference/mitsuba_scenes.py",)
HDR_SUFFIXES = (".exr", ".hdr")
REFERENCE_SEED = 10_000  # the references' parts take seeds from here; the equal-time renders' seeds stay below
CALIBRATION_FRACTION = 1 / 8  # Mitsuba's calibration renders grow until one takes this share of the budget


# ---------------------------------------------------------------------- arithmetic
def rmse(image, reference) -> float:
    """Root mean square difference over every pixel and channel, in float64."""
    d = np.asarray(image, np.float64) - np.asarray(reference, np.float64)
    return float(np.sqrt(np.mean(d * d)))


def reference_noise(parts) -> float:
    """The reference's own mean square error: mean over pixels and channels of s^2 / P, s^2 the sample variance
    (ddof 1) of a pixel over the P parts whose mean the reference is."""
    parts = np.asarray(parts, np.float64)
    return float(np.mean(parts.var(axis=0, ddof=1)) / len(parts))


def errors(image, parts) -> dict:
    """rmse, rel_rmse (over the reference's mean) and rmse_own (the reference's noise taken out) of an image against
    the mean of `parts` (P, H, W, 3)."""
    reference = np.asarray(parts, np.float64).mean(axis=0)
    e = rmse(image, reference)
    return dict(rmse=e, rel_rmse=e / float(reference.mean()), rmse_own=float(np.sqrt(max(e * e - reference_noise(parts), 0.0))))


def spp_for_budget(budget: float, points) -> int:
    """The spp whose render takes `budget` seconds on the line through the last two (spp, seconds) points (a fixed
    cost plus a cost per spp); through the origin and the last point when the two do not rise."""
    (s1, t1), (s2, t2) = points[-2], points[-1]
    slope = (t2 - t1) / (s2 - s1) if s2 != s1 else 0.0
    if slope <= 0:
        return max(1, round(budget / t2 * s2))
    fixed = max(t2 - slope * s2, 0.0)
    return max(1, round((budget - fixed) / slope))


def agreement_line(ours, theirs) -> str:
    """How the two references agree: their means per channel, the RMS of their difference against what their noise
    alone gives (sqrt of the sum of their reference_noise: about 1 when they agree), and a block z-test
    (tests/reference/ztest.py) over their parts."""
    from tests.reference.ztest import two_sample_z

    a, b = np.asarray(ours, np.float64), np.asarray(theirs, np.float64)
    ma, mb = a.mean(axis=(0, 1, 2)), b.mean(axis=(0, 1, 2))
    excess = rmse(a.mean(0), b.mean(0)) / np.sqrt(reference_noise(a) + reference_noise(b))
    h, w = a.shape[1:3]
    block = next(k for k in (8, 4, 2, 1) if h % k == 0 and w % k == 0)
    z = two_sample_z(a, b, block=block)
    return (
        f"references: mean RGB clrender {np.round(ma, 4).tolist()} vs Mitsuba {np.round(mb, 4).tolist()} "
        f"(relative difference {np.round(ma / mb - 1, 4).tolist()}); RMS difference {excess:.2f}x what their noise gives; "
        f"{block}x{block} block z-test over {len(a)} + {len(b)} parts: worst p {z.worst_p:.3g} "
        f"(Šidák threshold {z.threshold:.3g}): {'agree' if z.passed else 'DIFFER'}"
    )


# ---------------------------------------------------------------------- scenes and the reference cache
@dataclass
class Setup:
    name: str
    scene: object  # clrender's Scene
    camera: int  # its camera number
    mitsuba: dict  # the scene dict tests/reference/mitsuba_scenes.py converts (one camera: camera 1)
    width: int
    height: int
    digest: str  # of the scene's content


def scene_setup(name: str, size: int, out: Path) -> Setup:
    from clrender.scene.scene import Scene

    if name == "cornell_box":
        from tests.reference import path_scenes

        d = path_scenes.cornell_box(size)
        return Setup(name, Scene.from_dict(d), 1, d, size, size, digest(d))
    if name == "assets":
        from .assets import picture_scenes

        folder = out / "quality_assets"
        folder.mkdir(parents=True, exist_ok=True)
        ours, theirs = picture_scenes(folder, size, size * 5 // 8, 1024)
        return Setup(name, Scene.from_dict(ours), 1, theirs, size, size * 5 // 8, digest(ours, theirs))
    from .path import wizard_cat_path_dict, wizard_cat_scene

    d = wizard_cat_path_dict(3)
    return Setup(name, wizard_cat_scene(3), 3, d, size, size, digest(d))


def digest(*items) -> str:
    """SHA-256 of nested dicts, lists, arrays, numbers and strings; a `file` entry's content counts, not its path (an
    EXR's or HDR's pixels, any other file's bytes)."""
    h = hashlib.sha256()

    def feed(x, key=None):
        if isinstance(x, dict):
            for k in sorted(x):
                h.update(f"<{k}>".encode())
                feed(x[k], k)
        elif isinstance(x, (list, tuple)):
            h.update(b"[")
            for v in x:
                feed(v)
            h.update(b"]")
        elif isinstance(x, np.ndarray):
            h.update(f"{x.dtype}{x.shape}".encode() + np.ascontiguousarray(x).tobytes())
        elif key == "file" and Path(x).suffix.lower() in HDR_SUFFIXES:  # its pixels: the header holds a time stamp
            from tests.reference.mitsuba_scenes import read_image

            feed(read_image(x))
        elif key == "file":
            h.update(Path(x).read_bytes())
        else:
            h.update(json.dumps(x).encode() if not isinstance(x, np.generic) else x.tobytes())

    for item in items:
        feed(item)
    return h.hexdigest()


def code_digest(paths, *extra) -> str:
    """SHA-256 of the files under `paths` (relative to the repository root, in name order) and of `extra` strings."""
    h = hashlib.sha256()
    for rel in paths:
        p = ROOT / rel
        for f in sorted(p.rglob("*")) if p.is_dir() else [p]:
            if f.is_file() and "__pycache__" not in f.parts:
                h.update(str(f.relative_to(ROOT)).encode() + f.read_bytes())
    for e in extra:
        h.update(str(e).encode())
    return h.hexdigest()


def cached_parts(cache: Path, tag: str, key: str, render, parts: int, part_spp: int) -> tuple[np.ndarray, bool]:
    """((P, H, W, 3) float32 parts of a reference, whether read from the cache): render(spp, seed) for seeds 10000 +
    0..P-1 unless `cache`/<tag>_<key[:16]>.npz holds them."""
    path = cache / f"{tag}_{key[:16]}.npz"
    if path.exists():
        return np.load(path)["parts"], True
    stack = np.stack([np.asarray(render(part_spp, REFERENCE_SEED + i), np.float32) for i in range(parts)])
    cache.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp.npz")
    np.savez(tmp, parts=stack)
    os.replace(tmp, path)
    return stack, False


# ---------------------------------------------------------------------- the two renderers
class Clrender:
    """clrender's path tracer on one scene: the tracer built and the kernels compiled once."""

    label = "clrender"

    def __init__(self, setup: Setup, args):
        from clrender.trace.tracer import Tracer

        self.setup, self.args = setup, args
        self.tracer = Tracer(setup.scene)
        self.render(1, 0)  # compiles the kernels
        self.threads = self.tracer.device.device.max_compute_units
        self.code = code_digest(CLRENDER_CODE, self.tracer.device.name)

    def _run(self, spp: int, seed: int, budget=None):
        from clrender.trace.renderer import Renderer

        s, a = self.setup, self.args
        settings = dict(integrator="path", spp=spp, max_depth=a.max_depth, width=s.width, height=s.height, camera=s.camera)
        return Renderer(s.scene, tracer=self.tracer, seed=seed, time_budget=budget, **settings).run()

    def render(self, spp: int, seed: int) -> np.ndarray:
        return self._run(spp, seed).image

    def equal_time(self, budget: float, seed: int) -> dict:
        wall, cpu = time.perf_counter(), time.process_time()
        result = self._run(self.args.pass_spp, seed, budget)
        seconds, cpu_s = time.perf_counter() - wall, time.process_time() - cpu
        return dict(image=result.image, seconds=seconds, cpu_s=cpu_s, spp=result.samples_per_pixel)


class Mitsuba:
    """Mitsuba 3 llvm_ad_rgb on one scene: loaded once, its spp for the budget calibrated once."""

    label = "mitsuba llvm_ad_rgb"

    def __init__(self, setup: Setup, args):
        import drjit as dr
        import mitsuba

        from clrender.trace.path import RR_DEPTH

        from tests.reference import mitsuba_scenes

        self.setup, self.args, self.dr = setup, args, dr
        dr.set_thread_count(args.threads)
        self.threads = dr.thread_count()
        rr_depth = None if args.mitsuba_rr == "default" else RR_DEPTH
        settings = dict(spp=1, max_depth=args.max_depth, width=setup.width, height=setup.height, exact=False, rr_depth=rr_depth)
        self.mi, self.loaded = mitsuba_scenes.load(setup.mitsuba, variant="llvm_ad_rgb", **settings)
        self.render_loaded = mitsuba_scenes.render_loaded
        self.code = code_digest(MITSUBA_CODE, mitsuba.__version__, dr.__version__, "llvm_ad_rgb", "exact=False")
        self.render(1, 0)  # traces and compiles the kernels
        self.spp = None

    def _timed(self, spp: int, seed: int):
        """(image, wall s without Dr.Jit's compiles of new kernels, CPU s likewise)."""
        dr = self.dr
        dr.set_flag(dr.JitFlag.KernelHistory, True)
        dr.kernel_history()  # empties it
        wall, cpu = time.perf_counter(), time.process_time()
        image = self.render(spp, seed)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        compiled = sum(k.get("codegen_time", 0.0) + k.get("backend_time", 0.0) for k in dr.kernel_history() if k.get("cache_hit") == 0) / 1000
        dr.set_flag(dr.JitFlag.KernelHistory, False)
        return image, max(wall - compiled, 0.0), max(cpu - compiled, 0.0)

    def render(self, spp: int, seed: int) -> np.ndarray:
        return self.render_loaded(self.mi, self.loaded, spp=spp, seed=seed)

    def calibrate(self, budget: float) -> int:
        """The spp of one render that takes `budget` seconds (spp_for_budget over timed renders of growing spp)."""
        spp, points = 1, []
        while True:
            points.append((spp, self._timed(spp, 900 + len(points))[1]))
            if (points[-1][1] >= CALIBRATION_FRACTION * budget and len(points) >= 2 and points[-2][1] > 0) or spp >= 2**20:
                break
            spp *= 2 if points[-1][1] >= CALIBRATION_FRACTION * budget else 4
        return spp_for_budget(budget, points)

    def equal_time(self, budget: float, seed: int) -> dict:
        if self.spp is None:
            self.spp = self.calibrate(budget)
        image, seconds, cpu_s = self._timed(self.spp, seed)
        return dict(image=image, seconds=seconds, cpu_s=cpu_s, spp=self.spp)


# ---------------------------------------------------------------------- the measurement
def measure(name: str, args, out: Path, cache: Path) -> tuple[list, list]:
    """(table rows, lines under the table) of one scene: each renderer's reference (cached) and --runs equal-time
    renders a side, alternating."""
    from clrender.image.files import write_display_image

    setup = scene_setup(name, args.size, out)
    sides = [Clrender(setup, args)]
    if args.peer == "mitsuba":
        sides.append(Mitsuba(setup, args))
    parts, lines = {}, []
    for side in sides:
        tag = f"{name}_{side.label.split()[0]}_{setup.width}x{setup.height}_{args.ref_spp}spp_d{args.max_depth}"
        key = digest(setup.digest, side.code, args.ref_parts, args.max_depth)
        start = time.perf_counter()
        parts[side.label], hit = cached_parts(cache, tag, key, side.render, args.ref_parts, args.ref_spp // args.ref_parts)
        lines.append(f"{name}: {side.label} reference {'read from' if hit else f'rendered in {time.perf_counter() - start:.0f} s into'} {cache}")
    runs = {side.label: [] for side in sides}
    for k in range(args.runs):  # ABBA: neither renderer always goes first
        for side in sides if k % 2 == 0 else sides[::-1]:
            r = side.equal_time(args.budget, args.seed + k)
            runs[side.label].append({**r, **errors(r["image"], parts[side.label])})
    rows = []
    for side in sides:
        done = runs[side.label]
        med = {key: statistics.median(r[key] for r in done) for key in ("seconds", "cpu_s", "spp", "rmse", "rel_rmse", "rmse_own")}
        at_budget = statistics.median(r["rmse_own"] * np.sqrt(r["seconds"] / args.budget) for r in done)
        row = dict(scene=name, renderer=side.label, threads=side.threads, size=f"{setup.width}x{setup.height}", budget_s=args.budget)
        rows.append({**row, **med, "own_at_budget": at_budget, "ref_spp": args.ref_spp})
        np.save(out / f"quality_{name}_{side.label.split()[0]}.npy", done[-1]["image"])
    if len(sides) == 2:
        ours, theirs = rows
        for key in ("rmse", "rmse_own", "own_at_budget"):
            ours[f"{key}_ratio"], theirs[f"{key}_ratio"] = ours[key] / theirs[key] if theirs[key] > 0 else float("nan"), 1.0
        lines.append(f"{name}: {agreement_line(parts[sides[0].label], parts[sides[1].label])}")
    images = [runs[side.label][-1]["image"] for side in sides] + [parts[side.label].mean(0) for side in sides]
    write_display_image(out / f"quality_{name}.png", np.concatenate(images, axis=1))
    return rows, lines


def pin_threads(threads: int) -> int:
    """Pin this process (every thread it has and will start: PoCL's or Intel's workers, Dr.Jit's pool) to its first
    `threads` CPUs; 0: all it may use.  Returns the count."""
    cpus = sorted(os.sched_getaffinity(0))
    if threads <= 0 or threads >= len(cpus):
        return len(cpus)
    os.sched_setaffinity(0, cpus[:threads])
    return threads


def parse_args(argv):
    ap = argparse.ArgumentParser(prog="python -m bench quality", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--peer", choices=("mitsuba",), help="also render with Mitsuba 3 llvm_ad_rgb (skipped, said, when it cannot run)")
    ap.add_argument("--budget", type=float, default=10.0, help="seconds of each equal-time render (default 10)")
    ap.add_argument("--size", type=int, default=128, help="image width in pixels (default 128)")
    ap.add_argument("--ref-spp", type=int, default=4096, help="paths a pixel of each renderer's reference (default 4096)")
    ap.add_argument("--ref-parts", type=int, default=8, help="renders the reference is the mean of, >= 2 (default 8)")
    ap.add_argument("--pass-spp", type=int, default=16, help="clrender: paths a pixel per pass of the time budget (default 16)")
    ap.add_argument("--max-depth", type=int, default=8, help="bounces after the primary hit (default 8; Mitsuba's max_depth + 2)")
    ap.add_argument("--runs", type=int, default=3, help="equal-time renders a renderer and scene; medians reported (default 3)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the first equal-time render a side, the next one more (default 1)")
    ap.add_argument("--threads", type=int, default=0, help="CPUs for both renderers (default 0: all this process may use)")
    ap.add_argument(
        "--mitsuba-rr",
        choices=("default", "same"),
        default="default",
        help="Mitsuba's Russian roulette: its own start (rr_depth 5) or clrender's (clrender/trace/path.py RR_DEPTH)",
    )
    ap.add_argument("--scenes", nargs="+", choices=SCENES, default=["cornell_box", "assets"])
    ap.add_argument("--out", default="bench/out", help="folder for quality.csv / quality.md and the images (default bench/out)")
    ap.add_argument("--cache", default=str(Path.home() / ".cache/clrender/bench"), help="folder of the cached references")
    args = ap.parse_args(argv)
    if args.budget <= 0 or args.size < 2 or args.runs < 1 or args.pass_spp < 1:
        ap.error("--budget must be > 0, --size >= 2, --runs and --pass-spp >= 1")
    if not 0 <= args.seed <= REFERENCE_SEED - args.runs:
        ap.error(f"--seed {args.seed} must be from 0 to {REFERENCE_SEED - args.runs}: the references' seeds start at {REFERENCE_SEED}")
    if args.ref_parts < 2 or args.ref_spp % args.ref_parts:
        ap.error(f"--ref-spp {args.ref_spp} must be a multiple of --ref-parts {args.ref_parts} >= 2")
    return args


def main(argv=None):
    args = parse_args(argv)
    args.threads = pin_threads(args.threads)
    if args.peer == "mitsuba":
        from tests.reference import mitsuba_scenes

        reason = mitsuba_scenes.unavailable("llvm_ad_rgb")
        if reason:
            print(f"mitsuba llvm_ad_rgb: not measured: {reason}")
            args.peer = None
    out, cache = Path(args.out), Path(args.cache).expanduser()
    out.mkdir(parents=True, exist_ok=True)
    load = os.getloadavg()[0]
    rows, lines = [], []
    for name in args.scenes:
        r, l = measure(name, args, out, cache)
        rows += r
        lines += l
    lines.append(f"CPU: {cpu_model()}, {args.threads} threads each; load average {load:.1f} at the start, {os.getloadavg()[0]:.1f} at the end")
    title = f"Equal-time quality: {args.budget:g} s a render, RMSE against each renderer's own {args.ref_spp} spp reference (median of {args.runs})"
    table = write_table(out, "quality", rows, title)
    with open(out / "quality.md", "a") as f:
        f.write("\n" + "\n".join(f"- {line}" for line in lines) + "\n")
    print(table)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
