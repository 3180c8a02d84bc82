"""Scenes: TOML files, or the same structure as a Python dict.

A scene file is exactly the dict `Scene.from_dict` takes, so anything a user
can write in TOML they can build in Python.  Every key and its default is
listed in docs/scene-format.md's key table.  Errors name the file, the key
and what is allowed.

Each table is read by its own reader next to what it builds (camera.py, materials.py, lights.py, and
the objects here), with its keys declared once as a `checks.TypeReader`; the checks they share live in
checks.py.  Imports go one way: this module imports gltf.py (which reads a glTF file into the dict
`Scene.from_dict` takes, and a node's triangles), never the reverse.
"""

from __future__ import annotations

import functools
import io
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..layout import PATH_SAMPLERS, PATH_SCHEDULES
from ..package_data import data_dir
from . import environment, gltf, obj_mtl, textures
from .camera import Camera, read_camera

# The limits and the shared checks live in checks.py (every reader imports them); named here too for older callers.
from .checks import (  # noqa: F401
    COORD_LIMIT,
    FOV_RANGE,
    GENERATOR_PARAMS,
    IOR_RANGE,
    MAX_AREA_SAMPLES,
    MAX_CAMERAS,
    MAX_LIGHTS,
    MAX_MATERIALS,
    MAX_MESSAGE,
    MAX_NAME,
    MAX_NESTING,
    MAX_OBJECTS,
    MAX_SIDE,
    MAX_TRIANGLES,
    MAX_VALUES,
    MESH_GENERATORS,
    MIN_LENGTH,
    RADIANCE_LIMIT,
    RELATIVE_PRECISION,
    SEED_RANGE,
    SHININESS_LIMIT,
    UV_LIMIT,
    Checks,
    TypeReader,
    as_float,
    escape,
    is_number,
    shorten,
    show,
)
from .lights import Light, read_light
from .materials import DEFAULT_MATERIAL, Material, read_material
from .mesh_files import load_mesh_file
from .shapes import Instance, Shape, mirrored_faces, vertex_attributes
from .toml_text import read_toml


@dataclass
class Sphere:
    center: tuple
    radius: float
    material: str = "default"


@dataclass
class Mesh:
    """Triangles with optional per-vertex normals (used when `smooth`): a shape (shapes.py) placed in the scene.

    A mesh read from a file or a generator keeps only what places it (`placed`): its world vertices and
    normals are made on first read and then kept (`world_made` says which), so 30 objects naming one
    file hold one array until something (the flat Tracer) asks for each copy; the instanced Tracer never does.
    """

    vertices: np.ndarray | None  # (V, 3) float64 in world space; None: made from `placed` on first read
    faces: np.ndarray  # (F, 3) int
    vertex_normals: np.ndarray | None = None  # (V, 3) unit normals for smooth shading (from `placed` when it has normals)
    material: str = "default"
    smooth: bool = False  # interpolate vertex normals (True) or use each face's normal
    source: str = ""  # file or generator it came from, for messages
    uvs: np.ndarray | None = None  # (V, 2) texture coordinates (glTF's convention: (0, 0) the image's top-left)
    uvs1: np.ndarray | None = None  # (V, 2) a second set (glTF TEXCOORD_1)
    colours: np.ndarray | None = None  # (V, 3) linear RGB vertex colours, multiplying the base colour
    tangents: np.ndarray | None = None  # (V, 4) unit tangents along +u and the bitangent's sign (glTF TANGENT); None: from the UVs
    file_material: dict | None = None  # an OBJ's .mtl material (textures.mtl_material), made a scene material on reading
    # the shape it places and where (shapes.Instance; clrender/trace/instancing.py): None for a mesh made in code
    instance: Instance | None = None
    # What vertices and vertex_normals are made from on first read: (points, normals or None, 4x4 matrix M), the
    # points placed by M and the normals by its inverse transpose.  A file's or generator's: the instance's vertices
    # and to_world; a glTF node's: the node's world vertices and the object's own transform (the order the loader
    # always used, so the world vertices are the same bits however they are made).
    placed: tuple | None = field(default=None, repr=False)

    def __post_init__(self):
        for name in _LAZY_FIELDS:  # None and placed given: read through _MadeOnFirstRead
            if self.__dict__.get(name, 0) is None and self.placed is not None and (name == "vertices" or self.placed[1] is not None):
                del self.__dict__[name]

    @property
    def shape_key(self) -> tuple | None:
        """The shape this mesh places (shapes.Instance.shape_key): equal keys, one object-space mesh."""
        return None if self.instance is None else self.instance.shape_key

    @property
    def local_vertices(self) -> np.ndarray | None:
        """(V, 3) float64 object-space vertices, one array for every copy (shapes.Instance.vertices)."""
        return None if self.instance is None else self.instance.vertices

    @property
    def to_world(self) -> np.ndarray | None:
        """(4, 4) object-to-world matrix (shapes.Instance.to_world)."""
        return None if self.instance is None else self.instance.to_world

    @property
    def has_vertex_normals(self) -> bool:
        """Whether vertex_normals is an array (given, or to be made from `placed`), without making it."""
        if "vertex_normals" in self.__dict__:
            return self.__dict__["vertex_normals"] is not None
        return self.placed is not None and self.placed[1] is not None

    @property
    def world_made(self) -> tuple:
        """The names of the world arrays this mesh holds (made on reading, or given)."""
        return tuple(name for name in _LAZY_FIELDS if self.__dict__.get(name) is not None)


def _place_points(placed) -> np.ndarray:
    points, _, matrix = placed
    with np.errstate(over="ignore", invalid="ignore"):  # a huge file coordinate times scale: _check_placed refused it
        return np.asarray(points, np.float64) @ matrix[:3, :3].T + matrix[:3, 3]


def _place_normals(placed) -> np.ndarray:
    _, local, matrix = placed
    n = local @ np.linalg.inv(matrix[:3, :3])  # normals transform by the inverse transpose; renormalised afterwards
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)


