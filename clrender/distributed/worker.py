"""What runs on a Dask worker: a per-process cache of built scenes, and the tasks.

Building a Tracer (flatten, BVH, upload) and compiling the kernels is the
expensive part of a small task, so each worker process keeps them in a
module-level cache keyed by the scene's content hash and the settings that
shape them; every later task for the same scene reuses them.  The device
follows `settings.device`, else the worker's own $CLRENDER_DEVICE, and PoCL's
thread count is whatever the worker's environment set before OpenCL started
(POCL_MAX_PTHREAD_COUNT / POCL_CPU_MAX_CU_NUM; see cluster.py).

A kernel object holds its arguments between `set_args` and the launch, so
two threads of one worker must not launch at once: one lock per process.
"""

from __future__ import annotations

import functools
import os
import threading
import time
from collections import OrderedDict
from dataclasses import replace

from ..errors import RenderFailure, UsageError
from ..trace.renderer import Renderer, RenderSettings, instancing_for
from ..trace.tracer import Tracer
from .payload import ScenePayload, code_fingerprint, join

TRACERS_KEPT = 4  # scenes (BVH + device buffers) a worker keeps
RENDERERS_KEPT = 16  # (scene, settings, camera) combinations a worker keeps

_LOCK = threading.RLock()
_SCENES: OrderedDict = OrderedDict()  # scene key -> Scene
_TRACERS: OrderedDict = OrderedDict()  # (scene key, bvh, builder, device) -> Tracer
_RENDERERS: OrderedDict = OrderedDict()  # (scene key, settings repr) -> Renderer


def task(fn):
    """A Dask task whose clrender errors reach the client as themselves: re-raised without their
    cause, since a chained pyopencl error does not pickle and Dask would send a generic
    Exception with the whole build log instead of the one-line error."""

    @functools.wraps(fn)
    def run(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except (UsageError, RenderFailure) as exc:
            plain = type(exc)(str(exc))
        raise plain  # outside the except block: no __context__ either

    return run


def _cached(cache: OrderedDict, key, build, keep: int):
    """cache[key], built on first use; the least recently used entries beyond `keep` are dropped."""
    value = cache.get(key)
    if value is None:
        value = build()
        cache[key] = value
        while len(cache) > keep:
            cache.popitem(last=False)
    cache.move_to_end(key)
    return value


def is_built(payload: ScenePayload, settings: RenderSettings) -> bool:
    return (payload.key, repr(settings), None) in _RENDERERS


def check_code(payload: ScenePayload) -> None:
    """Refuse to render for a client that runs other clrender code (the bytes would differ)."""
    if payload.code and payload.code != code_fingerprint():
        import socket

        raise RenderFailure(
            f"the worker on {socket.gethostname()} (pid {os.getpid()}) runs different clrender code "
            f"(fingerprint {code_fingerprint()}, the client's {payload.code}); install the same "
            "version on the client and every worker"
        )


def scene_of(payload: ScenePayload):
    return _cached(_SCENES, payload.key, lambda: join(payload), TRACERS_KEPT)


def tracer_for(payload: ScenePayload, settings: RenderSettings) -> Tracer:
    key = (payload.key, settings.bvh, settings.bvh_builder, settings.device, settings.instancing)

    def build() -> Tracer:
        scene = scene_of(payload)
        s = settings
        return Tracer(scene, use_bvh=s.bvh, builder=s.bvh_builder, device=s.device, instancing=instancing_for(scene, s))

    return _cached(_TRACERS, key, build, TRACERS_KEPT)


def renderer_for(payload: ScenePayload, settings: RenderSettings, scene=None) -> Renderer:
    """A Renderer for the scene (or `scene`, the same geometry with other cameras) and settings, built once."""
    key = (payload.key, repr(settings), None if scene is None else repr(scene.cameras))
    return _cached(_RENDERERS, key, lambda: Renderer(scene or scene_of(payload), settings, tracer=tracer_for(payload, settings)), RENDERERS_KEPT)


def _info(renderer: Renderer, start: float, ready: float, built: bool, cpu_ready: float) -> dict:
    """Where and how long a task ran: setup (scene, BVH, kernels; 0 when cached), compute wall and CPU seconds."""
    return {
        "pid": os.getpid(),
        "device": renderer.tracer.device.name,
        "setup": ready - start if built else 0.0,
        "compute": time.perf_counter() - ready,
        "compute_cpu": time.process_time() - cpu_ready,
        "bvh": renderer.tracer.bvh_seconds if built else 0.0,
        "compile_kernels": renderer.compile_seconds if built else 0.0,
    }


@task
def trace_pixels(payload: ScenePayload, settings: RenderSettings, pixels, sampler: str, n: int, record: bool, first_sample: int = 0):
    """One tile (or edge-pixel chunk, or a path-tracing pass's tile): what `Renderer.launch` returns, plus timing info."""
    check_code(payload)
    with _LOCK:
        start = time.perf_counter()
        built = not is_built(payload, settings)
        renderer = renderer_for(payload, settings)
        ready, cpu_ready = time.perf_counter(), time.process_time()
        out = renderer.launch(pixels, sampler, n, record, first_sample)
        return out, _info(renderer, start, ready, built, cpu_ready)


@task
def render_frame(payload: ScenePayload, settings: RenderSettings, camera):
    """One whole image with `camera` in place of the scene's cameras (a turntable frame)."""
    check_code(payload)
    with _LOCK:
        start = time.perf_counter()
        scene = replace(scene_of(payload), cameras=[camera])
        renderer = Renderer(scene, replace(settings, camera=1), tracer=tracer_for(payload, settings))
        ready, cpu_ready = time.perf_counter(), time.process_time()
        image = renderer.run().image
        return image, _info(renderer, start, ready, True, cpu_ready)


@task
def fit_gauss(target, config, device: str | None):
    """One Gaussian-splat fit on this worker's device (the local `fit`, nothing else)."""
    from ..device import get_device
    from ..splat.fit import fit

    with _LOCK:
        return fit(get_device(device), target, config)


@task
def splat_voronoi(image, settings, device: str | None):
    """One Voronoi splatting on this worker's device."""
    from ..device import get_device
    from ..splat.voronoi import splat

    with _LOCK:
        return splat(get_device(device), image, settings)
