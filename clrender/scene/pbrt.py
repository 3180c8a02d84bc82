"""pbrt-v4 scene files (`clrender render scene.pbrt`) read into the scene dict `Scene.from_dict` takes.

pbrt_parse.py turns the text into directives; this module keeps pbrt's graphics state (the current
transform, attributes, materials, area light, named coordinate systems, object definitions) and maps each
directive onto clrender's dict; pbrt_values.py holds the value conversions (spectra, roughness, matrices).
docs/scene-formats-pbrt.md is the table of what maps onto what, and what is refused.

Handedness.  pbrt's camera space is left-handed: +x right, +y up, looking down +z, and LookAt's right vector
is up × dir, so with the usual right-handed arithmetic a pbrt image shows world −x on its right when it looks
down −z with +y up.  clrender's camera shows dir × up on its right.  The reader therefore mirrors the whole
world in x (MIRROR) as it writes it: points, directions and the camera frame alike, so every point lands on
the pixel pbrt puts it on.  A mirror reverses triangle winding, so the winding is reversed back where pbrt's
rule says the surface faces the other way (`_faces`).

What cannot be read raises UsageError `FILE:LINE: what (supported: ...)`; with approximate=True the reader
substitutes a documented stand-in and lists each substitution instead (PbrtFile.substitutions).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import UsageError
from . import pbrt_values as pv
from .confine import scene_file
from .pbrt_parse import Directive, Parser, fail
from .samplers import path_sampler_of

MIRROR = np.diag([-1.0, 1.0, 1.0, 1.0])  # pbrt's world to clrender's (see the module docstring)
SUPPORTED = {
    "Shape": ("trianglemesh", "plymesh", "sphere", "disk", "bilinearmesh"),
    "Material": ("diffuse", "conductor", "dielectric", "thindielectric", "coateddiffuse", "mix"),
    "Texture": ("imagemap", "checkerboard", "scale", "constant"),
    "LightSource": ("point", "spot", "distant", "infinite"),
    "AreaLightSource": ("diffuse",),
    "Camera": ("perspective", "orthographic"),
    "PixelFilter": ("box", "triangle", "gaussian"),
    "Integrator": ("path", "volpath"),
}
FILTERS = {"box": "box", "triangle": "tent", "gaussian": "gaussian"}
IGNORED = ("Accelerator", "ColorSpace", "Option", "WorldEnd", "TransformTimes")  # no effect on clrender's image


@dataclass
class PbrtFile:
    scene: dict  # the scene dict (Scene.from_dict)
    settings: dict  # render settings the file gives (RenderSettings names): integrator, max_depth, spp, rfilter
    substitutions: list = field(default_factory=list)  # with approximate=True: what was substituted, one string each


def read_pbrt(path, defines=None, approximate: bool = False, allow_outside: bool = True) -> dict:
    """The scene dict of a pbrt-v4 file (paths in it relative to the file's folder)."""
    return read_pbrt_file(path, defines, approximate, allow_outside).scene


def read_pbrt_file(path, defines=None, approximate: bool = False, allow_outside: bool = True) -> PbrtFile:
    """The scene dict, render settings and substitutions of a pbrt-v4 file."""
    path = Path(path)
    if defines:
        raise UsageError(f"{path}: -D {next(iter(defines))}=...: pbrt files have no substitutions; allowed: -D with Mitsuba XML scenes")
    reader = _Reader(path, None if allow_outside else path.parent, approximate)
    for directive in Parser(path, reader.root, reader.resolve).directives():
        reader.directive(directive)
    return reader.finish()


@dataclass
class _State:
    ctm: np.ndarray
    reverse: bool = False
    material: str = "default"
    area: dict | None = None  # {"emission": rgb} of an AreaLightSource
    instance: np.ndarray | None = None  # in an ObjectInstance: its transform (ctm is then the definition's)

    @property
    def full_ctm(self) -> np.ndarray:
        return self.ctm if self.instance is None else self.instance @ self.ctm


class _Reader:
    def __init__(self, path: Path, root, approximate: bool):
        self.path, self.folder, self.root, self.approximate = path, path.parent, root, approximate
        self.state = _State(np.eye(4))
        self.stack = []  # (state, kind) of AttributeBegin / TransformBegin
        self.coords = {}
        self.materials = {"default": {"diffuse": [0.5, 0.5, 0.5]}}  # pbrt's default: diffuse, reflectance 0.5
        self.textures, self.image_textures = {}, {}
        self.objects, self.lights, self.environment = [], [], None
        self.definitions, self.defining = {}, None  # ObjectBegin name -> [(directive, state)]
        self.instanced = {}  # (id of a definition's Shape, flipped) -> its arrays, shared by every ObjectInstance
        self.camera, self.film = None, {}
        self.settings, self.substitutions = {}, []
        self.counter = 0
        self.emitting = {}  # (material, emission) -> the name of that material emitting

    # ------------------------------------------------------------------ plumbing
    def resolve(self, name: str, what: str) -> Path:
        path = scene_file(self.folder, name, self.root, what)
        if not path.is_file():
            raise UsageError(f"{what}: file {name!r} does not exist (paths are relative to {str(self.folder)!r})")
        return path

    def unsupported(self, d: Directive, what: str, supported, stand_in: str):
        """Refuse `what` in one line, or with approximate=True note the stand-in and go on."""
        if not self.approximate:
            fail(d.where, f"{what} is not supported (supported: {', '.join(supported)})")
        self.substitutions.append(f"{d.where}: {what} -> {stand_in}")

    def params(self, d: Directive, allowed, defaults=None) -> dict:
        """name -> values of the directive's parameters, refusing any not in `allowed` (one line)."""
        for name in d.params:
            if name not in allowed:
                self.unsupported(d, f'{d.name} "{d.args[0] if d.args else ""}" parameter "{name}"', allowed or ("none",), "ignored")
        out = dict(defaults or {})
        out.update({name: p for name, p in d.params.items() if name in allowed})
        return out

    def number(self, d: Directive, p, default: float) -> float:
        if p is None or not hasattr(p, "values"):
            return default
        if p.type not in ("float", "integer") or len(p.values) != 1:
            fail(p.where, f'parameter "{p.name}": expected one float, got {p.type} with {len(p.values)} values')
        return float(p.values[0])

    def colour(self, p, default):
        """An RGB triple from an rgb, spectrum or blackbody parameter (or one float: grey)."""
        if p is None or not hasattr(p, "values"):
            return list(default)
        v = p.values
        if p.type == "rgb" and len(v) == 3:
            return [float(x) for x in v]
        if p.type == "float" and len(v) == 1:
            return [float(v[0])] * 3
        if p.type == "blackbody" and len(v) == 1:
            return [1.0, 1.0, 1.0]
        if p.type == "spectrum" and len(v) == 1 and isinstance(v[0], str):
            named = pv.named_spectrum(v[0])
            if isinstance(named, tuple):
                return list(named)
            fail(p.where, f'spectrum "{v[0]}" is not known (supported: metal-{{Ag,Al,Au,Cu,CuZn,MgO,TiO2}}-{{eta,k}}, stdillum-*)')
        if p.type == "spectrum" and len(v) >= 2 and len(v) % 2 == 0 and all(isinstance(x, float) for x in v):
            return [float(np.mean(v[1::2]))] * 3
        fail(p.where, f'parameter "{p.name}": expected an rgb (3 numbers), a spectrum or a blackbody, got {p.type} with {len(v)} values')

    # ------------------------------------------------------------------ directives
    def directive(self, d: Directive):
        if self.defining is not None and d.name == "Shape":
            self.defining.append((d, replace(self.state, ctm=self.state.ctm.copy())))
            return
        handler = getattr(self, f"_{d.name}", None)
        if handler is not None:
            handler(d)
        elif d.name in IGNORED:
            pass
        elif d.name in ("MakeNamedMedium", "MediumInterface"):
            self.unsupported(d, f"{d.name} (participating media)", ("surfaces only",), "ignored: no media")
        else:
            self.unsupported(d, d.name, ("the directives of docs/scene-formats-pbrt.md",), "ignored")

    def _concat(self, d, m):
        if m is None:
            fail(d.where, f"{d.name}: degenerate (a zero axis, or the eye at the look-at point or up along the view)")
        self.state.ctm = self.state.ctm @ m

    def _Translate(self, d):
        self._concat(d, pv.translate(*d.args))

    def _Scale(self, d):
        self._concat(d, pv.scale(*d.args))

    def _Rotate(self, d):
        self._concat(d, pv.rotate(*d.args))

    def _LookAt(self, d):
        self._concat(d, pv.look_at(d.args[0:3], d.args[3:6], d.args[6:9]))

    def _ConcatTransform(self, d):
        self._concat(d, pv.matrix16(d.args))

    def _Transform(self, d):
        self.state.ctm = pv.matrix16(d.args)

    def _Identity(self, d):
        self.state.ctm = np.eye(4)

    def _CoordinateSystem(self, d):
        self.coords[d.args[0]] = self.state.ctm.copy()

    def _CoordSysTransform(self, d):
        if d.args[0] not in self.coords:
            fail(d.where, f'CoordSysTransform: unknown coordinate system "{d.args[0]}"; defined: {", ".join(sorted(self.coords)) or "none"}')
        self.state.ctm = self.coords[d.args[0]].copy()

    def _ReverseOrientation(self, d):
        self.state.reverse = not self.state.reverse

    def _AttributeBegin(self, d):
        self.stack.append((replace(self.state, ctm=self.state.ctm.copy()), "Attribute"))

    def _TransformBegin(self, d):
        self.stack.append((replace(self.state, ctm=self.state.ctm.copy()), "Transform"))

    def _AttributeEnd(self, d, kind="Attribute"):
        if not self.stack:
            fail(d.where, f"{d.name} without a matching {kind}Begin")
        saved, _ = self.stack.pop()
        self.state = saved if kind == "Attribute" else replace(self.state, ctm=saved.ctm)

    def _TransformEnd(self, d):
        self._AttributeEnd(d, "Transform")

    def _WorldBegin(self, d):
        self.coords["world"] = np.eye(4)
        self.state.ctm = np.eye(4)

    def _ActiveTransform(self, d):
        self.unsupported(d, "ActiveTransform (motion blur)", ("a static transform",), "ignored")

    def _Attribute(self, d):
        self.unsupported(d, f'Attribute "{d.args[0]}"', ("parameters given on each directive",), "ignored")

    # ------------------------------------------------------------------ camera and settings
    def _Camera(self, d):
        kind = d.args[0]
        if kind not in SUPPORTED["Camera"]:
            self.unsupported(d, f'Camera "{kind}"', SUPPORTED["Camera"], "perspective")
            kind = "perspective"
        p = self.params(d, ("fov", "lensradius", "focaldistance"))
        self.camera = (kind, {k: self.number(d, v, 0.0) for k, v in p.items()}, self.state.ctm.copy(), d)
        if abs(np.linalg.det(self.state.ctm[:3, :3])) > 0:
            self.coords["camera"] = np.linalg.inv(self.state.ctm)

    def _Film(self, d):
        p = self.params(d, ("xresolution", "yresolution", "filename", "diagonal", "savefp16"))
        for key, name in (("xresolution", "width"), ("yresolution", "height")):
            if key in p:
                value = self.number(d, p[key], 0)
                if value != int(value) or not 1 <= value <= 16384:
                    fail(p[key].where, f'"{key}" {value:g}; allowed: a whole number from 1 to 16384')
                self.film[name] = int(value)

    def _Sampler(self, d):
        p = self.params(d, ("pixelsamples", "xsamples", "ysamples", "jitter", "seed", "randomization", "dimensions"))
        if d.args[0] == "stratified":
            spp = self.number(d, p.get("xsamples"), 4) * self.number(d, p.get("ysamples"), 4)
        else:
            spp = self.number(d, p.get("pixelsamples"), 16)
        if spp != int(spp) or spp < 1:
            fail(d.where, f"Sampler: {spp:g} samples; allowed: a whole number >= 1")
        self.settings["spp"] = int(spp)
        self.settings["path_sampler"] = path_sampler_of(d.args[0])

    def _Integrator(self, d):
        kind = d.args[0]
        if kind not in SUPPORTED["Integrator"]:
            self.unsupported(d, f'Integrator "{kind}"', SUPPORTED["Integrator"], "path")
        p = self.params(d, ("maxdepth", "regularize", "lightsampler"))
        depth = self.number(d, p.get("maxdepth"), 5)
        if depth != int(depth) or depth < 1:
            fail(d.where, f'Integrator "maxdepth" {depth:g}; allowed: a whole number >= 1 (clrender always adds direct light)')
        self.settings.update(integrator="path", max_depth=int(depth) - 1)  # pbrt counts the first hit's light as depth 1

    def _PixelFilter(self, d):
        kind = d.args[0]
        if kind not in FILTERS:
            self.unsupported(d, f'PixelFilter "{kind}"', SUPPORTED["PixelFilter"], "box")
            kind = "box"
        self.params(d, ("xradius", "yradius", "sigma"))
        self.settings["rfilter"] = FILTERS[kind]

    # ------------------------------------------------------------------ materials and textures
    def _Material(self, d):
        self.state.material = self._new_material(d, d.args[0], d.params, None)

    def _MakeNamedMaterial(self, d):
        kind = d.params.get("type")
        if kind is None or kind.type != "string":
            fail(d.where, f'MakeNamedMaterial "{d.args[0]}" needs a "string type" parameter')
        params = {k: v for k, v in d.params.items() if k != "type"}
        self._new_material(d, kind.values[0], params, d.args[0])

    def _NamedMaterial(self, d):
        if d.args[0] not in self.materials:
            fail(d.where, f'NamedMaterial "{d.args[0]}" is not defined; defined: {", ".join(sorted(self.materials))[:200]}')
        self.state.material = d.args[0]

    def _new_material(self, d, kind, params, name):
        from .pbrt_materials import material

        probe = Directive("Material", [kind], params, d.where)
        if name is None:
            self.counter += 1
            name = f"material{self.counter}"
        if kind == "mix":
            self.materials[name] = dict(self.materials[self._mix(probe)])
        elif kind not in SUPPORTED["Material"]:
            self.unsupported(d, f'Material "{kind}"', SUPPORTED["Material"], "grey diffuse")
            self.materials[name] = {"diffuse": [0.5, 0.5, 0.5]}
        else:
            self.materials[name] = material(self, probe, kind)
        return name

    def _mix(self, d):
        """pbrt-v4's MixMaterial picks materials[1] with probability `amount` at each hit; clrender has no
        per-hit choice between two materials, so only amount 0 or 1 (one of them) is read exactly."""
        p = self.params(d, ("materials", "amount"))
        names = p.get("materials")
        if names is None or names.type != "string" or len(names.values) != 2:
            fail(d.where, 'Material "mix" needs "string materials" with two names')
        for n in names.values:
            if n not in self.materials:
                fail(d.where, f'Material "mix": material "{n}" is not defined')
        amount = self.number(d, p.get("amount"), 0.5)
        if 0 < amount < 1:
            self.unsupported(d, f'Material "mix" with amount {amount:g}', ("mix with amount 0 or 1",), f'"{names.values[amount >= 0.5]}" alone')
        return names.values[1 if amount >= 0.5 else 0]

    def _Texture(self, d):
        from .pbrt_materials import texture

        self.textures[d.args[0]] = texture(self, d)

    # ------------------------------------------------------------------ lights
    def _AreaLightSource(self, d):
        if d.args[0] != "diffuse":
            self.unsupported(d, f'AreaLightSource "{d.args[0]}"', SUPPORTED["AreaLightSource"], "no light")
            return
        p = self.params(d, ("L", "scale", "twosided", "power", "filename"))
        for key in ("power", "filename"):
            if key in p:
                self.unsupported(d, f'AreaLightSource "diffuse" parameter "{key}"', ("L", "scale", "twosided"), "ignored")
        twosided = bool(p["twosided"].values[0]) if "twosided" in p else False
        if twosided:
            self.unsupported(d, 'AreaLightSource "twosided" true', ("one-sided emitters",), "the front side only")
        scale = self.number(d, p.get("scale"), 1.0)
        self.state.area = {"emission": [c * scale for c in self.colour(p.get("L"), (1, 1, 1))]}

    def _LightSource(self, d):
        from .pbrt_lights import light

        light(self, d)

    # ------------------------------------------------------------------ shapes and instances
    def _Shape(self, d):
        from .pbrt_shapes import shape

        shape(self, d, self.state)

    def _ObjectBegin(self, d):
        if self.defining is not None:
            fail(d.where, "ObjectBegin inside another ObjectBegin")
        self._AttributeBegin(d)
        self.defining = self.definitions[d.args[0]] = []

    def _ObjectEnd(self, d):
        if self.defining is None:
            fail(d.where, "ObjectEnd without ObjectBegin")
        self.defining = None
        self._AttributeEnd(d)

    def _ObjectInstance(self, d):
        from .pbrt_shapes import shape

        if self.defining is not None:
            fail(d.where, "ObjectInstance inside ObjectBegin (pbrt-v4 refuses nested instances too)")
        if d.args[0] not in self.definitions:
            fail(d.where, f'ObjectInstance "{d.args[0]}" is not defined (ObjectBegin) before it')
        for shape_directive, state in self.definitions[d.args[0]]:
            shape(self, shape_directive, replace(state, instance=self.state.ctm.copy()))

    # ------------------------------------------------------------------ the dict
    def material_for(self, state: _State) -> str:
        """The name of the state's material, with the area light's emission when one is active."""
        if state.area is None:
            return state.material
        key = (state.material, tuple(state.area["emission"]))  # one material for every shape under the same light
        if key not in self.emitting:
            name = self.emitting[key] = f"{state.material}+emission{len(self.emitting) + 1}"
            self.materials[name] = {**self.materials[state.material], "emission": state.area["emission"]}
        return self.emitting[key]

    def finish(self) -> PbrtFile:
        if self.stack:
            raise UsageError(f"{self.path}: {len(self.stack)} AttributeBegin without AttributeEnd at the end of the file")
        width, height = self.film.get("width", 1280), self.film.get("height", 720)
        data = {"width": width, "height": height, "cameras": [self._camera(width, height)]}
        data["materials"] = self.materials
        if self.image_textures:
            data["textures"] = self.image_textures
        data["lights"], data["objects"] = self.lights, self.objects
        if self.environment is not None:
            data["environment"] = self.environment
        return PbrtFile(data, self.settings, self.substitutions)

    def _camera(self, width: int, height: int) -> dict:
        """clrender's camera of pbrt's: its frame mirrored into clrender's world, pbrt's fov (of the image's
        shorter side) as the vertical fov."""
        kind, p, camera_from_world, d = self.camera or ("perspective", {}, np.eye(4), None)
        det = np.linalg.det(camera_from_world[:3, :3])
        if not det > 0:
            what = "mirrors the image" if det < 0 else "is singular (a zero scale)"
            raise UsageError(f"{d.where if d else self.path}: Camera: its transform {what}; allowed: an invertible transform without a reflection")
        world = MIRROR @ np.linalg.inv(camera_from_world)
        position = world[:3, 3]
        forward = world[:3, 2] / np.linalg.norm(world[:3, 2])
        up = world[:3, 1] / np.linalg.norm(world[:3, 1])
        camera = {"position": position.tolist(), "look_at": (position + forward).tolist(), "up": up.tolist()}
        if kind == "orthographic":
            camera.update(projection="orthographic", ortho_height=2.0 if width >= height else 2.0 * height / width)
        else:
            fov = p.get("fov", 90.0)
            if width < height:  # pbrt's fov spans the shorter side, here the width
                fov = math.degrees(2 * math.atan(math.tan(math.radians(fov) / 2) * height / width))
            camera["fov"] = fov
        if p.get("lensradius", 0.0) > 0:
            camera["aperture"] = p["lensradius"]
            camera["focus_distance"] = p.get("focaldistance") or 1e6
        return camera

    def to_world(self, ctm: np.ndarray) -> np.ndarray:
        """clrender world from pbrt object space: the current transform, then the mirror."""
        return MIRROR @ ctm
