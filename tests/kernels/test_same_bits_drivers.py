"""Same bits on every CPU driver that compiles here: a path-traced Cornell box, a Whitted render and a Gaussian
splat render with its gradients, on Intel's OpenCL CPU runtime and on PoCL (issue 35: "the same seed gives the same
bits on any driver").  The path tracer gets there through kernels/mathf.h (its own sin, cos, exp, ... and no
contraction into fma); before it, 44% of a Cornell box's pixels differed between PoCL and Intel in the last bits.
The splats' exp, sin, cos and log are mathf.h's too (the builtins gave other bits on each driver).  Skipped unless
two drivers compile.  Oclgrind, the simulator, is no CPU driver here (device.cpu_devices leaves it out: it needs its
own build options); tests/kernels/test_mathf_drivers.py compares it."""

from __future__ import annotations

import numpy as np
import pytest

from clrender.device import _cannot_compile, _describe, cpu_devices, get_device
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests.reference import path_scenes


def compiling_drivers() -> list[str]:
    """One device description per CPU platform that builds a kernel here (pip's PoCL 3.0 fails on Zen 5)."""
    names, platforms = [], set()
    for d in cpu_devices():
        if d.platform.name not in platforms and _cannot_compile(d) is None:
            platforms.add(d.platform.name)
            names.append(_describe(d))
    return names


def render(spec: str, integrator: str) -> np.ndarray:
    device = get_device(spec)
    scene = Scene.from_dict(path_scenes.cornell_box(24))
    spp = 4 if integrator == "path" else 1
    return Renderer(scene, tracer=Tracer(scene, device=device), integrator=integrator, spp=spp, width=24, height=24, seed=3).run().image


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["path", "whitted"])
def test_same_bits_on_every_cpu_driver(integrator):
    drivers = compiling_drivers()
    if len(drivers) < 2:
        pytest.skip(f"one CPU driver compiles here ({drivers}); the comparison needs two")
    images = {name: render(name, integrator) for name in drivers}
    first, *others = drivers
    for name in others:
        differ = np.any(images[name] != images[first], axis=-1)
        assert not differ.any(), f"{name} against {first}: {differ.mean():.1%} of pixels differ"


def splat_bits(spec: str) -> list[np.ndarray]:
    """tools/render_hashes.py's Gaussian splat case: 300 generated splats in both blends, and their gradients for a
    random image gradient."""
    from clrender.splat.gauss import GaussRenderer
    from tools.render_hashes import gauss_params

    out = []
    for blend in ("normalized", "sum"):
        params = gauss_params(300, 48, 32, blend)
        renderer = GaussRenderer(get_device(spec), 48, 32, blend, params.background)
        frame = renderer.forward(params)
        grads = renderer.backward(frame, np.random.default_rng(4).standard_normal((32, 48, 3)).astype(np.float32))
        out += [frame.image, *(grads[k] for k in sorted(grads))]
    return out


@pytest.mark.slow
def test_splats_same_bits_on_every_cpu_driver():
    drivers = compiling_drivers()
    if len(drivers) < 2:
        pytest.skip(f"one CPU driver compiles here ({drivers}); the comparison needs two")
    first, *others = drivers
    reference = splat_bits(first)
    for name in others:
        for k, (a, b) in enumerate(zip(splat_bits(name), reference)):
            assert np.array_equal(a, b), f"{name} against {first}: output {k} differs"
