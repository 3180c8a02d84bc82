"""The path tracer's host side (kernels/path.cl): emissive triangles as a power distribution, and the
values of one launch of `render_path`.

PathIntegrator (integrators.py) owns the settings and passes; this module knows what the path kernel
takes beyond the frame every render kernel shares.
"""

from __future__ import annotations

import numpy as np

from ..errors import UsageError
from ..layout import EMITTER_DTYPE, PATH_PARAMS_DTYPE, TEXTURE_SLOTS
from .geometry import Primitives

RR_DEPTH = 3  # Russian roulette from this many bounces on, when RenderSettings.rr_depth is None


def emitters(primitives: Primitives) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The emissive triangles (layout.EMITTER_DTYPE records), every primitive id's index among them (-1: none) and
    each one's power (float64 W, the share NEE picks it by: trace/light_choice.py): pi times its area times its
    material's mean emitted radiance (one-sided Lambertian emission).

    With an emissive texture the radiance is the factor times the texture's mean texel over the whole image, not
    over the triangle's own UVs: an approximation of the power that only shapes the sampling density.  Both
    strategies evaluate the texel at the point they find (path.cl emission_at, emission_met), so the estimate
    stays unbiased as long as no triangle that emits gets a zero share, which a texture of mean 0 (black
    everywhere) cannot make emit."""
    n_tri = primitives.n_triangles
    emission = primitives.materials["emission"].astype(np.float64)  # (M, 3)
    slot = TEXTURE_SLOTS["emissive"]
    for m, texture in enumerate(primitives.materials["textures"][:, slot]):
        if texture >= 0:
            emission[m] = emission[m] * primitives.textures[texture].mean_rgb()
    material_of = primitives.objects["material"][primitives.object_of[:n_tri]]
    glowing = np.flatnonzero(emission[material_of].mean(axis=1) > 0)  # only these triangles are gathered
    tri = primitives.triangles_at(glowing)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    power = area * emission[material_of[glowing]].mean(axis=1)
    keep = power > 0
    ids, tri, area = glowing[keep], tri[keep], area[keep]
    index_of = np.full(max(primitives.count, 1), -1, np.int32)
    index_of[ids] = np.arange(len(ids), dtype=np.int32)
    records = np.zeros(len(ids), EMITTER_DTYPE)
    if len(ids):
        records["v0"], records["v1"], records["v2"] = tri[:, 0], tri[:, 1], tri[:, 2]
        records["area"] = area
        records["prim"] = ids
    return records, index_of, np.pi * power[keep]


def path_params(integrator, frame: np.ndarray, first_sample: int) -> np.ndarray:
    """One launch's PathParams record (integrator: a PathIntegrator) around `frame`, its FrameParams."""
    spp = integrator.spp
    if not 0 <= first_sample <= (1 << 32) - spp:  # integrators.SAMPLE_INDEX_LIMIT: the kernels' sample counter is 32-bit
        allowed = f"0 to 2**32 - spp ({spp}), a pixel's paths are numbered below 2**32"
        raise UsageError(f"first sample {first_sample} is not allowed; allowed: {allowed}")
    p = np.zeros((), PATH_PARAMS_DTYPE)
    p["frame"] = frame
    p["environment"] = integrator.renderer.scene.environment
    p["n_emitters"], p["spp"], p["first_sample"] = integrator.n_emitters, spp, first_sample
    rr_depth = integrator.settings.rr_depth
    p["rr_depth"] = RR_DEPTH if rr_depth is None else rr_depth
    return p
