"""Light sources and their units.

Every light has a colour c and an intensity I.  With `falloff = "none"` (the
unnormalised model, the default) a surface point receives c*I*max(0, n.l) from a
point or directional light, and an area light adds c*I/n^2 times the same
term for each of its n x n unblocked samples, so I is the brightness a
surface facing the light head-on would get.  With `falloff =
"inverse_square"` the light is physical: a point light's I is radiant
intensity (the value is irradiance c*I*cos/r^2), and an area light's I is
radiance, so the sum estimates the irradiance E = I * integral of
cos(theta) cos(theta_light) / r^2 over the light (two-sided emitter); the
surface then reflects E with the energy-conserving BRDF kd/pi + ks (s+8)/(8 pi)
(n.h)^s (kernels/shade.h, blinn_phong).

A spot light is always physical: a point light at `position` whose radiant intensity towards d is
c*I*profile(d) (W/sr; I at the axis `direction`), falling off as 1/r^2; profile is Mitsuba 3's (1 within
beam_width of the axis, linear in the angle down to 0 at cutoff_angle) or pbrt-v4's (smoothstep in the
cosine between cutoff_angle and beam_width, pbrt's coneangle and coneangle - conedelta): kernels/spot.h.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..layout import LIGHT_DTYPE, LIGHT_TYPES, SPOT_PROFILES
from ..layout import LIGHT_FALLOFFS as FALLOFFS
from .checks import MAX_AREA_SAMPLES, RADIANCE_LIMIT, Checks, TypeReader

__all__ = ["FALLOFFS", "LIGHT_READERS", "LIGHT_TYPES", "Light", "read_light"]


@dataclass(frozen=True)
class Light:
    type: str = "point"  # "point", "directional", "area" or "spot"
    position: tuple = (0.0, 0.0, 0.0)  # point light position, or an area light's corner
    direction: tuple = (0.0, -1.0, 0.0)  # directional light: the direction light travels
    edge_a: tuple = (1.0, 0.0, 0.0)  # area light: first edge vector from the corner
    edge_b: tuple = (0.0, 0.0, 1.0)  # area light: second edge vector
    color: tuple = (1.0, 1.0, 1.0)  # linear RGB
    intensity: float = 1.0  # see the module docstring for units
    samples: int = 5  # area light: samples per side (n x n stratified)
    falloff: str = "none"  # "none" (unnormalised: no 1/r^2, no 1/pi) or "inverse_square" (physical)
    cutoff_angle: float = 20.0  # spot: degrees from the axis where its light stops (Mitsuba's default)
    beam_width: float = 15.0  # spot: degrees from the axis within which it is at full intensity
    profile: str = "mitsuba"  # spot: "mitsuba" or "pbrt" (kernels/spot.h)

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
        cutoff, beam = math.radians(self.cutoff_angle), math.radians(self.beam_width)
        record["spot_cutoff"], record["spot_beam"] = cutoff, beam
        record["spot_cos_cutoff"], record["spot_cos_beam"] = math.cos(cutoff), math.cos(beam)
        record["spot_profile"] = SPOT_PROFILES[self.profile]
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


def _spot(checks: Checks, l: dict, path: str) -> dict:
    args = {"position": checks.vec3(l, "position", path), "direction": checks.vec3(l, "direction", path, kind="vector")}
    args["cutoff_angle"] = checks.number(l, "cutoff_angle", path, Light.cutoff_angle, low=0.0, high=180.0, positive=True)
    args["beam_width"] = checks.number(l, "beam_width", path, 0.75 * args["cutoff_angle"], low=0.0, high=180.0)
    if args["beam_width"] > args["cutoff_angle"]:
        checks.fail(f"{path}.beam_width", f"{args['beam_width']:g} is wider than cutoff_angle {args['cutoff_angle']:g}; allowed: 0 to cutoff_angle")
    args["profile"] = checks.choice(l, "profile", path, Light.profile, tuple(SPOT_PROFILES))
    if l.get("falloff", "inverse_square") != "inverse_square":
        checks.fail(f"{path}.falloff", f"{l['falloff']!r}: a spot light is physical; allowed: 'inverse_square'")
    args["falloff"] = "inverse_square"
    return args


# Each light type: its keys (the common ones and its own) and what it reads of its own.
LIGHT_READERS = {
    "point": TypeReader((*COMMON_KEYS, "position"), _point),
    "directional": TypeReader((*COMMON_KEYS, "direction"), _directional),
    "area": TypeReader((*COMMON_KEYS, "corner", "edge_a", "edge_b", "samples"), _area),
    "spot": TypeReader((*COMMON_KEYS, "position", "direction", "cutoff_angle", "beam_width", "profile"), _spot),
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
