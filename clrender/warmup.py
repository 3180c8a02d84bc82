"""Every kernel variant a render can build, compiled ahead of time: `clrender warmup` or `python -m clrender.warmup`.

A render builds its kernels from kernels/*.cl with -D defines (clrender/device.py), once a process, and
pyopencl keeps the binaries on disk, so only the first render of each variant waits for the compiler
(10 to 60 s each on a CPU runtime).  CI images and cluster nodes run this once to fill that cache.

The variants are the combinations a render can reach, each a trace/variant.py Variant as the Tracer and the
renderer make it, with the device's work layout:
- the Tracer: with or without a BVH; flat, instanced, or instanced with a wide top tree (BVH only);
- each integrator's render kernel for each of those, with or without AOV writes, alpha testing and back-face
  culling, as a render under the default settings builds it (Integrator.warm_variant): trace.cl `render`, and
  path.cl's `render_path_lanes` where the device takes lanes and the build does not fall back, else `render_path`
  (the box film, the Sobol sampler);
- the ray queries' build of trace.cl (the Tracer's defines alone) for each Tracer variant;
- the BVH builder (bvh_build.cl).
"""

from __future__ import annotations

import itertools
import sys
import time
from dataclasses import replace

from .device import Device
from .trace.variant import Variant

# (use_bvh, instanced, top_wide): the Tracer states; a wide top tree needs a BVH (Tracer._top)
TRACER_STATES = ((True, False, False), (True, True, False), (True, True, True), (False, False, False), (False, True, False))


def variants(device: Device) -> list[Variant]:
    """Every variant a render on `device` can build, in the order warmup compiles them."""
    from .trace.integrators import INTEGRATORS
    from .trace.renderer import RenderSettings
    from .trace.work_layout import work_layout

    rays_per_item, defaults = work_layout(device.device).rays_per_item, RenderSettings()
    out = [Variant("bvh_build.cl", tracing=False, extra=tuple(sorted(bvh_build_defines().items())), label="bvh builder")]
    for use_bvh, instanced, top_wide in TRACER_STATES:
        tracer = Variant(use_bvh=use_bvh, instanced=instanced, top_wide=top_wide, rays_per_item=rays_per_item)
        shape = f"{'bvh' if use_bvh else 'no bvh'}, {'flat' if not instanced else 'instanced, wide top' if top_wide else 'instanced'}"
        out.append(replace(tracer, label=f"ray queries, {shape}"))
        for integrator, kind in INTEGRATORS.items():
            for aov, alpha, cull in itertools.product((False, True), repeat=3):
                flags = ", ".join(word for word, on in (("aovs", aov), ("alpha test", alpha), ("back-face culling", cull)) if on) or "plain"
                render = kind.warm_variant(replace(tracer, render=True, write_aov=aov, alpha_test=alpha, cull_backfaces=cull), device, defaults)
                out.append(replace(render, label=f"{integrator}, {shape}, {flags}"))
    return out


def bvh_build_defines() -> dict:
    """The -D defines trace/bvh.py's device builder uses (its default bin count)."""
    import inspect

    from .trace import bvh

    bins = inspect.signature(bvh.build_bvh).parameters["bins"].default
    return dict(BINS=bins, BUILD_STACK=bvh.BUILD_STACK)


def warm(device: Device, chosen: list[Variant], out=None, jobs: int = 1, spec: str | None = None) -> list[tuple[Variant, float]]:
    """Build each variant (from pyopencl's cache when it has it), with a progress bar; print and return its seconds.

    A driver's compiler runs on one core, so with `jobs` > 1 the variants are built by that many fresh
    processes at once (`spec`: the --device they open, the one `device` was made from). They fill
    pyopencl's cache on disk, from which `device` then loads each program in a fraction of a second;
    the seconds are then the processes' build times."""
    from .progress import progress

    built = _build_in_processes(chosen, jobs, spec) if jobs > 1 and len(chosen) > 1 else []
    seconds = []
    for i, variant in enumerate(chosen if built else progress(chosen, desc="compiling", unit="variant")):
        start = time.perf_counter()
        variant.build(device)
        took = built[i] if built else time.perf_counter() - start
        seconds.append((variant, took))
        print(f"{took:7.2f}s  {variant.label}", file=out or sys.stdout, flush=True)
    return seconds


def _build_in_processes(chosen: list[Variant], jobs: int, spec: str | None) -> list[float]:
    """Build `chosen` in `jobs` spawned processes (a fork would inherit the parent's OpenCL state); each one's seconds."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    from .progress import progress

    with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = {pool.submit(_build_one, spec, variant): i for i, variant in enumerate(chosen)}
        seconds = [0.0] * len(chosen)
        for future in progress(as_completed(futures), total=len(futures), desc=f"compiling on {jobs} processes", unit="variant"):
            seconds[futures[future]] = future.result()
        return seconds


def _build_one(spec: str | None, variant: Variant) -> float:
    from .device import get_device

    start = time.perf_counter()
    variant.build(get_device(spec))
    return time.perf_counter() - start


if __name__ == "__main__":  # python -m clrender.warmup [options]: the same as `clrender warmup [options]`
    import importlib  # the command line by name: run as a script only, so the library imports nothing of it

    sys.exit(importlib.import_module("clrender.cli").main(["warmup", *sys.argv[1:]]))
