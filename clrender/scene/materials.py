"""Surface materials: the Phong model (Lambert + Blinn-Phong, mirror, transparency + IOR), and the
glTF 2.0 metallic-roughness model with emission and transmission that the path tracer renders.

A material given with `base_color`, `metallic`, `roughness` or `transmission` is a metallic-roughness
material (MATERIAL_MODELS["gltf"]); any other is a Phong material, which the path tracer maps onto its lobes
by one rule (docs/materials.md).  `emission` and `ior` belong to both.  The Whitted integrator draws a
metallic-roughness material as Lambert with kd = base colour (what it drew of glTF materials before the path
tracer), and nothing else of it.

Textures (scene/textures.py) modulate the parameters per hit: `diffuse_texture` (Phong) or `base_color_texture`
multiplies kd / base colour, `metallic_roughness_texture` metallic (B) and roughness (G), `emissive_texture` the
emission; `occlusion_texture` darkens only the albedo AOV and the Whitted ambient term; `normal_texture` tilts
the shading normal (docs/materials.md).

A material with `type = "conductor"`, `"coated_diffuse"` or `"thin_dielectric"` is one of the lobes Mitsuba and pbrt
scenes need (kernels/bsdf_exchange.h, docs/materials.md); the Whitted integrator draws it with a stand-in: a
conductor as Lambert with kd = tint x F(normal incidence), a coated diffuse as Lambert with kd = its diffuse, a thin
dielectric as fully transparent with IOR 1 (light passes straight through)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layout import ALPHA_MODES, COAT_TABLE_RES, MATERIAL_DTYPE, MATERIAL_MODELS, SMITH_MODELS, TEXTURE_SLOT_TABLE, TEXTURE_SLOTS
from . import coat
from .checks import IOR_RANGE, SHININESS_LIMIT, Checks, TypeReader
from .textures import TextureRef, read_ref


@dataclass(frozen=True)
class Material:
    diffuse: tuple = (0.8, 0.8, 0.8)  # Lambertian albedo kd (linear RGB)
    specular: tuple = (0.0, 0.0, 0.0)  # Blinn-Phong colour ks
    shininess: float = 32.0  # Blinn-Phong exponent p in (n.h)^p
    mirror: float = 0.0  # fraction reflected as a perfect mirror, in [0, 1]
    transparency: float = 0.0  # fraction passed on to the refracted ray, in [0, 1]
    ior: float = 1.0  # index of refraction (> 0); air is 1.0, glass 1.5, water 1.333
    base_color: tuple | None = None  # glTF base colour (linear RGB); None: a Phong material, the keys above
    metallic: float = 0.0  # glTF metalness, 0 (dielectric) to 1 (metal)
    roughness: float = 0.5  # glTF perceptual roughness r, 0 to 1; GGX alpha = r^2
    transmission: float = 0.0  # fraction of the dielectric part that is transmitted (KHR_materials_transmission)
    emission: tuple = (0.0, 0.0, 0.0)  # emitted radiance of the front faces, W/(m^2 sr) per channel (path tracer)
    # one per layout.TEXTURE_SLOT_TABLE slot, which says what it scales (None: none)
    base_color_texture: TextureRef | None = None
    metallic_roughness_texture: TextureRef | None = None
    emissive_texture: TextureRef | None = None
    occlusion_texture: TextureRef | None = None
    normal_texture: TextureRef | None = None
    alpha: float = 1.0  # coverage, times the base colour texture's alpha (docs/materials.md#alpha)
    alpha_mode: str = "opaque"  # "opaque", "mask" (there where alpha >= alpha_cutoff) or "blend" (there with probability alpha)
    alpha_cutoff: float = 0.5
    double_sided: bool = True  # False: camera rays look past back faces (glTF's doubleSided false, docs/materials.md)
    # the `type = ...` materials (docs/materials.md); roughness above is theirs too (0: the smooth, delta form)
    kind: str = ""  # "" (the model follows from the keys), "conductor", "coated_diffuse" or "thin_dielectric"
    smith: str = "correlated"  # GGX masking-shadowing: "correlated" (height-correlated G2) or "separable" (Mitsuba's)
    eta: tuple = (0.0, 0.0, 0.0)  # conductor: complex IOR eta + i k per channel; (0, 1): F = 1, a perfect mirror
    k: tuple = (1.0, 1.0, 1.0)
    tint: tuple = (1.0, 1.0, 1.0)  # specular reflectance (Mitsuba's specular_reflectance)
    transmittance: tuple = (1.0, 1.0, 1.0)  # thin dielectric: specular transmittance
    lobe_ior: float = 1.5  # coat / thin sheet IOR, inside over outside
    nonlinear: bool = False  # coated diffuse: Mitsuba's nonlinear internal scattering

    @property
    def base_color_or_kd(self) -> tuple:
        return self.kd if self.base_color is None else self.base_color

    @property
    def model(self) -> str:
        if self.kind:
            return self.kind
        return "phong" if self.base_color is None else "gltf"

    @property
    def smith_code(self) -> int:
        return SMITH_MODELS[self.smith]

    @property
    def transmit_tint(self) -> tuple:
        return self.transmittance

    @property
    def coat_weight(self) -> float:
        return coat.sampling_weight(self.diffuse, self.tint)

    def _coat(self) -> tuple:
        """(external transmittance table, internal reflectance) of a coated diffuse; zeros otherwise."""
        if self.kind != "coated_diffuse":
            return np.zeros(COAT_TABLE_RES), 0.0
        if self.roughness == 0.0:
            return np.zeros(COAT_TABLE_RES), coat.fresnel_diffuse_reflectance(1.0 / self.lobe_ior)
        return coat.rough_coat(float(self.lobe_ior), float(np.float32(self.roughness) ** 2), self.smith == "separable")

    @property
    def coat_transmittance(self) -> np.ndarray:
        return self._coat()[0]

    @property
    def coat_internal(self) -> float:
        return self._coat()[1]

    @property
    def kd(self) -> tuple:
        """The Whitted integrator's diffuse colour."""
        return self.diffuse if self.base_color is None else self.base_color

    def pack(self) -> np.ndarray:
        """The material's record (layout.MATERIAL_DTYPE): each field from the attribute of the same name, so a
        field added to both reaches the kernels with no other change."""
        record = np.zeros((), MATERIAL_DTYPE)
        for name in MATERIAL_DTYPE.names:
            record[name] = getattr(self, RECORD_NAMES.get(name, name))
        return record

    @property
    def model_code(self) -> int:
        return MATERIAL_MODELS[self.model]

    @property
    def alpha_mode_code(self) -> int:
        return ALPHA_MODES[self.alpha_mode]

    @property
    def occlusion_strength(self) -> float:
        return 1.0 if self.occlusion_texture is None else self.occlusion_texture.strength

    @property
    def normal_scale(self) -> float:
        return 1.0 if self.normal_texture is None else self.normal_texture.strength

    def _refs(self) -> list:
        return [getattr(self, f"{slot}_texture") for slot in TEXTURE_SLOTS]

    @property
    def texture_indices(self) -> list:
        return [-1 if r is None else r.index for r in self._refs()]

    @property
    def texture_coords(self) -> list:
        return [0 if r is None else r.tex_coord for r in self._refs()]

    @property
    def texture_transforms(self) -> list:
        return [[1.0, 0.0, 0.0, 0.0, 1.0, 0.0] if r is None else r.matrix() for r in self._refs()]


