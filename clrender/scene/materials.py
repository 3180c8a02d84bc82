"""Surface materials: the seed's Whitted model (Lambert + Blinn-Phong, mirror, transparency + IOR), and the
glTF 2.0 metallic-roughness model with emission and transmission that the path tracer renders.

A material given with `base_color`, `metallic`, `roughness` or `transmission` is a metallic-roughness
material (MATERIAL_MODELS["gltf"]); any other is a seed material, which the path tracer maps onto its lobes
by one rule (docs/materials.md).  `emission` and `ior` belong to both.  The Whitted integrator draws a
metallic-roughness material as Lambert with kd = base colour (what it drew of glTF materials before the path
tracer), and nothing else of it.

Textures (scene/textures.py) modulate the parameters per hit: `diffuse_texture` (seed) or `base_color_texture`
multiplies kd / base colour, `metallic_roughness_texture` metallic (B) and roughness (G), `emissive_texture` the
emission; `occlusion_texture` darkens only the albedo AOV and the Whitted ambient term; `normal_texture` tilts
the shading normal (docs/materials.md)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layout import ALPHA_MODES, MATERIAL_DTYPE, MATERIAL_MODELS, TEXTURE_SLOTS
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
    base_color: tuple | None = None  # glTF base colour (linear RGB); None: a seed material, the keys above
    metallic: float = 0.0  # glTF metalness, 0 (dielectric) to 1 (metal)
    roughness: float = 0.5  # glTF perceptual roughness r, 0 to 1; GGX alpha = r^2
    transmission: float = 0.0  # fraction of the dielectric part that is transmitted (KHR_materials_transmission)
    emission: tuple = (0.0, 0.0, 0.0)  # emitted radiance of the front faces, W/(m^2 sr) per channel (path tracer)
    # textures by layout.TEXTURE_SLOTS slot (None: none); base_color_texture is the seed model's diffuse_texture
    base_color_texture: TextureRef | None = None  # times kd / base colour (sRGB-decoded)
    metallic_roughness_texture: TextureRef | None = None  # B times metallic, G times roughness (linear)
    emissive_texture: TextureRef | None = None  # times emission (sRGB-decoded)
    occlusion_texture: TextureRef | None = None  # R: ambient occlusion (linear)
    normal_texture: TextureRef | None = None  # tangent-space normals (linear; glTF's normalTexture)
    alpha: float = 1.0  # coverage, times the base colour texture's alpha (docs/materials.md#alpha)
    alpha_mode: str = "opaque"  # "opaque", "mask" (there where alpha >= alpha_cutoff) or "blend" (there with probability alpha)
    alpha_cutoff: float = 0.5
    double_sided: bool = True  # False: camera rays look past back faces (glTF's doubleSided false, docs/materials.md)

    @property
    def base_color_or_kd(self) -> tuple:
        return self.kd if self.base_color is None else self.base_color

    @property
    def model(self) -> str:
        return "seed" if self.base_color is None else "gltf"

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
}
DEFAULT_MATERIAL = Material()


# ------------------------------------------------------------------ reading
SEED_KEYS = ("diffuse", "specular", "shininess", "mirror", "transparency", "diffuse_texture")
GLTF_KEYS = (
    "base_color",
    "metallic",
    "roughness",
    "transmission",
    "base_color_texture",
    "metallic_roughness_texture",
    "occlusion_texture",
    "normal_texture",
)


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


def _build_material(checks: Checks, m: dict, path: str) -> Material:
    d = DEFAULT_MATERIAL
    seed, gltf = [k for k in SEED_KEYS if k in m], [k for k in GLTF_KEYS if k in m]
    if seed and gltf:
        sets = f"{', '.join(SEED_KEYS)} or {', '.join(GLTF_KEYS)}"
        checks.fail(f"{path}.{gltf[0]}", f"a metallic-roughness key beside the Whitted key {seed[0]!r}; a material uses one set: {sets}")
    common = dict(
        ior=checks.number(m, "ior", path, d.ior, low=IOR_RANGE[0], high=IOR_RANGE[1], positive=True),
        emission=checks.vec3(m, "emission", path, d.emission, kind="colour"),
        **_refs(checks, m, path, {"emissive_texture": "emissive_texture"}),
        **(_alpha(checks, m["alpha"], f"{path}.alpha") if "alpha" in m else {}),
        double_sided=checks.boolean(m, "double_sided", path, d.double_sided),
    )
    if gltf:
        slots = ("base_color", "metallic_roughness", "occlusion", "normal")
        common.update(_refs(checks, m, path, {f"{s}_texture": f"{s}_texture" for s in slots}))
        occlusion = common.get("occlusion_texture")
        if occlusion is not None and not 0.0 <= occlusion.strength <= 1.0:
            checks.fail(f"{path}.occlusion_texture.strength", f"{occlusion.strength:g} is out of range; allowed: 0 to 1")
        return Material(
            base_color=checks.vec3(m, "base_color", path, (1.0, 1.0, 1.0), kind="albedo"),
            metallic=checks.number(m, "metallic", path, d.metallic, low=0.0, high=1.0),
            roughness=checks.number(m, "roughness", path, d.roughness, low=0.0, high=1.0),
            transmission=checks.number(m, "transmission", path, d.transmission, low=0.0, high=1.0),
            **common,
        )
    return Material(
        diffuse=checks.vec3(m, "diffuse", path, d.diffuse, kind="albedo"),
        specular=checks.vec3(m, "specular", path, d.specular, kind="albedo"),
        shininess=checks.number(m, "shininess", path, d.shininess, low=0.0, high=SHININESS_LIMIT),
        mirror=checks.number(m, "mirror", path, d.mirror, low=0.0, high=1.0),
        transparency=checks.number(m, "transparency", path, d.transparency, low=0.0, high=1.0),
        **_refs(checks, m, path, {"diffuse_texture": "base_color_texture"}),
        **common,
    )


# A `[materials.NAME]` table: its keys, with the defaults of Material's fields.
MATERIAL_READER = TypeReader((*SEED_KEYS, "ior", *GLTF_KEYS, "emission", "emissive_texture", "alpha", "double_sided"), _build_material)


def read_material(checks: Checks, m, path: str) -> Material:
    checks.table(m, path)
    return MATERIAL_READER.read(checks, m, path)
