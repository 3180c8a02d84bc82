"""`clrender render`: ray trace a bundled scene or a scene file to an image."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
import warnings
from pathlib import Path
from typing import NamedTuple

from ..errors import RenderWarning, UsageError
from ..image.tonemap import TONEMAPS
from ..layout import PATH_SAMPLERS, PATH_SCHEDULES
from ..trace import film
from ..trace.renderer import AA_MODES, INTEGRATORS, SAMPLERS, RenderSettings
from . import add_device_argument, add_foreign_arguments, scene_defaults

PATH_DEFAULT_SPP = 64  # --integrator path without --spp or --samples

EXAMPLES = """examples:
  clrender render refract1 -o refract1.png
  clrender render bunny --aa edge_detect --sampler stratified --samples 4 --edges-out edges.png -o bunny.png
  clrender render my_scene.toml --camera 2 --width 800 --height 600 --no-bvh -o out.exr
  clrender render teapot.obj -o teapot.png            # a mesh file: framed and lit by default
  clrender render model.glb --list                    # a file's cameras
  clrender render wizard_cat 3 edge_detect stratified 6 1.0 true -o cat.png   # the same settings as positionals
"""


# setup phases of RenderResult.timings besides load, bvh and compile, named in the summary when they take this long
SETUP_PHASES = ("geometry", "attributes", "textures", "upload", "emitters")
SHOWN_PHASE_SECONDS = 0.1


def _bool(text: str) -> bool:
    low = text.lower()
    if low in ("true", "1", "yes", "on"):
        return True
    if low in ("false", "0", "no", "off"):
        return False
    raise UsageError(f"DETECT_SHADOWS {text!r} must be true or false")


def print_scene_list(scenes: dict) -> None:
    """Each bundled scene's description and cameras, its default camera marked '*' (read from the
    TOML alone: no mesh is built)."""
    import tomllib

    for name, path in scenes.items():
        print_scene_cameras(name, tomllib.loads(path.read_text()))
    print("(* the scene's default view, rendered when --camera is not given: the one it was made for; --camera picks any)")


def print_scene_cameras(name: str, data: dict) -> None:
    """A scene dict's description and its cameras, by number and name, the default one marked '*'."""
    from ..scene.scene import OLD_TOP_KEYS

    print(f"{name}: {data.get('description', '')}".rstrip(": "))
    default = next((data[k] for k in ("default_camera", *OLD_TOP_KEYS) if k in data), 1)  # or an older spelling
    for number, camera in enumerate(data.get("cameras", [{}]), start=1):
        mark = "*" if number == default else " "
        print(f"  {mark} --camera {number}  {camera.get('name', '')}".rstrip())


def print_file_cameras(text: str) -> None:
    """`render SCENE --list`: the cameras of one scene, checked by loading it first: a bundled scene's or a
    TOML file's as its file names them, a glTF file's by their names, a mesh file's one framing camera."""
    import tomllib

    from ..scene import gltf
    from ..scene.framing import CAMERA_NAME
    from ..scene.scene import MESH_SUFFIXES, Scene, bundled_scenes

    scene = Scene.load(text)  # refuses a bad file as rendering it would
    path = bundled_scenes().get(text, Path(text))
    if gltf.is_gltf(path):
        data = gltf.scene_dict(path)
    elif path.suffix.lower() in MESH_SUFFIXES:  # a bare mesh: framing.py's camera
        data = {"description": scene.description, "cameras": [{"name": CAMERA_NAME}]}
    elif path.suffix.lower() == ".pbrt":  # a pbrt-v4 file: its one camera
        data = {"cameras": [{}]}
    else:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    print_scene_cameras(scene.name, data)


