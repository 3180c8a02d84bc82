"""Scenes: TOML files, or the same structure as a Python dict.

A scene file is exactly the dict `Scene.from_dict` takes, so anything a user
can write in TOML they can build in Python.  Every key and its default is
listed in the README's scene-format table.  Errors name the file, the key
and what is allowed.
"""
from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .camera import Camera
from .errors import UsageError
from .package_data import data_dir
from .lights import FALLOFFS, LIGHT_TYPES, Light
from .materials import DEFAULT_MATERIAL, Material

MESH_GENERATORS = ("bunny", "wizard_hat", "tower", "cat", "dense")


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

    # ------------------------------------------------------------------ loading
    @classmethod
    def from_file(cls, path) -> "Scene":
        path = Path(path)
        if not path.is_file():
            raise UsageError(f"scene file {str(path)!r} does not exist")
        try:
            data = tomllib.loads(path.read_text())
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise UsageError(f"{path}: not valid TOML ({exc})") from None
        return cls.from_dict(data, base_dir=path.parent, where=str(path), name=path.stem)

    @classmethod
    def from_dict(cls, data: dict, base_dir=".", where: str = "<dict>", name: str = "scene") -> "Scene":
        return _SceneReader(Path(base_dir), where).read(data, name)

    @classmethod
    def load(cls, name_or_path) -> "Scene":
        """A bundled scene by name (see `bundled_scenes()`), or a scene file by path."""
        if isinstance(name_or_path, Scene):
            return name_or_path
        if isinstance(name_or_path, dict):
            return cls.from_dict(name_or_path)
        text = str(name_or_path)
        bundled = bundled_scenes()
        if text in bundled:
            return cls.from_file(bundled[text])
        path = Path(text)
        if path.suffix == ".toml" or path.exists():
            return cls.from_file(path)
        raise UsageError(f"unknown scene {text!r}; bundled scenes: {', '.join(sorted(bundled))}, or a path to a .toml file")

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


