"""An environment map on the device (kernels/envmap.h): its EnvMap record and buffers for the render kernels,
and, for tests, its sampler and lookup run in batches (kernels/envmap_probe.cl).

scene/environment.py reads the map and builds its distribution; this module only packs and uploads it.
A scene without a map gets a record of width 0 and one-texel placeholder buffers (the kernels never read them).
"""

from __future__ import annotations

import math

import numpy as np

from ..layout import ENV_MAP_DTYPE
from ..scene.environment import Distribution, EnvironmentMap, distribution
from .tracer import trace_defines
from .work_layout import read_items

PROBE = "envmap_probe.cl"


def record(env: EnvironmentMap | None, d: Distribution | None = None) -> np.ndarray:
    """The EnvMap record (layout.ENV_MAP_DTYPE) of `env` uploaded as `d`; width 0 for None."""
    r = np.zeros((), ENV_MAP_DTYPE)
    if env is not None:
        angle = math.radians(env.rotation)
        r["width"], r["height"] = d.width, d.height
        r["cos_rotation"], r["sin_rotation"] = math.cos(angle), math.sin(angle)
        r["sampled"] = d.sampled
        r["row_buckets"], r["column_buckets"] = d.row_buckets, d.column_buckets
    return r


def arrays(env: EnvironmentMap | None) -> tuple[np.ndarray, dict]:
    """The EnvMap record of `env` and its host arrays by the render kernels' names: env_texels, env_marginal,
    env_conditional, env_guides (one-texel placeholders without a map)."""
    if env is None:
        placeholder = np.zeros(4, np.float32)
        return record(None), {name: placeholder for name in ("env_texels", "env_marginal", "env_conditional", "env_guides")}
    d = distribution(env)
    return record(env, d), dict(env_texels=d.texels, env_marginal=d.marginal, env_conditional=d.conditional, env_guides=d.guides)


def upload(device, env: EnvironmentMap | None) -> dict:
    """Keyword arguments of the probe kernels for `env`: env_map, env_texels, env_marginal, env_conditional, env_guides."""
    env_map, host = arrays(env)
    return dict(env_map=env_map, **{name: device.to_device(a) for name, a in host.items()})


class EnvProbe:
    """envmap.h's sampler and lookup for a map, run on the device for many directions at once (tests)."""

    def __init__(self, device, env: EnvironmentMap):
        self.device = device
        self.args = upload(device, env)
        self._sample = device.kernel(PROBE, "env_sample_probe", trace_defines())
        self._eval = device.kernel(PROBE, "env_eval_probe", trace_defines())

    def _run(self, kernel, name: str, values: np.ndarray) -> np.ndarray:
        dev, n = self.device, len(values)
        return read_items(dev, kernel, n, (n, 4), np.float32, n=np.int32(n), **{name: dev.to_device(values)}, **self.args)

    def sample(self, u) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Directions (n, 3), their radiance (n, 3) and solid-angle densities (n,) for uniforms u (n, 2) in [0, 1)."""
        u = np.ascontiguousarray(u, np.float32).reshape(-1, 2)
        rows = self._run(self._sample, "u", u)
        radiance = self._run(self._eval, "directions", np.ascontiguousarray(np.pad(rows[:, :3], ((0, 0), (0, 1)))))[:, :3]
        return rows[:, :3], radiance, rows[:, 3]

    def eval(self, directions) -> tuple[np.ndarray, np.ndarray]:
        """Radiance (n, 3) and solid-angle density (n,) towards unit world directions (n, 3)."""
        d = np.zeros((len(directions), 4), np.float32)
        d[:, :3] = directions
        rows = self._run(self._eval, "directions", d)
        return rows[:, :3], rows[:, 3]
