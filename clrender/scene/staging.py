"""A model set in a studio from the command line: `render Duck.glb --env studio.hdr --ground`.

`Stage` holds the options (--env, --env-intensity, --env-rotation, --ground, --up, --smooth) and `load`
reads the scene with them (docs/scene-format.md, "Product shots"):

- `env`: an equirectangular .hdr/.exr map (or a bundled one by name: `studio`, made by tools/studio_hdr.py)
  becomes the scene's `[environment]` (file, intensity, rotation, as the TOML table reads them). A file without
  lights of its own (a bare mesh, a glTF without KHR_lights_punctual) loses framing.py's key light and constant
  fill: the map lights it alone.
  `env_intensity` and `env_rotation` without `env` change the scene's own map.
- `ground`: a square, neutral grey (0.5) diffuse plane under the bounding box of every object, 100 times the
  box's diagonal across, a ten-thousandth of the diagonal below its lowest point (coplanar faces would fight).
  An ordinary plane, not a shadow catcher: it shows under the model in both integrators and bounces light.
- `up`, `smooth`: for bare mesh files only (the file's up axis turned to +y; interpolated normals).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import UsageError
from .checks import Checks
from .environment import ENVIRONMENT_READER, ROTATION_LIMIT, EnvironmentMap
from .materials import Material

GROUND_MATERIAL = "ground"  # the plane's material: grey 0.5, diffuse in both integrators
GROUND_ALBEDO = 0.5
GROUND_SIZE = 100.0  # the plane's side, times the bounding box's diagonal: its far edge near the horizon
GROUND_GAP = 1e-4  # the plane sits this much (times the diagonal) under the lowest point
UP_CHOICES = ("y", "z", "x")


@dataclass(frozen=True)
class Stage:
    env: str | None = None  # an environment map file; None: the scene's own
    env_intensity: float | None = None  # its radiance scale, >= 0; None: 1 (or the scene map's)
    env_rotation: float | None = None  # degrees about +y; None: 0 (or the scene map's)
    ground: bool = False  # a grey plane under the model
    up: str | None = None  # a bare mesh file's up axis: y (default), z or x
    smooth: bool = False  # a bare mesh file: interpolated vertex normals

    @property
    def given(self) -> bool:
        return self != Stage()

    @classmethod
    def from_args(cls, args) -> Stage:
        """The staging a command line asks for (`clrender render`'s --env, --ground, --up, ... options)."""
        names = ("env", "env_intensity", "env_rotation", "ground", "up", "smooth")
        return cls(**{name: getattr(args, name) for name in names if getattr(args, name, None) is not None})


def load(text: str, stage: Stage, read=None):
    """The scene SCENE names (`read(text)`, by default Scene.load), set up as `stage` says; UsageError for a value
    not allowed."""
    from .scene import MESH_SUFFIXES, UP_AXES, Scene, _load_mesh_scene, bundled_scenes

    _check_values(stage)
    is_mesh = text not in bundled_scenes() and Path(text).suffix.lower() in MESH_SUFFIXES
    if (stage.up is not None or stage.smooth) and not is_mesh:
        flag = f"--up {stage.up}" if stage.up is not None else "--smooth"
        raise UsageError(f"{flag} is for a bare mesh file ({', '.join(MESH_SUFFIXES)}); {text!r} places and shades its own objects")
    assert set(UP_AXES) == set(UP_CHOICES)
    scene = _load_mesh_scene(Path(text), up=stage.up or "y", smooth=stage.smooth or None) if is_mesh else (read or Scene.load)(text)
    _set_environment(scene, stage)
    if stage.ground:
        add_ground(scene)
    return scene


def _check_values(stage: Stage) -> None:
    if stage.up is not None and stage.up not in UP_CHOICES:
        raise UsageError(f"--up {stage.up!r} is not an axis; allowed: {', '.join(UP_CHOICES)}")
    if stage.env_intensity is not None and not (np.isfinite(stage.env_intensity) and stage.env_intensity >= 0):
        raise UsageError(f"--env-intensity {stage.env_intensity:g} is not allowed; allowed: a number >= 0 (1: the map's own radiance)")
    if stage.env_rotation is not None and not (np.isfinite(stage.env_rotation) and abs(stage.env_rotation) <= ROTATION_LIMIT):
        raise UsageError(f"--env-rotation {stage.env_rotation:g} is not allowed; allowed: degrees from -{ROTATION_LIMIT:g} to {ROTATION_LIMIT:g}")
    if stage.env is not None and env_path(stage.env) is None:
        bundled = ", ".join(bundled_maps())
        raise UsageError(f"--env {stage.env!r} does not exist; allowed: an equirectangular .hdr or .exr image, or a bundled map ({bundled})")


def bundled_maps() -> dict:
    """Name -> path of every environment map shipped in the package (scenes/*.hdr; `--env studio`)."""
    from ..package_data import data_dir

    return {p.stem: p for p in sorted(data_dir("scenes").glob("*.hdr"))}


def env_path(text: str) -> Path | None:
    """The file --env names: a path, else a bundled map's name; None when neither exists."""
    if Path(text).is_file():
        return Path(text)
    return bundled_maps().get(text)


def _set_environment(scene, stage: Stage) -> None:
    """--env as the scene's map (replacing a default rig's key light and fill); --env-intensity and --env-rotation on it."""
    table = {k: v for k, v in (("intensity", stage.env_intensity), ("rotation", stage.env_rotation)) if v is not None}
    if stage.env is None:
        if not table:
            return
        if scene.environment_map is None:
            flag = "--env-intensity" if "intensity" in table else "--env-rotation"
            raise UsageError(f"{flag} changes an environment map; scene {scene.name!r} has none: give one with --env FILE")
        scene.environment_map = replace(scene.environment_map, **table)
        return
    env = ENVIRONMENT_READER.read(Checks("--env", Path(".")), {"file": str(env_path(stage.env).resolve()), **table}, "environment")
    assert isinstance(env, EnvironmentMap)
    scene.environment_map = env
    if scene.default_lighting:  # framing.py's key light and fill: the map lights the model instead
        scene.lights, scene.environment = [], (0.0, 0.0, 0.0)
        scene.default_lighting = False


def add_ground(scene) -> None:
    """A grey square plane under the bounding box of every object (GROUND_* above), in a material of its own."""
    from .scene import OBJECT_READERS

    lo, hi = scene_bounds(scene)
    diagonal = float(np.linalg.norm(hi - lo))
    centre = (lo + hi) / 2
    point = [float(centre[0]), float(lo[1] - GROUND_GAP * diagonal), float(centre[2])]
    scene.materials[GROUND_MATERIAL] = Material(diffuse=(GROUND_ALBEDO,) * 3)
    plane = {"type": "plane", "point": point, "normal": [0.0, 1.0, 0.0], "size": GROUND_SIZE * diagonal, "material": GROUND_MATERIAL}
    scene.objects.append(OBJECT_READERS["plane"].read(Checks("--ground"), plane, "ground", scene.materials, True))


def scene_bounds(scene) -> tuple[np.ndarray, np.ndarray]:
    """(lo, hi) corners of the box around every sphere and mesh of the scene."""
    from .scene import Mesh, Sphere

    los, his = [], []
    for o in scene.objects:
        if isinstance(o, Sphere):
            los.append(np.subtract(o.center, o.radius))
            his.append(np.add(o.center, o.radius))
        elif isinstance(o, Mesh):
            los.append(o.vertices.min(axis=0))
            his.append(o.vertices.max(axis=0))
    if not los:
        raise UsageError(f"--ground needs objects to stand under; scene {scene.name!r} has none")
    return np.min(los, axis=0), np.max(his, axis=0)
