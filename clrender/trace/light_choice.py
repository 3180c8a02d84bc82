"""Next-event estimation's light: the path tracer (kernels/path.cl direct_lighting) sends one shadow ray a vertex, to
ONE light picked mostly by its power (pbrt-v4's PowerLightSampler, with a defensive even share), not one to every light.

The lights, in the order of their LightChoice records (layout.LIGHT_CHOICE_DTYPE): the scene's lights, then the
emissive triangles (trace/path.py), then the environment (the map, or the constant colour).  Their power, in W
(float64; mean over R, G and B), with r the radius of the scene's bounding sphere:

| light | power |
|---|---|
| point, `inverse_square` | 4 pi I |
| spot | 2 pi I ((1 - cos beam) + (cos beam - cos cutoff) / 2) (pbrt-v4's SpotLight::Phi) |
| area, `inverse_square` (two-sided radiance I) | 2 pi A I |
| directional, `inverse_square` | pi r^2 I: the irradiance I through the scene's disc |
| point, directional or area with falloff `none` | pi r^2 pi I: their irradiance pi I is the same everywhere |
| emissive triangle | pi A Le |
| environment | 4 pi pi r^2 L, L its mean radiance over the sphere (pbrt-v4's infinite lights' Phi) |

A light's probability is (1 - DEFENSIVE_SHARE) times its share of all the power plus DEFENSIVE_SHARE divided evenly
over the groups that have power (each scene light, the emissive triangles together, the environment), inside a group
by power: a defensive mixture (Hesterberg 1995).  The second moment of a vertex's light estimate is then at most
1 / (1 - DEFENSIVE_SHARE) times that of the choice by power alone, and far less where a dim light lies close to what
it lights (the power knows nothing of distance).

With NEAR_SHARE (near_share: when two or more scene lights other than physical area lights have power) every share
above is scaled by 1 - NEAR_SHARE and one more record, the near choice, takes NEAR_SHARE: the kernel then picks a
scene light by its unoccluded irradiance at the vertex (path.cl light_nearness, pick_near), and a scene light's
probability there is its record's plus NEAR_SHARE times its part of the nearness (path.cl direct_lighting).

The power only shapes the choice: both strategies of multiple importance sampling use the chosen light's
probability times its own density, so the estimate is unbiased whatever the powers are, as long as every light that
emits can be chosen.  So each light of positive power keeps a share of at least MIN_SHARE, and if no light has any
power (a black scene) every one is equally likely.  The records hold float32 running sums `cdf` (the kernel's binary
search) and `prob`, each record's difference of consecutive sums: the width of the interval of uniforms that picks
it (to float32 rounding), so the probability the kernel weights by is the one it samples with.
"""

from __future__ import annotations

import math

import numpy as np

from ..layout import LIGHT_CHOICE_DTYPE

MIN_SHARE = 2.0**-20  # a light's least share of the choice: 16 float32 steps below 1, so its cdf interval is never empty
# the share of the choice spread evenly over the light groups (each scene light, the emissive triangles together, the
# environment), the rest by power: a light much dimmer than the rest but near what it lights is picked often enough
# that its 1/p does not make fireflies (docs/benchmarks.md, "One light a vertex": 0.5 against power alone)
DEFENSIVE_SHARE = 0.5
# the share of the choice given to the near choice (path.cl pick_near): a scene light (not a physical area light)
# picked in proportion to its unoccluded irradiance at the vertex, I / d^2 (docs/materials.md)
NEAR_SHARE = 0.5
NO_GEOMETRY_RADIUS = 1.0  # the scene radius r when the flat part has no primitive (only instances): a neutral guess


def scene_radius(primitives) -> float:
    """The radius of the sphere about the primitives' bounding box (NO_GEOMETRY_RADIUS without primitives)."""
    if primitives.count == 0:
        return NO_GEOMETRY_RADIUS
    lo, hi = primitives.bounds()
    radius = 0.5 * float(np.linalg.norm(hi.max(axis=0).astype(np.float64) - lo.min(axis=0)))
    return radius if math.isfinite(radius) and radius > 0 else NO_GEOMETRY_RADIUS


def light_power(light, radius: float) -> float:
    """The power of one scene light (scene/lights.py Light) in the module docstring's table."""
    strength = light.intensity * float(np.mean(light.color))
    disc = math.pi * radius * radius
    if light.type == "spot":
        cos_beam, cos_cutoff = math.cos(math.radians(light.beam_width)), math.cos(math.radians(light.cutoff_angle))
        return 2 * math.pi * strength * ((1 - cos_beam) + (cos_beam - cos_cutoff) / 2)
    if light.falloff != "inverse_square":
        return disc * math.pi * strength
    if light.type == "point":
        return 4 * math.pi * strength
    if light.type == "area":
        area = float(np.linalg.norm(np.cross(np.asarray(light.edge_a, np.float64), np.asarray(light.edge_b, np.float64))))
        return 2 * math.pi * area * strength
    return disc * strength  # directional