# ---------------------------------------------------------------------- reading
class _SceneReader:
    def __init__(self, base_dir: Path, where: str):
        self.base_dir = base_dir
        self.where = where

    def fail(self, key: str, message: str):
        raise UsageError(f"{self.where}: {key}: {message}")

    # typed getters ---------------------------------------------------------
    def table(self, data, key):
        if not isinstance(data, dict):
            self.fail(key, f"expected a table, got {type(data).__name__}")
        return data

    def check_keys(self, data: dict, key: str, allowed):
        unknown = sorted(set(data) - set(allowed))
        if unknown:
            self.fail(f"{key}.{unknown[0]}" if key else unknown[0], f"unknown key; allowed: {', '.join(sorted(allowed))}")

    def number(self, data, key, path, default=None, *, low=None, low_open=False, high=None):
        value = data.get(key, default)
        full = f"{path}.{key}" if path else key
        if value is None:
            self.fail(full, "is required (a number)")
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(full, f"expected a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            self.fail(full, f"expected a finite number, got {value!r}")
        if low is not None and (value <= low if low_open else value < low):
            self.fail(full, f"must be {'>' if low_open else '>='} {low:g}, got {value:g}")
        if high is not None and value > high:
            self.fail(full, f"must be <= {high:g}, got {value:g}")
        return value

    def integer(self, data, key, path, default=None, *, low=None):
        value = data.get(key, default)
        full = f"{path}.{key}" if path else key
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(full, f"expected an integer, got {value!r}")
        if low is not None and value < low:
            self.fail(full, f"must be >= {low}, got {value}")
        return value

    def vec3(self, data, key, path, default=None, *, nonzero=False):
        value = data.get(key, default)
        full = f"{path}.{key}" if path else key
        if value is None:
            self.fail(full, "is required (a list of 3 numbers)")
        if (not isinstance(value, (list, tuple)) or len(value) != 3
                or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value)):
            self.fail(full, f"expected a list of 3 numbers, got {value!r}")
        vec = tuple(float(v) for v in value)
        if not all(math.isfinite(v) for v in vec):
            self.fail(full, f"expected finite numbers, got {value!r}")
        if nonzero and not any(vec):
            self.fail(full, "must not be the zero vector")
        return vec

    def choice(self, data, key, path, default, allowed):
        value = data.get(key, default)
        if value not in allowed:
            self.fail(f"{path}.{key}", f"{value!r} is not one of {', '.join(map(repr, allowed))}")
        return value

    def boolean(self, data, key, path, default):
        value = data.get(key, default)
        if not isinstance(value, bool):
            self.fail(f"{path}.{key}", f"expected true or false, got {value!r}")
        return value

    # sections ----------------------------------------------------------------
    def read(self, data: dict, name: str) -> Scene:
        self.table(data, "scene")
        self.check_keys(data, "", ("width", "height", "background", "ambient", "cameras", "materials", "lights", "objects", "name"))
        scene = Scene(name=str(data.get("name", name)))
        scene.width = self.integer(data, "width", "", 640, low=1)
        scene.height = self.integer(data, "height", "", 480, low=1)
        scene.background = self.vec3(data, "background", "", (0.0, 0.0, 0.0))
        scene.ambient = self.vec3(data, "ambient", "", (0.0, 0.0, 0.0))
        cameras = data.get("cameras", [{}])
        if not isinstance(cameras, list) or not cameras:
            self.fail("cameras", "expected a non-empty list of camera tables")
        scene.cameras = [self.camera(c, f"cameras[{i}]") for i, c in enumerate(cameras)]
        materials = self.table(data.get("materials", {}), "materials")
        scene.materials = {"default": DEFAULT_MATERIAL}
        scene.materials.update({k: self.material(v, f"materials.{k}") for k, v in materials.items()})
        scene.lights = [self.light(l, f"lights[{i}]") for i, l in enumerate(self.list(data, "lights"))]
        objects = []
        for i, o in enumerate(self.list(data, "objects")):
            objects.append(self.object(o, f"objects[{i}]", scene.materials))
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
        cam = Camera(
            position=self.vec3(c, "position", path, (0.0, 0.0, 0.0)),
            look_at=self.vec3(c, "look_at", path, (0.0, 0.0, -1.0)),
            up=self.vec3(c, "up", path, (0.0, 1.0, 0.0), nonzero=True),
            fov=self.number(c, "fov", path, 60.0, low=0.0, low_open=True, high=179.0),
        )
        forward = np.subtract(cam.look_at, cam.position)
        if not forward.any():
            self.fail(f"{path}.look_at", "must differ from position")
        if np.linalg.norm(np.cross(forward, cam.up)) < 1e-9 * np.linalg.norm(forward) * np.linalg.norm(cam.up):
            self.fail(f"{path}.up", "must not be parallel to the viewing direction")
        return cam

    def material(self, m, path) -> Material:
        self.table(m, path)
        self.check_keys(m, path, ("diffuse", "specular", "shininess", "mirror", "transparency", "ior"))
        d = DEFAULT_MATERIAL
        return Material(
            diffuse=self.vec3(m, "diffuse", path, d.diffuse),
            specular=self.vec3(m, "specular", path, d.specular),
            shininess=self.number(m, "shininess", path, d.shininess, low=0.0),
            mirror=self.number(m, "mirror", path, d.mirror, low=0.0, high=1.0),
            transparency=self.number(m, "transparency", path, d.transparency, low=0.0, high=1.0),
            ior=self.number(m, "ior", path, d.ior, low=0.0, low_open=True),
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
            color=self.vec3(l, "color", path, d.color),
            intensity=self.number(l, "intensity", path, d.intensity, low=0.0),
            falloff=self.choice(l, "falloff", path, "none", tuple(FALLOFFS)),
        )
        if kind == "point":
            args["position"] = self.vec3(l, "position", path)
        elif kind == "directional":
            args["direction"] = self.vec3(l, "direction", path, nonzero=True)
        else:
            args["position"] = self.vec3(l, "corner", path)
            args["edge_a"] = self.vec3(l, "edge_a", path, nonzero=True)
            args["edge_b"] = self.vec3(l, "edge_b", path, nonzero=True)
            args["samples"] = self.integer(l, "samples", path, 5, low=1)
        return Light(**args)

    def material_ref(self, o, path, materials):
        name = o.get("material", "default")
        if name not in materials:
            self.fail(f"{path}.material", f"unknown material {name!r}; defined: {', '.join(sorted(materials))}")
        return name

    def object(self, o, path, materials):
        self.table(o, path)
        kind = self.choice(o, "type", path, None, ("sphere", "triangle", "quad", "plane", "mesh"))
        if kind == "sphere":
            self.check_keys(o, path, ("type", "center", "radius", "material"))
            return Sphere(self.vec3(o, "center", path), self.number(o, "radius", path, low=0.0, low_open=True),
                          self.material_ref(o, path, materials))
        if kind == "triangle":
            self.check_keys(o, path, ("type", "vertices", "material"))
            verts = o.get("vertices")
            if not isinstance(verts, list) or len(verts) != 3:
                self.fail(f"{path}.vertices", f"expected 3 points, got {verts!r}")
            points = np.array([self.vec3({"v": v}, "v", f"{path}.vertices[{i}]") for i, v in enumerate(verts)])
            return Mesh(points, np.array([[0, 1, 2]]), material=self.material_ref(o, path, materials), source=path)
        if kind in ("quad", "plane"):
            if kind == "quad":
                self.check_keys(o, path, ("type", "corner", "edge_a", "edge_b", "material"))
                corner = np.array(self.vec3(o, "corner", path))
                a = np.array(self.vec3(o, "edge_a", path, nonzero=True))
                b = np.array(self.vec3(o, "edge_b", path, nonzero=True))
            else:
                # A plane is a large square centred on `point` (ray tracers need finite bounds).
                self.check_keys(o, path, ("type", "point", "normal", "size", "material"))
                point = np.array(self.vec3(o, "point", path, (0.0, 0.0, 0.0)))
                normal = np.array(self.vec3(o, "normal", path, (0.0, 1.0, 0.0), nonzero=True))
                size = self.number(o, "size", path, 1000.0, low=0.0, low_open=True)
                normal /= np.linalg.norm(normal)
                helper = np.array([1.0, 0, 0]) if abs(normal[0]) < 0.9 else np.array([0, 0, 1.0])
                b = np.cross(normal, helper)
                b *= size / np.linalg.norm(b)
                a = np.cross(b, normal)
                corner = point - 0.5 * (a + b)
            verts = np.array([corner, corner + a, corner + a + b, corner + b])
            return Mesh(verts, np.array([[0, 1, 2], [0, 2, 3]]), material=self.material_ref(o, path, materials), source=path)
        return self.mesh(o, path, materials)

    def mesh(self, o, path, materials) -> Mesh:
        self.check_keys(o, path, ("type", "file", "generator", "params", "translate", "rotate", "scale", "smooth", "material"))
        if ("file" in o) == ("generator" in o):
            self.fail(path, "a mesh needs exactly one of 'file' or 'generator'")
        if "file" in o:
            file = o["file"]
            if not isinstance(file, str):
                self.fail(f"{path}.file", f"expected a path, got {file!r}")
            tm = load_mesh_file(self.base_dir / file, f"{self.where}: {path}.file")
            source = file
        else:
            tm = self.generated_mesh(o, path)
            source = o["generator"]
        scale = o.get("scale", 1.0)
        if isinstance(scale, (int, float)) and not isinstance(scale, bool):
            scale = (float(scale),) * 3
        else:
            scale = self.vec3(o, "scale", path)
        if not all(math.isfinite(s) and s != 0 for s in scale):
            self.fail(f"{path}.scale", f"must be non-zero finite numbers, got {o.get('scale')!r}")
        rotate = self.vec3(o, "rotate", path, (0.0, 0.0, 0.0))
        translate = self.vec3(o, "translate", path, (0.0, 0.0, 0.0))
        matrix = transform_matrix(translate, rotate, scale)
        vertices = np.asarray(tm.vertices, np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
        smooth = self.boolean(o, "smooth", path, False)
        normals = None
        if smooth:
            # Normals transform by the inverse transpose; renormalise afterwards.
            n = np.asarray(tm.vertex_normals, np.float64) @ np.linalg.inv(matrix[:3, :3])
            normals = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        return Mesh(vertices, np.asarray(tm.faces, np.int64), normals, self.material_ref(o, path, materials), smooth, source)


    def generated_mesh(self, o, path):
        """A built-in mesh: `generator` names a function of clrender.meshes, `params` its keyword arguments."""
        import inspect

        from . import meshes

        gen = self.choice(o, "generator", path, None, MESH_GENERATORS)
        params = self.table(o.get("params", {}), f"{path}.params")
        function = getattr(meshes, gen)
        accepted = [p for p in inspect.signature(function).parameters]
        for key, value in params.items():
            if key not in accepted:
                self.fail(f"{path}.params.{key}", f"unknown parameter of generator {gen!r}; allowed: {', '.join(accepted) or 'none'}")
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                self.fail(f"{path}.params.{key}", f"expected a number, got {value!r}")
        return function(**params)


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


def load_mesh_file(path: Path, what: str):
    """A trimesh.Trimesh from any format trimesh reads, checked for emptiness and NaNs."""
    import trimesh

    if not path.is_file():
        raise UsageError(f"{what}: mesh file {str(path)!r} does not exist")
    try:
        tm = trimesh.load(str(path), force="mesh", process=False)
    except Exception as exc:  # trimesh raises many kinds for malformed files
        raise UsageError(f"{what}: cannot read mesh {str(path)!r} ({exc})") from None
    if not isinstance(tm, trimesh.Trimesh) or len(tm.faces) == 0:
        raise UsageError(f"{what}: mesh {str(path)!r} has no triangles")
    if not np.isfinite(tm.vertices).all():
        raise UsageError(f"{what}: mesh {str(path)!r} has NaN or infinite vertices")
    return tm
