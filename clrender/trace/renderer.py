"""Rendering an image: settings, tiles, and the edge-only anti-aliasing pipeline.

`render(scene, **settings)` returns a linear float32 (H, W, 3) image.
`Renderer(scene, settings).run()` returns a RenderResult with the object-id
and shadow buffers, the edge mask, timings and traversal statistics.

Work is launched per tile (a list of pixel indices), so tiles can later be
spread over processes or machines; the edge pass launches a compacted list
of only the masked pixels.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field, fields, replace

import numpy as np
import pyopencl as cl

from ..arena import alignment, offsets, pack
from ..device import compile_notice
from ..errors import UsageError, require, value_shown, warn
from ..layout import AOV_DTYPE, FRAME_PARAMS_DTYPE, ID_RECORD_DTYPE, LIGHT_DTYPE, OUT_REGIONS_DTYPE, PIXEL_FILTERS, SAMPLERS, WORLD_REGIONS_DTYPE
from ..layout import PATH_SCHEDULES as SCHEDULES  # the path tracer's schedules (RenderSettings.path_schedule)
from ..progress import progress
from ..scene.scene import Scene
from . import film, integrators
from .aov import AOV_NAMES
from .tracer import BUILDERS, Tracer
from .work_layout import global_size

AA_MODES = ("none", "full", "edge_detect")
# the Whitted tracer (the default), or unidirectional path tracing (kernels/path.cl): integrators.py
INTEGRATORS = tuple(integrators.INTEGRATORS)
MAX_SPP = 1 << 20  # paths per pixel in one pass
LIGHT_SAMPLERS = ("stratified", "random")
MAX_PIXELS = 1 << 26  # 67 M pixels: beyond this the host buffers alone need many GiB
KERNEL_AOVS = AOV_DTYPE.names  # the ones the render kernel's -DWRITE_AOV=1 variant writes: depth, normal, albedo
# The kernel's AOV record (layout.AOV_DTYPE) per pixel before the trace, what a miss leaves: depth 0 as Mitsuba's
# `aov` integrator writes it (renders never hold inf; the id AOV, -1 there, tells a miss from a hit), zero normal
# and albedo.
AOV_MISS = np.zeros(1, AOV_DTYPE)


@dataclass
class RenderSettings:
    width: int | None = None  # image width in pixels; None: the scene's (or kept to its aspect ratio from height)
    height: int | None = None  # image height in pixels; None: the scene's (or kept to its aspect ratio from width)
    camera: int = 1  # camera number, counting from 1 (1 is the canonical camera)
    integrator: str = "whitted"  # "whitted" (recursive Whitted ray tracing) or "path" (physically based: docs/materials.md)
    spp: int = 0  # path: paths per pixel per pass; 0: samples x samples
    time_budget: float | None = None  # path: whole-image passes of spp paths while this many seconds last; None: one pass
    aa: str = "none"  # anti-aliasing: "none", "full" or "edge_detect"
    sampler: str = "stratified"  # "uniform", "random", "stratified" or "sobol"
    samples: int = 1  # N: N x N samples per pixel when anti-aliasing
    pixel_filter: str = "box"  # how a pixel's samples are averaged: "box" (plain mean), "tent" or "gaussian"
    thickness: float = integrators.THICKNESS  # edge_detect: radius of the disc marked around each edge pixel
    shadow_edges: bool = True  # edge_detect: changes in light visibility count as edges
    contrast: float = 0.03  # edge_detect: a step above this between neighbours (sRGB, any channel) is an edge too; 0: IDs only
    light_samples: int = 0  # area-light samples per side for every light; 0 keeps each light's own
    light_sampler: str = "stratified"  # area-light samples: "stratified" (one jittered sample per cell of an n x n grid) or "random"
    max_depth: int = 8  # mirror/refraction bounces after the primary hit
    fresnel: bool = False  # split transparency by Schlick's Fresnel term instead of the fixed split by `transparency`
    seed: int = 0  # seeds every random choice; the same seed gives the same image
    bvh: bool = True  # False tests every primitive for every ray (the benchmark's baseline)
    bvh_builder: str = "sah"  # "sah" (binned surface-area heuristic) or "median" (object-median split)
    tile_size: int = 128  # tiles are tile_size x tile_size pixels per kernel launch
    device: str | None = None  # OpenCL device substring; None: $CLRENDER_DEVICE, else the fastest CPU driver
    aovs: tuple = ()  # extra outputs on RenderResult.aovs: any of "depth", "normal", "albedo", "id", "edges"
    # meshes that several objects place stored once and placed per hit (clrender/trace/instancing.py);
    # None: when that saves at least instancing.AUTO_MIN_TRIANGLES triangles (docs/bvh.md, "Instancing")
    instancing: bool | None = None
    rfilter: str = "box"  # path: the film's reconstruction filter, "box" (a pixel's own samples), "tent" or "gaussian" (trace/film.py)
    hide_emitters: bool = False  # path: camera rays look past emitting surfaces and area lights and see no environment (Mitsuba's)
    rr_depth: int | None = None  # path: Russian roulette from this many bounces after the primary hit; None: path.RR_DEPTH (3)
    path_sampler: str = "sobol"  # path: its random numbers, "sobol" (Owen-scrambled Sobol, kernels/sobol.h) or "independent" (hashed)
    # path: "lanes" (render_path_lanes, 16 or 8 paths a work-item in SIMD lanes on a CPU: trace/lane_schedule.py, the
    # megakernel where it does not apply), "megakernel" (render_path, a path per work-item) or "wavefront" (a kernel per
    # step: trace/wavefront.py); the same bits (docs/lanes.md)
    path_schedule: str = "lanes"

    def validate(self, scene: Scene) -> RenderSettings:
        """A copy with the image size filled in and every number a Python int or float; UsageError for any
        value of the wrong type or out of range (the command line's checks are these, so both say the same),
        then a RenderWarning for each value that changes nothing (see `pointless`)."""
        v = value_shown
        for name in ("width", "height"):
            value = getattr(self, name)
            require(value is None or _whole(value), f"{name} {v(value)} must be a whole number >= 1, or None for the scene's")
        require(_whole(self.camera), f"camera {v(self.camera)} must be a whole number (1 is the scene's first camera)")
        # ints from here on: numpy's int32 would wrap width * height past the pixel limit
        width, height = (None if x is None else int(x) for x in (self.width, self.height))
        # one side given: the other keeps the scene's aspect ratio (width 100 alone is not a 100x360 sliver)
        if width is not None and height is None:
            height = max(1, round(width * scene.height / scene.width))
        elif height is not None and width is None:
            width = max(1, round(height * scene.width / scene.height))
        s = replace(self, width=scene.width if width is None else width, height=scene.height if height is None else height, camera=int(self.camera))
        require(s.width >= 1 and s.height >= 1, f"image size {s.width}x{s.height} must be at least 1x1")
        require(s.width * s.height <= MAX_PIXELS, f"image size {s.width}x{s.height} is too large; at most {MAX_PIXELS} pixels")
        require(_name_in(s.aa, AA_MODES), f"unknown anti-aliasing mode {v(s.aa)}; allowed: {', '.join(AA_MODES)}")
        require(_name_in(s.integrator, INTEGRATORS), f"unknown integrator {v(s.integrator)}; allowed: {', '.join(INTEGRATORS)}")
        require(_whole(s.spp) and 0 <= s.spp <= MAX_SPP, f"spp {v(s.spp)} must be a whole number from 0 (samples x samples) to {MAX_SPP}")
        require(
            s.time_budget is None or (_real(s.time_budget) and math.isfinite(s.time_budget) and s.time_budget > 0),
            f"time budget {v(s.time_budget)} must be a number of seconds > 0, or None",
        )
        require(_name_in(s.sampler, SAMPLERS), f"unknown sampler {v(s.sampler)}; allowed: {', '.join(SAMPLERS)}")
        require(_name_in(s.pixel_filter, PIXEL_FILTERS), f"unknown pixel filter {v(s.pixel_filter)}; allowed: {', '.join(PIXEL_FILTERS)}")
        require(_name_in(s.rfilter, film.FILTERS), f"unknown reconstruction filter {v(s.rfilter)}; allowed: {', '.join(film.FILTERS)}")
        kind = integrators.integrator_type(s.integrator)
        kind.check(s)
        require(s.rfilter == "box" or s.pixel_filter == "box", f"give --rfilter {s.rfilter} or --pixel-filter {s.pixel_filter}, not both")
        require(_whole(s.samples) and 1 <= s.samples <= 64, f"samples {v(s.samples)} must be an integer from 1 to 64 (N x N per pixel)")
        require(_real(s.thickness) and math.isfinite(s.thickness) and s.thickness >= 0, f"thickness {v(s.thickness)} must be a real number >= 0")
        require(_real(s.contrast) and math.isfinite(s.contrast) and s.contrast >= 0, f"contrast {v(s.contrast)} must be a real number >= 0 (0: off)")
        require(_whole(s.light_samples) and 0 <= s.light_samples <= 64, f"light samples {v(s.light_samples)} must be from 0 (each light's own) to 64")
        require(_name_in(s.light_sampler, LIGHT_SAMPLERS), f"unknown light sampler {v(s.light_sampler)}; allowed: {', '.join(LIGHT_SAMPLERS)}")
        paths = integrators.PATH_SAMPLERS
        require(_name_in(s.path_sampler, paths), f"unknown path sampler {v(s.path_sampler)}; allowed: {', '.join(paths)}")
        require(_name_in(s.path_schedule, SCHEDULES), f"unknown path schedule {v(s.path_schedule)}; allowed: {', '.join(SCHEDULES)}")
        depth_limit = kind.depth_limit
        require(_whole(s.max_depth) and 0 <= s.max_depth <= depth_limit, f"max depth {v(s.max_depth)} must be from 0 to {depth_limit}")
        require(
            s.rr_depth is None or (_whole(s.rr_depth) and 0 <= s.rr_depth <= integrators.PATH_DEPTH_LIMIT),
            f"rr depth {v(s.rr_depth)} must be from 0 to {integrators.PATH_DEPTH_LIMIT}, or None for the path tracer's own",
        )
        require(_name_in(s.bvh_builder, BUILDERS), f"unknown BVH builder {v(s.bvh_builder)}; allowed: {', '.join(BUILDERS)}")
        require(_whole(s.seed) and 0 <= s.seed < 2**32, f"seed {v(s.seed)} must be from 0 to 2**32-1")
        require(_whole(s.tile_size) and s.tile_size >= 1, f"tile size {v(s.tile_size)} must be a whole number >= 1")
        for name in ("shadow_edges", "fresnel", "bvh", "hide_emitters"):
            require(isinstance(getattr(s, name), (bool, np.bool_)), f"{name} {v(getattr(s, name))} must be True or False")
        require(
            s.instancing is None or isinstance(s.instancing, (bool, np.bool_)),
            f"instancing {v(s.instancing)} must be True, False or None (automatic)",
        )
        require(s.device is None or isinstance(s.device, str), f"device {v(s.device)} must be a device name (a string) or None")
        require(
            isinstance(s.aovs, (tuple, list)) and all(_name_in(a, AOV_NAMES) for a in s.aovs),
            f"aovs {v(s.aovs)} must be a tuple of names from: {', '.join(AOV_NAMES)}",
        )
        camera = scene.camera(s.camera)
        # edge-only AA gives a pixel away from object edges one ray: behind a lens that is one point of the
        # lens, so a blurred region would be noise; every pixel needs its N x N lens samples
        require(
            not (s.aa == "edge_detect" and camera.aperture > 0),
            f"--aa edge_detect needs a pinhole camera, and camera {s.camera} has aperture {camera.aperture:g} "
            "(a thin lens blurs every pixel away from the focal plane); use --aa full",
        )
        s = replace(
            s,
            **{k: int(getattr(s, k)) for k in ("samples", "spp", "light_samples", "max_depth", "seed", "tile_size")},
            time_budget=None if s.time_budget is None else float(s.time_budget),
            **{k: float(getattr(s, k)) for k in ("thickness", "contrast")},
            **{k: bool(getattr(s, k)) for k in ("shadow_edges", "fresnel", "bvh", "hide_emitters")},
            rr_depth=None if s.rr_depth is None else int(s.rr_depth),
        )
        if not _on_a_dask_worker():  # a worker re-checks the client's settings: the client has warned already
            for message in s.pointless(scene):
                warn(message)
        return s

    def pointless(self, scene: Scene) -> list[str]:
        """What these (valid) settings ask for that changes nothing, or that renders only darkness, in words: each
        integrator's judgement (integrators.py), e.g. `samples` other than 1 with aa "none", `thickness` other than
        its default without aa "edge_detect" or the edges AOV, a scene without lights."""
        return integrators.integrator_type(self.integrator).pointless(self, scene)


def _whole(value) -> bool:
    """An integer (Python's or numpy's), never a bool nor a float that happens to be whole."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def _real(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def _name_in(value, names) -> bool:
    """`value` is one of `names` (a string: a list or dict would not hash, and 0 is no name)."""
    return isinstance(value, str) and value in names


def _on_a_dask_worker() -> bool:
    """Inside a task on a Dask worker (looked up only when distributed is loaded: nothing is imported for it)."""
    distributed = sys.modules.get("distributed")
    if distributed is None:
        return False
    try:
        distributed.get_worker()
    except ValueError:
        return False
    return True


@dataclass
class RenderResult:
    image: np.ndarray  # (H, W, 3) float32 linear RGB
    path_ids: np.ndarray  # (H, W, PATH_LEN) int32 object ids along each pixel's path, -1 past its end
    facets: np.ndarray  # (H, W) int32 primitive id of the primary hit on a flat-shaded mesh, else -1
    shadow: np.ndarray  # (H, W, L) float32 visible fraction of each light at the primary hit
    edge_mask: np.ndarray | None  # (H, W) bool pixels resampled by edge-only AA
    # seconds: "bvh", the other setup phases ("attributes", "textures", "geometry", "upload", "emitters"), "compile",
    # "trace", "edges", "resample"
    timings: dict = field(default_factory=dict)
    node_visits: int = 0  # BVH nodes visited (or primitives tested without a BVH), all rays
    rays: int = 0  # rays traced (camera, reflected, refracted, shadow)
    aovs: dict = field(default_factory=dict)  # name -> (H, W[, 3]) array for each of settings.aovs (clrender/trace/aov.py)
    samples_per_pixel: int = 0  # path integrator: paths per pixel over all passes (0 for Whitted renders)
    passes: int = 0  # path integrator: whole-image passes run (more than one only under a time budget)

    @property
    def ids(self) -> np.ndarray:
        """Object id of the primary hit per pixel (-1: background)."""
        return self.path_ids[..., 0]

    @property
    def resampled_fraction(self) -> float:
        return float(self.edge_mask.mean()) if self.edge_mask is not None else 0.0

    def _repr_png_(self) -> bytes:
        """The image inline in Jupyter (sRGB 8-bit); clrender.show(result.edge_mask) shows the mask."""
        from ..image.display import png_bytes

        return png_bytes(self.image, linear=True)

    def srgb8(self, exposure: float = 0.0, tonemap: str = "clamp") -> np.ndarray:
        """(H, W, 3) uint8 sRGB codes of the image after the display transform (clrender/image/tonemap.py):
        2**exposure times the linear image, then the tone curve ("clamp", "aces" or "agx"), as a PNG stores it."""
        from ..image.files import DisplaySettings, srgb8

        return srgb8(self.image, DisplaySettings(exposure=exposure, tonemap=tonemap))

    def save(self, path, exposure: float = 0.0, tonemap: str = "clamp", overwrite: bool = True):
        """Write the image: EXR, HDR and PFM scene-linear, PNG/JPEG after the display transform
        (as srgb8); returns the path written."""
        from ..image.files import DisplaySettings, write_display_image

        return write_display_image(path, self.image, overwrite=overwrite, display=DisplaySettings(exposure=exposure, tonemap=tonemap))


class Renderer:
    def __init__(self, scene, settings: RenderSettings | None = None, tracer: Tracer | None = None, **overrides):
        self.scene = Scene.load(scene) if not isinstance(scene, Scene) else scene
        self.settings = settings_with(settings, overrides).validate(self.scene)
        s = self.settings
        self.tracer = tracer or Tracer(self.scene, use_bvh=s.bvh, builder=s.bvh_builder, device=s.device, instancing=instancing_for(self.scene, s))
        self.tracer.upload_shading()  # the shading's records: a Tracer made for queries holds none
        dev = self.tracer.device
        self.setup_seconds = {}  # "upload" (camera, lights, environment map and its distribution), "emitters" (path)
        self.integrator = integrators.make_integrator(s.integrator, self)
        extra = self.integrator.world()  # its arrays of the world arena (the path tracer's emitters)
        start = time.perf_counter()
        self.camera = self.scene.camera(s.camera).frame(s.width, s.height)  # the FrameParams' Camera record
        self.n_lights = len(self.scene.lights)
        lights = np.array([light.pack() for light in self.scene.lights] or [np.zeros((), LIGHT_DTYPE)], LIGHT_DTYPE)
        from .envmap import arrays

        self.env_map, env = arrays(self.scene.environment_map)  # the EnvMap record (width 0 without a map) and its arrays
        self.world = pack(dev, WORLD_REGIONS_DTYPE, dict(lights=lights, **env, **extra))
        self.setup_seconds["upload"] = time.perf_counter() - start
        self.write_aov = any(a in KERNEL_AOVS for a in s.aovs)
        self.align = alignment(dev)
        self.variant = self.integrator.variant(self.tracer.variant.rendering(self.scene, self.write_aov))  # its -D defines
        start = time.perf_counter()
        with compile_notice(dev):  # a line on stderr when the build is slow (a cold cache)
            self.kernel = self.integrator.make_kernel(dev, self.variant)  # render_path, or the wavefront schedule's loop
            self.launch(np.zeros(1, np.int32), "uniform", 1, True)  # PoCL finishes compiling on first launch
        self.compile_seconds = time.perf_counter() - start

    def frame(self, k: int, sampler: str, n: int, record: bool, out_regions: np.ndarray | None = None) -> np.ndarray:
        """A launch's FrameParams record (layout.FRAME_PARAMS_DTYPE): k pixels of n x n samples by `sampler`, the first
        sample's ids, shadows and AOVs written when `record`, the outputs at `out_regions` (OutRegions)."""
        s, t = self.settings, self.tracer
        f = np.zeros((), FRAME_PARAMS_DTYPE)
        f["camera"], f["env_map"], f["tables"], f["world"] = self.camera, self.env_map, t.tables.record, self.world.record
        if out_regions is not None:
            f["out"] = out_regions
        f["n_work"], f["width"], f["height"] = k, s.width, s.height
        f["sampler"], f["samples_per_side"], f["pixel_filter"] = SAMPLERS[sampler], n, PIXEL_FILTERS[s.pixel_filter]
        f["seed"], f["max_depth"], f["record"] = s.seed, s.max_depth, record
        f["n_lights"], f["n_prims"], f["n_instances"] = self.n_lights, t.n_prims, t.n_instances
        return f

    def _outputs(self, k: int, record: bool):
        """One launch's output arena (uninitialised but for what the kernel may leave unwritten) and its OutRegions."""
        dev, L = self.tracer.device, max(self.n_lights, 1)
        aov_records = k if record and self.write_aov else 1
        sizes = dict(colour=k * 16 * self.integrator.colour_slots, ids=k * ID_RECORD_DTYPE.itemsize, shadow=k * 4 * L, stats=k * 8)
        regions, total = offsets(OUT_REGIONS_DTYPE, {**sizes, "aov": aov_records * AOV_DTYPE.itemsize}, self.align)
        out = dev.empty(total)
        if record:  # background pixels never write their shadow entries (the path tracer none): all lights visible
            cl.enqueue_fill_buffer(dev.queue, out, np.float32(1.0), int(regions["shadow"]), k * 4 * L)
        if record and self.write_aov:
            cl.enqueue_fill_buffer(dev.queue, out, AOV_MISS, int(regions["aov"]), k * AOV_DTYPE.itemsize)
        self.integrator.clear(dev, out, regions, k, record)
        return out, regions

    def launch(self, pixels: np.ndarray, sampler: str, n: int, record: bool, first_sample: int = 0):
        """Trace the given pixel indices: colours (k, 3), id records (k,) of layout.ID_RECORD_DTYPE, shadow (k, L), stats (k, 2),
        and with AOVs on and `record`, the primary hits' AOV records (k,) of layout.AOV_DTYPE, else None.
        The path integrator's colours are (k, 4): each pixel's filtered mean, then its filter weight; its samples
        are first_sample ... first_sample + spp - 1 of each pixel's sequence (sampler and n are the settings')."""
        t, dev = self.tracer, self.tracer.device
        k, slots = len(pixels), self.integrator.colour_slots
        out, regions = self._outputs(k, record)
        params = self.integrator.params(self.frame(k, sampler, n, record, regions), first_sample)
        local = t.layout.local_size
        pixels = dev.to_device(pixels.astype(np.int32))
        self.kernel(dev.queue, global_size(k, local), (local,), **t.render_buffers(), world=self.world.buffer, pixels=pixels, params=params, out=out)
        host = dict(
            colour=np.empty((k, 4) if slots == 1 else (k, slots, 4), np.float32),
            ids=np.empty(k, ID_RECORD_DTYPE),
            shadow=np.empty((k, max(self.n_lights, 1)), np.float32),
            stats=np.empty((k, 2), np.uint32),
            aov=np.empty(k, AOV_DTYPE) if record and self.write_aov else None,
        )
        for name, array in host.items():
            if array is not None:
                cl.enqueue_copy(dev.queue, array, out, src_offset=int(regions[name]))
        return self.integrator.colour(host["colour"]), host["ids"], host["shadow"][:, : self.n_lights], host["stats"], host["aov"]

    def _pass(self, pixel_lists, sampler, n, record, desc, first_sample=0):
        """Trace each pixel list in turn; returns the concatenated outputs."""
        parts = [self.launch(p, sampler, n, record, first_sample) for p in progress(pixel_lists, desc=desc, unit="tile")]
        return [np.concatenate(x) if x[0] is not None else None for x in zip(*parts)]

    def tiles(self):
        """Pixel-index lists of the image's tiles, row-major within and between tiles."""
        s = self.settings
        ts = s.tile_size
        for y0 in range(0, s.height, ts):
            for x0 in range(0, s.width, ts):
                ys, xs = np.mgrid[y0 : min(y0 + ts, s.height), x0 : min(x0 + ts, s.width)]
                yield (ys * s.width + xs).ravel()

    @property
    def spp(self) -> int:
        """Paths per pixel in one pass of the path integrator."""
        return self.integrator.spp

    def run(self) -> RenderResult:
        s = self.settings
        H, W = s.height, s.width
        # every setup phase (docs/command-line.md, "Timings"): the tracer's and the renderer's, then the kernels' compile
        timings = {"bvh": self.tracer.bvh_seconds, **self.tracer.setup_seconds, **self.setup_seconds, "compile": self.compile_seconds}
        tiles = list(self.tiles())
        order = np.concatenate(tiles)
        start = time.perf_counter()
        (colour, ids, shadow, stats, aov), passes = self.integrator.trace(tiles)
        timings["trace"] = time.perf_counter() - start
        image = np.empty((H * W, 3), np.float32)
        records = np.empty(H * W, ID_RECORD_DTYPE)
        shadows = np.empty((H * W, self.n_lights), np.float32)
        image[order], records[order], shadows[order] = colour, ids, shadow
        visits, rays = stats.sum(axis=0, dtype=np.int64)
        records = records.reshape(H, W)
        result = RenderResult(
            image.reshape(H, W, 3), records["path"], records["facet"], shadows.reshape(H, W, self.n_lights), None, timings, int(visits), int(rays)
        )
        result.samples_per_pixel, result.passes = self.integrator.samples_per_pixel(passes), passes
        if s.aa == "edge_detect":
            self._resample_edges(result)
        if s.aovs:
            records = None
            if aov is not None:
                records = np.empty(H * W, AOV_DTYPE)
                records[order] = aov
                records = records.reshape(H, W)
            result.aovs = self._aovs(result, records)
        return result

    def _aovs(self, result: RenderResult, records) -> dict:
        """The requested AOVs, all from the ray the ids come from (see clrender/trace/aov.py)."""
        s = self.settings
        out = {}
        for name in s.aovs:
            if name in KERNEL_AOVS:  # a field of the kernel's AOV records
                out[name] = np.ascontiguousarray(records[name])
            elif name == "id":
                out[name] = result.ids.copy()
            elif name == "edges":
                out[name] = result.edge_mask if result.edge_mask is not None else self._edge_mask(result)
        return out

    def _edge_mask(self, result: RenderResult) -> np.ndarray:
        """The mask edge-only AA would resample, for renders that did not run it."""
        from ..image.files import linear_to_srgb
        from .edges import edge_mask

        s = self.settings
        # a change of facet on a flat-shaded mesh is a shading edge too
        ids = np.concatenate([result.path_ids, result.facets[..., None]], axis=-1)
        return edge_mask(ids, s.thickness, result.shadow if self.n_lights else None, s.shadow_edges, linear_to_srgb(result.image), s.contrast)

    def _resample_edges(self, result: RenderResult):
        """Pass 2 of edge-only AA: re-render just the masked pixels with the chosen sampler."""
        s = self.settings
        start = time.perf_counter()
        mask = self._edge_mask(result)
        result.timings["edges"] = time.perf_counter() - start
        result.edge_mask = mask
        pixels = np.flatnonzero(mask.ravel())
        chunk = s.tile_size * s.tile_size
        start = time.perf_counter()
        if len(pixels):
            chunks = [pixels[i : i + chunk] for i in range(0, len(pixels), chunk)]
            colour, _, _, stats, _ = self._pass(chunks, s.sampler, s.samples, False, "edges")
            result.image.reshape(-1, 3)[pixels] = colour
            visits, rays = stats.sum(axis=0, dtype=np.int64)
            result.node_visits += int(visits)
            result.rays += int(rays)
        result.timings["resample"] = time.perf_counter() - start


def settings_with(settings, overrides: dict) -> RenderSettings:
    """`settings` (a RenderSettings or None for the defaults) with the keyword overrides; UsageError for anything else."""
    if not (settings is None or isinstance(settings, RenderSettings)):
        raise UsageError(f"settings {value_shown(settings)} is not allowed; allowed: a clrender.RenderSettings or None (keywords set single values)")
    names = [f.name for f in fields(RenderSettings)]
    unknown = [k for k in overrides if k not in names]
    if unknown:
        raise UsageError(f"unknown render setting {unknown[0]!r}; allowed: {', '.join(names)}")
    return replace(settings or RenderSettings(), **overrides)


def instancing_for(scene: Scene, settings: RenderSettings) -> bool:
    """Whether the Tracer of a render stores repeated meshes once: settings.instancing, or when None, whether that
    saves at least instancing.AUTO_MIN_TRIANGLES triangles (the same answer on every machine of a Dask render)."""
    from .instancing import worth_instancing

    return worth_instancing(scene) if settings.instancing is None else bool(settings.instancing)


def render(scene, settings: RenderSettings | None = None, **overrides) -> np.ndarray:
    """Render `scene` (a Scene, bundled name, path or dict) to a linear float32 (H, W, 3) image."""
    return Renderer(scene, settings, **overrides).run().image