def add_parser(sub):
    d = RenderSettings()
    p = sub.add_parser(
        "render",
        help="ray trace a scene to an image",
        epilog=EXAMPLES,
        description="Ray trace SCENE (a bundled scene name, a .toml scene file, a .gltf/.glb glTF file or a mesh file) with OpenCL. "
        "A mesh file (.obj, .ply, .stl, .off), or a glTF file without cameras, gets a camera that frames its bounding sphere "
        "in a three-quarter view; a bare mesh also gets a key light and a uniform fill (docs/scene-format.md).",
    )
    _add_scene_arguments(p)
    _add_view_arguments(p)
    _add_sampling_arguments(p, d)
    _add_edge_arguments(p, d)
    _add_display_arguments(p)
    add_stage_arguments(p)
    _add_integrator_arguments(p, d)
    # foreign scene files (Mitsuba 3 .xml, pbrt-v4 .pbrt: clrender/scene/foreign.py, docs/scene-formats.md)
    add_foreign_arguments(p)
    _add_trace_arguments(p, d)
    add_device_argument(p)
    p.add_argument(
        "--list",
        action="store_true",
        help="list the bundled scenes with their cameras and exit; with SCENE: that scene's cameras (a mesh file: its framing camera)",
    )
    # Dask cluster and turntable options (commands/cluster.py, commands/turntable.py; docs/distributed.md)
    from .cluster import add_cluster_arguments
    from .turntable import add_turntable_arguments

    add_cluster_arguments(p)
    add_turntable_arguments(p)
    p.set_defaults(run=run)


def _add_scene_arguments(p) -> None:
    """SCENE and the short form's positional arguments."""
    p.add_argument(
        "scene",
        metavar="SCENE",
        nargs="?",
        help="bundled scene name (see --list), or a .toml scene file, a .gltf/.glb glTF file, a .pbrt file or a mesh file (.obj, .ply, .stl, .off)",
    )
    p.add_argument(
        "positional_args",
        nargs="*",
        metavar="ARG",
        help="the short form: CAMERA AA_TYPE SAMPLE_TYPE [AA_SAMPLES] [THICKNESS] [DETECT_SHADOWS], instead of the options of the same meaning",
    )


def _add_view_arguments(p) -> None:
    """-o, --overwrite, --camera, --width, --height: the output file and the view."""
    # Options the positionals can also set default to None, so giving both is caught; their
    # help states the real default in words.
    p.add_argument(
        "-o", "--output", default=None, help="output image (.png/.jpg sRGB 8-bit, .exr linear float) (default: SCENE.png in the current folder)"
    )
    p.add_argument("--overwrite", action="store_true", help="replace an existing output file")
    p.add_argument(
        "--camera",
        type=int,
        default=None,
        help="camera number, 1 = the scene's first; --list marks each scene's own view with * (default: the scene's own, else 1)",
    )
    p.add_argument(
        "--width", type=positive_int, default=None, help="image width (default: the scene's, or kept to its aspect ratio when only --height is given)"
    )
    p.add_argument(
        "--height",
        type=positive_int,
        default=None,
        help="image height (default: the scene's, or kept to its aspect ratio when only --width is given)",
    )


def _add_sampling_arguments(p, d) -> None:
    """--aa, --sampler, --samples, --pixel-filter, --rfilter: where samples fall in a pixel and how they are weighted."""
    p.add_argument("--aa", choices=AA_MODES, default=None, help=f"anti-aliasing mode (default: the scene's aa, else {d.aa})")
    p.add_argument("--sampler", choices=tuple(SAMPLERS), default=None, help=f"where AA samples fall in a pixel (default: {d.sampler})")
    p.add_argument(
        "--path-sampler",
        choices=tuple(PATH_SAMPLERS),
        default=None,
        help="path tracer: its random numbers, sobol (Owen-scrambled Sobol: less noise at equal time) or independent "
        f"(hashed uniform numbers) (default: the scene's path_sampler, else {d.path_sampler})",
    )
    p.add_argument(
        "--path-schedule",
        choices=PATH_SCHEDULES,
        default=None,
        help="path tracer: lanes (16 paths a work-item in SIMD lanes on a CPU), megakernel (a path per work-item) or wavefront (a "
        f"kernel per step); the same bits; docs/lanes.md (default: the scene's path_schedule, else {d.path_schedule})",
    )
    p.add_argument("--samples", type=int, default=None, help="N: N x N samples per pixel (default: 1 with --aa none, else 4)")
    p.add_argument(
        "--pixel-filter",
        choices=("box", "tent", "gaussian"),
        default=None,
        help=f"weighting of a pixel's samples (box: plain average) (default: a foreign scene file's, else {d.pixel_filter})",
    )
    p.add_argument(
        "--rfilter",
        choices=("box", "tent", "gaussian"),
        default=None,
        help=f"path tracer: the film's reconstruction filter, Mitsuba's (box: a pixel's own samples; tent, gaussian: "
        f"splatted across pixels; default: a scene file's own, else {d.rfilter})",
    )


