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

from ..device import compile_notice
from ..errors import UsageError, require, value_shown, warn
from ..layout import AOV_DTYPE, ID_RECORD_DTYPE, LIGHT_DTYPE, PIXEL_FILTERS, RENDER_PARAMS_DTYPE, SAMPLERS
from ..progress import progress
from ..scene.scene import Scene
from . import film
from .aov import AOV_NAMES
from .tracer import BUILDERS, MAX_DEPTH_LIMIT, Tracer, global_size

AA_MODES = ("none", "full", "edge_detect")
INTEGRATORS = ("whitted", "path")  # the seed's Whitted tracer (the default), or unidirectional path tracing (kernels/path.cl)
MAX_SPP = 1 << 20  # paths per pixel in one pass
# a pixel's paths are numbered by a 32-bit counter (the kernels' random numbers are keyed by it): --time-budget
# stops before a pass would number a path past it (2**32 paths a pixel, 4096 passes at MAX_SPP)
SAMPLE_INDEX_LIMIT = 1 << 32
PATH_DEPTH_LIMIT = 1024  # bounces of a path (Russian roulette ends most much sooner)
LIGHT_SAMPLERS = ("stratified", "random")
MAX_PIXELS = 1 << 26  # 67 M pixels: beyond this the host buffers alone need many GiB
KERNEL_AOVS = AOV_DTYPE.names  # the ones the render kernel's -DWRITE_AOV=1 variant writes: depth, normal, albedo
# The kernel's AOV record (layout.AOV_DTYPE) per pixel before the trace, what a miss leaves: depth 0 as Mitsuba's
# `aov` integrator writes it (renders never hold inf; the id AOV, -1 there, tells a miss from a hit), zero normal
# and albedo.
AOV_MISS = np.zeros(1, AOV_DTYPE)
THICKNESS = 1.0  # the edge mask's default disc radius (RenderSettings.thickness): another value without edge_detect is warned about