# record fields whose Material attribute has another name (the kernels' shading formulas name them)
RECORD_NAMES = {
    "ks": "specular",
    "model": "model_code",
    "base_color": "base_color_or_kd",
    "textures": "texture_indices",
    "tex_coord": "texture_coords",
    "tex_transform": "texture_transforms",
    "alpha_mode": "alpha_mode_code",
    "smith": "smith_code",
}
DEFAULT_MATERIAL = Material()


# ------------------------------------------------------------------ reading
# the texture keys, from layout.TEXTURE_SLOT_TABLE: a slot's own key, read by its models; its Phong-model alias
SLOT_KEYS = {model: {f"{s.name}_texture": f"{s.name}_texture" for s in TEXTURE_SLOT_TABLE if s.models == model} for model in ("gltf", "all")}
ALIAS_KEYS = {s.alias: f"{s.name}_texture" for s in TEXTURE_SLOT_TABLE if s.alias}
PHONG_KEYS = ("diffuse", "specular", "shininess", "mirror", "transparency", *ALIAS_KEYS)
GLTF_KEYS = ("base_color", "metallic", "roughness", "transmission", *SLOT_KEYS["gltf"])


def _refs(checks: Checks, m: dict, path: str, keys: dict) -> dict:
    """Material attributes {slot_texture: TextureRef} of the texture keys present (`keys`: key -> attribute)."""
    return {attr: read_ref(checks, m[key], f"{path}.{key}") for key, attr in keys.items() if key in m}