def _add_edge_arguments(p, d) -> None:
    """--thickness, --shadow-edges, --contrast, --edges-out, --aov, --aov-out: the edge pass and the AOVs."""
    p.add_argument("--thickness", type=float, default=None, help=f"edge_detect: disc radius around edge pixels (default: {d.thickness})")
    p.add_argument(
        "--shadow-edges",
        action=argparse.BooleanOptionalAction,
        default=None,
        help=f"count changes in light visibility as edges (default: {'on' if d.shadow_edges else 'off'})",
    )
    p.add_argument(
        "--contrast",
        type=float,
        default=d.contrast,
        help="edge_detect: a colour step above this between neighbours (sRGB) is an edge too; 0: object IDs only",
    )
    p.add_argument("--edges-out", default=None, metavar="PATH", help="also write the render with edge pixels in green (default: not written)")
    p.add_argument(
        "--aov",
        default=None,
        metavar="LIST",
        help="also write AOVs, comma-separated from depth,normal,albedo,id,edges, as named EXR channels "
        "(in OUT itself when it is .exr, else in --aov-out) (default: none)",
    )
    p.add_argument(
        "--aov-out", default=None, metavar="PATH", help="EXR file for the AOVs (default: OUT itself when OUT is .exr, else OUT.aov.exr beside it)"
    )


def _add_display_arguments(p) -> None:
    """--exposure, --tonemap, --denoise, --noisy-out: what is done to the image once rendered."""
    p.add_argument(
        "--exposure",
        type=exposure_value,
        default=None,
        metavar="STOPS",
        help="PNG/JPEG: multiply the linear image by 2**STOPS before the tone curve, or auto: darken only as far as brings the "
        "97th percentile of luminance to 1 (docs/display.md); EXR stays as rendered (default: auto with --integrator path, else 0)",
    )
    p.add_argument(
        "--tonemap",
        choices=TONEMAPS,
        default="clamp",
        help="PNG/JPEG tone curve: clamp clips at 1, aces (Hill's RRT+ODT fit) and agx (AgX base) roll highlights off (default: clamp)",
    )
    p.add_argument(
        "--denoise",
        action="store_true",
        help="path: denoise the image with Intel Open Image Denoise, using the albedo and normal AOVs (needs clrender[denoise])",
    )
    p.add_argument("--noisy-out", default=None, metavar="PATH", help="with --denoise: also write the image before denoising (default: not written)")


def _add_integrator_arguments(p, d) -> None:
    """--light-samples, --integrator, --spp, --time-budget, --max-depth: the integrator and its samples."""
    p.add_argument("--light-samples", type=int, default=d.light_samples, help="area-light samples per side (0: each light's own)")
    p.add_argument(
        "--integrator",
        choices=INTEGRATORS,
        default=None,
        help="whitted: the classic ray tracer; path: physically based path tracing (docs/materials.md) (default: a foreign scene's, else whitted)",
    )
    p.add_argument(
        "--spp", type=int, default=None, help=f"path: paths per pixel per pass (default: N x N from --samples, or {PATH_DEFAULT_SPP} without it)"
    )
    p.add_argument(
        "--time-budget",
        type=float,
        default=None,
        metavar="SECONDS",
        help="path: repeat whole-image passes of --spp paths while time is left (default: one pass)",
    )
    p.add_argument(
        "--max-depth",
        type=int,
        default=None,
        help=f"mirror/refraction bounces (path: bounces after the first hit) (default: a foreign scene file's, else {d.max_depth})",
    )


