"""The integrators on the host, one type each: what it adds to the settings' checks, its kernel and -D defines,
its launch record, its buffers in the world arena, and its passes over the image.

`make_integrator(name, renderer)` builds one by its name (RenderSettings.integrator; INTEGRATORS lists them).
The Renderer (renderer.py) owns the scene, the Tracer, the tiles and the outputs; it launches the integrator's
kernel, which takes the same buffers for both (kernels/trace.cl render, path.cl render_path): the Tracer's
geometry, the scene tables, the world, the pixels, the launch record (layout.WhittedParams or PathParams, each
holding the shared FrameParams) and one launch's outputs.
"""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np

from ..errors import require, warn
from ..layout import EMITTER_DTYPE, LIGHT_CHOICE_DTYPE, PATH_SAMPLERS, WHITTED_PARAMS_DTYPE
from . import film
from .variant import MAX_DEPTH_LIMIT, Variant

PATH_DEPTH_LIMIT = 1024  # bounces of a path (Russian roulette ends most much sooner)
# a pixel's paths are numbered by a 32-bit counter (the kernels' random numbers are keyed by it): --time-budget
# stops before a pass would number a path past it (2**32 paths a pixel, 4096 passes at MAX_SPP)
SAMPLE_INDEX_LIMIT = 1 << 32
THICKNESS = 1.0  # the edge mask's default disc radius (RenderSettings.thickness): another value without edges is warned about


class Integrator:
    """What every integrator has; the subclasses fill in their own."""

    name = ""
    kernel = ("", "")  # (kernels/ file, kernel name)
    depth_limit = 0  # the largest max_depth
    monte_carlo = False  # True: noise that more paths or a denoiser remove

    def __init__(self, renderer):
        self.renderer = renderer
        self.settings = renderer.settings

    @classmethod
    def check(cls, settings) -> None:
        """UsageError for settings this integrator cannot render (RenderSettings.validate calls it)."""

    @classmethod
    def pointless(cls, settings, scene) -> list[str]:
        """What these (valid) settings ask for that changes nothing under this integrator, in words."""
        return []

    def variant(self, rendering: Variant) -> Variant:
        """This integrator's kernel build: the render kernels' variant (Variant.rendering) in its file."""
        return replace(rendering, filename=self.kernel[0])

    @classmethod
    def warm_variant(cls, rendering: Variant, device, settings) -> Variant:
        """The build a render under `settings` makes of `rendering` on `device` (clrender/warmup.py: the defaults)."""
        return replace(rendering, filename=cls.kernel[0])

    def make_kernel(self, device, variant: Variant):
        """What Renderer.launch calls with the render kernels' named buffers: this integrator's kernel."""
        return device.kernel(variant.filename, self.kernel[1], variant.defines())

    def world(self) -> dict:
        """This integrator's arrays of the world arena (layout.WORLD_REGIONS_DTYPE): placeholders here."""
        return dict(emitters=np.zeros(1, EMITTER_DTYPE), emitter_of_prim=np.full(1, -1, np.int32), light_choices=np.zeros(1, LIGHT_CHOICE_DTYPE))

    @property
    def spp(self) -> int:
        """Samples (paths) per pixel in one pass: settings.spp, or samples x samples."""
        return self.settings.spp or self.settings.samples**2

    @property
    def colour_slots(self) -> int:
        """float4 colours a pixel writes."""
        return 1

    def clear(self, device, out, regions, k: int, record: bool) -> None:
        """Fill what this kernel leaves unwritten in a launch's outputs before it runs."""

    def colour(self, colours: np.ndarray) -> np.ndarray:
        """A launch's colours as Renderer.launch returns them."""
        return colours

    def trace(self, tiles) -> tuple[list, int]:
        """The whole image's first outputs (colour, ids, shadow, stats, aov) and the path passes it took (0: none)."""
        raise NotImplementedError

    def samples_per_pixel(self, passes: int) -> int:
        """RenderResult.samples_per_pixel: paths per pixel over every pass (0: not a path tracer)."""
        return 0