class _MadeOnFirstRead:
    """A Mesh field made from `placed` when first read and kept in the instance (a non-data descriptor, like
    functools.cached_property: once the instance holds the value, reads never come here again)."""

    def __init__(self, name: str, make):
        self.name, self.make = name, make

    def __get__(self, mesh, owner=None):
        if mesh is None:
            return self
        value = mesh.__dict__[self.name] = self.make(mesh.placed)
        mesh.__dict__.setdefault("_made_here", set()).add(self.name)
        return value

    def given(self, mesh):
        """The value as the mesh was given it: None when it is (or would be) made from `placed`, so that
        payload.py ships `placed` alone and the worker makes the same bits."""
        if self.name in mesh.__dict__.get("_made_here", ()):
            return None
        return mesh.__dict__.get(self.name)


_LAZY_FIELDS = ("vertices", "vertex_normals")
Mesh.vertices = _MadeOnFirstRead("vertices", _place_points)
Mesh.vertex_normals = _MadeOnFirstRead("vertex_normals", _place_normals)


@dataclass
class Scene:
    cameras: list = field(default_factory=lambda: [Camera()])  # camera 1 is cameras[0]
    width: int = 640  # default image width in pixels
    height: int = 480  # default image height in pixels
    background: tuple = (0.0, 0.0, 0.0)  # colour of rays that hit nothing (linear RGB)
    ambient: tuple = (0.0, 0.0, 0.0)  # ambient light, multiplied by each material's diffuse colour
    environment: tuple = (0.0, 0.0, 0.0)  # path tracer: radiance arriving from every direction that meets nothing (linear RGB)
    environment_map: environment.EnvironmentMap | None = None  # an image instead: both integrators' escaping rays see it
    materials: dict = field(default_factory=lambda: {"default": DEFAULT_MATERIAL})
    lights: list = field(default_factory=list)
    objects: list = field(default_factory=list)  # Sphere and Mesh, in file order; index = object id
    textures: list = field(default_factory=list)  # decoded textures (textures.TextureImage) the materials index
    name: str = "scene"
    description: str = ""  # one line shown by `clrender render --list`
    default_camera: int = 1  # the view the scene is made for, marked * by `render --list`: `render` uses it when --camera is not given
    aa: str | None = None  # the anti-aliasing `render` uses when --aa is not given (None: the command line's default, none)
    path_sampler: str | None = None  # the path tracer's sampler `render` uses when --path-sampler is not given (None: sobol)
    path_schedule: str | None = None  # the path tracer's schedule `render` uses when --path-schedule is not given (None: lanes)
    default_lighting: bool = False  # lights, fill and environment are framing.py's (the file brought none): --env replaces them
    render_settings: dict = field(default_factory=dict)  # a foreign file's own (foreign.py): integrator, spp, max_depth, rfilter
    substitutions: list = field(default_factory=list)  # a foreign file read with approximate=True: the stand-ins used, one line each

    @property
    def featured_camera(self) -> int:
        """An older name of `default_camera` (as is `seed_camera`), still accepted."""
        return self.default_camera

    @featured_camera.setter
    def featured_camera(self, value: int) -> None:
        self.default_camera = value

    seed_camera = featured_camera

    # ------------------------------------------------------------------ loading
    @classmethod
    def from_file(cls, path, allow_outside: bool = True, defines: dict | None = None, approximate: bool = False) -> Scene:
        """Read a TOML scene file (or a glTF file, a Mitsuba 3 `.xml` or a pbrt-v4 `.pbrt` file: foreign.py, which take
        `defines`, the `-D name=value` parameters, and `approximate`); mesh paths are relative to its folder (see
        `from_dict` for allow_outside)."""
        path = Path(path)
        from .foreign import is_foreign

        if is_foreign(path):
            return _load_foreign(path, defines, approximate, allow_outside)
        if path.suffix.lower() in (".gltf", ".glb"):
            return _load_gltf(path, allow_outside=allow_outside)
        if path.suffix.lower() in MESH_SUFFIXES:  # a bare mesh, framed and lit by framing.py
            return _load_mesh_scene(path, allow_outside=allow_outside)
        where = escape(str(path))
        if not path.is_file():
            raise UsageError(f"scene file {shorten(where, 200)!r} does not exist")
        try:
            data = read_toml(path, where, MAX_NESTING)  # its size and dotted keys bounded before tomllib parses it
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            if path.suffix.lower() != ".toml":  # not a scene file of any kind: say which kinds there are
                kind = escape(path.suffix) or "no suffix"
                message = f"{shorten(where, 200)}: neither a TOML scene nor a file type clrender reads ({kind}); {SCENE_FILES}"
                raise UsageError(shorten(message, MAX_MESSAGE)) from None
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
        return _read_scene(Checks(where, Path(base_dir), allow_outside), data, name)

    @classmethod
    def load(cls, name_or_path) -> Scene:
        """A bundled scene by name (see `bundled_scenes()`), or by path a .toml scene file, a .gltf/.glb file or
        a mesh file (.obj, .ply, .stl, .off: framed and lit by framing.py)."""
        if isinstance(name_or_path, Scene):
            return name_or_path
        if isinstance(name_or_path, dict):
            return cls.from_dict(name_or_path)
        if not isinstance(name_or_path, (str, os.PathLike)):  # str() of an array or a number would read as a file name
            got = f"a numpy array of shape {name_or_path.shape}" if isinstance(name_or_path, np.ndarray) else type(name_or_path).__name__
            raise UsageError(f"a scene is a Scene, a scene dict, a bundled scene name or a path (str or os.PathLike); got {got}")
        text = str(name_or_path)
        bundled = bundled_scenes()
        if text in bundled:
            return cls.from_file(bundled[text])
        path = Path(text)
        if path.suffix.lower() in (".gltf", ".glb"):  # a glTF 2.0 file with its cameras, lights and materials
            return _load_gltf(path)
        if path.suffix.lower() in MESH_SUFFIXES:  # a bare mesh with the default camera and lights
            return _load_mesh_scene(path)
        if path.suffix.lower() in (".xml", ".pbrt"):  # another renderer's scene file (foreign.py)
            return cls.from_file(path)
        if path.suffix == ".toml" or path.exists():
            return cls.from_file(path)
        files = f"a .toml scene file, a .gltf/.glb file or a mesh file ({', '.join(MESH_SUFFIXES)})"
        raise UsageError(f"unknown scene {text!r}; bundled scenes: {', '.join(sorted(bundled))}, or {files}")

    def camera(self, number: int) -> Camera:
        """Camera `number`, counting from 1 as the command line does."""
        if not 1 <= number <= len(self.cameras):
            raise UsageError(f"camera {number} does not exist in scene {self.name!r}; allowed: 1 to {len(self.cameras)}")
        return self.cameras[number - 1]

    @property
    def triangle_count(self) -> int:
        return sum(len(o.faces) for o in self.objects if isinstance(o, Mesh))

    @property
    def has_vertex_attributes(self) -> bool:
        """Whether the device gets every triangle's uvs, vertex colours and tangents (geometry.Primitives.any_attributes)."""
        has = lambda m: any(getattr(m, k) is not None for k in ("uvs", "uvs1", "colours", "tangents"))
        return bool(self.textures) or any(has(o) for o in self.objects if isinstance(o, Mesh))

    @property
    def sphere_count(self) -> int:
        return sum(isinstance(o, Sphere) for o in self.objects)