def _add_trace_arguments(p, d) -> None:
    """--fresnel, --bvh, --bvh-builder, --instancing, --seed, --filter."""
    p.add_argument("--fresnel", action="store_true", help="split transparency with Schlick's Fresnel term")
    p.add_argument("--bvh", action=argparse.BooleanOptionalAction, default=d.bvh, help="use the BVH (off: test every primitive)")
    p.add_argument("--bvh-builder", choices=("sah", "median"), default=d.bvh_builder, help="BVH construction")
    from ..trace.instancing import AUTO_MIN_TRIANGLES

    p.add_argument(
        "--instancing",
        action=argparse.BooleanOptionalAction,
        default=d.instancing,
        help=f"store a mesh that several objects place once (default: when the copies save >= {AUTO_MIN_TRIANGLES:,} triangles; docs/bvh.md)",
    )
    p.add_argument("--seed", type=int, default=d.seed, help="random seed (same seed, same image)")
    p.add_argument(
        "--filter", action="append", default=[], metavar="NAME", help="convolution filter applied to the result, repeatable (default: none)"
    )


def add_stage_arguments(p) -> None:
    """--env, --env-intensity, --env-rotation, --ground, --up, --smooth: a model set up for a product shot (scene/staging.py)."""
    from ..scene.staging import UP_CHOICES

    p.add_argument(
        "--env",
        default=None,
        metavar="FILE",
        help="light the scene with this equirectangular .hdr/.exr map, or `studio`, the bundled one (default: the scene's own environment)",
    )
    p.add_argument("--env-intensity", type=float, default=None, metavar="X", help="scale of the map's radiance, >= 0 (default: 1)")
    p.add_argument("--env-rotation", type=float, default=None, metavar="DEGREES", help="turn the map about +y (default: 0)")
    p.add_argument("--ground", action="store_true", help="add a grey (0.5) plane under the scene's bounding box (default: none)")
    p.add_argument("--up", default=None, metavar="AXIS", help=f"a bare mesh file's up axis, {'|'.join(UP_CHOICES)} (default: y)")
    p.add_argument("--smooth", action="store_true", help="a bare mesh file: interpolate vertex normals (default: flat faces)")


def positive_int(text: str) -> int:
    """argparse type: a whole number >= 1 (0 would silently mean 'the scene's' otherwise)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number; allowed: 1 or more") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not allowed; allowed: 1 or more")
    return value


# the positional arguments after SCENE, in order, and the setting each one gives
POSITIONAL_NAMES = {
    "camera": "CAMERA",
    "aa": "AA_TYPE",
    "sampler": "SAMPLE_TYPE",
    "samples": "AA_SAMPLES",
    "thickness": "THICKNESS",
    "shadow_edges": "DETECT_SHADOWS",
}


def warn(message: str) -> None:
    """A pointless or doubtful request that still renders: one line on stderr (never 'clrender:', which means an error)."""
    sys.stderr.write(f"warning: {message}\n")


@contextlib.contextmanager
def warning_lines():
    """The library's RenderWarnings (RenderSettings.validate) as this command's `warning:` lines, each
    once: the settings are checked at several steps (here, by the renderer, once per turntable frame).
    Other warnings keep Python's own display."""
    said = set()
    with warnings.catch_warnings():
        warnings.simplefilter("always", RenderWarning)
        python_shows = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if not issubclass(category, RenderWarning):
                return python_shows(message, category, filename, lineno, file, line)
            if str(message) not in said:
                said.add(str(message))
                warn(str(message))

        warnings.showwarning = show
        yield


