"""Rendering on a Dask cluster: the same images, byte for byte, spread over many processes or machines.

    from dask.distributed import Client, LocalCluster
    import clrender.distributed as crd

    with Client(LocalCluster(n_workers=2, threads_per_worker=1)) as client:
        image = crd.render("refract1", client=client, aa="edge_detect", samples=4)
        frames = crd.turntable("refract1", frames=36, client=client)

Tiles (and edge-only AA's compacted edge-pixel chunks) are tasks; the image
is assembled on the client by the very code the local Renderer uses
(`Renderer.run` with its tile pass swapped), and every random choice is a
hash of (seed, pixel, sample), so where a tile runs does not change a bit.
The scene travels as a dict plus its mesh arrays, scattered once
(payload.py); workers build its Tracer and kernels once (worker.py).
Needs the extra: pip install 'clrender[distributed]'.
"""

from __future__ import annotations

import time
import uuid
from dataclasses import dataclass, field, replace

import numpy as np

from ..progress import progress
from ..scene.scene import Scene
from ..trace.integrators import make_integrator
from ..trace.renderer import Renderer, RenderResult, RenderSettings
from . import worker
from .cluster import INSTALL_HINT, connect, require_dask
from .deadlines import Deadlines
from .payload import ScenePayload, join, split
from .waiting import collect, release, scatter

__all__ = [
    "DistributedRenderer",
    "render",
    "run",
    "turntable",
    "iter_turntable",
    "connect",
    "split",
    "join",
    "ScenePayload",
    "Deadlines",
    "INSTALL_HINT",
]


@dataclass
class _SceneSummary:
    """What the CLI reports about the tracer, without building one on the client."""

    n_prims: int
    bvh_seconds: float = 0.0
    setup_seconds: dict = field(default_factory=dict)  # the workers' setup phases are not sent back


def _client(client):
    if client is not None:
        return client
    distributed = require_dask()
    try:
        return distributed.get_client()
    except ValueError:
        from ..errors import UsageError

        raise UsageError("no Dask client: pass client=..., or create a dask.distributed.Client first") from None


class DistributedRenderer(Renderer):
    """A Renderer whose tile and edge-pixel passes run as tasks on a Dask cluster.

    `run()` is the local Renderer's own: only `_pass` (trace a list of pixel
    lists) is replaced, so the assembly, the edge mask and the result are
    the same code and the same bytes.  The client builds nothing on a device.
    """

    def __init__(self, scene, settings: RenderSettings | None = None, client=None, deadlines: Deadlines | None = None, **overrides):
        self.scene = Scene.load(scene)
        self.deadlines = deadlines  # None: the defaults (clrender.distributed.deadlines.current)
        self.settings = replace(settings or RenderSettings(), **overrides).validate(self.scene)
        self.client = _client(client)
        self.n_lights = len(self.scene.lights)
        self.integrator = make_integrator(self.settings.integrator, self)  # its passes, by this _pass
        self.tracer = _SceneSummary(n_prims=self.scene.triangle_count + self.scene.sphere_count)
        self.compile_seconds = 0.0
        self.setup_seconds = {}
        self.payload = split(self.scene)
        self.task_log: list[dict] = []  # one entry per finished task: worker pid, setup and compute seconds
        self.first_result_seconds = None  # from run() to the first tile back on the client
        self._scattered = None
        self._started = None

    def _scene_future(self):
        if self._scattered is None:  # sent once to every worker, shared by every task
            self._scattered = scatter(self.client, self.payload, broadcast=True, deadlines=self.deadlines)
        return self._scattered

    def _pass(self, pixel_lists, sampler, n, record, desc, first_sample=0):
        payload = self._scene_future()
        token = uuid.uuid4().hex[:12]
        futures = [
            self.client.submit(
                worker.trace_pixels,
                payload,
                self.settings,
                p.astype(np.int32),
                sampler,
                n,
                record,
                first_sample,
                key=f"clrender-{desc.replace(' ', '-')}-{token}-{i}",
            )
            for i, p in enumerate(pixel_lists)
        ]
        parts = [None] * len(futures)
        try:
            with progress(total=len(futures), desc=desc, unit="task") as bar:
                for i, (out, info) in collect(self.client, futures, desc, self.deadlines):
                    parts[i] = out
                    info.update(index=i, task=desc, received=time.perf_counter())
                    self.task_log.append(info)
                    if self.first_result_seconds is None:
                        self.first_result_seconds = info["received"] - self._started
                    bar.update()
        except BaseException:  # Ctrl-C or a failed task: nothing else should keep running for us
            release(futures)
            raise
        # as Renderer._pass: outputs a pass does not produce (AOVs off) stay None
        return [np.concatenate(x) if x[0] is not None else None for x in zip(*parts)]

    def run(self) -> RenderResult:
        self._started = time.perf_counter()
        try:
            result = super().run()
        finally:
            if self._scattered is not None:
                release([self._scattered])
                self._scattered = None
        built = [t for t in self.task_log if t["setup"] > 0]
        result.timings["bvh"] = max((t["bvh"] for t in built), default=0.0)
        result.timings["compile"] = max((t["compile_kernels"] for t in built), default=0.0)
        result.timings["first_result"] = self.first_result_seconds or 0.0
        return result


def run(scene, settings: RenderSettings | None = None, client=None, deadlines: Deadlines | None = None, **overrides) -> RenderResult:
    """`Renderer(scene, settings).run()` on a Dask cluster: the same RenderResult."""
    return DistributedRenderer(scene, settings, client, deadlines, **overrides).run()


def render(scene, settings: RenderSettings | None = None, client=None, deadlines: Deadlines | None = None, **overrides) -> np.ndarray:
    """`clrender.render` on a Dask cluster: the same linear float32 (H, W, 3) image, bit for bit."""
    return run(scene, settings, client, deadlines, **overrides).image


def iter_turntable(scene, settings: RenderSettings | None = None, frames: int = 36, client=None, deadlines: Deadlines | None = None, **overrides):
    """Yield (k, image) for each turntable frame as it finishes (any order); one task per frame."""
    from ..trace.turntable import orbit

    client = _client(client)
    scene = Scene.load(scene)
    settings = replace(settings or RenderSettings(), **overrides).validate(scene)
    cameras = orbit(scene.camera(settings.camera), frames)
    payload = scatter(client, split(scene), broadcast=True, deadlines=deadlines)
    token = uuid.uuid4().hex[:12]
    futures = [client.submit(worker.render_frame, payload, settings, camera, key=f"clrender-frame-{token}-{k}") for k, camera in enumerate(cameras)]
    try:
        for k, (image, _info) in collect(client, futures, "frame", deadlines):
            yield k, image
    finally:  # also on Ctrl-C, an error, or the caller stopping early
        release(futures + [payload])


def turntable(scene, settings: RenderSettings | None = None, frames: int = 36, client=None, deadlines: Deadlines | None = None, **overrides) -> list:
    """The turntable's frames in order, as `clrender.trace.turntable.render_turntable` gives them locally."""
    images = [None] * frames
    with progress(total=frames, desc="frames", unit="frame") as bar:
        for k, image in iter_turntable(scene, settings, frames, client, deadlines, **overrides):
            images[k] = image
            bar.update()
    return images


def __getattr__(name):  # submodules load on first use: clrender.distributed.X after a plain `import clrender`
    from .. import _submodule

    return _submodule(__name__, name)