def bundled_scenes() -> dict:
    """Name -> path of every scene shipped in the package."""
    folder = data_dir("scenes")
    return {p.stem: p for p in sorted(folder.glob("*.toml"))}


# ---------------------------------------------------------------------- reading
# The top level's keys; each section's tables are read by the readers of camera.py, materials.py,
# lights.py and OBJECT_READERS below, each declaring its own keys (tested against docs/scene-format.md).
TOP_KEYS = (
    "width",
    "height",
    "background",
    "ambient",
    "environment",
    "cameras",
    "materials",
    "lights",
    "objects",
    "name",
    "description",
    "default_camera",
    "aa",
    "textures",
    "path_sampler",
    "path_schedule",
)
# Older spellings of top-level keys, still accepted: each is read as the key it names (docs/scene-format.md)
OLD_TOP_KEYS = {"featured_camera": "default_camera", "seed_camera": "default_camera"}
# `[environment]`: what the path tracer sees in every direction that meets nothing, a colour or an image
# (environment.py; an image is what the Whitted tracer's escaping rays see too)
ENVIRONMENT_READER = environment.ENVIRONMENT_READER


def _read_scene(checks: Checks, data: dict, name: str) -> Scene:
    checks.check_shape(data)
    data = _renamed_keys(checks, data)
    checks.check_keys(data, "", TOP_KEYS)
    data = _expand_model_files(checks, data)
    scene = Scene(name=checks.name(data.get("name", name), "name"))
    scene.width = checks.integer(data, "width", "", 640, low=1, high=MAX_SIDE)
    scene.height = checks.integer(data, "height", "", 480, low=1, high=MAX_SIDE)
    scene.background = checks.vec3(data, "background", "", (0.0, 0.0, 0.0), kind="colour")
    scene.ambient = checks.vec3(data, "ambient", "", (0.0, 0.0, 0.0), kind="colour")
    cameras = data.get("cameras", [{}])
    if not isinstance(cameras, list) or not cameras:
        checks.fail("cameras", "expected a non-empty list of camera tables")
    cameras = checks.counted(data, "cameras", MAX_CAMERAS) if "cameras" in data else cameras
    scene.cameras = [read_camera(checks, c, f"cameras[{i}]") for i, c in enumerate(cameras)]
    scene.description = checks.name(data["description"], "description") if "description" in data else ""
    scene.default_camera = checks.integer(data, "default_camera", "", 1, low=1, high=len(scene.cameras))
    scene.aa = checks.choice(data, "aa", "", None, ("none", "full", "edge_detect")) if "aa" in data else None
    scene.path_sampler = checks.choice(data, "path_sampler", "", None, tuple(PATH_SAMPLERS)) if "path_sampler" in data else None
    scene.path_schedule = checks.choice(data, "path_schedule", "", None, PATH_SCHEDULES) if "path_schedule" in data else None
    materials = checks.table(data.get("materials", {}), "materials")
    if len(materials) > MAX_MATERIALS:
        checks.fail("materials", f"{len(materials)} materials; allowed: at most {MAX_MATERIALS}")
    scene.materials = {"default": DEFAULT_MATERIAL}
    scene.materials.update({checks.name(k, "materials"): read_material(checks, v, f"materials.{k}") for k, v in materials.items()})
    scene.lights = [read_light(checks, l, f"lights[{i}]") for i, l in enumerate(checks.counted(data, "lights", MAX_LIGHTS))]
    specs = textures.read_specs(checks, data.get("textures", {}))
    entries = checks.counted(data, "objects", MAX_OBJECTS)
    for i, o in enumerate(entries):  # every cheap check before any mesh is built or loaded
        read_object(checks, o, f"objects[{i}]", scene.materials, False)
    scene.materials, scene.textures = textures.resolve(checks, specs, scene.materials)
    if "environment" in data:  # after the cheap checks: an image map is read here
        env = ENVIRONMENT_READER.read(checks, checks.table(data["environment"], "environment"), "environment")
        if isinstance(env, environment.EnvironmentMap):
            scene.environment_map = env
        else:
            scene.environment = env
    else:  # no [environment]: the path tracer's rays that meet nothing see `background`, as the Whitted tracer's do
        scene.environment = scene.background
    objects = []
    triangles = 0
    for i, o in enumerate(entries):
        obj = read_object(checks, o, f"objects[{i}]", scene.materials, True)
        if isinstance(obj, Mesh):
            triangles += len(obj.faces)
            if triangles > MAX_TRIANGLES:
                checks.fail(f"objects[{i}]", f"the scene has more than {MAX_TRIANGLES} triangles")
        objects.append(obj)
    scene.objects = objects
    _adopt_file_materials(checks, scene)
    return scene


def _renamed_keys(checks: Checks, data: dict) -> dict:
    """`data` with each older key spelling (OLD_TOP_KEYS) under today's name; two spellings of one key are refused."""
    for old, new in OLD_TOP_KEYS.items():
        if old in data:
            if new in data:
                checks.fail(old, f"is an older name of {new}; give only {new}")
            data = {(new if k == old else k): v for k, v in data.items()}
    return data


