"""glTF BLEND in the path tracer (kernels/alpha.h point_kept): a point is kept with probability alpha, for camera
and shadow rays alike, and the instanced variant with a BLEND material runs at the default work layout
(issue 38: defect 0, a segfault on PoCL, and the behaviour "keeps a point with probability alpha").

The card scene: an orthographic camera looks straight down at a red card (alpha 0.3, no texture) 1 above a white
floor, lit by a directional light straight down (falloff none: a Lambert point shows kd cos = kd).  A camera
sample over the card passes it with probability 1 - a and reaches the floor, whose shadow ray passes the card
with probability 1 - a again: the green channel (red card, white floor) of such a sample is 1 with probability
(1 - a)^2 and 0 otherwise.  Keeping with probability 1 - a instead gives a^2 (0.09 for 0.49)."""

import numpy as np
import pytest

from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer

from tests.scenetools import copies_scene

A = 0.3
N, SPP = 32, 8


def card_scene(tmp_path):
    return Scene.from_dict(
        {
            "width": N,
            "height": N,
            "cameras": [{"position": [0, 0, 10], "look_at": [0, 0, 0], "projection": "orthographic", "ortho_height": 3.0}],
            "materials": {"card": {"diffuse": [1, 0, 0], "alpha": {"mode": "blend", "factor": A}}, "floor": {"diffuse": [1, 1, 1]}},
            "lights": [{"type": "directional", "direction": [0, 0, -1]}],
            "objects": [
                {"type": "quad", "corner": [-1, -1, 1], "edge_a": [2, 0, 0], "edge_b": [0, 2, 0], "material": "card"},
                {"type": "quad", "corner": [-4, -4, 0], "edge_a": [8, 0, 0], "edge_b": [0, 8, 0], "material": "floor"},
            ],
        },
        base_dir=tmp_path,
    )


def test_blend_keeps_a_point_with_probability_alpha(tmp_path):
    image = Renderer(card_scene(tmp_path), integrator="path", spp=SPP, max_depth=0, seed=3).run().image.astype(np.float64)
    c = ((np.arange(N) + 0.5) / N * 2 - 1) * 1.5  # pixel centres; the card covers |x|, |y| < 1
    x, y = np.meshgrid(c, c)
    inside = (np.abs(x) < 1 - 3.0 / N) & (np.abs(y) < 1 - 3.0 / N)  # whole pixels on the card (jitter stays inside)
    outside = (np.abs(x) > 1 + 3.0 / N) | (np.abs(y) > 1 + 3.0 / N)
    np.testing.assert_allclose(image[outside], 1.0, atol=1e-5)  # the lit floor: kd cos = 1
    green = image[inside][:, 1]
    want = (1 - A) ** 2
    se = np.sqrt(want * (1 - want) / (green.size * SPP))  # Bernoulli samples: pixel means of SPP each
    z = (green.mean() - want) / se
    assert abs(z) < 4.5, (green.mean(), want, z)  # two-sided, false alarm about 7e-6
    red = image[inside][:, 0]  # card or floor: a + (1 - a)^2 either way (not what tells the rules apart)
    assert abs(red.mean() - (A + (1 - A) ** 2)) < 4.5 * 0.5 / np.sqrt(red.size * SPP)


@pytest.mark.slow
def test_instanced_blend_path_render_at_the_default_layout(tmp_path):
    """Defect 0: instanced meshes with a BLEND material, path-traced at the device's default work layout (64-item
    groups on PoCL, where this crashed by overflowing the stack), render a finite image whose BLEND spheres let
    the background through: every pixel finite, and the copies both seen and seen through."""
    scene = copies_scene(tmp_path, 12, material={"diffuse": [0.8, 0.7, 0.6], "alpha": {"mode": "blend", "factor": 0.5}})
    r = Renderer(scene, integrator="path", spp=2, width=48, height=36, instancing=True)
    assert r.tracer.defines.get("INSTANCED") == 1
    image = r.run().image
    assert np.isfinite(image).all() and image.max() > 0


@pytest.mark.slow
def test_alpha_variant_private_memory_stays_near_the_plain_one():
    """Defect 0's cause: each inlined closest_hit holds its own traversal stacks, and the ALPHA_TEST variant's
    look-past loop had two call sites in every visibility test plus a private copy of the 256-byte Material, so
    the instanced path kernel's private memory doubled (Intel's CL_KERNEL_PRIVATE_MEM_SIZE: 985,984 B without
    ALPHA_TEST, 2,001,664 B with; now 1,003,392 B), which PoCL's stack could not hold at 64-item groups.  The
    variant may cost a little more, never a second copy of the stacks."""
    import pyopencl as cl

    from clrender.device import get_device
    from clrender.trace.tracer import trace_defines

    dev = get_device()
    sizes = []
    for extra in ({}, {"ALPHA_TEST": 1}):
        kernel = dev.program("path.cl", {**trace_defines(instanced=True), "WRITE_AOV": 0, **extra}).render_path
        sizes.append(kernel.get_work_group_info(cl.kernel_work_group_info.PRIVATE_MEM_SIZE, dev.device))
    if sizes[0] == 0:
        pytest.skip(f"{dev.name} reports no private memory size")
    assert sizes[1] <= 1.25 * sizes[0], sizes
