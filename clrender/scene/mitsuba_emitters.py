"""Mitsuba 3's emitters as clrender lights and environments (area emitters sit on shapes: mitsuba_plugins.py).

Units: Mitsuba's `point` intensity is W/sr and `directional` irradiance W/m², which are clrender's physical
lights (`falloff = "inverse_square"`); `constant` radiance is `[environment] color`; `envmap` is
`[environment] file` with `scale` as `intensity` and a to_world that may only turn about +y (the map's
convention is Mitsuba's: docs/scene-format.md#environment-maps).  `spot` is written with the spot light's
contract keys (docs/scene-formats.md) and refused until this build has the spot light.
"""

from __future__ import annotations

import math

import numpy as np

from .lights import LIGHT_READERS


def _position(e) -> list:
    if e.has("position"):
        return list(e.get("position"))
    return e.get("to_world", np.eye(4))[:3, 3].tolist()


def _direction(e, default_axis) -> list:
    """`direction` if given, else the to_world's image of the local axis (Mitsuba's emitters shine along +z)."""
    if e.has("direction"):
        return list(e.get("direction"))
    d = e.get("to_world", np.eye(4))[:3, :3] @ np.asarray(default_axis, np.float64)
    return (d / np.linalg.norm(d)).tolist()


def point(reader, e):
    rgb, _ = reader.colour(e, "intensity", 1.0, texture=False)
    reader.out["lights"].append({"type": "point", "position": _position(e), "color": rgb, "intensity": 1.0, "falloff": "inverse_square"})


def directional(reader, e):
    rgb, _ = reader.colour(e, "irradiance", 1.0, texture=False)
    reader.out["lights"].append(
        {"type": "directional", "direction": _direction(e, (0, 0, 1)), "color": rgb, "intensity": 1.0, "falloff": "inverse_square"}
    )


def spot(reader, e):
    light = spot_light(reader, e)
    if e.child("texture") is not None:
        reader.refuse(e, 'emitter "spot" with a projected texture is not supported', "no texture")
    if "spot" not in LIGHT_READERS:
        reader.refuse(e, 'emitter "spot" needs the spot light, which this build of clrender does not have yet', "left out")
        return
    reader.out["lights"].append(light)


def spot_light(reader, e) -> dict:
    """The spot light contract's dict: Mitsuba's cone (`cutoff_angle`, `beam_width`, degrees) and its falloff profile."""
    rgb, _ = reader.colour(e, "intensity", 1.0, texture=False)
    cutoff = reader.scalar(e, "cutoff_angle", 20.0)
    light = {
        "type": "spot",
        "position": _position(e),
        "direction": _direction(e, (0, 0, 1)),
        "cutoff_angle": cutoff,
        "beam_width": reader.scalar(e, "beam_width", cutoff * 3 / 4),
        "profile": "mitsuba",
        "color": rgb,
        "intensity": 1.0,
        "falloff": "inverse_square",
    }
    return light


def constant(reader, e):
    rgb, _ = reader.colour(e, "radiance", 1.0, texture=False)
    reader.out["environment"] = {"color": rgb}


def envmap(reader, e):
    name = e.get("filename")
    if not isinstance(name, str):
        e.fail('emitter "envmap" needs a filename')
    m = e.get("to_world", np.eye(4))[:3, :3]
    angle = math.degrees(math.atan2(m[0, 2], m[0, 0]))
    turn = np.array(
        [
            [math.cos(math.radians(angle)), 0, math.sin(math.radians(angle))],
            [0, 1, 0],
            [-math.sin(math.radians(angle)), 0, math.cos(math.radians(angle))],
        ]
    )
    if not np.allclose(m, turn, atol=1e-5):
        e.fail('emitter "envmap" to_world must be a rotation about +y (clrender turns maps only about y)')
    reader.out["environment"] = {"file": name, "intensity": reader.scalar(e, "scale", 1.0), "rotation": angle}


EMITTER_MAPPERS = {"point": point, "directional": directional, "spot": spot, "constant": constant, "envmap": envmap}