def settings_from_args(args) -> RenderSettings:
    """Named options or the positional arguments after SCENE (never both for one setting), then the defaults
    (RenderSettings.validate warns about values that change nothing)."""
    d = RenderSettings()
    named = dict(camera=args.camera, aa=args.aa, sampler=args.sampler, samples=args.samples, thickness=args.thickness, shadow_edges=args.shadow_edges)
    values = {}
    extra = list(args.positional_args)
    if len(extra) > 6:
        raise UsageError(f"too many arguments {extra!r}; the order is CAMERA AA_TYPE SAMPLE_TYPE [AA_SAMPLES] [THICKNESS] [DETECT_SHADOWS]")
    if extra and len(extra) < 3:
        raise UsageError("the positional order needs at least CAMERA AA_TYPE SAMPLE_TYPE, e.g. 'wizard_cat 3 edge_detect stratified 6'")
    converters = [
        ("camera", int, "an integer from 1 to 5"),
        ("aa", str, "|".join(AA_MODES)),
        ("sampler", str, "|".join(SAMPLERS)),
        ("samples", int, "an integer > 0"),
        ("thickness", float, "a real number >= 0"),
        ("shadow_edges", _bool, "true|false"),
    ]
    for text, (key, convert, allowed) in zip(extra, converters):
        if named[key] is not None:
            raise UsageError(
                f"--{key.replace('_', '-')} {named[key]} and the positional {POSITIONAL_NAMES[key]} {text!r} set the same thing; give one of them"
            )
        try:
            values[key] = convert(text)
        except ValueError:
            raise UsageError(f"{key.upper()} {text!r} is not valid; allowed: {allowed}") from None
    explicit = {k for k, v in named.items() if v is not None} | set(values)
    for key, value in named.items():
        values.setdefault(key, getattr(d, key) if value is None else value)
    if "samples" not in explicit:  # the default depends on --aa: 1 without anti-aliasing, else 4
        values["samples"] = 1 if values["aa"] == "none" else 4
    integrator = d.integrator if args.integrator is None else args.integrator
    spp = args.spp
    if spp is None and integrator == "path" and "samples" not in explicit:
        spp = PATH_DEFAULT_SPP
    if args.aov is not None:
        from ..trace.aov import parse_aov_list

        values["aovs"] = parse_aov_list(args.aov)
    return RenderSettings(
        width=args.width,
        height=args.height,
        light_samples=args.light_samples,
        pixel_filter=d.pixel_filter if args.pixel_filter is None else args.pixel_filter,
        rfilter=d.rfilter if args.rfilter is None else args.rfilter,
        path_sampler=d.path_sampler if getattr(args, "path_sampler", None) is None else args.path_sampler,
        path_schedule=d.path_schedule if getattr(args, "path_schedule", None) is None else args.path_schedule,
        contrast=args.contrast,
        max_depth=d.max_depth if args.max_depth is None else args.max_depth,
        integrator=integrator,
        spp=0 if spp is None else spp,
        time_budget=args.time_budget,
        fresnel=args.fresnel,
        bvh=args.bvh,
        bvh_builder=args.bvh_builder,
        instancing=args.instancing,
        seed=args.seed,
        device=args.device,
        **values,
    )


def load_scene(args):
    """The scene SCENE names; a foreign file (.xml, .pbrt) with the -D values, and --approximate's stand-ins
    said on one line."""
    from ..scene import staging
    from ..scene.foreign import is_foreign, parse_defines
    from ..scene.scene import Scene

    defines = parse_defines(getattr(args, "defines", []))
    if not is_foreign(args.scene):
        if defines or getattr(args, "approximate", False):
            raise UsageError("-D and --approximate are for foreign scene files (Mitsuba .xml, pbrt .pbrt)")
        return staging.load(args.scene, staging.Stage.from_args(args))
    read = lambda text: Scene.from_file(text, defines=defines, approximate=args.approximate)  # noqa: E731
    scene = staging.load(args.scene, staging.Stage.from_args(args), read)
    if scene.substitutions:
        warn(f"{len(scene.substitutions)} stand-ins: " + "; ".join(scene.substitutions))
    return scene