def environment_radiance(scene) -> float:
    """The environment's mean radiance over the sphere of directions: a map's texels (times its intensity) weighted
    by sin(theta) of their rows, or the constant colour."""
    env = scene.environment_map
    if env is None:
        return float(np.mean(scene.environment))
    rows = env.texels.astype(np.float64).mean(axis=2).mean(axis=1)  # (H,) each row's mean over u and RGB
    sin_theta = np.sin(np.pi * (np.arange(len(rows)) + 0.5) / len(rows))
    return env.intensity * float((rows * sin_theta).sum() / sin_theta.sum())


def powers(scene, primitives, emitter_power: np.ndarray) -> np.ndarray:
    """Every light's power (float64), in the LightChoice order: scene lights, emissive triangles, environment."""
    radius = scene_radius(primitives)
    lights = [light_power(light, radius) for light in scene.lights]
    environment = 4 * math.pi * math.pi * radius * radius * environment_radiance(scene)
    return np.concatenate([np.asarray(lights, np.float64), np.asarray(emitter_power, np.float64), [environment]])


def groups(scene, n_emitters: int) -> np.ndarray:
    """Each light's group for DEFENSIVE_SHARE, in the LightChoice order: every scene light its own, the emissive
    triangles one together, the environment one."""
    n = len(scene.lights)
    return np.concatenate([np.arange(n), np.full(n_emitters, n), [n + 1]])


def near_share(scene) -> float:
    """NEAR_SHARE where two or more scene lights of positive power can take the near choice (any but a physical area
    light), else 0: with one, the near choice would be a fixed pick of that light, taking picks from the others
    whatever the vertex (wizard_cat's directional light beside its physical area light: 1.8x the variance)."""
    radius = NO_GEOMETRY_RADIUS  # any: only the sign of the power matters here
    near = [light for light in scene.lights if light_power(light, radius) > 0 and not (light.type == "area" and light.falloff == "inverse_square")]
    return NEAR_SHARE if len(near) >= 2 else 0.0


def choices(power: np.ndarray, group: np.ndarray | None = None, defensive: float = 0.0, near: float | None = None) -> np.ndarray:
    """LightChoice records of lights of these powers (the module docstring's rules): a share `defensive` of the
    choice spread evenly over the groups (`group`: each light's; default one group each) that have power, in
    proportion to power inside each, the rest by power; with `near`, every share times 1 - near and one more record,
    the near choice, of share `near`."""
    power = np.where(np.isfinite(power) & (power > 0), power, 0.0)
    if power.sum() > 0:
        group = np.arange(len(power)) if group is None else np.asarray(group)
        group_power = np.bincount(group, power)[group]
        live = np.unique(group[power > 0])
        inside = np.divide(power, group_power, out=np.zeros_like(power), where=group_power > 0)
        share = (1 - defensive) * power / power.sum() + defensive * inside / len(live)
        share = np.where(share > 0, np.maximum(share, MIN_SHARE), 0.0)
    else:
        share = np.ones(len(power))
    if near is not None:
        share = np.append(share / share.sum() * (1 - near), near)
    cdf = (np.cumsum(share) / share.sum()).astype(np.float32)
    cdf[np.flatnonzero(share)[-1] :] = 1.0  # from the last light that can be chosen on: u < 1 always finds one
    records = np.zeros(len(share), LIGHT_CHOICE_DTYPE)
    records["cdf"] = cdf
    records["prob"] = np.diff(cdf.astype(np.float64), prepend=0.0)  # the intervals' widths
    return records


PROBE = "light_choice_probe.cl"


def picks(device, records: np.ndarray, n: int, seed: int = 0, lanes: int = 1) -> np.ndarray:
    """The records (n,) kernels/light_choice.h picks for the first random number of streams (seed, i, 0), i < n,
    run on the device (kernels/light_choice_probe.cl; tests), `lanes` (1, 8 or 16) picks a work-item."""
    from .tracer import trace_defines
    from .work_layout import read_items

    kernel = device.kernel(PROBE, "light_pick_probe", {**trace_defines(), "LANES": lanes})
    choices = device.to_device(np.ascontiguousarray(records, LIGHT_CHOICE_DTYPE))
    args = dict(n=np.int32(n), seed=np.uint32(seed), choices=choices, n_choices=np.int32(len(records)))
    return read_items(device, kernel, -(-n // lanes), n, np.int32, **args)