def _alpha(checks: Checks, a, path: str) -> dict:
    """`alpha = { mode = "mask", cutoff = 0.5, factor = 1 }` as Material keyword arguments."""
    checks.table(a, path)
    checks.check_keys(a, path, ("mode", "cutoff", "factor"))
    return dict(
        alpha_mode=checks.choice(a, "mode", path, "opaque", tuple(ALPHA_MODES)),
        alpha_cutoff=checks.number(a, "cutoff", path, 0.5, low=0.0, high=1.0),
        alpha=checks.number(a, "factor", path, 1.0, low=0.0, high=1.0),
    )


# The `type = ...` materials: each type's own keys (with COMMON_KEYS; docs/materials.md)
COMMON_KEYS = ("type", "emission", *SLOT_KEYS["all"], "alpha", "double_sided")
TYPE_KEYS = {
    "conductor": ("eta", "k", "roughness", "tint", "smith"),
    "coated_diffuse": ("diffuse", "diffuse_texture", "ior", "roughness", "tint", "nonlinear", "smith"),
    "thin_dielectric": ("ior", "tint", "transmittance"),
}
TYPES = ("phong", "gltf", *TYPE_KEYS)  # `type`: the two models by name, or one of the lobes above
OLD_TYPES = {"seed": "phong"}  # older spellings of a `type`, still accepted (docs/scene-format.md)


def _type_of(m: dict):
    """The table's `type`, an older spelling (OLD_TYPES) read as today's."""
    kind = m.get("type")
    return OLD_TYPES[kind] if isinstance(kind, str) and kind in OLD_TYPES else kind


def _typed_material(checks: Checks, m: dict, path: str, kind: str, common: dict) -> Material:
    """A `type = "conductor" | "coated_diffuse" | "thin_dielectric"` material, with the Whitted stand-in's keys."""
    checks.check_keys(m, path, (*COMMON_KEYS, *TYPE_KEYS[kind]))
    d = DEFAULT_MATERIAL
    args = dict(kind=kind, tint=checks.vec3(m, "tint", path, d.tint, kind="colour"))
    if "smith" in TYPE_KEYS[kind]:
        args["smith"] = checks.choice(m, "smith", path, d.smith, tuple(SMITH_MODELS))
        args["roughness"] = checks.number(m, "roughness", path, 0.0, low=0.0, high=1.0)
    if kind == "conductor":
        args["eta"] = checks.vec3(m, "eta", path, d.eta, kind="colour")
        args["k"] = checks.vec3(m, "k", path, d.k, kind="colour")
        f0 = coat.conductor_normal_reflectance(args["eta"], args["k"])
        args["diffuse"] = tuple(t * f for t, f in zip(args["tint"], f0))  # the Whitted stand-in
    else:
        args["lobe_ior"] = checks.number(m, "ior", path, d.lobe_ior, low=IOR_RANGE[0], high=IOR_RANGE[1], positive=True)
    if kind == "coated_diffuse":
        args["diffuse"] = checks.vec3(m, "diffuse", path, (0.5, 0.5, 0.5), kind="colour")
        args["nonlinear"] = checks.boolean(m, "nonlinear", path, d.nonlinear)
        common.update(_refs(checks, m, path, ALIAS_KEYS))
        if args["lobe_ior"] == 1.0 and args["roughness"] > 0:
            checks.fail(f"{path}.ior", "1 leaves a rough coat without an interface; allowed: any other IOR")
    if kind == "thin_dielectric":
        args.update(diffuse=(0.0, 0.0, 0.0), transparency=1.0)  # the Whitted stand-in: straight through (ior 1)
        args["transmittance"] = checks.vec3(m, "transmittance", path, d.transmittance, kind="colour")
    return Material(**args, **common)