def foreign_settings(args, settings, scene):
    """A foreign file's own settings (its integrator, spp, depth, reconstruction filter, hidden emitters, Russian
    roulette depth) where the command line gives none; the last three only for the path tracer (the Whitted
    integrator averages each pixel's own samples and has neither)."""
    own = scene.render_settings
    if not own:
        return settings
    from dataclasses import replace

    given = {
        "integrator": args.integrator is not None,
        "spp": args.spp is not None or args.samples is not None,
        "max_depth": args.max_depth is not None,
        "rfilter": args.rfilter is not None,
        "hide_emitters": False,  # no flags: only a scene file sets them
        "rr_depth": False,
        "path_sampler": getattr(args, "path_sampler", None) is not None,
    }
    path_only = ("rfilter", "hide_emitters", "rr_depth", "path_sampler")
    settings = replace(settings, **{k: v for k, v in own.items() if k in given and not given[k] and k not in path_only})
    if settings.integrator == "path":
        settings = replace(settings, **{k: own[k] for k in path_only if k in own and not given[k]})
    return settings


def run(args):
    with warning_lines():
        return _render(args)


def exposure_value(text: str):
    """argparse type of --exposure: a number of stops, or "auto"."""
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number of stops; allowed: a number from -64 to 64, or auto") from None


def auto_exposure_wanted(args) -> bool:
    """--exposure auto, given or by default (path-traced renders: their radiance has no fixed white)."""
    exposure = getattr(args, "exposure", None)
    return exposure == "auto" or (exposure is None and getattr(args, "integrator", "whitted") == "path")


def display_from_args(args, output=None):
    """The display transform of PNG/JPEG outputs (clrender/image/tonemap.py), its exposure 0 where it is
    automatic (`_render` sets it from the image once rendered and denoised); a warning when the one output named is a float
    file, which stays scene-linear."""
    from ..image.files import FLOAT_EXTENSIONS
    from ..image.tonemap import DisplaySettings

    exposure = getattr(args, "exposure", None)
    display = DisplaySettings(exposure=0.0 if exposure in (None, "auto") else exposure, tonemap=getattr(args, "tonemap", "clamp"))
    given = display != DisplaySettings() or exposure == "auto"
    if output is not None and Path(output).suffix.lower() in FLOAT_EXTENSIONS and given:
        warn(f"--exposure and --tonemap change nothing in {Path(output).name}: float outputs stay scene-linear")
    return display


def check_denoise(args, settings) -> None:
    """--denoise and --noisy-out: refused where they do not apply, and without OIDN installed (before any work)."""
    if args.noisy_out is not None and not args.denoise:
        raise UsageError("--noisy-out needs --denoise (without it the output is the noisy image)")
    if not args.denoise:
        return
    from ..trace.integrators import integrator_type

    if not integrator_type(settings.integrator).monte_carlo:
        raise UsageError(f"--denoise is for --integrator path (Monte Carlo noise); --integrator {settings.integrator} has none to remove")
    if args.turntable is not None or args.video:
        raise UsageError("--denoise is for single renders; --turntable writes the frames as rendered")
    from ..image.denoise import require_oidn

    require_oidn()


class _Outputs(NamedTuple):
    """The files one render writes, checked before any work (None: not asked for), in the order stdout lists them."""

    output: Path
    aov_out: Path | None
    edges_out: Path | None
    noisy_out: Path | None


