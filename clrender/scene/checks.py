"""What every scene reader shares: the limits, the checks of one value, and messages that name the file and the key.

Each section's reader lives next to what it builds (camera.py, lights.py, materials.py, and the
objects in scene.py) and declares the keys it accepts once, as a `TypeReader`; docs/scene-format.md's
key table is tested against those declarations (tests/scene/test_scene_keys.py).  This module imports
nothing from the rest of the scene package, so every reader may import it.
"""

from __future__ import annotations

import math
import reprlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UsageError, escaped

# ---------------------------------------------------------------------- limits
# Every value from a file is checked against these before anything is built.  Coordinates and
# lengths stay far inside float32 (3.4e38) so that the kernels' products (squared distances,
# colour x intensity x albedo x falloff, with 1/r^2 capped in kernels/shade.h) cannot overflow;
# counts are bounded so that no file can ask for hours of work or gigabytes of memory.
COORD_LIMIT = 1e6  # |x| of every coordinate and vector component, radius and plane size (scene units)
MIN_LENGTH = 1e-6  # shortest radius, edge, direction or scale factor
RELATIVE_PRECISION = 1e-5  # a length must be >= this x the distance of its object from the origin (float32 resolves it)
RADIANCE_LIMIT = 1e6  # colours (background, ambient, light colour, emission) and light intensity
ALBEDO_LIMIT = 1.0  # reflectances (diffuse, specular, base_color): glTF's [0, 1], so no lobe returns more than it receives
UV_LIMIT = 1e6  # |u|, |v| of a texture coordinate: times a texture transform (<= 1e6) it stays inside float32
SHININESS_LIMIT = 1e6  # Blinn-Phong exponent
IOR_RANGE = (0.01, 100.0)  # index of refraction
FOV_RANGE = (1e-3, 179.0)  # vertical field of view, degrees
MAX_SIDE = 16384  # image width or height given in a scene file
MAX_CAMERAS = 64
MAX_LIGHTS = 64
MAX_MATERIALS = 1024
MAX_OBJECTS = 100_000  # entries of `objects`; a mesh counts once however many triangles it has
MAX_TRIANGLES = 10_000_000  # triangles of all meshes together
MAX_AREA_SAMPLES = 64  # area light samples per side (the CLI's --light-samples cap)
MAX_NESTING = 8  # tables and lists inside one another (a valid scene needs 5)
MAX_VALUES = 1_000_000  # tables, lists and values in the whole document
MAX_NAME = 200  # characters in a scene or material name
SEED_RANGE = (0, 2**32 - 1)
# Keyword arguments each mesh generator accepts from a file: whole numbers in [low, high].
# The highs keep one generator call within seconds (bunny 192: 8 s, 129k triangles).
GENERATOR_PARAMS = {
    "bunny": {"resolution": (16, 192)},
    "cat": {"resolution": (16, 192)},
    "dense": {"n_triangles": (8, 2_000_000), "seed": SEED_RANGE},
    "wizard_hat": {"segments": (3, 4096)},
    "tower": {"segments": (3, 4096)},
}
MESH_GENERATORS = tuple(GENERATOR_PARAMS)

# Messages are one line a person reads: control characters are shown escaped, values are cut.
MAX_MESSAGE = 300
_SHOW = reprlib.Repr()
_SHOW.maxlevel, _SHOW.maxstring, _SHOW.maxother, _SHOW.maxlist, _SHOW.maxdict = 2, 40, 40, 4, 4


escape = escaped  # control, bidi and separator characters as escapes: one rule for every message (errors.py)


def shorten(text: str, limit: int) -> str:
    return text if len(text) <= limit else text[: limit - 3] + "..."


def show(value) -> str:
    """A short, escaped repr of a value from a file (nested or huge values are abbreviated)."""
    return shorten(escape(_SHOW.repr(value)), 60)


def is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def as_float(value) -> float:
    """float(value), or inf for an integer too large for a float."""
    try:
        return float(value)
    except OverflowError:
        return math.inf if value > 0 else -math.inf


