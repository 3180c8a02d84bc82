"""Renders for the tests against Mitsuba 3 (several test folders): K independent renders a side of one
scene dict, by Mitsuba (tests/reference/mitsuba_scenes.py) and by clrender's path tracer."""

import numpy as np
import pytest

from tests.reference import mitsuba_scenes

K = 4  # independent renders per side
SPP = 64  # samples per pixel of each render: 256 a pixel per side
MAX_DEPTH = 6  # clrender's bounces after the primary hit (Mitsuba's max_depth 8)
LLVM, SCALAR = "llvm_ad_rgb", "scalar_rgb"


def mitsuba_or_skip(variant: str):
    reason = mitsuba_scenes.unavailable(variant)
    if reason:
        pytest.skip(reason)
    return mitsuba_scenes.load_mitsuba(variant)


def mitsuba_renders(scene: dict, variant: str = LLVM, seeds=range(K), spp: int = SPP, exact: bool = True) -> np.ndarray:
    """(K, H, W, 3): one Mitsuba render per seed."""
    mitsuba_or_skip(variant)
    mi, loaded = mitsuba_scenes.load(scene, variant=variant, spp=spp, max_depth=MAX_DEPTH, exact=exact)
    return np.stack([mitsuba_scenes.render_loaded(mi, loaded, spp=spp, seed=s) for s in seeds])


def clrender_path_renders(scene: dict, device, seeds=range(K)) -> np.ndarray:
    """(K, H, W, 3) from clrender's path tracer, one render per seed; skips until it exists (issue 25)."""
    from clrender.trace.renderer import RenderSettings

    if "integrator" not in RenderSettings.__dataclass_fields__:
        pytest.skip("clrender has no path tracer yet (RenderSettings.integrator, issue 25)")
    from clrender import Renderer
    from clrender.scene.scene import Scene
    from clrender.trace.tracer import Tracer

    loaded = Scene.from_dict(scene)
    tracer = Tracer(loaded, device=device)
    render = lambda seed: Renderer(loaded, tracer=tracer, integrator="path", spp=SPP, max_depth=MAX_DEPTH, seed=seed).run().image
    return np.stack([render(s) for s in seeds])
