"""Mitsuba 3's plugins mapped onto clrender's scene dict (the dict a TOML scene is).

`read_mitsuba(path, defines)` reads the file (mitsuba_xml.Document) and returns a `Foreign` record: the scene
dict, the render settings the file asks for (integrator, spp, max_depth, pixel filter) and the stand-ins used
under --approximate.  Shapes, emitters and sensors are mapped here, BSDFs and textures in mitsuba_bsdfs.py.
The mapping of every plugin is tabled in docs/scene-formats.md.

What cannot be read is one line naming the element and its line: `scene.xml:41: bsdf "hair" is not
supported (supported: diffuse, ...)`.  With approximate=True the reader goes on with a documented stand-in
(a grey diffuse for a BSDF; an emitter or shape is left out) and lists each substitution.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import UsageError
from . import mitsuba_bsdfs
from .mitsuba_xml import Document, Plugin
from .samplers import path_sampler_of

SHAPES = ("obj", "ply", "serialized", "rectangle", "cube", "sphere", "disk", "cylinder", "shapegroup", "instance")
EMITTERS = ("area", "point", "spot", "directional", "envmap", "constant")
SENSORS = ("perspective", "thinlens", "orthographic")
TEXTURES = ("bitmap", "checkerboard")
INTEGRATORS = ("path", "volpath", "direct")  # volpath without media is path
FILTERS = {"box": "box", "tent": "tent", "gaussian": "gaussian"}
DEFAULT_BSDF = {"diffuse": [0.5, 0.5, 0.5]}  # a shape without a bsdf: Mitsuba's default diffuse
PATH_DEPTH_UNLIMITED = 1024  # Mitsuba's max_depth -1 (no limit): clrender's deepest path (integrators.PATH_DEPTH_LIMIT)
# parameters every plugin of a kind may carry that change nothing clrender draws (read and ignored)
IGNORED = {
    "sensor": (
        "near_clip",
        "far_clip",
        "shutter_open",
        "shutter_close",
        "srf",
        "principal_point_offset_x",
        "principal_point_offset_y",
        "focus_distance",
    ),
    "film": ("pixel_format", "component_format", "file_format", "banner", "sample_border", "compensate", "high_quality_edges"),
    "sampler": ("seed", "jitter", "dimension", "scramble_type"),
    "rfilter": ("radius", "stddev", "lobes"),
    "integrator": ("samples_per_pass", "timeout", "emitter_samples", "bsdf_samples"),
    "emitter": ("sampling_weight",),  # how often light sampling picks it: noise, not the image
}


@dataclass
class Foreign:
    """What a foreign scene file became: the scene dict, its render settings, and the stand-ins used."""

    scene: dict
    settings: dict = field(default_factory=dict)  # integrator, spp, max_depth, rfilter (RenderSettings names)
    substitutions: list = field(default_factory=list)  # "scene.xml:41: bsdf 'hair' -> grey diffuse", under --approximate


def read_mitsuba(path, defines: dict | None = None, approximate: bool = False, allow_outside: bool = True) -> Foreign:
    """Read a Mitsuba 3 XML file; `defines` are `-D name=value` (they win over `<default>`)."""
    doc = Document(path, defines)
    reader = Reader(doc, approximate)
    reader.root = None if allow_outside else doc.folder  # meshes and textures read by the reader itself (confine.py)
    reader.read()
    return Foreign(reader.out, reader.settings, reader.substitutions)


def supported(kind: str, names) -> str:
    return f"supported: {', '.join(names)}"


class Reader:
    """Walks the document's plugins, filling `out` (the scene dict) and `settings`."""

    def __init__(self, doc: Document, approximate: bool):
        self.doc, self.approximate = doc, approximate
        self.out = {"name": doc.path.stem, "materials": {}, "textures": {}, "lights": [], "objects": [], "cameras": []}
        self.settings: dict = {}
        self.substitutions: list = []
        self.material_names: dict = {}  # id(Plugin) -> material name
        self.texture_names: dict = {}  # (id(Plugin), srgb) -> texture name

    # ------------------------------------------------------------------ refusals
    def refuse(self, p: Plugin, message: str, stand_in: str = "") -> None:
        """Unsupported: one line, exit 2; or, approximating, note the substitution and go on."""
        if not self.approximate:
            raise UsageError(f"{p.where}: {message}")
        self.substitutions.append(f"{p.where}: {message}" + (f" -> {stand_in}" if stand_in else ""))

    def check_used(self, p: Plugin, also=()) -> None:
        """Mitsuba refuses parameters no plugin reads; so does this reader (they would change the picture)."""
        ignored = set(IGNORED.get(p.tag, ())) | set(also)
        for name in sorted(set(p.props) - p.used - ignored):
            self.refuse(p, f'{p.tag} "{p.type}" parameter {name!r} is not supported', "ignored")

    # ------------------------------------------------------------------ values
    def scalar(self, p: Plugin, name: str, default: float) -> float:
        value = p.get(name, default)
        if p.child(name) is not None:
            self.refuse(p, f'{p.tag} "{p.type}" {name!r} as a texture is not supported (supported: a number)', "its default")
            return default
        if isinstance(value, tuple):
            if len(set(value)) != 1:
                self.refuse(p, f'{p.tag} "{p.type}" {name!r} is a colour; supported: a number', "its mean")
            return float(sum(value) / len(value))
        if not isinstance(value, (int, float)) or isinstance(value, bool):
            p.fail(f'{p.tag} "{p.type}" {name!r} is {value!r}; expected a number')
        return float(value)

    def colour(self, p: Plugin, name: str, default, texture: bool = True):
        """(rgb list, texture or None) of a colour parameter: rgb, spectrum, float, or a nested texture."""
        child = p.child(name)
        p.used.add(name)
        if child is not None:
            if not texture:
                self.refuse(p, f'{p.tag} "{p.type}" {name!r} as a texture is not supported (supported: a colour)', "white")
                return [1.0, 1.0, 1.0], None
            return [1.0, 1.0, 1.0], self.texture(child, srgb=True)
        value = p.props.get(name, default)
        if isinstance(value, tuple):
            return [float(v) for v in value], None
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return [float(value)] * 3, None
        p.fail(f'{p.tag} "{p.type}" {name!r} is {value!r}; expected a colour (rgb, spectrum or float)')

    def expect_white(self, p: Plugin, name: str) -> None:
        rgb, _ = self.colour(p, name, 1.0, texture=False)
        if rgb != [1.0, 1.0, 1.0]:
            self.refuse(p, f'{p.tag} "{p.type}" {name} other than 1 is not supported', "1")

    # ------------------------------------------------------------------ the walk
    def read(self):
        for _, p in self.doc.scene.children:
            if p.tag in ("medium", "volume", "phase"):
                self.refuse(p, f'{p.tag} "{p.type}": volumes and media are not supported', "left out")
            elif p.tag == "sensor":
                self.sensor(p)
            elif p.tag == "integrator":
                self.integrator(p)
            elif p.tag == "shape":
                if p.type != "shapegroup":  # a shape group draws only through its instances
                    self.shape(p, np.eye(4))
            elif p.tag == "emitter":
                self.emitter(p)
        if not self.out["cameras"]:
            del self.out["cameras"]
        for key in ("materials", "textures", "lights"):
            if not self.out[key]:
                del self.out[key]
        self.settings.setdefault("integrator", "path")  # Mitsuba's default integrator
        self.settings.setdefault("spp", 4)  # Mitsuba's default sampler: independent, 4 samples a pixel
        self.settings.setdefault("max_depth", PATH_DEPTH_UNLIMITED)

    # ------------------------------------------------------------------ integrator, sensor, film
    def integrator(self, p: Plugin):
        if p.type not in INTEGRATORS:
            self.refuse(p, f'integrator "{p.type}" is not supported ({supported("integrator", INTEGRATORS)})', "path")
        depth = int(p.get("max_depth", -1))
        if p.type == "direct":  # direct light only: clrender's path tracer at depth 0
            depth = 2
        if depth == -1:
            self.settings["max_depth"] = PATH_DEPTH_UNLIMITED
        elif depth < 2:
            self.refuse(p, f"integrator max_depth {depth} (emitters alone or nothing) is not supported (supported: -1, or 2 and more)", "max_depth 2")
            self.settings["max_depth"] = 0
        else:
            self.settings["max_depth"] = depth - 2  # Mitsuba counts the camera segment and the emitter's; clrender counts bounces after the first hit
        self.settings["integrator"] = "path"
        if p.has("rr_depth"):  # Mitsuba counts the primary hit as depth 1 when it starts Russian roulette
            self.settings["rr_depth"] = max(0, int(p.get("rr_depth")) - 1)
        if p.get("hide_emitters", False):
            self.settings["hide_emitters"] = True
        self.check_used(p)

    def sensor(self, p: Plugin):
        if p.type not in SENSORS:
            self.refuse(p, f'sensor "{p.type}" is not supported ({supported("sensor", SENSORS)})', "left out")
            return
        width, height = self.film(p.nested("film")[0] if p.nested("film") else None, first=not self.out["cameras"])
        for s in p.nested("sampler"):
            self.sampler(s, first=not self.out["cameras"])
        m = p.get("to_world", np.eye(4))
        m3 = m[:3, :3]
        if np.linalg.det(m3) <= 0:
            self.refuse(
                p, "a sensor whose to_world mirrors the image is not supported (supported: rotations, translations and scales > 0)", "left out"
            )
            return
        position = m[:3, 3]
        forward = m3[:, 2] / np.linalg.norm(m3[:, 2])
        up = m3[:, 1] / np.linalg.norm(m3[:, 1])
        camera = {"position": position.tolist(), "look_at": (position + forward).tolist(), "up": up.tolist()}
        if p.type == "orthographic":
            camera["projection"] = "orthographic"
            camera["ortho_height"] = float(2 * np.linalg.norm(m3[:, 0]) * height / width)  # Mitsuba: x spans [-1, 1] before to_world
        else:
            camera["fov"] = vertical_fov(p, width, height)
        if p.type == "thinlens":
            camera["aperture"] = self.scalar(p, "aperture_radius", 0.0)
            camera["focus_distance"] = self.scalar(p, "focus_distance", 10000.0)
        self.check_used(p)
        self.out["cameras"].append(camera)

    def film(self, f: Plugin | None, first: bool) -> tuple[int, int]:
        if f is None:  # Mitsuba's default film: hdrfilm 768 x 576, gaussian filter
            if first:
                self.out["width"], self.out["height"] = 768, 576
                self.settings.setdefault("rfilter", "gaussian")
            return 768, 576
        width, height = int(f.get("width", 768)), int(f.get("height", 576))
        if any(f.has(k) for k in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height")):
            for k in ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height"):
                f.get(k)
            self.refuse(f, "film crop is not supported (clrender renders the whole film)", "the whole film")
        for r in f.nested("rfilter"):
            if r.type not in FILTERS:
                self.refuse(r, f'rfilter "{r.type}" is not supported (supported: {", ".join(FILTERS)})', "gaussian")
            if first:
                self.settings["rfilter"] = FILTERS.get(r.type, "gaussian")
            self.check_used(r)
        if first:
            self.out["width"], self.out["height"] = width, height
            self.settings.setdefault("rfilter", "gaussian")  # Mitsuba's default reconstruction filter
        self.check_used(f)
        return width, height

    def sampler(self, s: Plugin, first: bool):
        count = int(s.get("sample_count", 4))
        if first:
            self.settings["spp"] = max(1, count)
            self.settings["path_sampler"] = path_sampler_of(s.type)
        self.check_used(s)

    # ------------------------------------------------------------------ shapes
    def shape(self, p: Plugin, parent: np.ndarray, inherited: Plugin | None = None):
        if p.type not in SHAPES:
            self.refuse(p, f'shape "{p.type}" is not supported ({supported("shape", SHAPES)})', "left out")
            return
        if p.type == "instance":
            groups = [g for _, g in p.children if g.tag == "shape" and g.type == "shapegroup"]
            if len(groups) != 1:
                p.fail('shape "instance" needs one shapegroup (a ref to its id)')
            m = parent @ p.get("to_world", np.eye(4))
            for _, inner in groups[0].children:
                if inner.tag == "shape":
                    self.shape(inner, m)
            self.check_used(p)
            return
        if p.type == "shapegroup":
            p.fail("a shapegroup inside a shape is not supported (supported: shapegroups at the top level, drawn by instances)")
        matrix = parent @ p.get("to_world", np.eye(4))
        if abs(np.linalg.det(matrix[:3, :3])) < 1e-30:
            p.fail(f'shape "{p.type}" to_world is singular (it flattens the shape)')
        material = self.shape_material(p)
        from .mitsuba_shapes import shape_objects

        for obj in shape_objects(self, p, matrix, material):
            self.out["objects"].append(obj)
        self.check_used(p)

    def shape_material(self, p: Plugin) -> str:
        bsdfs = p.nested("bsdf")
        name = self.material(bsdfs[0]) if bsdfs else self.default_material()
        emitters = p.nested("emitter")
        if not emitters:
            return name
        e = emitters[0]
        if e.type != "area":
            self.refuse(e, f'emitter "{e.type}" on a shape is not supported (supported: area)', "left out")
            return name
        radiance, tex = self.colour(e, "radiance", 1.0, texture=False)
        self.check_used(e)
        emissive = dict(self.out["materials"][name])
        emissive["emission"] = radiance
        key, n = f"{name}+emission", 1
        while self.out["materials"].get(key, emissive) != emissive:  # another radiance: another material
            n += 1
            key = f"{name}+emission{n}"
        self.out["materials"][key] = emissive
        return key

    def default_material(self) -> str:
        self.out["materials"].setdefault("mitsuba_default", dict(DEFAULT_BSDF))
        return "mitsuba_default"

    def material(self, b: Plugin) -> str:
        """The name of b's material in the scene dict (made once per plugin: refs share it)."""
        if id(b) in self.material_names:
            return self.material_names[id(b)]
        m = mitsuba_bsdfs.fit_to_build(self.bsdf_dict(b), b, self)
        name = b.id or f"bsdf{len(self.material_names) + 1}"
        while name in self.out["materials"]:
            name += "_"
        self.out["materials"][name] = m
        self.material_names[id(b)] = name
        return name

    def bsdf_dict(self, b: Plugin) -> dict:
        """The contract dict of one bsdf plugin (before fit_to_build)."""
        mapper = mitsuba_bsdfs.BSDFS.get(b.type)
        if mapper is None:
            self.refuse(b, f'bsdf "{b.type}" is not supported ({supported("bsdf", mitsuba_bsdfs.BSDFS)})', "grey diffuse")
            return dict(mitsuba_bsdfs.STAND_IN)
        m = mapper(b, self)
        self.check_used(b)
        return m

    # ------------------------------------------------------------------ textures
    def texture(self, t: Plugin, srgb: bool = True):
        from .mitsuba_textures import texture_ref

        return texture_ref(self, t, srgb)

    def texture_child(self, p: Plugin, name: str, srgb: bool):
        t = p.child(name) or next(iter(p.nested("texture")), None)
        if t is None:
            p.fail(f'bsdf "{p.type}" needs a nested texture {name!r}')
        return self.texture(t, srgb)

    # ------------------------------------------------------------------ emitters
    def emitter(self, e: Plugin):
        from .mitsuba_emitters import EMITTER_MAPPERS

        mapper = EMITTER_MAPPERS.get(e.type)
        if mapper is None:
            where = " (an area emitter belongs on a shape)" if e.type == "area" else ""
            self.refuse(e, f'emitter "{e.type}" is not supported{where} ({supported("emitter", EMITTERS)})', "left out")
            return
        mapper(self, e)
        self.check_used(e)


def vertical_fov(p: Plugin, width: int, height: int) -> float:
    """Mitsuba's `fov` along `fov_axis` (x, y, diagonal, smaller, larger; or `focal_length` in 35 mm film
    terms, along the diagonal) as clrender's vertical field of view, for this film's aspect."""
    if p.has("focal_length"):
        text = str(p.get("focal_length")).strip().removesuffix("mm")
        try:
            focal = float(text)
        except ValueError:
            p.fail(f"focal_length {p.props['focal_length']!r} is not a length in mm")
        half_tan, axis = math.hypot(36, 24) / (2 * focal), "diagonal"
    else:
        half_tan = math.tan(math.radians(float(p.get("fov", 39.3077))) / 2)
        axis = p.get("fov_axis", "x")
    if axis == "smaller":
        axis = "x" if width <= height else "y"
    elif axis == "larger":
        axis = "x" if width > height else "y"
    ratio = {"x": height / width, "y": 1.0, "diagonal": height / math.hypot(width, height)}.get(axis)
    if ratio is None:
        p.fail(f"fov_axis {axis!r} is not one of x, y, diagonal, smaller, larger")
    return math.degrees(2 * math.atan(half_tan * ratio))