def _expand_model_files(checks: Checks, data: dict) -> dict:
    """A mesh object whose `file` is a glTF file, with neither `node` nor `material`, becomes one object per
    primitive of the file, each in the file's own material (renamed FILE:NAME, its textures FILE:texture_N),
    placed by its node and then by the object's own scale, rotate and translate: the model as the file made it.
    Naming a `material` keeps the old meaning (every triangle of the file in that material)."""
    entries = data.get("objects")
    if not isinstance(entries, list) or not any(_is_model_file(o) for o in entries):
        return data
    data = dict(data)
    materials, texture_specs = dict(checks.table(data.get("materials", {}), "materials")), dict(checks.table(data.get("textures", {}), "textures"))
    objects = []
    for i, o in enumerate(entries):
        if not _is_model_file(o):
            objects.append(o)
            continue
        model = gltf.scene_dict(_mesh_path(checks, o["file"], f"objects[{i}].file"), root=checks.root, keep=True)
        prefix = f"{o['file']}:"
        for name, spec in model["textures"].items():
            texture_specs[prefix + name] = {**spec, "file": o["file"]}
        for name, table in model["materials"].items():
            materials[prefix + name] = {k: ({**v, "texture": prefix + v["texture"]} if k.endswith("_texture") else v) for k, v in table.items()}
        own = {k: v for k, v in o.items() if k != "smooth"}  # its transform; any other key is refused by the mesh reader as before
        for part in model["objects"]:
            material = "default" if part["material"] == "default" else prefix + part["material"]
            smooth = o["smooth"] if not isinstance(o.get("smooth", False), bool) else part["smooth"] or o.get("smooth", False)
            objects.append({**part, **own, "material": material, "smooth": smooth})
    data.update(objects=objects, materials=materials, textures=texture_specs)
    return data


def _is_model_file(o) -> bool:
    """A mesh object naming a whole glTF file and no material (_expand_model_files)."""
    return (
        isinstance(o, dict)
        and o.get("type") == "mesh"
        and isinstance(o.get("file"), str)
        and o["file"].lower().endswith((".gltf", ".glb"))
        and "node" not in o
        and "material" not in o
    )


def _adopt_file_materials(checks: Checks, scene) -> None:
    """Every mesh's file material (mtl_material) becomes a scene material named after the file and its material,
    its map_Kd image a texture; the mesh then uses it.  The meshes keep no reference to trimesh's objects.
    Objects naming one file share its material: its image is decoded once."""
    from ..memory import require

    adopted = set()  # names made here: a second copy of a file uses the first's material and texture
    for obj in scene.objects:
        found = getattr(obj, "file_material", None)
        if found is None:
            continue
        obj.file_material = None
        found = dict(found)
        image, name = found.pop("image"), f"{obj.source}:{found.pop('name')}"
        if name in adopted:
            obj.material = name
            continue
        adopted.add(name)
        ref = None
        if isinstance(image, Path):  # an OBJ's map_Kd, checked by obj_mtl: decoded from its file
            pixels = textures.decode(image, srgb=True, what=f"{obj.source} map_Kd", require=require)
            ref = textures.TextureRef(texture=name, index=len(scene.textures))
            scene.textures.append(textures.TextureImage(pixels, source=f"{obj.source} map_Kd"))
        elif image is not None:
            buffer = io.BytesIO()
            try:
                image.save(buffer, format="PNG")
            except (OSError, ValueError) as exc:
                raise UsageError(f"{checks.where}: {obj.source}: its map_Kd image cannot be read ({exc})") from None
            pixels = textures.decode(buffer.getvalue(), srgb=True, what=f"{obj.source} map_Kd", require=require)
            ref = textures.TextureRef(texture=name, index=len(scene.textures))
            scene.textures.append(textures.TextureImage(pixels, source=f"{obj.source} map_Kd"))
        scene.materials[name] = Material(**found, base_color_texture=ref)
        obj.material = name


# Mesh files that are a whole scene on their own (`clrender render teapot.obj`): the formats of trimesh's
# that hold triangles (its .xyz is points, .dxf mostly 2D lines); glTF has its own reader.
MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off")
SCENE_FILES = f"allowed: a .toml scene, a .gltf/.glb file or a triangle mesh file ({', '.join(MESH_SUFFIXES)})"


# `up` of a bare mesh file: the rotation that turns that axis of the file into +y (the framing's up), about x or z
UP_AXES = {"y": (0.0, 0.0, 0.0), "z": (-90.0, 0.0, 0.0), "x": (0.0, 0.0, 90.0)}


