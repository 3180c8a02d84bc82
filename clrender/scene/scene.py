"""Scenes: TOML files, or the same structure as a Python dict.

A scene file is exactly the dict `Scene.from_dict` takes, so anything a user
can write in TOML they can build in Python.  Every key and its default is
listed in docs/scene-format.md's key table.  Errors name the file, the key
and what is allowed.
"""

from __future__ import annotations

import math
import reprlib
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UsageError, escaped
from ..package_data import data_dir
from .camera import Camera
from .lights import FALLOFFS, LIGHT_TYPES, Light
from .materials import DEFAULT_MATERIAL, Material
from .toml_text import read_toml


@dataclass
class Sphere:
    center: tuple
    radius: float
    material: str = "default"


@dataclass
class Mesh:
    """Triangles with optional per-vertex normals (used when `smooth`)."""

    vertices: np.ndarray  # (V, 3) float64 in world space
    faces: np.ndarray  # (F, 3) int
    vertex_normals: np.ndarray | None = None  # (V, 3) unit normals for smooth shading
    material: str = "default"
    smooth: bool = False  # interpolate vertex normals (True) or use each face's normal
    source: str = ""  # file or generator it came from, for messages


@dataclass
class Scene:
    cameras: list = field(default_factory=lambda: [Camera()])  # camera 1 is cameras[0]
    width: int = 640  # default image width in pixels
    height: int = 480  # default image height in pixels
    background: tuple = (0.0, 0.0, 0.0)  # colour of rays that hit nothing (linear RGB)
    ambient: tuple = (0.0, 0.0, 0.0)  # ambient light, multiplied by each material's diffuse colour
    materials: dict = field(default_factory=lambda: {"default": DEFAULT_MATERIAL})
    lights: list = field(default_factory=list)
    objects: list = field(default_factory=list)  # Sphere and Mesh, in file order; index = object id
    name: str = "scene"
    description: str = ""  # one line shown by `clrender render --list`
    featured_camera: int = 1  # the view the scene is made for, marked * by `render --list` (not a default: --camera is 1 unless given)

    @property
    def seed_camera(self) -> int:
        """The old name of `featured_camera`, still accepted."""
        return self.featured_camera

    @seed_camera.setter
    def seed_camera(self, value: int) -> None:
        self.featured_camera = value

    # ------------------------------------------------------------------ loading
    @classmethod
    def from_file(cls, path, allow_outside: bool = True) -> Scene:
        """Read a TOML scene file (or a glTF file); mesh paths are relative to its folder (see `from_dict` for allow_outside)."""
        path = Path(path)
        if path.suffix.lower() in (".gltf", ".glb"):
            from .gltf import load_scene

            return load_scene(path, allow_outside=allow_outside)
        where = escape(str(path))
        if not path.is_file():
            raise UsageError(f"scene file {shorten(where, 200)!r} does not exist")
        try:
            data = read_toml(path, where, MAX_NESTING)  # its size and dotted keys bounded before tomllib parses it
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise UsageError(shorten(escape(f"{where}: not valid TOML ({exc})"), MAX_MESSAGE)) from None
        except RecursionError:  # tomllib recurses once per nested array or inline table
            raise UsageError(shorten(f"{where}: not valid TOML (nested too deeply; allowed: {MAX_NESTING} levels)", MAX_MESSAGE)) from None
        return cls.from_dict(data, base_dir=path.parent, where=where, name=path.stem, allow_outside=allow_outside)

    @classmethod
    def from_dict(cls, data: dict, base_dir=".", where: str = "<dict>", name: str = "scene", allow_outside: bool = True) -> Scene:
        """A scene from the dict a TOML file parses to.  Every value is checked (types, ranges, counts,
        nesting; see the limits below) before any mesh is built or read.  Mesh `file` paths are relative
        to `base_dir`; they may be absolute or climb out with ../ (fine for local files), unless
        allow_outside=False, which refuses any path that resolves outside base_dir (symlinks followed),
        for services that read scenes from others."""
        return _SceneReader(Path(base_dir), where, allow_outside).read(data, name)

    @classmethod
    def load(cls, name_or_path) -> Scene:
        """A bundled scene by name (see `bundled_scenes()`), or a .toml scene file or .gltf/.glb file by path."""
        if isinstance(name_or_path, Scene):
            return name_or_path
        if isinstance(name_or_path, dict):
            return cls.from_dict(name_or_path)
        text = str(name_or_path)
        bundled = bundled_scenes()
        if text in bundled:
            return cls.from_file(bundled[text])
        path = Path(text)
        if path.suffix.lower() in (".gltf", ".glb"):  # a glTF 2.0 file with its cameras, lights and materials
            from .gltf import load_scene

            return load_scene(path)
        if path.suffix == ".toml" or path.exists():
            return cls.from_file(path)
        raise UsageError(f"unknown scene {text!r}; bundled scenes: {', '.join(sorted(bundled))}, or a .toml scene file or a .gltf/.glb file")

    def camera(self, number: int) -> Camera:
        """Camera `number`, counting from 1 as the seed does."""
        if not 1 <= number <= len(self.cameras):
            raise UsageError(f"camera {number} does not exist in scene {self.name!r}; allowed: 1 to {len(self.cameras)}")
        return self.cameras[number - 1]

    @property
    def triangle_count(self) -> int:
        return sum(len(o.faces) for o in self.objects if isinstance(o, Mesh))

    @property
    def sphere_count(self) -> int:
        return sum(isinstance(o, Sphere) for o in self.objects)