# ---------------------------------------------------------------------- checks
class Checks:
    """Typed getters for the values of one scene document: each refuses a bad value with a UsageError
    naming the file (`where`), the key and what is allowed.  base_dir and root tell mesh readers where
    files are (root: a confined scene's folder, see confine.py)."""

    def __init__(self, where: str, base_dir: Path = Path("."), allow_outside: bool = True):
        self.base_dir = base_dir
        self.where = where
        self.allow_outside = allow_outside
        self.root = None if allow_outside else base_dir  # a confined scene reads only files inside it (confine.py)
        self.shapes = {}  # shapes.Shape read or built so far, by scene.py's _shape_key: each is loaded once
        self.array_meshes = {}  # numpy `vertices` checked so far, by the arrays' ids: each is checked once

    def fail(self, key: str, message: str):
        # the key is cut on its own so that what is allowed still fits on the line
        raise UsageError(shorten(f"{self.where}: {shorten(escape(key), 100)}: {escape(message)}", MAX_MESSAGE))

    # the document's shape, before any value is read ------------------------
    def check_shape(self, data):
        """Tables with string keys, nesting and size bounded (an iterative walk: no recursion)."""
        self.table(data, "scene")
        stack = [(data, "", 0)]
        count = 0
        while stack:
            value, path, depth = stack.pop()
            count += 1
            if count > MAX_VALUES:
                self.fail(path or "scene", f"the scene has more than {MAX_VALUES} values")
            if depth > MAX_NESTING:
                self.fail(path, f"nested more than {MAX_NESTING} levels deep")
            if isinstance(value, dict):
                for key, item in value.items():
                    if not isinstance(key, str):
                        self.fail(path or "scene", f"key {show(key)} is not a string")
                    stack.append((item, f"{path}.{key}" if path else key, depth + 1))
            elif isinstance(value, (list, tuple)):
                if len(value) > MAX_VALUES:
                    self.fail(path, f"a list of {len(value)} items; allowed: at most {MAX_VALUES}")
                stack.extend((item, f"{path}[{i}]", depth + 1) for i, item in enumerate(value))

    # typed getters ---------------------------------------------------------
    def table(self, data, key):
        if not isinstance(data, dict):
            self.fail(key, f"expected a table, got {type(data).__name__}")
        return data

    def check_keys(self, data: dict, key: str, allowed):
        unknown = sorted(set(data) - set(allowed))
        if unknown:
            self.fail(f"{key}.{unknown[0]}" if key else unknown[0], f"unknown key; allowed: {', '.join(sorted(allowed))}")

    def number(self, data, key, path, default=None, *, low, high, low_open=False, positive=False):
        """A finite number in [low, high] (or (low, high] with low_open); `positive` says "> 0" when refusing."""
        value = data.get(key, default)
        full = f"{path}.{key}" if path else key
        if value is None:
            self.fail(full, "is required (a number)")
        if not is_number(value):
            self.fail(full, f"expected a number, got {show(value)}")
        number = as_float(value)
        if not math.isfinite(number):
            self.fail(full, f"expected a finite number, got {show(value)}")
        if number < low or (low_open and number == low) or number > high:
            allowed = f"{'>' if low_open else '>='} {low:g} and <= {high:g}"
            self.fail(full, f"{number:.6g} is out of range; allowed: " + (f"> 0 ({low:g} to {high:g})" if positive else allowed))
        return number

    def integer(self, data, key, path, default=None, *, low, high):
        value = data.get(key, default)
        full = f"{path}.{key}" if path else key
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            self.fail(full, f"{show(value)}; allowed: whole numbers {low} to {high}")
        return value

    def vec3(self, data, key, path, default=None, *, kind="point"):
        """Three numbers.  kind: "point" (|x| <= COORD_LIMIT), "colour" (0 to RADIANCE_LIMIT), "albedo" (0 to
        ALBEDO_LIMIT), "vector" (|x| <= COORD_LIMIT and length >= MIN_LENGTH)."""
        value = data.get(key, default)
        full = f"{path}.{key}" if path else key
        if value is None:
            self.fail(full, "is required (a list of 3 numbers)")
        if not isinstance(value, (list, tuple)) or len(value) != 3 or not all(is_number(v) for v in value):
            self.fail(full, f"expected a list of 3 numbers, got {show(value)}")
        vec = tuple(as_float(v) for v in value)
        if not all(math.isfinite(v) for v in vec):
            self.fail(full, f"expected finite numbers, got {show(value)}")
        if kind in ("colour", "albedo"):
            top = RADIANCE_LIMIT if kind == "colour" else ALBEDO_LIMIT
            if not all(0.0 <= v <= top for v in vec):
                what = "" if kind == "colour" else " (a reflectance: a surface returns at most the light it receives)"
                self.fail(full, f"{show(value)} is out of range; allowed: 0 to {top:g} per channel{what}")
        elif not all(abs(v) <= COORD_LIMIT for v in vec):
            self.fail(full, f"{show(value)} is out of range; allowed: -{COORD_LIMIT:g} to {COORD_LIMIT:g}")
        elif kind == "vector" and math.hypot(*vec) < MIN_LENGTH:
            self.fail(full, f"{show(value)} is too short; allowed: length >= {MIN_LENGTH:g}")
        return vec

    def choice(self, data, key, path, default, allowed):
        value = data.get(key, default)
        if not isinstance(value, str) or value not in allowed:
            self.fail(f"{path}.{key}" if path else key, f"{show(value)} is not one of {', '.join(map(repr, allowed))}")
        return value

    def boolean(self, data, key, path, default):
        value = data.get(key, default)
        if not isinstance(value, bool):
            self.fail(f"{path}.{key}", f"expected true or false, got {show(value)}")
        return value

    def name(self, value, path):
        """A name or one-line description: 1 to MAX_NAME printable characters (it is shown on terminals)."""
        if not isinstance(value, str) or not 1 <= len(value) <= MAX_NAME or escape(value) != value:
            self.fail(path, f"expected 1 to {MAX_NAME} printable characters (no control characters), got {show(value)}")
        return value

    def length(self, data, key, path, at, default=None):
        """A radius or size: MIN_LENGTH to COORD_LIMIT and resolvable in float32 at distance `at`."""
        value = self.number(data, key, path, default, low=MIN_LENGTH, high=COORD_LIMIT, positive=True)
        smallest = RELATIVE_PRECISION * at
        if value < smallest:
            self.fail(
                f"{path}.{key}",
                f"{value:.6g} is too small this far from the origin; allowed: >= {smallest:.3g} ({RELATIVE_PRECISION:g} x the distance)",
            )
        return value

    def counted(self, data, key, limit):
        value = self.list(data, key)
        if len(value) > limit:
            self.fail(key, f"{len(value)} entries; allowed: at most {limit}")
        return value

    def list(self, data, key):
        value = data.get(key, [])
        if not isinstance(value, list):
            self.fail(key, f"expected a list of tables ([[{key}]] in TOML), got {type(value).__name__}")
        return value

    def not_parallel(self, a, b, key):
        if np.linalg.norm(np.cross(a, b)) < 1e-6 * np.linalg.norm(a) * np.linalg.norm(b):
            self.fail(key, "must not be parallel to edge_a (the parallelogram would have no area)")


@dataclass(frozen=True)
class TypeReader:
    """One type of a section (a light type, an object type, the camera, ...): the keys its table may hold,
    declared once (checked here, and against docs/scene-format.md by tests/scene/test_scene_keys.py), and
    `build(checks, table, path, *context)`, which reads them, with their defaults, into what it makes."""

    keys: tuple
    build: Callable

    def read(self, checks: Checks, data: dict, path: str, *context):
        checks.check_keys(data, path, self.keys)
        return self.build(checks, data, path, *context)