def _load_mesh_scene(path, allow_outside: bool = True, up: str = "y", smooth: bool | None = None) -> Scene:
    """A scene of one mesh file, in its own material (an OBJ's .mtl, as a TOML `file =` object reads it) or else
        the default grey, seen and lit by framing.py's camera and lights (a glTF file's own cameras and lights are read
        by _load_gltf instead); allow_outside=False reads only files (an OBJ's materials) inside the file's folder.
    `up` ("y", "z" or "x"): the file's up axis, turned to +y (a Z-up file's front, -y, then faces the camera);
    `smooth`: interpolated vertex normals (None: framing.py's default, flat)."""
    from . import framing

    path = Path(path)
    settings = framing.FRAMING
    try:
        tm = load_mesh_file(path, "scene", root=None if allow_outside else path.parent)
    except UsageError as exc:  # what is wrong with the file, then what a scene may be
        raise UsageError(shorten(f"{exc}; {SCENE_FILES}", 2 * MAX_MESSAGE)) from None
    checks = Checks(escape(str(path)), path.parent, allow_outside)
    if len(tm.faces) > MAX_TRIANGLES:
        checks.fail("mesh", f"{len(tm.faces)} triangles; allowed: at most {MAX_TRIANGLES}")
    vertices = np.asarray(tm.vertices, np.float64)
    if up != "y":
        vertices = vertices @ transform_matrix(rotate_degrees=UP_AXES[up])[:3, :3].T
    _check_placed(checks, vertices, "mesh")
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    if not np.linalg.norm(hi - lo) >= MIN_LENGTH:  # the camera's distance follows the size: float32 needs some
        checks.fail("mesh", f"its bounding box is {np.linalg.norm(hi - lo):.3g} across; allowed: at least {MIN_LENGTH:g}")
    if not gltf.has_area(vertices, np.asarray(tm.faces)):  # nothing would be drawn: an empty frame
        checks.fail("mesh", "no triangle has an area (all are lines or points); allowed: a mesh with at least one proper triangle")
    rig = framing.rig(lo, hi, settings)
    normals = None
    smooth = settings.smooth if smooth is None else smooth
    if smooth:
        from .meshes import shading_normals

        normals = shading_normals(vertices, tm.faces)
    uvs, _, _, _ = vertex_attributes(tm)  # an OBJ's vt, for its map_Kd
    mesh = Mesh(vertices, np.asarray(tm.faces, np.int64), normals, "default", smooth, source=path.name, uvs=uvs)
    # an OBJ's .mtl, as a TOML `file =` object gets it
    mesh.file_material = textures.mtl_material(tm, tm.metadata.get(obj_mtl.METADATA_KEY, False))

    def fields(table: dict) -> dict:  # a scene dict's table as dataclass fields: lists as tuples, no `name`
        return {k: tuple(v) if isinstance(v, list) else v for k, v in table.items() if k != "name"}

    scene = Scene(
        cameras=[Camera(**fields(camera)) for camera in rig["cameras"]],
        width=rig["width"],
        height=rig["height"],
        ambient=tuple(rig["ambient"]),
        environment=tuple(rig["environment"]["color"]),
        lights=[Light(**fields(light)) for light in rig["lights"]],
        objects=[mesh],
        name=shorten(escape(path.stem), MAX_NAME) or "scene",
        description=f"{shorten(escape(path.name), 100)}: {len(tm.faces)} triangles, framed and lit by default",
        default_lighting=True,
    )
    _adopt_file_materials(checks, scene)
    return scene


def _load_gltf(path, allow_outside: bool = True) -> Scene:
    """A Scene of a glTF file (gltf.py reads it into a scene dict), checked as any scene file is;
    allow_outside=False reads only files (its buffers) inside the file's folder."""
    path = Path(path)
    from . import framing

    root = None if allow_outside else path.parent
    data = gltf.scene_dict(path, root, keep=True)
    scene = Scene.from_dict(data, base_dir=path.parent, where=str(path), name=path.stem, allow_outside=allow_outside)
    scene.default_lighting = data["lights"] == framing.lighting(data["cameras"][0])["lights"]  # the file brought none
    return scene


def _load_foreign(path: Path, defines, approximate: bool, allow_outside: bool) -> Scene:
    """A Scene of another renderer's file (foreign.py), carrying the file's render settings and the stand-ins used."""
    from .foreign import read_foreign

    foreign = read_foreign(path, defines, approximate, allow_outside)
    scene = Scene.from_dict(foreign.scene, base_dir=path.parent, where=str(path), name=path.stem, allow_outside=allow_outside)
    scene.render_settings, scene.substitutions = dict(foreign.settings), list(foreign.substitutions)
    return scene


# ---------------------------------------------------------------------- objects
def material_ref(checks: Checks, o, path, materials):
    name = o.get("material", "default")
    if not isinstance(name, str):
        checks.fail(f"{path}.material", f"expected a material name, got {show(name)}")
    if name not in materials:
        checks.fail(f"{path}.material", f"unknown material {show(name)}; defined: {shorten(', '.join(sorted(materials)), 100)}")
    return name


def read_object(checks: Checks, o, path, materials, build=True):
    """One entry of `objects`: its type first, then the keys that type accepts; with build=False only
    the checks that need no mesh to be built or read (a mesh then gives None)."""
    checks.table(o, path)
    kind = checks.choice(o, "type", path, None, tuple(OBJECT_READERS))
    return OBJECT_READERS[kind].read(checks, o, path, materials, build)


def _sphere(checks: Checks, o, path, materials, build) -> Sphere:
    center = checks.vec3(o, "center", path)
    radius = checks.length(o, "radius", path, max(map(abs, center)))
    return Sphere(center, radius, material_ref(checks, o, path, materials))


def _triangle(checks: Checks, o, path, materials, build) -> Mesh:
    verts = o.get("vertices")
    if not isinstance(verts, list) or len(verts) != 3:
        checks.fail(f"{path}.vertices", f"expected 3 points, got {show(verts)}")
    points = np.array([checks.vec3({"v": v}, "v", f"{path}.vertices[{i}]") for i, v in enumerate(verts)])
    return Mesh(points, np.array([[0, 1, 2]]), material=material_ref(checks, o, path, materials), source=path)


def _quad(checks: Checks, o, path, materials, build) -> Mesh:
    corner = np.array(checks.vec3(o, "corner", path))
    a = np.array(checks.vec3(o, "edge_a", path, kind="vector"))
    b = np.array(checks.vec3(o, "edge_b", path, kind="vector"))
    checks.not_parallel(a, b, f"{path}.edge_b")
    return _parallelogram(checks, o, path, materials, corner, a, b)


def _plane(checks: Checks, o, path, materials, build) -> Mesh:
    """A large square centred on `point` (ray tracers need finite bounds)."""
    point = np.array(checks.vec3(o, "point", path, (0.0, 0.0, 0.0)))
    normal = np.array(checks.vec3(o, "normal", path, (0.0, 1.0, 0.0), kind="vector"))
    size = checks.length(o, "size", path, np.abs(point).max(), 1000.0)
    normal /= np.linalg.norm(normal)
    helper = np.array([1.0, 0, 0]) if abs(normal[0]) < 0.9 else np.array([0, 0, 1.0])
    b = np.cross(normal, helper)
    b *= size / np.linalg.norm(b)
    a = np.cross(b, normal)
    corner = point - 0.5 * (a + b)
    return _parallelogram(checks, o, path, materials, corner, a, b)