def bundled_scenes() -> dict:
    """Name -> path of every scene shipped in the package."""
    folder = data_dir("scenes")
    return {p.stem: p for p in sorted(folder.glob("*.toml"))}


# ---------------------------------------------------------------------- limits
# Every value from a file is checked against these before anything is built.  Coordinates and
# lengths stay far inside float32 (3.4e38) so that the kernels' products (squared distances,
# colour x intensity x albedo x falloff, with 1/r^2 capped in kernels/shade.h) cannot overflow;
# counts are bounded so that no file can ask for hours of work or gigabytes of memory.
COORD_LIMIT = 1e6  # |x| of every coordinate and vector component, radius and plane size (scene units)
MIN_LENGTH = 1e-6  # shortest radius, edge, direction or scale factor
RELATIVE_PRECISION = 1e-5  # a length must be >= this x the distance of its object from the origin (float32 resolves it)
RADIANCE_LIMIT = 1e6  # colours (background, ambient, diffuse, specular, light colour) and light intensity
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


# ---------------------------------------------------------------------- reading
class _SceneReader:
    def __init__(self, base_dir: Path, where: str, allow_outside: bool = True):
        self.base_dir = base_dir
        self.where = where
        self.allow_outside = allow_outside
        self.root = None if allow_outside else base_dir  # a confined scene reads only files inside it (confine.py)

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
        """Three numbers.  kind: "point" (|x| <= COORD_LIMIT), "colour" (0 to RADIANCE_LIMIT),
        "vector" (|x| <= COORD_LIMIT and length >= MIN_LENGTH)."""
        value = data.get(key, default)
        full = f"{path}.{key}" if path else key
        if value is None:
            self.fail(full, "is required (a list of 3 numbers)")
        if not isinstance(value, (list, tuple)) or len(value) != 3 or not all(is_number(v) for v in value):
            self.fail(full, f"expected a list of 3 numbers, got {show(value)}")
        vec = tuple(as_float(v) for v in value)
        if not all(math.isfinite(v) for v in vec):
            self.fail(full, f"expected finite numbers, got {show(value)}")
        if kind == "colour":
            if not all(0.0 <= v <= RADIANCE_LIMIT for v in vec):
                self.fail(full, f"{show(value)} is out of range; allowed: 0 to {RADIANCE_LIMIT:g} per channel")
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

    # sections ----------------------------------------------------------------
    def read(self, data: dict, name: str) -> Scene:
        self.check_shape(data)
        if "seed_camera" in data:  # the old name of featured_camera, still accepted
            if "featured_camera" in data:
                self.fail("seed_camera", "is the old name of featured_camera; give only featured_camera")
            data = {("featured_camera" if k == "seed_camera" else k): v for k, v in data.items()}
        self.check_keys(
            data,
            "",
            ("width", "height", "background", "ambient", "cameras", "materials", "lights", "objects", "name", "description", "featured_camera"),
        )
        scene = Scene(name=self.name(data.get("name", name), "name"))
        scene.width = self.integer(data, "width", "", 640, low=1, high=MAX_SIDE)
        scene.height = self.integer(data, "height", "", 480, low=1, high=MAX_SIDE)
        scene.background = self.vec3(data, "background", "", (0.0, 0.0, 0.0), kind="colour")
        scene.ambient = self.vec3(data, "ambient", "", (0.0, 0.0, 0.0), kind="colour")
        cameras = data.get("cameras", [{}])
        if not isinstance(cameras, list) or not cameras:
            self.fail("cameras", "expected a non-empty list of camera tables")
        cameras = self.counted(data, "cameras", MAX_CAMERAS) if "cameras" in data else cameras
        scene.cameras = [self.camera(c, f"cameras[{i}]") for i, c in enumerate(cameras)]
        scene.description = self.name(data["description"], "description") if "description" in data else ""
        scene.featured_camera = self.integer(data, "featured_camera", "", 1, low=1, high=len(scene.cameras))
        materials = self.table(data.get("materials", {}), "materials")
        if len(materials) > MAX_MATERIALS:
            self.fail("materials", f"{len(materials)} materials; allowed: at most {MAX_MATERIALS}")
        scene.materials = {"default": DEFAULT_MATERIAL}
        scene.materials.update({self.name(k, "materials"): self.material(v, f"materials.{k}") for k, v in materials.items()})
        scene.lights = [self.light(l, f"lights[{i}]") for i, l in enumerate(self.counted(data, "lights", MAX_LIGHTS))]
        entries = self.counted(data, "objects", MAX_OBJECTS)
        for i, o in enumerate(entries):  # every cheap check before any mesh is built or loaded
            self.object(o, f"objects[{i}]", scene.materials, build=False)
        objects = []
        triangles = 0
        for i, o in enumerate(entries):
            obj = self.object(o, f"objects[{i}]", scene.materials)
            if isinstance(obj, Mesh):
                triangles += len(obj.faces)
                if triangles > MAX_TRIANGLES:
                    self.fail(f"objects[{i}]", f"the scene has more than {MAX_TRIANGLES} triangles")
            objects.append(obj)
        scene.objects = objects
        return scene

    def list(self, data, key):
        value = data.get(key, [])
        if not isinstance(value, list):
            self.fail(key, f"expected a list of tables ([[{key}]] in TOML), got {type(value).__name__}")
        return value

    def camera(self, c, path) -> Camera:
        self.table(c, path)
        self.check_keys(c, path, ("position", "look_at", "up", "fov", "name"))
        if "name" in c:
            self.name(c["name"], f"{path}.name")
        cam = Camera(
            position=self.vec3(c, "position", path, (0.0, 0.0, 0.0)),
            look_at=self.vec3(c, "look_at", path, (0.0, 0.0, -1.0)),
            up=self.vec3(c, "up", path, (0.0, 1.0, 0.0), kind="vector"),
            fov=self.number(c, "fov", path, 60.0, low=FOV_RANGE[0], high=FOV_RANGE[1]),
        )
        forward = np.subtract(cam.look_at, cam.position)
        if np.linalg.norm(forward) < MIN_LENGTH:
            self.fail(f"{path}.look_at", f"must differ from position by at least {MIN_LENGTH:g}")
        if np.linalg.norm(np.cross(forward, cam.up)) < 1e-6 * np.linalg.norm(forward) * np.linalg.norm(cam.up):
            self.fail(f"{path}.up", "must not be parallel to the viewing direction")
        return cam

    def material(self, m, path) -> Material:
        self.table(m, path)
        self.check_keys(m, path, ("diffuse", "specular", "shininess", "mirror", "transparency", "ior"))
        d = DEFAULT_MATERIAL
        return Material(
            diffuse=self.vec3(m, "diffuse", path, d.diffuse, kind="colour"),
            specular=self.vec3(m, "specular", path, d.specular, kind="colour"),
            shininess=self.number(m, "shininess", path, d.shininess, low=0.0, high=SHININESS_LIMIT),
            mirror=self.number(m, "mirror", path, d.mirror, low=0.0, high=1.0),
            transparency=self.number(m, "transparency", path, d.transparency, low=0.0, high=1.0),
            ior=self.number(m, "ior", path, d.ior, low=IOR_RANGE[0], high=IOR_RANGE[1], positive=True),
        )

    def light(self, l, path) -> Light:
        self.table(l, path)
        kind = self.choice(l, "type", path, "point", tuple(LIGHT_TYPES))
        common = ("type", "color", "intensity", "falloff")
        own = {"point": ("position",), "directional": ("direction",), "area": ("corner", "edge_a", "edge_b", "samples")}[kind]
        self.check_keys(l, path, common + own)
        d = Light()
        args = dict(
            type=kind,
            color=self.vec3(l, "color", path, d.color, kind="colour"),
            intensity=self.number(l, "intensity", path, d.intensity, low=0.0, high=RADIANCE_LIMIT),
            falloff=self.choice(l, "falloff", path, "none", tuple(FALLOFFS)),
        )
        if kind == "point":
            args["position"] = self.vec3(l, "position", path)
        elif kind == "directional":
            args["direction"] = self.vec3(l, "direction", path, kind="vector")
        else:
            args["position"] = self.vec3(l, "corner", path)
            args["edge_a"] = self.vec3(l, "edge_a", path, kind="vector")
            args["edge_b"] = self.vec3(l, "edge_b", path, kind="vector")
            self.not_parallel(args["edge_a"], args["edge_b"], f"{path}.edge_b")
            args["samples"] = self.integer(l, "samples", path, 5, low=1, high=MAX_AREA_SAMPLES)
        return Light(**args)

    def not_parallel(self, a, b, key):
        if np.linalg.norm(np.cross(a, b)) < 1e-6 * np.linalg.norm(a) * np.linalg.norm(b):
            self.fail(key, "must not be parallel to edge_a (the parallelogram would have no area)")

    def material_ref(self, o, path, materials):
        name = o.get("material", "default")
        if not isinstance(name, str):
            self.fail(f"{path}.material", f"expected a material name, got {show(name)}")
        if name not in materials:
            self.fail(f"{path}.material", f"unknown material {show(name)}; defined: {shorten(', '.join(sorted(materials)), 100)}")
        return name

    def object(self, o, path, materials, build=True):
        """One entry of `objects`; with build=False only the checks that need no mesh to be built or read."""
        self.table(o, path)
        kind = self.choice(o, "type", path, None, ("sphere", "triangle", "quad", "plane", "mesh"))
        if kind == "sphere":
            self.check_keys(o, path, ("type", "center", "radius", "material"))
            center = self.vec3(o, "center", path)
            radius = self.length(o, "radius", path, max(map(abs, center)))
            return Sphere(center, radius, self.material_ref(o, path, materials))
        if kind == "triangle":
            self.check_keys(o, path, ("type", "vertices", "material"))
            verts = o.get("vertices")
            if not isinstance(verts, list) or len(verts) != 3:
                self.fail(f"{path}.vertices", f"expected 3 points, got {show(verts)}")
            points = np.array([self.vec3({"v": v}, "v", f"{path}.vertices[{i}]") for i, v in enumerate(verts)])
            return Mesh(points, np.array([[0, 1, 2]]), material=self.material_ref(o, path, materials), source=path)
        if kind in ("quad", "plane"):
            if kind == "quad":
                self.check_keys(o, path, ("type", "corner", "edge_a", "edge_b", "material"))
                corner = np.array(self.vec3(o, "corner", path))
                a = np.array(self.vec3(o, "edge_a", path, kind="vector"))
                b = np.array(self.vec3(o, "edge_b", path, kind="vector"))
                self.not_parallel(a, b, f"{path}.edge_b")
            else:
                # A plane is a large square centred on `point` (ray tracers need finite bounds).
                self.check_keys(o, path, ("type", "point", "normal", "size", "material"))
                point = np.array(self.vec3(o, "point", path, (0.0, 0.0, 0.0)))
                normal = np.array(self.vec3(o, "normal", path, (0.0, 1.0, 0.0), kind="vector"))
                size = self.length(o, "size", path, np.abs(point).max(), 1000.0)
                normal /= np.linalg.norm(normal)
                helper = np.array([1.0, 0, 0]) if abs(normal[0]) < 0.9 else np.array([0, 0, 1.0])
                b = np.cross(normal, helper)
                b *= size / np.linalg.norm(b)
                a = np.cross(b, normal)
                corner = point - 0.5 * (a + b)
            verts = np.array([corner, corner + a, corner + a + b, corner + b])
            return Mesh(verts, np.array([[0, 1, 2], [0, 2, 3]]), material=self.material_ref(o, path, materials), source=path)
        return self.mesh(o, path, materials, build)

    def mesh(self, o, path, materials, build=True) -> Mesh | None:
        self.check_keys(o, path, ("type", "file", "generator", "params", "translate", "rotate", "scale", "smooth", "material", "node", "primitive"))
        if ("file" in o) == ("generator" in o):
            self.fail(path, "a mesh needs exactly one of 'file' or 'generator'")
        gltf_node = self.gltf_node(o, path)
        if "file" in o:
            file = self.mesh_path(o.get("file"), f"{path}.file")
        else:
            gen, params = self.generator(o, path)
        scale = o.get("scale", 1.0)
        if is_number(scale):
            scale = self.number(o, "scale", path, 1.0, low=-COORD_LIMIT, high=COORD_LIMIT)
            scale = (scale,) * 3
        else:
            scale = self.vec3(o, "scale", path)
        if not all(abs(s) >= MIN_LENGTH for s in scale):
            self.fail(
                f"{path}.scale", f"{show(o.get('scale'))}: each factor must be {MIN_LENGTH:g} to {COORD_LIMIT:g} in magnitude (negative mirrors)"
            )
        rotate = self.vec3(o, "rotate", path, (0.0, 0.0, 0.0))
        translate = self.vec3(o, "translate", path, (0.0, 0.0, 0.0))
        smooth = self.boolean(o, "smooth", path, False)
        material = self.material_ref(o, path, materials)
        if not build:
            return None
        if gltf_node is not None:  # one node's mesh of a glTF file, in its world space
            from .gltf import node_mesh

            tm = node_mesh(file, *gltf_node, root=self.root)
            source = f"{o['file']} node {gltf_node[0]}"
        elif "file" in o:
            tm = load_mesh_file(file, f"{self.where}: {path}.file", root=self.root)
            source = o["file"]
        else:
            from . import meshes

            tm = getattr(meshes, gen)(**params)
            source = gen
        if len(tm.faces) > MAX_TRIANGLES:
            self.fail(f"{path}", f"{len(tm.faces)} triangles; allowed: at most {MAX_TRIANGLES}")
        matrix = transform_matrix(translate, rotate, scale)
        with np.errstate(over="ignore", invalid="ignore"):  # a huge file coordinate times scale: check_placed refuses it
            vertices = np.asarray(tm.vertices, np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
        self.check_placed(vertices, path)
        normals = None
        if smooth:
            from .meshes import shading_normals

            # Given normals: a generator's, or a glTF node's from its file (trimesh drops a file's
            # own); shading_normals computes the rest, welded across patches, and replaces zero/NaN ones.
            given = tm.vertex_normals if "generator" in o else getattr(tm, "normals", None)
            # Normals transform by the inverse transpose; renormalise afterwards.
            n = shading_normals(tm.vertices, tm.faces, given) @ np.linalg.inv(matrix[:3, :3])
            normals = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        return Mesh(vertices, np.asarray(tm.faces, np.int64), normals, material, smooth, source)

    def check_placed(self, vertices, path):
        """A transformed mesh lies within the coordinate limits and is big enough for float32 where it is."""
        reach = np.abs(vertices).max()
        if not reach <= 10 * COORD_LIMIT:
            self.fail(path, f"after scale and translate the mesh reaches {reach:.3g}; allowed: within {10 * COORD_LIMIT:g} of the origin")
        extent = np.ptp(vertices, axis=0).max()
        if extent < RELATIVE_PRECISION * reach:
            self.fail(
                f"{path}.scale",
                f"the mesh is {extent:.3g} across at distance {reach:.3g}; allowed: at least "
                f"{RELATIVE_PRECISION:g} x its distance from the origin (float32 precision)",
            )

    def gltf_node(self, o, path):
        """(node, primitive or None) when the mesh is one node of a glTF file (keys `node`, `primitive`), else None."""
        if "node" not in o:
            if "primitive" in o:
                self.fail(f"{path}.primitive", "needs 'node' (a node of a glTF file)")
            return None
        if not str(o.get("file", "")).lower().endswith((".gltf", ".glb")):
            self.fail(f"{path}.node", "only a .gltf or .glb 'file' has nodes")
        node = self.integer(o, "node", path, low=0, high=2**31 - 1)
        primitive = self.integer(o, "primitive", path, low=0, high=2**31 - 1) if "primitive" in o else None
        return node, primitive

    def mesh_path(self, file, key) -> Path:
        """The mesh file's path: relative to the scene's folder; absolute or ../ paths only when allow_outside."""
        if not isinstance(file, str) or not file or "\x00" in file:
            self.fail(key, f"expected a path, got {show(file)}")
        from .confine import scene_file

        return scene_file(self.base_dir, file, self.root, f"{self.where}: {key}")

    def generator(self, o, path):
        """(name, params) of a built-in mesh: `generator` names a function of clrender.scene.meshes, `params` its keyword arguments."""
        gen = self.choice(o, "generator", path, None, MESH_GENERATORS)
        params = self.table(o.get("params", {}), f"{path}.params")
        bounds = GENERATOR_PARAMS[gen]
        for key in params:
            if key not in bounds:
                self.fail(f"{path}.params.{key}", f"unknown parameter of generator {gen!r}; allowed: {', '.join(bounds)}")
        return gen, {key: self.integer(params, key, f"{path}.params", low=low, high=high) for key, (low, high) in bounds.items() if key in params}


def transform_matrix(translate=(0, 0, 0), rotate_degrees=(0, 0, 0), scale=(1, 1, 1)) -> np.ndarray:
    """4x4 matrix: scale, then rotate about x, y, z (degrees, in that order), then translate."""
    rx, ry, rz = np.radians(rotate_degrees)
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    m = np.eye(4)
    m[:3, :3] = Rz @ Ry @ Rx @ np.diag(scale)
    m[:3, 3] = translate
    return m


def load_mesh_file(path: Path, what: str, root=None):
    """A trimesh.Trimesh from any format trimesh reads, checked for emptiness, NaNs and face indices."""
    import trimesh

    from ..errors import MAX_SHOWN, first_line, one_line, shown

    if not path.is_file():
        raise UsageError(f"{what}: mesh file {str(path)!r} does not exist")
    try:
        from .confine import trimesh_resolver

        # a confined scene's mesh reads its materials, images and buffers through confine.py too
        resolver = None if root is None else trimesh_resolver(path, root)
        tm = trimesh.load(str(path), force="mesh", process=False, resolver=resolver)
    except Exception as exc:  # trimesh raises many kinds for malformed files
        # On undecodable text trimesh reaches for an optional encoding guesser (charset_normalizer):
        # the missing module is trimesh's detail, the file is the user's problem.
        kind = one_line(path.suffix.lstrip(".").upper() or "a mesh", 20)
        if isinstance(exc, ImportError) and exc.name == "charset_normalizer":
            reason = "not text in a known encoding"
        elif isinstance(exc, ImportError):
            reason = f"reading {kind} needs the Python module {exc.name}, which is not installed"
        else:
            reason = first_line(str(exc)) or type(exc).__name__
        raise UsageError(f"{what}: cannot parse mesh {shown(path)} as {kind} ({one_line(reason, MAX_SHOWN)})") from None
    if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
        raise UsageError(f"{what}: mesh {str(path)!r} has no triangles")
    faces = np.asarray(tm.faces)
    if not 0 <= faces.min() <= faces.max() < len(tm.vertices):  # numpy would wrap -1 silently, or raise IndexError
        bad = faces.min() if faces.min() < 0 else faces.max()
        raise UsageError(f"{what}: mesh {shown(path)} has face index {bad}; allowed: 0 to {len(tm.vertices) - 1} (its vertices)")
    if not np.isfinite(tm.vertices).all():
        raise UsageError(f"{what}: mesh {str(path)!r} has NaN or infinite vertices")
    return tm
