"""pbrt-v4 LightSource directives as clrender lights (docs/scene-formats-pbrt.md).

pbrt-v4 divides a light's spectrum by its luminance (SpectrumToPhotometric) and an RGB's by its illuminant's,
so an `rgb I` (or `L`) is the RGB radiant intensity (radiance) itself: the colour, times `scale` as intensity.
Point and spot lights use clrender's physical `inverse_square` model (intensity in W/sr), distant lights give
irradiance `L·scale` (the same model's directional light).
"""

from __future__ import annotations

import numpy as np

from .pbrt_parse import fail


def light(reader, d):
    kind = d.args[0]
    handler = {"point": _point, "spot": _spot, "distant": _distant, "infinite": _infinite}.get(kind)
    if handler is None:
        reader.unsupported(d, f'LightSource "{kind}"', ("point", "spot", "distant", "infinite"), "no light")
        return
    handler(reader, d)


def _point_of(reader, p, key, default):
    v = p[key].values if key in p else default
    if len(v) != 3:
        fail(p[key].where, f'"{key}": expected 3 numbers')
    m = reader.to_world(reader.state.ctm)
    return m[:3, :3] @ np.asarray(v, np.float64) + m[:3, 3]


def _no_power(reader, d, p):
    if "power" in p:
        reader.unsupported(d, f'LightSource "{d.args[0]}" parameter "power"', ("I or L with scale",), "ignored")


def _point(reader, d):
    p = reader.params(d, ("I", "scale", "from", "power"))
    _no_power(reader, d, p)
    reader.lights.append(
        {
            "type": "point",
            "position": _point_of(reader, p, "from", (0, 0, 0)).tolist(),
            "color": reader.colour(p.get("I"), (1, 1, 1)),
            "intensity": reader.number(d, p.get("scale"), 1.0),
            "falloff": "inverse_square",
        }
    )


def _spot(reader, d):
    """pbrt-v4's SpotLight: full intensity inside coneangle − conedelta, smoothstep to 0 at coneangle."""
    p = reader.params(d, ("I", "scale", "from", "to", "coneangle", "conedelta", "power"))
    _no_power(reader, d, p)
    origin, target = _point_of(reader, p, "from", (0, 0, 0)), _point_of(reader, p, "to", (0, 0, 1))
    cone, delta = reader.number(d, p.get("coneangle"), 30.0), reader.number(d, p.get("conedelta"), 5.0)
    if np.linalg.norm(target - origin) == 0:
        fail(d.where, 'LightSource "spot": "from" and "to" are the same point')
    reader.lights.append(
        {
            "type": "spot",
            "position": origin.tolist(),
            "direction": ((target - origin) / np.linalg.norm(target - origin)).tolist(),
            "cutoff_angle": cone,
            "beam_width": max(cone - delta, 0.0),
            "profile": "pbrt",
            "color": reader.colour(p.get("I"), (1, 1, 1)),
            "intensity": reader.number(d, p.get("scale"), 1.0),
        }
    )


def _distant(reader, d):
    p = reader.params(d, ("L", "scale", "from", "to", "illuminance"))
    if "illuminance" in p:
        reader.unsupported(d, 'LightSource "distant" parameter "illuminance"', ("L with scale",), "ignored")
    direction = _point_of(reader, p, "to", (0, 0, 1)) - _point_of(reader, p, "from", (0, 0, 0))
    if np.linalg.norm(direction) == 0:
        fail(d.where, 'LightSource "distant": "from" and "to" are the same point')
    reader.lights.append(
        {
            "type": "directional",
            "direction": (direction / np.linalg.norm(direction)).tolist(),
            "color": reader.colour(p.get("L"), (1, 1, 1)),
            "intensity": reader.number(d, p.get("scale"), 1.0),
            "falloff": "inverse_square",
        }
    )


def _infinite(reader, d):
    """A constant sky (`L`) is clrender's environment colour; an image (`filename`) is refused: pbrt-v4 reads
    only equal-area octahedral square maps, clrender only equirectangular ones, and converting would write a file."""
    p = reader.params(d, ("L", "scale", "filename", "illuminance", "portal"))
    if "filename" in p:
        reader.unsupported(d, 'LightSource "infinite" "filename" (an equal-area octahedral map)', ("infinite with L",), "its L (default 1)")
    if "illuminance" in p or "portal" in p:
        reader.unsupported(d, 'LightSource "infinite" "illuminance"/"portal"', ("L with scale",), "ignored")
    scale = reader.number(d, p.get("scale"), 1.0)
    colour = [c * scale for c in reader.colour(p.get("L"), (1, 1, 1))]
    if reader.environment is not None:
        reader.environment["color"] = [a + b for a, b in zip(reader.environment["color"], colour, strict=True)]
    else:
        reader.environment = {"color": colour}