def _parallelogram(checks: Checks, o, path, materials, corner, a, b) -> Mesh:
    verts = np.array([corner, corner + a, corner + a + b, corner + b])
    # the image laid upright on it: edge_a along its width (u), edge_b up its height (v runs down the image)
    uvs = np.array([[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]])
    return Mesh(verts, np.array([[0, 1, 2], [0, 2, 3]]), material=material_ref(checks, o, path, materials), source=path, uvs=uvs)


def _mesh(checks: Checks, o, path, materials, build) -> Mesh | None:
    """A triangle mesh from a file (any format trimesh reads, or one node of a glTF file), a built-in
    generator or inline `vertices` and `faces`, scaled, rotated and translated; with build=False only
    checked (None).  What it is made from is a Shape (shapes.py), read once for every object that names it."""
    if sum(k in o for k in ("file", "generator", "vertices")) != 1 or ("vertices" in o) != ("faces" in o):
        checks.fail(path, "a mesh needs exactly one of 'file', 'generator' or 'vertices' with 'faces'")
    gltf_node = _gltf_node(checks, o, path)
    if "file" in o:
        made = dict(file=_mesh_path(checks, o.get("file"), f"{path}.file"))
    elif "generator" in o:
        made = dict(zip(("gen", "params"), _generator(checks, o, path)))
    else:
        made = dict(inline=_inline_mesh(checks, o, path))
    matrix = _mesh_matrix(checks, o, path)
    if "uvs" in o and "vertices" not in o:
        checks.fail(f"{path}.uvs", "goes with inline 'vertices' (a file's or generator's mesh brings its own)")
    smooth = checks.boolean(o, "smooth", path, False)
    material = material_ref(checks, o, path, materials)
    if not build:
        return None
    shape = _shape(checks, o, path, made, gltf_node)
    mesh = _place_shape(checks, shape, made.get("inline"), matrix, path, smooth)
    mesh.material = material
    if "material" not in o and "file" in o and gltf_node is None:  # the file's own material, if it brings one
        mesh.file_material = textures.mtl_material(shape.mesh, shape.mesh.metadata.get(obj_mtl.METADATA_KEY, False))
    return mesh


def _mesh_matrix(checks: Checks, o, path) -> np.ndarray:
    """A mesh object's object-to-world matrix: its `matrix`, or its `scale`, `rotate` and `translate`."""
    scale = o.get("scale", 1.0)
    if is_number(scale):
        scale = checks.number(o, "scale", path, 1.0, low=-COORD_LIMIT, high=COORD_LIMIT)
        scale = (scale,) * 3
    else:
        scale = checks.vec3(o, "scale", path)
    if not all(abs(s) >= MIN_LENGTH for s in scale):
        checks.fail(f"{path}.scale", f"{show(o.get('scale'))}: each factor must be {MIN_LENGTH:g} to {COORD_LIMIT:g} in magnitude (negative mirrors)")
    rotate = checks.vec3(o, "rotate", path, (0.0, 0.0, 0.0))
    translate = checks.vec3(o, "translate", path, (0.0, 0.0, 0.0))
    given_matrix = _given_matrix(checks, o, path)  # `matrix`: instead of scale, rotate and translate
    return transform_matrix(translate, rotate, scale) if given_matrix is None else given_matrix


def _shape(checks: Checks, o, path, made: dict, gltf_node) -> Shape | None:
    """The Shape a mesh object places (checks.shapes: one per shape key, read on first use), or None for inline
    `vertices` that no other object shares."""
    key = _shape_key(o, made.get("file"), gltf_node, made.get("gen"), made.get("params"))
    if "matrix" in o and isinstance(o.get("vertices"), np.ndarray):  # arrays placed by a matrix: shared by identity
        key = ("arrays", id(o["vertices"]), id(o["faces"]), id(o.get("uvs")))
    if key is None:
        return None
    shape = checks.shapes.get(key)
    if shape is not None:
        return shape
    if gltf_node is not None:  # one node's mesh of a glTF file in its world space, and the node placing its glTF mesh
        mesh_index, own, node_matrix = gltf.node_shape(made["file"], *gltf_node, root=checks.root)
        node = (("gltf", key[1], mesh_index, gltf_node[1]), own, node_matrix)
        shape = Shape(key, gltf.node_mesh(made["file"], *gltf_node, root=checks.root), f"{o['file']} node {gltf_node[0]}", gltf=node)
        checks.shapes.setdefault(node[0], shape)  # nodes sharing a glTF mesh share its own vertices: the first one's Shape
    elif "file" in made:
        shape = Shape(key, load_mesh_file(made["file"], f"{checks.where}: {path}.file", root=checks.root), o["file"])
    elif "inline" in made:
        shape = Shape(key, made["inline"], path)
    else:
        from . import meshes

        shape = Shape(key, meshes.generate(made["gen"], **made["params"]), made["gen"], generated=True)  # bare arrays: no trimesh import
    checks.shapes[key] = shape
    return shape


def _place_shape(checks: Checks, shape: Shape | None, inline, matrix: np.ndarray, path, smooth: bool) -> Mesh:
    """A Mesh placing `shape` by `matrix` (its world vertices and normals made on first read: the instanced Tracer
    never reads them), or, with no shape, the `inline` arrays placed now."""
    tm = inline if shape is None else shape.mesh
    if len(tm.faces) > MAX_TRIANGLES:
        checks.fail(f"{path}", f"{len(tm.faces)} triangles; allowed: at most {MAX_TRIANGLES}")
    if shape is None:
        points, faces = np.asarray(tm.vertices, np.float64), np.asarray(tm.faces, np.int64)
        vertices = _place_points((points, None, matrix))
        _check_placed(checks, vertices, path)
        normals = None
        if smooth:
            from .meshes import shading_normals

            normals = _place_normals((points, shading_normals(tm.vertices, tm.faces, None), matrix))
        if np.linalg.det(matrix[:3, :3]) < 0:  # a mirror: the winding reversed (mirrored_faces)
            faces = mirrored_faces(faces)
        mesh = Mesh(vertices, faces, normals, "default", smooth, path)
        mesh.uvs, mesh.uvs1, mesh.colours, mesh.tangents = _turned(vertex_attributes(tm), matrix)
        mesh.instance = Instance(None, points, matrix)
        return mesh
    _check_placed_box(checks, shape.points, shape.box, matrix, path)
    normals = shape.normals if smooth else None
    local_vertices, to_world, mirrored = shape.points, matrix, shape
    key = shape.key
    if shape.gltf is not None:  # the glTF mesh's own vertices, placed by the node and then the object's transform
        key, own, node_matrix = shape.gltf
        mirrored = checks.shapes[key]
        local_vertices, to_world = mirrored.gltf[1], matrix @ node_matrix
    faces = mirrored.mirrored_faces if np.linalg.det(np.asarray(to_world, np.float64)[:3, :3]) < 0 else shape.faces
    mesh = Mesh(None, faces, None, "default", smooth, shape.source, placed=(shape.points, normals, matrix))
    mesh.uvs, mesh.uvs1, mesh.colours, mesh.tangents = _turned(shape.attributes, matrix)
    mesh.instance = Instance(key, local_vertices, to_world)
    return mesh