@dataclass
class RenderSettings:
    width: int | None = None  # image width in pixels; None: the scene's (or kept to its aspect ratio from height)
    height: int | None = None  # image height in pixels; None: the scene's (or kept to its aspect ratio from width)
    camera: int = 1  # camera number, counting from 1 (1 is the canonical camera)
    integrator: str = "whitted"  # "whitted" (the seed's) or "path" (physically based: docs/materials.md)
    spp: int = 0  # path: paths per pixel per pass; 0: samples x samples
    time_budget: float | None = None  # path: whole-image passes of spp paths while this many seconds last; None: one pass
    aa: str = "none"  # anti-aliasing: "none", "full" or "edge_detect"
    sampler: str = "stratified"  # "uniform", "random", "stratified" or "sobol"
    samples: int = 1  # N: N x N samples per pixel when anti-aliasing
    pixel_filter: str = "box"  # how a pixel's samples are averaged: "box" (plain mean), "tent" or "gaussian"
    thickness: float = THICKNESS  # edge_detect: radius of the disc marked around each edge pixel
    shadow_edges: bool = True  # edge_detect: changes in light visibility count as edges
    contrast: float = 0.03  # edge_detect: a step above this between neighbours (sRGB, any channel) is an edge too; 0: IDs only (the seed)
    light_samples: int = 0  # area-light samples per side for every light; 0 keeps each light's own
    light_sampler: str = "stratified"  # area-light samples: "stratified" (the seed's jittered grid) or "random"
    max_depth: int = 8  # mirror/refraction bounces after the primary hit
    fresnel: bool = False  # split transparency by Schlick's Fresnel term instead of the seed's fixed split
    seed: int = 0  # seeds every random choice; the same seed gives the same image
    bvh: bool = True  # False tests every primitive for every ray (the benchmark's baseline)
    bvh_builder: str = "sah"  # "sah" (binned surface-area heuristic) or "median" (the seed's)
    tile_size: int = 128  # tiles are tile_size x tile_size pixels per kernel launch
    device: str | None = None  # OpenCL device substring; None: $CLRENDER_DEVICE, else the fastest CPU driver
    aovs: tuple = ()  # extra outputs on RenderResult.aovs: any of "depth", "normal", "albedo", "id", "edges"
    # meshes that several objects place stored once and placed per hit (clrender/trace/instancing.py);
    # None: when that saves at least instancing.AUTO_MIN_TRIANGLES triangles (docs/bvh.md, "Instancing")
    instancing: bool | None = None
    rfilter: str = "box"  # path: the film's reconstruction filter, "box" (a pixel's own samples), "tent" or "gaussian" (trace/film.py)
    hide_emitters: bool = False  # path: camera rays look past emitting surfaces and area lights and see no environment (Mitsuba's)
    rr_depth: int | None = None  # path: Russian roulette from this many bounces after the primary hit; None: the kernel's (3)

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
        require(
            not (s.integrator == "path" and s.aa == "edge_detect"),
            "--aa edge_detect is a Whitted feature: with --integrator path every pixel gets the same --spp "
            "(more paths only at edges would bias the image)",
        )
        require(_name_in(s.sampler, SAMPLERS), f"unknown sampler {v(s.sampler)}; allowed: {', '.join(SAMPLERS)}")
        require(_name_in(s.pixel_filter, PIXEL_FILTERS), f"unknown pixel filter {v(s.pixel_filter)}; allowed: {', '.join(PIXEL_FILTERS)}")
        require(_name_in(s.rfilter, film.FILTERS), f"unknown reconstruction filter {v(s.rfilter)}; allowed: {', '.join(film.FILTERS)}")
        require(
            s.rfilter == "box" or s.integrator == "path",
            f"--rfilter {s.rfilter} is the path tracer's film (--integrator path); "
            "Whitted anti-aliasing weighs a pixel's own samples by --pixel-filter",
        )
        require(s.rfilter == "box" or s.pixel_filter == "box", f"give --rfilter {s.rfilter} or --pixel-filter {s.pixel_filter}, not both")
        require(_whole(s.samples) and 1 <= s.samples <= 64, f"samples {v(s.samples)} must be an integer from 1 to 64 (N x N per pixel)")
        require(_real(s.thickness) and math.isfinite(s.thickness) and s.thickness >= 0, f"thickness {v(s.thickness)} must be a real number >= 0")
        require(_real(s.contrast) and math.isfinite(s.contrast) and s.contrast >= 0, f"contrast {v(s.contrast)} must be a real number >= 0 (0: off)")
        require(_whole(s.light_samples) and 0 <= s.light_samples <= 64, f"light samples {v(s.light_samples)} must be from 0 (each light's own) to 64")
        require(_name_in(s.light_sampler, LIGHT_SAMPLERS), f"unknown light sampler {v(s.light_sampler)}; allowed: {', '.join(LIGHT_SAMPLERS)}")
        depth_limit = PATH_DEPTH_LIMIT if s.integrator == "path" else MAX_DEPTH_LIMIT  # the path tracer keeps no ray stack
        require(_whole(s.max_depth) and 0 <= s.max_depth <= depth_limit, f"max depth {v(s.max_depth)} must be from 0 to {depth_limit}")
        require(
            s.rr_depth is None or (_whole(s.rr_depth) and 0 <= s.rr_depth <= PATH_DEPTH_LIMIT),
            f"rr depth {v(s.rr_depth)} must be from 0 to {PATH_DEPTH_LIMIT}, or None for the path tracer's own",
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
        """What these (valid) settings ask for that changes nothing, or that renders only darkness, in words.
        Judged by value: `samples` other than 1 with aa "none", `thickness` other than its default
        without aa "edge_detect" or the edges AOV, a scene without lights."""
        said = []
        if self.integrator == "path":
            return self._pointless_for_paths(scene)
        if self.spp or self.time_budget is not None:
            said.append("--spp and --time-budget have no effect with --integrator whitted (they set the path tracer's samples)")
        if self.hide_emitters or self.rr_depth is not None:
            said.append("hide_emitters and rr_depth have no effect with --integrator whitted (they are the path tracer's)")
        if self.aa == "none" and self.samples != 1:
            said.append(
                f"{self.samples} x {self.samples} samples have no effect with --aa none "
                "(one ray through each pixel centre); use --aa full or edge_detect"
            )
        if self.aa != "edge_detect" and self.thickness != THICKNESS and "edges" not in self.aovs:
            said.append(f"--thickness has no effect with --aa {self.aa} (it widens the edge mask of --aa edge_detect)")
        if self.aa == "none" and scene.camera(self.camera).aperture > 0:
            said.append(f"camera {self.camera} has a lens (aperture > 0) and --aa none traces one ray a pixel: its blur is noise; use --aa full")
        if not scene.lights and scene.environment_map is None:  # a map is seen where rays escape (mirrors, glass)
            said.append(f"scene {scene.name!r} has no lights: only the ambient term and the background will show")
        if scene.environment_map is not None:  # escaping rays show it, but only lights and the ambient term shade
            said.append("the environment map lights nothing under the Whitted integrator (rays that escape show it); use --integrator path")
        return said

    def _pointless_for_paths(self, scene: Scene) -> list[str]:
        said = []
        if self.thickness != THICKNESS and "edges" not in self.aovs:
            said.append("--thickness has no effect with --integrator path (it widens the edge mask of --aa edge_detect)")
        emitters = any(max(m.emission) > 0 for m in scene.materials.values()) or max(scene.environment) > 0 or scene.environment_map is not None
        if not scene.lights and not emitters:
            said.append(f"scene {scene.name!r} has no lights, emission or environment: the path tracer will render black")
        return said


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
        dev = self.tracer.device
        start = time.perf_counter()
        self.camera = dev.to_device(self.scene.camera(s.camera).frame(s.width, s.height))
        self.n_lights = len(self.scene.lights)
        self.params = self._params()
        lights = np.array([light.pack() for light in self.scene.lights] or [np.zeros((), LIGHT_DTYPE)], LIGHT_DTYPE)
        self.lights = dev.to_device(lights)
        from .envmap import upload

        self.env = upload(dev, self.scene.environment_map)  # the env_* kernel arguments (a placeholder without a map)
        self.setup_seconds = {"upload": time.perf_counter() - start}  # camera, lights, environment map and its distribution
        self.write_aov = any(a in KERNEL_AOVS for a in s.aovs)
        materials = self.scene.materials.values()
        alpha_test, cull = any(m.alpha_mode != "opaque" for m in materials), not all(m.double_sided for m in materials)
        defines = render_defines(self.tracer.defines, self.write_aov, alpha_test, cull)
        if s.integrator == "path":
            from .path import emitters

            start = time.perf_counter()
            records, index_of = emitters(self.tracer.primitives)
            self.n_emitters = len(records)
            self.emitters, self.emitter_of_prim = dev.to_device(records), dev.to_device(index_of)
            self.setup_seconds["emitters"] = time.perf_counter() - start
            defines = {**defines, **film.defines(s.rfilter)}  # a reconstruction filter wider than a pixel splats
            if s.hide_emitters:
                defines["HIDE_EMITTERS"] = 1
            if s.rr_depth is not None:
                defines["RR_DEPTH"] = s.rr_depth
        start = time.perf_counter()
        with compile_notice(dev):  # a line on stderr when the build is slow (a cold cache)
            file, name = ("path.cl", "render_path") if s.integrator == "path" else ("trace.cl", "render")
            self.kernel = dev.kernel(file, name, defines)
            self._no_aov = dev.empty(AOV_DTYPE.itemsize)  # the unused aov_out argument
            self.launch(np.zeros(1, np.int32), "uniform", 1, True)  # PoCL finishes compiling on first launch
        self.compile_seconds = time.perf_counter() - start

    def _params(self) -> np.ndarray:
        """The render kernel's RenderParams (layout.RENDER_PARAMS_DTYPE) with the values every launch shares."""
        s, t = self.settings, self.tracer
        params = np.zeros((), RENDER_PARAMS_DTYPE)
        params["background"] = self.scene.background
        params["ambient"] = self.scene.ambient
        params["width"], params["height"] = s.width, s.height
        params["pixel_filter"] = PIXEL_FILTERS[s.pixel_filter]
        params["seed"] = s.seed
        params["max_depth"] = s.max_depth
        params["fresnel"] = s.fresnel
        params["light_samples"] = s.light_samples
        params["light_stratified"] = s.light_sampler == "stratified"
        params["n_lights"] = self.n_lights
        params["n_prims"] = t.n_prims
        return params

    def launch(self, pixels: np.ndarray, sampler: str, n: int, record: bool, first_sample: int = 0):
        """Trace the given pixel indices: colours (k, 3), id records (k,) of layout.ID_RECORD_DTYPE, shadow (k, L), stats (k, 2),
        and with AOVs on and `record`, the primary hits' AOV records (k,) of layout.AOV_DTYPE, else None.
        The path integrator's colours are (k, 4): each pixel's filtered mean, then its filter weight; its samples
        are first_sample ... first_sample + spp - 1 of each pixel's sequence (sampler and n are the settings')."""
        t, dev = self.tracer, self.tracer.device
        k, L = len(pixels), max(self.n_lights, 1)
        slots = film.slots(self.settings.rfilter) if self.settings.integrator == "path" else 1
        out = {name: dev.empty(k * size) for name, size in (("colour_out", 16 * slots), ("ids_out", ID_RECORD_DTYPE.itemsize), ("stats_out", 8))}
        shadow = dev.empty(k * 4 * L)
        if record:  # background pixels never write their shadow entries (the path tracer none): all lights visible
            cl.enqueue_fill_buffer(dev.queue, shadow, np.float32(1.0), 0, k * 4 * L)
        out["aov_out"] = self._no_aov
        if record and self.write_aov:
            out["aov_out"] = dev.empty(k * AOV_DTYPE.itemsize)
            cl.enqueue_fill_buffer(dev.queue, out["aov_out"], AOV_MISS, 0, k * AOV_DTYPE.itemsize)
        geometry = dict(nodes=t.nodes, prims=t.prims, prim_object=t.prim_object, normals=t.normals, objects=t.objects, materials=t.materials)
        geometry.update(instances=t.instance_buffer, top=t.top, n_instances=t.n_instances)  # read only by -DINSTANCED=1 kernels
        geometry.update(attributes=t.attributes, textures=t.textures, texels=t.texels)
        scene = dict(lights=self.lights, camera=self.camera, pixels=dev.to_device(pixels.astype(np.int32)))
        if self.settings.integrator == "path":
            from .path import path_params

            if record:  # one object id a pixel, the rest of its id record -1
                cl.enqueue_fill_buffer(dev.queue, out["ids_out"], np.int32(-1), 0, k * ID_RECORD_DTYPE.itemsize)
            extra = dict(emitters=self.emitters, emitter_of_prim=self.emitter_of_prim, params=path_params(self, k, first_sample, record), **self.env)
        else:
            params = self.params.copy()
            params["n_work"], params["sampler"], params["samples_per_side"], params["record"] = k, SAMPLERS[sampler], n, record
            extra = dict(params=params, shadow_out=shadow, env_map=self.env["env_map"], env_texels=self.env["env_texels"])
        local = t.layout.local_size
        self.kernel(dev.queue, global_size(k, local), (local,), **geometry, **scene, **extra, **out)
        host = (
            np.empty((k, 4) if slots == 1 else (k, slots, 4), np.float32),
            np.empty(k, ID_RECORD_DTYPE),
            np.empty((k, L), np.float32),
            np.empty((k, 2), np.uint32),
        )
        for array, buf in zip(host, (out["colour_out"], out["ids_out"], shadow, out["stats_out"])):
            cl.enqueue_copy(dev.queue, array, buf)
        aov_host = None
        if out["aov_out"] is not self._no_aov:
            aov_host = np.empty(k, AOV_DTYPE)
            cl.enqueue_copy(dev.queue, aov_host, out["aov_out"])
        colour = host[0] if self.settings.integrator == "path" else host[0][:, :3]
        return colour, host[1], host[2][:, : self.n_lights], host[3], aov_host

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
        return self.settings.spp or self.settings.samples**2

    def _path_passes(self, tiles):
        """The path integrator's passes, each a whole image of spp paths per pixel, while the time budget lasts
        (one pass without one): the first pass's outputs with the passes' filtered mean in place of its colours."""
        s = self.settings
        start, passes, total, weight, first = time.perf_counter(), 0, 0.0, 0.0, None
        while True:
            out = self._pass(tiles, s.sampler, s.samples, passes == 0, self._pass_label(passes, time.perf_counter() - start), passes * self.spp)
            colour = out[0].astype(np.float64) if s.rfilter == "box" else self._gathered(out[0], tiles)
            total = total + colour[:, :3] * colour[:, 3:]
            weight = weight + colour[:, 3:]
            first = first or out
            passes += 1
            spent = time.perf_counter() - start
            if s.time_budget is None or spent * (passes + 1) / passes > s.time_budget:
                break
            if (passes + 1) * self.spp > SAMPLE_INDEX_LIMIT:
                warn(f"--time-budget stopped at {passes * self.spp} paths a pixel: a pixel's paths are numbered below 2**32")
                break
        mean = first[0][:, :3] if passes == 1 and s.rfilter == "box" else (total / weight).astype(np.float32)
        return [mean, *first[1:]], passes

    def _pass_label(self, passes: int, spent: float) -> str:
        """The progress bar's words for a pass: with a time budget, which pass and the seconds left."""
        budget = self.settings.time_budget
        if budget is None:
            return "trace"
        return f"pass {passes + 1}, {max(budget - spent, 0.0):.0f}s left"

    def _gathered(self, splats: np.ndarray, tiles) -> np.ndarray:
        """A pass's splat slots (tile order) gathered by the film's filter (trace/film.py): (k, 4) float64 colours in
        tile order, the sum of weighted radiance over the sum of weights and that sum."""
        s = self.settings
        order = np.concatenate(tiles)
        image_order = np.empty_like(splats)
        image_order[order] = splats
        sums = film.gather(image_order, s.width, s.height, s.rfilter).reshape(-1, 4)[order]
        return np.concatenate([sums[:, :3] / sums[:, 3:], sums[:, 3:]], axis=1)

    def run(self) -> RenderResult:
        s = self.settings
        H, W = s.height, s.width
        # every setup phase (docs/command-line.md, "Timings"): the tracer's and the renderer's, then the kernels' compile
        timings = {"bvh": self.tracer.bvh_seconds, **self.tracer.setup_seconds, **self.setup_seconds, "compile": self.compile_seconds}
        tiles = list(self.tiles())
        order = np.concatenate(tiles)
        first_sampler, first_n = ("uniform", 1) if s.aa != "full" else (s.sampler, s.samples)
        start = time.perf_counter()
        passes = 1
        if s.integrator == "path":
            (colour, ids, shadow, stats, aov), passes = self._path_passes(tiles)
        else:
            colour, ids, shadow, stats, aov = self._pass(tiles, first_sampler, first_n, True, "trace")
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
        result.samples_per_pixel = passes * self.spp if s.integrator == "path" else 0
        result.passes = passes if s.integrator == "path" else 0
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


def render_defines(tracer_defines: dict, write_aov: bool, alpha_test: bool, cull_backfaces: bool) -> dict:
    """The render kernel's -D variant (both integrators): the Tracer's, and
    - WRITE_AOV: renders without AOVs build and run the kernel with the AOV writes compiled out;
    - ALPHA_TEST: alpha-tested materials (glTF MASK, BLEND) make every ray look past the points they leave out
      (kernels/alpha.h); scenes without them keep the kernels they had;
    - CULL_BACKFACES: single-sided materials (glTF doubleSided false) hide their back faces from camera rays.
    clrender/warmup.py builds every combination of them."""
    defines = {**tracer_defines, "WRITE_AOV": int(write_aov)}
    if alpha_test:
        defines["ALPHA_TEST"] = 1
    if cull_backfaces:
        defines["CULL_BACKFACES"] = 1
    return defines


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