class WhittedIntegrator(Integrator):
    """The Whitted tracer (kernels/shade.h): one pass of N x N samples, edge-only AA resampling after."""

    name = "whitted"
    kernel = ("trace.cl", "render")
    depth_limit = MAX_DEPTH_LIMIT  # the kernel's ray stack

    def __init__(self, renderer):
        super().__init__(renderer)
        s, scene = self.settings, renderer.scene
        self.fixed = np.zeros((), WHITTED_PARAMS_DTYPE)  # the values every launch shares
        self.fixed["background"], self.fixed["ambient"] = scene.background, scene.ambient
        self.fixed["fresnel"], self.fixed["light_samples"] = s.fresnel, s.light_samples
        self.fixed["light_stratified"] = s.light_sampler == "stratified"

    @classmethod
    def check(cls, settings) -> None:
        require(
            settings.rfilter == "box",
            f"--rfilter {settings.rfilter} is the path tracer's film (--integrator path); "
            "Whitted anti-aliasing weighs a pixel's own samples by --pixel-filter",
        )

    @classmethod
    def pointless(cls, s, scene) -> list[str]:
        said = []
        if s.spp or s.time_budget is not None:
            said.append("--spp and --time-budget have no effect with --integrator whitted (they set the path tracer's samples)")
        if s.hide_emitters or s.rr_depth is not None:
            said.append("hide_emitters and rr_depth have no effect with --integrator whitted (they are the path tracer's)")
        if s.aa == "none" and s.samples != 1:
            said.append(
                f"{s.samples} x {s.samples} samples have no effect with --aa none (one ray through each pixel centre); use --aa full or edge_detect"
            )
        if s.aa != "edge_detect" and s.thickness != THICKNESS and "edges" not in s.aovs:
            said.append(f"--thickness has no effect with --aa {s.aa} (it widens the edge mask of --aa edge_detect)")
        if s.aa == "none" and scene.camera(s.camera).aperture > 0:
            said.append(f"camera {s.camera} has a lens (aperture > 0) and --aa none traces one ray a pixel: its blur is noise; use --aa full")
        if not scene.lights and scene.environment_map is None:  # a map is seen where rays escape (mirrors, glass)
            said.append(f"scene {scene.name!r} has no lights: only the ambient term and the background will show")
        if scene.environment_map is not None:  # escaping rays show it, but only lights and the ambient term shade
            said.append("the environment map lights nothing under the Whitted integrator (rays that escape show it); use --integrator path")
        return said

    def params(self, frame: np.ndarray, first_sample: int = 0) -> np.ndarray:
        """One launch's WhittedParams record around `frame` (its FrameParams)."""
        params = self.fixed.copy()
        params["frame"] = frame
        return params

    def colour(self, colours: np.ndarray) -> np.ndarray:
        return colours[:, :3]

    def trace(self, tiles) -> tuple[list, int]:
        s = self.settings
        sampler, n = (s.sampler, s.samples) if s.aa == "full" else ("uniform", 1)  # edge-only AA resamples the edges after
        return self.renderer._pass(tiles, sampler, n, True, "trace"), 0  # no path passes (RenderResult.passes)