def _turned(attributes: tuple, matrix: np.ndarray) -> tuple:
    """(uvs, uvs1, colours, tangents) of a mesh placed by `matrix`: its tangents turn with it."""
    uvs, uvs1, colours, tangents = attributes
    if tangents is not None:
        xyz = tangents[:, :3] @ matrix[:3, :3].T
        tangents = np.concatenate([xyz / np.maximum(np.linalg.norm(xyz, axis=1, keepdims=True), 1e-30), tangents[:, 3:]], 1)
    return uvs, uvs1, colours, tangents


def _given_matrix(checks: Checks, o, path) -> np.ndarray | None:
    """A mesh's `matrix` (4x4, row-major: vertices = M[:3, :3] @ v + M[:3, 3]; its last row 0, 0, 0, 1), or None."""
    if "matrix" not in o:
        return None
    if any(k in o for k in ("translate", "rotate", "scale")):
        checks.fail(f"{path}.matrix", "give either 'matrix' or 'translate', 'rotate' and 'scale'")
    try:
        m = np.array(o["matrix"], np.float64)
    except (TypeError, ValueError, OverflowError):
        m = None
    if m is None or m.shape != (4, 4) or isinstance(o["matrix"], str) or not np.all(np.abs(m) <= COORD_LIMIT):
        checks.fail(f"{path}.matrix", f"expected 4 rows of 4 finite numbers within {COORD_LIMIT:g}, got {show(o['matrix'])}")
    if not np.array_equal(m[3], [0, 0, 0, 1]) or not abs(np.linalg.det(m[:3, :3])) > 0:
        checks.fail(f"{path}.matrix", "its last row must be [0, 0, 0, 1] and its 3x3 part invertible")
    return m


@functools.lru_cache(maxsize=256)
def _resolved(file: str, cwd: str) -> str:
    """A file's resolved path, once per name and working folder (a 100,000-node glTF names its file 100,000 times)."""
    return str(Path(file).resolve())


def _shape_key(o, file, gltf_node, gen, params) -> tuple | None:
    """What an object's object-space mesh is made from: equal keys, equal meshes (None: inline vertices)."""
    if file is not None:
        return ("file", _resolved(str(file), os.getcwd()), gltf_node)
    if gen is not None:
        return ("generator", gen, repr(sorted(params.items())))
    return None


@dataclass
class _InlineMesh:
    vertices: np.ndarray  # (N, 3) float64
    faces: np.ndarray  # (M, 3) int64
    uv0: np.ndarray | None = None  # (N, 2) texture coordinates (`uvs`, glTF's convention), or None
    normals = None  # computed (shading_normals) when smooth
    uv1 = colours = tangents = None


def _inline_mesh(checks: Checks, o, path) -> _InlineMesh:
    """`vertices` (points) and `faces` (triples of vertex indices) given in the scene itself."""
    vertices, faces = o.get("vertices"), o.get("faces")
    if isinstance(vertices, np.ndarray):  # a dict made in Python (a pbrt file's meshes): checked as whole arrays, once
        key = (id(vertices), id(o.get("faces")), id(o.get("uvs")))
        if key not in checks.array_meshes:
            checks.array_meshes[key] = _array_mesh(checks, o, path)
        return checks.array_meshes[key]
    if not isinstance(vertices, list) or not vertices or len(vertices) > 3 * MAX_TRIANGLES:
        checks.fail(f"{path}.vertices", f"expected a non-empty list of at most {3 * MAX_TRIANGLES} points")
    if not isinstance(faces, list) or not faces or len(faces) > MAX_TRIANGLES:
        checks.fail(f"{path}.faces", f"expected a non-empty list of at most {MAX_TRIANGLES} triples of vertex indices")
    points = np.array([checks.vec3({"v": v}, "v", f"{path}.vertices[{i}]") for i, v in enumerate(vertices)], np.float64)
    for i, f in enumerate(faces):
        if not (isinstance(f, list) and len(f) == 3 and all(isinstance(k, int) and not isinstance(k, bool) and 0 <= k < len(points) for k in f)):
            checks.fail(f"{path}.faces[{i}]", f"{show(f)}: expected 3 vertex indices from 0 to {len(points) - 1}")
    uvs = o.get("uvs")
    if uvs is not None and (not isinstance(uvs, list) or len(uvs) != len(points)):
        checks.fail(f"{path}.uvs", f"expected {len(points)} [u, v] pairs, one a vertex")
    if uvs is not None:
        ok = lambda uv: isinstance(uv, list) and len(uv) == 2 and all(is_number(x) and abs(x) <= COORD_LIMIT for x in uv)  # noqa: E731
        bad = [i for i, uv in enumerate(uvs) if not ok(uv)]
        if bad:
            checks.fail(f"{path}.uvs[{bad[0]}]", f"{show(uvs[bad[0]])}: expected [u, v], each within {COORD_LIMIT:g}")
        uvs = np.array(uvs, np.float64)
    return _InlineMesh(points, np.array(faces, np.int64), uvs)