def _render(args):
    from ..scene.scene import bundled_scenes

    if args.list:
        if args.scene is None:
            print_scene_list(bundled_scenes())
        else:
            print_file_cameras(args.scene)
        return 0
    if args.scene is None:
        files = "a .toml scene file, a .gltf/.glb file or a mesh file (.obj, .ply, .stl, .off)"
        raise UsageError(f"render needs a SCENE: a bundled scene name (clrender render --list), {files}")
    settings = settings_from_args(args)
    check_denoise(args, settings)
    if args.turntable is not None or args.video:  # K frames into a folder (commands/turntable.py)
        from .turntable import run_turntable

        if args.exposure == "auto":
            raise UsageError("--exposure auto sets each image's own exposure, so a turntable's frames would flicker; give STOPS")
        return run_turntable(args, settings, display_from_args(args))
    outs, display = _check_outputs(args, settings)
    if args.filter:
        from ..image import filters

        for name in args.filter:
            filters.parse(name)
    requested_aovs = settings.aovs
    if args.denoise:  # OIDN's auxiliary images; only the AOVs asked for are written
        from dataclasses import replace

        from ..image.denoise import AUX_AOVS

        settings = replace(settings, aovs=requested_aovs + tuple(a for a in AUX_AOVS if a not in requested_aovs))
    start = time.perf_counter()
    scene = load_scene(args)
    settings = scene_defaults(args, foreign_settings(args, settings, scene), scene)
    load_seconds = time.perf_counter() - start
    # the scene's own width and height where not given; bad values are refused, then pointless ones warned about
    size = settings.validate(scene)
    _require_memory(args, scene, settings, size, outs.edges_out)
    from .cluster import renderer_for  # a DistributedRenderer under --scheduler / --workers

    with renderer_for(args, scene, settings) as renderer:
        result = renderer.run()
    image, noisy, denoise_seconds = _final_image(args, result, outs.noisy_out)
    aovs = {name: result.aovs[name] for name in requested_aovs}
    if auto_exposure_wanted(args):
        from dataclasses import replace

        from ..image.tonemap import auto_exposure

        display = replace(display, exposure=auto_exposure(image))
    _write_outputs(args, outs, result, image, noisy, aovs, display)
    for path in outs:  # stdout: every written path, for scripts
        if path is not None:
            print(path)
    if not args.quiet:
        _print_summary(args, scene, renderer, result, display, load_seconds, denoise_seconds)
    return 0


def _check_outputs(args, settings) -> tuple[_Outputs, object]:
    """The output paths, refused before any work where they exist (without --overwrite), clash or do not apply;
    and the display transform of the image outputs."""
    from ..image.files import check_distinct_outputs, check_output_path
    from ..trace.aov import aov_output

    output = check_output_path(args.output or f"{Path(args.scene).stem}.png", overwrite=args.overwrite)
    display = display_from_args(args, output)
    noisy_out = check_output_path(args.noisy_out, overwrite=args.overwrite) if args.noisy_out else None
    edges_out = check_output_path(args.edges_out, overwrite=args.overwrite) if args.edges_out else None
    if edges_out and settings.aa != "edge_detect":
        raise UsageError("--edges-out needs --aa edge_detect (the mask comes from the edge pass)")
    aov_out = aov_output(output, args.aov_out, settings.aovs, args.overwrite)
    check_distinct_outputs(**{"-o": output, "--edges-out": edges_out, "--aov-out": aov_out, "--noisy-out": noisy_out})
    return _Outputs(output, aov_out, edges_out, noisy_out), display


def _require_memory(args, scene, settings, size, edges_out) -> None:
    """Refuse a render whose images and buffers cannot fit in memory, before allocating any."""
    from .. import memory

    memory.require(
        memory.render_bytes(
            size.width,
            size.height,
            scene.triangle_count,
            aa=settings.aa,
            aovs=len(settings.aovs),
            filters=len(args.filter),
            extra_images=(edges_out is not None) + 2 * args.denoise,  # denoise: its output and the noisy copy
            attributes=scene.has_vertex_attributes,
            splat_slots=film.slots(settings.rfilter),
            denoise=args.denoise,
            texels=sum(t.pixels.shape[0] * t.pixels.shape[1] for t in scene.textures),
        ),
        f"a {size.width}x{size.height} render of {scene.triangle_count} triangles",
    )


