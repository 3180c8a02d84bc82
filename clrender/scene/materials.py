"""Surface materials: the seed's Whitted model (Lambert + Blinn-Phong, mirror, transparency + IOR)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layout import MATERIAL_DTYPE
from .checks import IOR_RANGE, SHININESS_LIMIT, Checks, TypeReader


@dataclass(frozen=True)
class Material:
    diffuse: tuple = (0.8, 0.8, 0.8)  # Lambertian albedo kd (linear RGB)
    specular: tuple = (0.0, 0.0, 0.0)  # Blinn-Phong colour ks
    shininess: float = 32.0  # Blinn-Phong exponent p in (n.h)^p
    mirror: float = 0.0  # fraction reflected as a perfect mirror, in [0, 1]
    transparency: float = 0.0  # fraction passed on to the refracted ray, in [0, 1]
    ior: float = 1.0  # index of refraction (> 0); air is 1.0, glass 1.5, water 1.333

    def pack(self) -> np.ndarray:
        """The material's record (layout.MATERIAL_DTYPE): each field from the attribute of the same name, so a
        field added to both reaches the kernels with no other change."""
        record = np.zeros((), MATERIAL_DTYPE)
        for name in MATERIAL_DTYPE.names:
            record[name] = getattr(self, RECORD_NAMES.get(name, name))
        return record


RECORD_NAMES = {"kd": "diffuse", "ks": "specular"}  # the record's fields named as the kernels' shading formulas name them
DEFAULT_MATERIAL = Material()


# ------------------------------------------------------------------ reading
def _build_material(checks: Checks, m: dict, path: str) -> Material:
    d = DEFAULT_MATERIAL
    return Material(
        diffuse=checks.vec3(m, "diffuse", path, d.diffuse, kind="colour"),
        specular=checks.vec3(m, "specular", path, d.specular, kind="colour"),
        shininess=checks.number(m, "shininess", path, d.shininess, low=0.0, high=SHININESS_LIMIT),
        mirror=checks.number(m, "mirror", path, d.mirror, low=0.0, high=1.0),
        transparency=checks.number(m, "transparency", path, d.transparency, low=0.0, high=1.0),
        ior=checks.number(m, "ior", path, d.ior, low=IOR_RANGE[0], high=IOR_RANGE[1], positive=True),
    )


# A `[materials.NAME]` table: its keys, with the defaults of Material's fields.
MATERIAL_READER = TypeReader(("diffuse", "specular", "shininess", "mirror", "transparency", "ior"), _build_material)


def read_material(checks: Checks, m, path: str) -> Material:
    checks.table(m, path)
    return MATERIAL_READER.read(checks, m, path)
