"""Where a path-traced render spends its time, by kernel source function, file and line, from `perf` samples.

    python -m tools.kernel_profile                         # the Cornell box, 256², 32 spp, 4 renders
    python -m tools.kernel_profile --scene wizard_cat --top 40
    python -m tools.kernel_profile --scene whitted           # bench whitted's Whitted render (trace.cl's render)
    python -m tools.kernel_profile --scene assets            # bench assets' picture (HDR sky, textures), 256 x 160

Needs Intel's OpenCL CPU runtime (the `fast` extra), `perf` (Debian's linux-perf) and `llvm-symbolizer`.  The
render's kernels are built with `-g` (the runtime then keeps a line table in its object code); a child process
renders under `perf record`, after finding where the runtime loaded the render kernel's code (the object's
`.ltext` section, searched for in the child's executable mappings); the samples inside it are mapped back
through the object's line table, inlined calls included.  Inclusive shares count a sample once for every function
on its inline chain (traversal: `mesh_walk_closest` and `mesh_walk_any`); innermost shares count the function or
line the sample's instruction belongs to.  PoCL cannot be profiled this way: the clone of the kernel it runs inside
its work-group function has no line table.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
# the summary's lines: what, and the functions whose samples it counts (a sample once, if any is on its chain)
GROUPS = (
    ("closest-hit walks", ("mesh_walk_closest",)),
    ("any-hit walks", ("mesh_walk_any",)),
    ("the sampler", ("rng_next", "rng_next2")),
)


def image_shape(scene: str, size: int) -> tuple[int, int]:
    """(width, height) a scene renders at: square, but bench assets' picture, 5/8 as high as wide."""
    return size, size * 5 // 8 if scene == "assets" else size


def child(args) -> None:
    """Render under perf: build with -g, find the kernel's code in memory, write where, then the timed renders."""
    sys.path.insert(0, str(REPO))
    import clrender.device as device_module
    from bench.path import clrender_setup
    from clrender.trace.renderer import Renderer
    from tools.kernel_asm import elf_sections, object_code

    plain = device_module.build_options
    device_module.build_options = lambda defines=None: [*plain(defines), "-g"]
    if args.scene == "whitted":  # bench whitted's opaque scene, its Whitted settings (36 samples a pixel)
        from bench.whitted import clrender_settings, scenes

        scene, settings = scenes("opaque")[0], clrender_settings(args.size, 6)
    elif args.scene == "assets":  # bench assets' picture: textured torus, gold sphere, checker floor, HDR sky
        from bench.assets import clrender_settings, picture_scenes
        from clrender.scene.scene import Scene

        folder = Path(args.out, "assets_scene")
        folder.mkdir(exist_ok=True)
        scene = Scene.from_dict(picture_scenes(folder, *image_shape(args.scene, args.size), 1024)[0])
        settings = clrender_settings(args.spp)
    else:
        scene, settings = clrender_setup(args.scene, args.size, args.spp, 8)
    if args.scene != "whitted":
        settings["path_schedule"] = args.schedule
    first = Renderer(scene, seed=0, **settings)
    first.run()
    kernel = first.kernel.kernel  # the megakernel's cl.Kernel, or the lane schedule's Kernel of it
    obj = object_code(getattr(kernel, "kernel", kernel).program.binaries[0])
    code = elf_sections(obj or b"").get(".ltext")
    base = code and code_address(code)
    Path(args.out, "kernel.o").write_bytes(obj or b"")
    Path(args.out, "where.json").write_text(json.dumps({"base": base, "size": len(code or b"")}))
    for seed in range(1, args.renders + 1):
        Renderer(scene, seed=seed, tracer=first.tracer, **settings).run()


def code_address(code: bytes) -> int | None:
    """Where this process holds a copy of `code` (its first 48 bytes, which no relocation touches), or None."""
    with open("/proc/self/mem", "rb") as memory:
        for line in Path("/proc/self/maps").read_text().splitlines():
            lo, hi, perm = re.match(r"([0-9a-f]+)-([0-9a-f]+) (\S+)", line).groups()
            lo, hi = int(lo, 16), int(hi, 16)
            if "x" not in perm or hi - lo > 1 << 28:
                continue
            try:
                memory.seek(lo)
                at = memory.read(hi - lo).find(code[:48])
            except OSError:
                continue
            if at >= 0:
                return lo + at
    return None