def _final_image(args, result, noisy_out):
    """The rendered image denoised (--denoise), then filtered (--filter): (image, the noisy image, denoise seconds or None)."""
    image = noisy = result.image
    denoise_seconds = None
    if args.denoise:
        from ..image.denoise import denoise_result

        start = time.perf_counter()
        image = denoise_result(result).image
        denoise_seconds = time.perf_counter() - start
    if args.filter:  # after denoising: OIDN is trained on the renderer's own noise, not on filtered images
        from ..image import filters

        image = filters.apply(image, *args.filter)
        noisy = filters.apply(noisy, *args.filter) if noisy_out is not None else noisy
    return image, noisy, denoise_seconds


def _write_outputs(args, outs: _Outputs, result, image, noisy, aovs, display) -> None:
    """Write every output, then put them all in place together."""
    from ..image.files import write_display_image
    from ..outputs import output_set
    from ..trace.aov import write_exr
    from ..trace.edges import overlay_edges

    with output_set(overwrite=args.overwrite):  # every output is written, then all are put in place together
        if aovs and outs.aov_out is None:  # an EXR output carries its AOVs as extra channels
            write_exr(outs.output, aovs, beauty=image)
        else:
            write_display_image(outs.output, image, display=display)
        if outs.aov_out is not None:
            write_exr(outs.aov_out, aovs)
        if outs.edges_out is not None:
            write_display_image(outs.edges_out, overlay_edges(result.image, result.edge_mask), display=display)
        if outs.noisy_out is not None:
            write_display_image(outs.noisy_out, noisy, display=display)


def _print_summary(args, scene, renderer, result, display, load_seconds, denoise_seconds) -> None:
    """One line on stderr: the image, its primitives and rays, and where the time went."""
    s = renderer.settings
    t = result.timings
    parts = [f"exposure {display.exposure:+.2f} (auto)"] if auto_exposure_wanted(args) and display.exposure else []
    parts += [f"load {load_seconds:.2f}s", f"bvh {t['bvh']:.2f}s"]
    parts += [f"{name} {t[name]:.2f}s" for name in SETUP_PHASES if t.get(name, 0.0) >= SHOWN_PHASE_SECONDS]
    parts += [f"compile {t['compile']:.2f}s", f"trace {t['trace']:.2f}s"]
    if result.passes:  # the path integrator's passes: what a --time-budget reached
        parts.append(f"{result.samples_per_pixel} spp in {result.passes} pass{'es' if result.passes != 1 else ''} of {renderer.spp}")
    if denoise_seconds is not None:
        parts.append(f"denoise {denoise_seconds:.2f}s")
    if "resample" in t:
        parts.append(f"edges {t['edges']:.2f}s, resample {t['resample']:.2f}s ({100 * result.resampled_fraction:.1f}% of pixels)")
    sys.stderr.write(
        f"{scene.name}: {s.width}x{s.height}, {primitive_count(renderer.tracer, scene)}, {result.rays / 1e6:.2f} M rays; " + ", ".join(parts) + "\n"
    )


def primitive_count(tracer, scene) -> str:
    """The summary's count: the flat part's primitives, and with instancing the instances and the triangles they place."""
    n_instances = getattr(tracer, "n_instances", 0)
    if not n_instances:
        return f"{tracer.n_prims} primitives"
    shapes = len(tracer.instances.shapes)
    return (
        f"{tracer.n_prims} primitives + {n_instances} instances of {shapes} mesh{'es' if shapes > 1 else ''} "
        f"({scene.triangle_count:,} triangles and {scene.sphere_count} spheres in all)"
    )
