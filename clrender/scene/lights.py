"""Light sources and their units.

Every light has a colour c and an intensity I.  With `falloff = "none"` (the
seed's model, the default) a surface point receives c*I*max(0, n.l) from a
point or directional light, and an area light adds c*I/n^2 times the same
term for each of its n x n unblocked samples, so I is the brightness a
surface facing the light head-on would get.  With `falloff =
"inverse_square"` the light is physical: a point light's I is radiant
intensity (the value is irradiance c*I*cos/r^2), and an area light's I is
radiance, so the sum estimates the irradiance E = I * integral of
cos(theta) cos(theta_light) / r^2 over the light (two-sided emitter); the
surface then reflects E with the energy-conserving BRDF kd/pi + ks (s+8)/(8 pi)
(n.h)^s (kernels/shade.h, blinn_phong).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..layout import LIGHT_DTYPE, LIGHT_TYPES
from ..layout import LIGHT_FALLOFFS as FALLOFFS
from .checks import MAX_AREA_SAMPLES, RADIANCE_LIMIT, Checks, TypeReader

__all__ = ["FALLOFFS", "LIGHT_READERS", "LIGHT_TYPES", "Light", "read_light"]


@dataclass(frozen=True)
class Light:
    type: str = "point"  # "point", "directional" or "area"
    position: tuple = (0.0, 0.0, 0.0)  # point light position, or an area light's corner
    direction: tuple = (0.0, -1.0, 0.0)  # directional light: the direction light travels
    edge_a: tuple = (1.0, 0.0, 0.0)  # area light: first edge vector from the corner
    edge_b: tuple = (0.0, 0.0, 1.0)  # area light: second edge vector
    color: tuple = (1.0, 1.0, 1.0)  # linear RGB
    intensity: float = 1.0  # see the module docstring for units
    samples: int = 5  # area light: samples per side (n x n stratified), the seed's 5
    falloff: str = "none"  # "none" (the seed) or "inverse_square" (physical)

    def pack(self) -> np.ndarray:
        """The light's record (layout.LIGHT_DTYPE, the kernels' `Light`), field by field."""
        record = np.zeros((), LIGHT_DTYPE)
        record["type"] = LIGHT_TYPES[self.type]
        record["samples"] = self.samples
        record["intensity"] = self.intensity
        record["falloff"] = FALLOFFS[self.falloff]
        record["position"] = self.position
        record["direction"] = self.direction
        record["colour"] = self.color
        record["edge_a"] = self.edge_a
        record["edge_b"] = self.edge_b
        return record


# ------------------------------------------------------------------ reading
# Keys every light type reads (`type`, and colour, intensity and falloff with Light's defaults).
COMMON_KEYS = ("type", "color", "intensity", "falloff")


def _point(checks: Checks, l: dict, path: str) -> dict:
    return {"position": checks.vec3(l, "position", path)}


def _directional(checks: Checks, l: dict, path: str) -> dict:
    return {"direction": checks.vec3(l, "direction", path, kind="vector")}


def _area(checks: Checks, l: dict, path: str) -> dict:
    args = {"position": checks.vec3(l, "corner", path)}
    args["edge_a"] = checks.vec3(l, "edge_a", path, kind="vector")
    args["edge_b"] = checks.vec3(l, "edge_b", path, kind="vector")
    checks.not_parallel(args["edge_a"], args["edge_b"], f"{path}.edge_b")
    args["samples"] = checks.integer(l, "samples", path, Light.samples, low=1, high=MAX_AREA_SAMPLES)
    return args


# Each light type: its keys (the common ones and its own) and what it reads of its own.
LIGHT_READERS = {
    "point": TypeReader((*COMMON_KEYS, "position"), _point),
    "directional": TypeReader((*COMMON_KEYS, "direction"), _directional),
    "area": TypeReader((*COMMON_KEYS, "corner", "edge_a", "edge_b", "samples"), _area),
}


def read_light(checks: Checks, l, path: str) -> Light:
    """A `[[lights]]` table: its type first, then the keys that type accepts."""
    checks.table(l, path)
    kind = checks.choice(l, "type", path, "point", tuple(LIGHT_TYPES))
    reader = LIGHT_READERS[kind]
    checks.check_keys(l, path, reader.keys)
    d = Light()
    args = dict(
        type=kind,
        color=checks.vec3(l, "color", path, d.color, kind="colour"),
        intensity=checks.number(l, "intensity", path, d.intensity, low=0.0, high=RADIANCE_LIMIT),
        falloff=checks.choice(l, "falloff", path, d.falloff, tuple(FALLOFFS)),
    )
    args.update(reader.build(checks, l, path))
    return Light(**args)