def shares(samples: Counter, chains: dict) -> dict[str, Counter]:
    """Sample counts by summary group (GROUPS), inclusive function, innermost function, innermost file and innermost
    line, from the samples' code offsets and each offset's inline chain [(function, file:line:column), innermost first]."""
    out = {name: Counter() for name in ("group", "inclusive", "function", "file", "line")}
    for offset, n in samples.items():
        chain = chains.get(offset) or [("?", "?:0:0")]
        on_chain = {f for f, _ in chain}
        for function in on_chain:
            out["inclusive"][function] += n
        for what, functions in GROUPS:
            if on_chain.intersection(functions):
                out["group"][what] += n
        function, place = chain[0]
        out["function"][function] += n
        out["file"][Path(place.split(":")[0]).name] += n
        out["line"][Path(place.rsplit(":", 1)[0]).name] += n
    return out


def symbolize(obj: Path, offsets: list[int]) -> dict:
    """Each offset's inline chain, by llvm-symbolizer on the object."""
    text = subprocess.run(
        ["llvm-symbolizer", f"--obj={obj}", "--inlining"], input="\n".join(map(hex, offsets)) + "\n", capture_output=True, text=True, check=True
    ).stdout
    chains = {}
    for offset, block in zip(offsets, text.strip("\n").split("\n\n")):
        lines = block.split("\n")
        chains[offset] = [(lines[i], lines[i + 1]) for i in range(0, len(lines) - 1, 2)]
    return chains


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tools.kernel_profile", description=__doc__.split("\n")[0])
    scenes = ("cornell_box", "wizard_cat", "whitted", "assets")
    ap.add_argument(
        "--scene",
        choices=scenes,
        default="cornell_box",
        help="whitted: bench whitted's opaque wizard_cat; assets: bench assets' picture (--size wide)",
    )
    ap.add_argument("--schedule", choices=("megakernel", "lanes"), default="megakernel", help="the path tracer's schedule (docs/lanes.md)")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--renders", type=int, default=4, help="renders sampled after the first (default 4)")
    ap.add_argument("--top", type=int, default=25, help="rows a table (default 25)")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        args.out = args.child
        child(args)
        return 0
    missing = [tool for tool in ("perf", "llvm-symbolizer") if shutil.which(tool) is None]
    if missing:
        print(f"tools.kernel_profile needs {' and '.join(missing)} on PATH (Debian: linux-perf, llvm)", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp, "perf.data")
        forwarded = [
            "--scene",
            args.scene,
            "--schedule",
            args.schedule,
            "--size",
            str(args.size),
            "--spp",
            str(args.spp),
            "--renders",
            str(args.renders),
        ]
        run = [sys.executable, "-m", "tools.kernel_profile", *forwarded, "--child", tmp]
        subprocess.run(
            ["perf", "record", "-q", "-F", "4000", "-o", str(data), "--", *run], check=True, cwd=REPO, env={**os.environ, "PYOPENCL_NO_CACHE": "1"}
        )
        where = json.loads(Path(tmp, "where.json").read_text())
        if not where["base"]:
            print("the render kernel's code was not found in memory: this needs Intel's OpenCL CPU runtime (CLRENDER_DEVICE=intel)", file=sys.stderr)
            return 2
        ips = subprocess.run(["perf", "script", "-i", str(data), "-F", "ip"], capture_output=True, text=True, check=True).stdout.split()
        everything = Counter(int(ip, 16) for ip in ips)
        samples = Counter({ip - where["base"]: n for ip, n in everything.items() if 0 <= ip - where["base"] < where["size"]})
        tables = shares(samples, symbolize(Path(tmp, "kernel.o"), sorted(samples)))
    total = sum(samples.values())
    per_pixel = "36 samples a pixel (Whitted)" if args.scene == "whitted" else f"{args.spp} spp"
    shape = "{} x {}".format(*image_shape(args.scene, args.size))
    print(f"{args.scene}, {shape}, {per_pixel}, {args.renders} renders: {total} of {sum(everything.values())} samples in the render kernel")
    groups = tables.pop("group")
    for what, functions in GROUPS:
        print(f"  {100 * groups[what] / total:5.1f}%  {what} ({', '.join(functions)}, inclusive)")
    for title, counter in tables.items():
        print(f"\n{title}:")
        for name, n in counter.most_common(args.top):
            print(f"  {100 * n / total:5.1f}%  {name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