def _build_material(checks: Checks, m: dict, path: str) -> Material:
    d = DEFAULT_MATERIAL
    kind = checks.choice({"type": _type_of(m)}, "type", path, "", TYPES) if "type" in m else ""
    if kind in TYPE_KEYS:
        common = dict(
            emission=checks.vec3(m, "emission", path, d.emission, kind="colour"),
            **_refs(checks, m, path, SLOT_KEYS["all"]),
            **(_alpha(checks, m["alpha"], f"{path}.alpha") if "alpha" in m else {}),
            double_sided=checks.boolean(m, "double_sided", path, d.double_sided),
        )
        return _typed_material(checks, m, path, kind, common)
    phong, gltf = [k for k in PHONG_KEYS if k in m], [k for k in GLTF_KEYS if k in m]
    if kind == "phong" and gltf:
        checks.fail(f"{path}.{gltf[0]}", f"a metallic-roughness key in a Phong material; allowed: {', '.join(PHONG_KEYS)}")
    if kind == "gltf" and phong:
        checks.fail(f"{path}.{phong[0]}", f"a Phong key in a gltf material; allowed: {', '.join(GLTF_KEYS)}")
    typed = [k for k in ("eta", "k", "tint", "transmittance", "nonlinear") if k in m]
    if typed:
        checks.fail(f"{path}.{typed[0]}", f"belongs to a `type` material; allowed types: {', '.join(TYPE_KEYS)}")
    if "smith" in m and not (gltf or kind == "gltf"):
        checks.fail(f"{path}.smith", "applies to GGX materials only; allowed on metallic-roughness and `type` materials")
    if phong and gltf:
        sets = f"{', '.join(PHONG_KEYS)} or {', '.join(GLTF_KEYS)}"
        checks.fail(f"{path}.{gltf[0]}", f"a metallic-roughness key beside the Phong key {phong[0]!r}; a material uses one set: {sets}")
    common = dict(
        ior=checks.number(m, "ior", path, d.ior, low=IOR_RANGE[0], high=IOR_RANGE[1], positive=True),
        emission=checks.vec3(m, "emission", path, d.emission, kind="colour"),
        **_refs(checks, m, path, SLOT_KEYS["all"]),
        **(_alpha(checks, m["alpha"], f"{path}.alpha") if "alpha" in m else {}),
        double_sided=checks.boolean(m, "double_sided", path, d.double_sided),
    )
    if gltf or kind == "gltf":
        common.update(_refs(checks, m, path, SLOT_KEYS["gltf"]))
        occlusion = common.get("occlusion_texture")
        if occlusion is not None and not 0.0 <= occlusion.strength <= 1.0:
            checks.fail(f"{path}.occlusion_texture.strength", f"{occlusion.strength:g} is out of range; allowed: 0 to 1")
        return Material(
            base_color=checks.vec3(m, "base_color", path, (1.0, 1.0, 1.0), kind="albedo"),
            metallic=checks.number(m, "metallic", path, d.metallic, low=0.0, high=1.0),
            roughness=checks.number(m, "roughness", path, d.roughness, low=0.0, high=1.0),
            transmission=checks.number(m, "transmission", path, d.transmission, low=0.0, high=1.0),
            smith=checks.choice(m, "smith", path, d.smith, tuple(SMITH_MODELS)),
            **common,
        )
    return Material(
        diffuse=checks.vec3(m, "diffuse", path, d.diffuse, kind="albedo"),
        specular=checks.vec3(m, "specular", path, d.specular, kind="albedo"),
        shininess=checks.number(m, "shininess", path, d.shininess, low=0.0, high=SHININESS_LIMIT),
        mirror=checks.number(m, "mirror", path, d.mirror, low=0.0, high=1.0),
        transparency=checks.number(m, "transparency", path, d.transparency, low=0.0, high=1.0),
        **_refs(checks, m, path, ALIAS_KEYS),
        **common,
    )


# A `[materials.NAME]` table: its keys, with the defaults of Material's fields.
MATERIAL_READER = TypeReader(
    (*PHONG_KEYS, "ior", *GLTF_KEYS, "emission", *SLOT_KEYS["all"], "alpha", "double_sided", "type", "smith")
    + ("eta", "k", "tint", "transmittance", "nonlinear"),
    _build_material,
)


# Each model's keys: an unknown key is refused naming those of the model the table is (its `type`, else glTF's when it
# has a metallic-roughness key, else the Phong model's); MATERIAL_READER declares their union.
_SHARED = ("emission", *SLOT_KEYS["all"], "alpha", "double_sided", "type")
MODEL_KEYS = {
    "phong": (*PHONG_KEYS, "ior", *_SHARED),
    "gltf": (*GLTF_KEYS, "ior", "smith", *_SHARED),
    **{kind: (*COMMON_KEYS, *keys) for kind, keys in TYPE_KEYS.items()},
}


def model_of(m: dict) -> str:
    """The model a material table is, for its key check (a bad `type` is refused when it is read)."""
    kind = _type_of(m)
    if isinstance(kind, str) and kind in MODEL_KEYS:
        return kind
    return "gltf" if any(k in m for k in GLTF_KEYS) and not any(k in m for k in PHONG_KEYS) else "phong"


def read_material(checks: Checks, m, path: str) -> Material:
    checks.table(m, path)
    if set(m) <= set(MATERIAL_READER.keys):  # the model's own rules (mixed key sets, typed keys) say what is wrong
        return _build_material(checks, m, path)
    checks.check_keys(m, path, MODEL_KEYS[model_of(m)])
    return _build_material(checks, m, path)