def _array_mesh(checks: Checks, o, path) -> _InlineMesh:
    """Inline `vertices` (N, 3), `faces` (M, 3) and optional `uvs` (N, 2) given as numpy arrays, as a dict made in
    Python may (pbrt.py's meshes): the same checks as lists get, on whole arrays, and no per-value count."""
    points, faces, uvs = o["vertices"], o.get("faces"), o.get("uvs")
    if points.ndim != 2 or points.shape[1] != 3 or not 0 < len(points) <= 3 * MAX_TRIANGLES or points.dtype.kind not in "fiu":
        checks.fail(f"{path}.vertices", f"expected an array of at most {3 * MAX_TRIANGLES} points (N, 3)")
    points = points.astype(np.float64)
    if not np.all(np.abs(points) <= COORD_LIMIT):
        checks.fail(f"{path}.vertices", f"a point is not finite or out of range; allowed: -{COORD_LIMIT:g} to {COORD_LIMIT:g}")
    shaped = isinstance(faces, np.ndarray) and faces.ndim == 2 and faces.shape[1] == 3 and faces.dtype.kind in "iu"
    if not shaped or not 0 < len(faces) <= MAX_TRIANGLES:
        checks.fail(f"{path}.faces", f"expected an integer array of at most {MAX_TRIANGLES} triples of vertex indices (M, 3)")
    if faces.min() < 0 or faces.max() >= len(points):
        checks.fail(f"{path}.faces", f"a vertex index is out of range; allowed: 0 to {len(points) - 1}")
    if uvs is not None:
        if not isinstance(uvs, np.ndarray) or uvs.shape != (len(points), 2) or not np.all(np.abs(uvs) <= COORD_LIMIT):
            checks.fail(f"{path}.uvs", f"expected an array of {len(points)} finite [u, v] pairs, one a vertex")
        uvs = uvs.astype(np.float64)
    return _InlineMesh(points, faces.astype(np.int64), uvs)


def _check_placed_box(checks: Checks, points, box, matrix, path):
    """_check_placed's answer without placing every vertex when the box of `points` (lo, hi) settles it: no
    coordinate of the placed points reaches past the placed box's corners (each is affine in the point), and
    the placed points span at least the smallest singular value of the matrix times the box's longest side,
    over sqrt(3) along some axis.  Near either limit the vertices are placed and checked as always."""
    lo, hi = box
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    with np.errstate(over="ignore", invalid="ignore"):
        reach = np.abs(corners @ matrix[:3, :3].T + matrix[:3, 3]).max()
        extent = np.linalg.svd(matrix[:3, :3], compute_uv=False).min() * (hi - lo).max() / np.sqrt(3)
    margin = 1 + 1e-6  # far above the rounding of either way of placing the points
    if reach * margin <= 10 * COORD_LIMIT and extent >= margin * RELATIVE_PRECISION * reach:
        return
    _check_placed(checks, _place_points((points, None, matrix)), path)


def _check_placed(checks: Checks, vertices, path):
    """A transformed mesh lies within the coordinate limits and is big enough for float32 where it is."""
    reach = np.abs(vertices).max()
    if not reach <= 10 * COORD_LIMIT:
        checks.fail(path, f"after scale and translate the mesh reaches {reach:.3g}; allowed: within {10 * COORD_LIMIT:g} of the origin")
    extent = np.ptp(vertices, axis=0).max()
    if extent < RELATIVE_PRECISION * reach:
        checks.fail(
            f"{path}.scale",
            f"the mesh is {extent:.3g} across at distance {reach:.3g}; allowed: at least "
            f"{RELATIVE_PRECISION:g} x its distance from the origin (float32 precision)",
        )


def _gltf_node(checks: Checks, o, path):
    """(node, primitive or None) when the mesh is one node of a glTF file (keys `node`, `primitive`), else None."""
    if "node" not in o:
        if "primitive" in o:
            checks.fail(f"{path}.primitive", "needs 'node' (a node of a glTF file)")
        return None
    if not str(o.get("file", "")).lower().endswith((".gltf", ".glb")):
        checks.fail(f"{path}.node", "only a .gltf or .glb 'file' has nodes")
    node = checks.integer(o, "node", path, low=0, high=2**31 - 1)
    primitive = checks.integer(o, "primitive", path, low=0, high=2**31 - 1) if "primitive" in o else None
    return node, primitive


def _mesh_path(checks: Checks, file, key) -> Path:
    """The mesh file's path: relative to the scene's folder; absolute or ../ paths only when allow_outside."""
    if not isinstance(file, str) or not file or "\x00" in file:
        checks.fail(key, f"expected a path, got {show(file)}")
    from .confine import scene_file

    return scene_file(checks.base_dir, file, checks.root, f"{checks.where}: {key}")


def _generator(checks: Checks, o, path):
    """(name, params) of a built-in mesh: `generator` names a function of clrender.scene.meshes, `params` its keyword arguments."""
    gen = checks.choice(o, "generator", path, None, MESH_GENERATORS)
    params = checks.table(o.get("params", {}), f"{path}.params")
    bounds = GENERATOR_PARAMS[gen]
    for key in params:
        if key not in bounds:
            checks.fail(f"{path}.params.{key}", f"unknown parameter of generator {gen!r}; allowed: {', '.join(bounds)}")
    return gen, {key: checks.integer(params, key, f"{path}.params", low=low, high=high) for key, (low, high) in bounds.items() if key in params}


# Each object type: its keys (declared once: checked by TypeReader.read, tested against the docs' table)
# and the function that builds it.  The built-in meshes' params are GENERATOR_PARAMS.
OBJECT_READERS = {
    "sphere": TypeReader(("type", "center", "radius", "material"), _sphere),
    "triangle": TypeReader(("type", "vertices", "material"), _triangle),
    "quad": TypeReader(("type", "corner", "edge_a", "edge_b", "material"), _quad),
    "plane": TypeReader(("type", "point", "normal", "size", "material"), _plane),
    "mesh": TypeReader(
        (
            "type",
            "file",
            "generator",
            "vertices",
            "faces",
            "uvs",
            "params",
            "translate",
            "rotate",
            "scale",
            "matrix",
            "smooth",
            "material",
            "node",
            "primitive",
        ),
        _mesh,
    ),
}


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
