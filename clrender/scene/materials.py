"""Surface materials: the seed's Whitted model (Lambert + Blinn-Phong, mirror, transparency + IOR)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layout import MATERIAL_DTYPE


@dataclass(frozen=True)
class Material:
    diffuse: tuple = (0.8, 0.8, 0.8)  # Lambertian albedo kd (linear RGB)
    specular: tuple = (0.0, 0.0, 0.0)  # Blinn-Phong colour ks
    shininess: float = 32.0  # Blinn-Phong exponent p in (n.h)^p
    mirror: float = 0.0  # fraction reflected as a perfect mirror, in [0, 1]
    transparency: float = 0.0  # fraction passed on to the refracted ray, in [0, 1]
    ior: float = 1.0  # index of refraction (> 0); air is 1.0, glass 1.5, water 1.333

    def pack(self) -> np.ndarray:
        """The material's record (layout.MATERIAL_DTYPE): (kd, shininess) (ks, mirror) (transparency, ior, 0, 0)."""
        record = np.zeros((), MATERIAL_DTYPE)
        record["kd_shininess"] = [*self.diffuse, self.shininess]
        record["ks_mirror"] = [*self.specular, self.mirror]
        record["transparency_ior"] = [self.transparency, self.ior, 0, 0]
        return record


DEFAULT_MATERIAL = Material()