class PathIntegrator(Integrator):
    """Unidirectional path tracing (kernels/path.cl): passes of spp paths a pixel while a time budget lasts."""

    name = "path"
    kernel = ("path.cl", "render_path")
    depth_limit = PATH_DEPTH_LIMIT  # the path tracer keeps no ray stack
    monte_carlo = True

    def __init__(self, renderer):
        super().__init__(renderer)
        self.n_emitters = 0

    @classmethod
    def check(cls, settings) -> None:
        require(
            settings.aa != "edge_detect",
            "--aa edge_detect is a Whitted feature: with --integrator path every pixel gets the same --spp "
            "(more paths only at edges would bias the image)",
        )

    @classmethod
    def pointless(cls, s, scene) -> list[str]:
        said = []
        if s.thickness != THICKNESS and "edges" not in s.aovs:
            said.append("--thickness has no effect with --integrator path (it widens the edge mask of --aa edge_detect)")
        emitters = any(max(m.emission) > 0 for m in scene.materials.values()) or max(scene.environment) > 0 or scene.environment_map is not None
        if not scene.lights and not emitters:
            said.append(f"scene {scene.name!r} has no lights, emission or environment: the path tracer will render black")
        return said

    @staticmethod
    def _with_settings(rendering: Variant, s) -> Variant:
        path_defines = {
            **film.defines(s.rfilter),  # a reconstruction filter wider than a pixel splats
            **({"HIDE_EMITTERS": 1} if s.hide_emitters else {}),  # camera rays look past emitters (Mitsuba's hide_emitters)
            **({"PATH_SAMPLER": PATH_SAMPLERS[s.path_sampler]} if s.path_sampler != "independent" else {}),  # kernels/sobol.h
        }
        return replace(rendering, filename=PathIntegrator.kernel[0], extra=rendering.extra + tuple(sorted(path_defines.items())))

    def variant(self, rendering: Variant) -> Variant:
        return self._with_settings(rendering, self.settings)

    @classmethod
    def warm_variant(cls, rendering: Variant, device, settings) -> Variant:
        """With LANES where the schedule takes the lanes on `device` (the program LaneKernel builds)."""
        from .lane_schedule import lanes_of

        variant = cls._with_settings(rendering, settings)
        lanes = lanes_of(variant.defines(), 1, device.device) if settings.path_schedule == "lanes" else 0
        return replace(variant, extra=variant.extra + (("LANES", lanes),)) if lanes else variant

    def make_kernel(self, device, variant: Variant):
        """render_path, or under settings.path_schedule "wavefront" its kernels' loop (trace/wavefront.py), or under "lanes"
        its pixels in SIMD lanes (trace/lane_schedule.py) where the scene and the device allow (lane_schedule.falls_back)."""
        from . import lane_schedule, wavefront

        defines, schedule = variant.defines(), self.settings.path_schedule
        if schedule == "wavefront":
            return wavefront.Wavefront(device, defines)
        lanes = lane_schedule.lanes_of(defines, self.renderer.tracer.n_prims, device.device) if schedule == "lanes" else 0
        return lane_schedule.LaneKernel(device, defines, lanes) if lanes else super().make_kernel(device, variant)

    def world(self) -> dict:
        from .light_choice import DEFENSIVE_SHARE, choices, groups, near_share, powers
        from .path import emitters

        start = time.perf_counter()
        primitives = self.renderer.tracer.primitives
        records, index_of, power = emitters(primitives)
        self.n_emitters = len(records)
        scene = self.renderer.scene
        power_of = powers(scene, primitives, power)  # NEE's one light a vertex: by power, or by nearness (the last record)
        light_choices = choices(power_of, groups(scene, len(records)), DEFENSIVE_SHARE, near_share(scene))
        self.renderer.setup_seconds["emitters"] = time.perf_counter() - start
        return dict(emitters=records if len(records) else np.zeros(1, EMITTER_DTYPE), emitter_of_prim=index_of, light_choices=light_choices)

    def params(self, frame: np.ndarray, first_sample: int = 0) -> np.ndarray:
        from .path import path_params

        return path_params(self, frame, first_sample)

    @property
    def colour_slots(self) -> int:
        return film.slots(self.settings.rfilter)

    def clear(self, device, out, regions, k: int, record: bool) -> None:
        import pyopencl as cl

        from ..layout import ID_RECORD_DTYPE

        if record:  # one object id a pixel, the rest of its id record -1
            cl.enqueue_fill_buffer(device.queue, out, np.int32(-1), int(regions["ids"]), k * ID_RECORD_DTYPE.itemsize)

    def samples_per_pixel(self, passes: int) -> int:
        return passes * self.spp

    def trace(self, tiles) -> tuple[list, int]:
        """Passes, each a whole image of spp paths per pixel, while the time budget lasts (one pass without one):
        the first pass's outputs with the passes' filtered mean in place of its colours."""
        s = self.settings
        start, passes, total, weight, first = time.perf_counter(), 0, 0.0, 0.0, None
        while True:
            label = self._pass_label(passes, time.perf_counter() - start)
            out = self.renderer._pass(tiles, s.sampler, s.samples, passes == 0, label, passes * self.spp)
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


INTEGRATORS = {kind.name: kind for kind in (WhittedIntegrator, PathIntegrator)}


def integrator_type(name: str) -> type[Integrator]:
    """The integrator type of a (checked) RenderSettings.integrator name."""
    return INTEGRATORS[name]


def make_integrator(name: str, renderer) -> Integrator:
    """The integrator `name` for `renderer` (a Renderer whose settings and Tracer are set)."""
    return integrator_type(name)(renderer)
