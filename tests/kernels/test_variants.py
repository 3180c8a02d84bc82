"""Kernel variants (clrender/trace/variant.py): every -D define comes from one Variant, which states the switches
the kernels turn off for others; every variant a render can reach compiles; no tracing or render kernel takes
more than 12 arguments (the rest travel in layout records and arenas, clrender/arena.py)."""

import os

import numpy as np
import pytest

from clrender.device import kernel_source
from clrender.launch import kernel_signatures
from clrender.scene.scene import Scene
from clrender.trace.variant import Variant

MAX_KERNEL_ARGUMENTS = 12  # the kernels' contract (STYLE.md)
SPHERE = {
    "width": 4,
    "height": 3,
    "objects": [{"type": "sphere", "center": [0, 0, -5], "radius": 1, "material": "cutout"}],
    "materials": {"cutout": {"diffuse": [0.5, 0.5, 0.5], "alpha": {"mode": "mask", "factor": 0.8}}},
    "lights": [{"type": "point", "position": [0, 5, 0]}],
}


@pytest.mark.parametrize("filename", ["trace.cl", "path.cl"])
def test_no_tracing_or_render_kernel_takes_more_than_12_arguments(filename):
    signatures = kernel_signatures(kernel_source(filename))
    assert signatures, filename
    too_many = {name: len(params) for name, params in signatures.items() if len(params) > MAX_KERNEL_ARGUMENTS}
    assert not too_many, too_many


def test_the_render_kernels_take_the_same_buffers_and_their_own_launch_record():
    render = kernel_signatures(kernel_source("trace.cl"))["render"]
    path = kernel_signatures(kernel_source("path.cl"))["render_path"]
    assert [p.name for p in render] == [p.name for p in path]
    assert {p.name: p.type for p in render}["params"] == "WhittedParams" and {p.name: p.type for p in path}["params"] == "PathParams"


def test_a_variant_states_what_its_switches_turn_off():
    assert Variant().exclusions() == []
    shafts, packets = Variant(instanced=True, alpha_test=True, render=True).exclusions(), Variant(use_bvh=False).exclusions()
    assert shafts == ["shadow shafts off: alpha-tested materials, instances (each shadow ray is traced alone)"]
    assert packets == [
        "shadow shafts off: no BVH (each shadow ray is traced alone)",
        "ray packets off: no BVH (each query ray walks alone)",
    ]
    assert Variant(bvh_width=2, rays_per_item=1).exclusions()[1] == "ray packets off: a 2-wide BVH, 1 ray a work-item (each query ray walks alone)"
    assert Variant(top_wide=True).exclusions() == ["wide top tree off: no instances"]
    assert "TOP_WIDE" not in Variant(top_wide=True).defines() and Variant(instanced=True, top_wide=True).defines()["TOP_WIDE"] == 1


def test_a_render_variant_is_derived_from_its_scene_and_settings(device):
    """An alpha-tested scene's render switches ALPHA_TEST on and says that its shadow rays lose their shafts; the
    program the renderer builds is the one of its Variant's defines."""
    from clrender.trace.renderer import Renderer
    from clrender.trace.tracer import Tracer

    scene = Scene.from_dict(SPHERE)
    renderer = Renderer(scene, tracer=Tracer(scene, device=device), aovs=("depth",))
    variant = renderer.variant
    assert variant.filename == "trace.cl" and variant.alpha_test and variant.write_aov and not variant.cull_backfaces
    assert variant.defines()["ALPHA_TEST"] == 1 and variant.defines()["WRITE_AOV"] == 1
    assert variant.exclusions() == ["shadow shafts off: alpha-tested materials (each shadow ray is traced alone)"]
    assert ("trace.cl", variant.key()) in device._programs
    assert np.isfinite(renderer.run().image).all()


# the kernels' switches as #if reads them (a name left undefined counts as 0 there)
SWITCHES = ("SHAFTS_ON", "ITEM_PACKETS", "INSTANCE_PACKETS")
PROBE = (
    '#include "trace.cl"\n__kernel void switches(__global int *out) {\n'
    + "".join(f"#if {name}\n    out[{i}] = 1;\n#else\n    out[{i}] = 0;\n#endif\n" for i, name in enumerate(SWITCHES))
    + "}\n"
)


@pytest.mark.slow
@pytest.mark.parametrize(
    "variant",
    [
        Variant(),
        Variant(render=True, alpha_test=True),
        Variant(instanced=True),
        Variant(instanced=True, ray_packets=False),
        Variant(use_bvh=False),
        Variant(bvh_width=2),
        Variant(rays_per_item=1),
    ],
)
def test_the_kernels_turn_off_what_the_variant_says(device, variant):
    """The kernels' own SHAFTS_ON, ITEM_PACKETS and INSTANCE_PACKETS, read from a build of trace.cl, are the
    Variant's shafts_on, query_packets and instance_packets."""
    import pyopencl as cl

    program = device.build(PROBE, "variant probe", variant.defines())
    out = np.zeros(3, np.int32)
    buf = device.empty(out.nbytes)
    program.switches(device.queue, (1,), None, buf)
    cl.enqueue_copy(device.queue, out, buf)
    assert [bool(x) for x in out] == [variant.shafts_on, variant.query_packets, variant.instance_packets]


@pytest.mark.slow
@pytest.mark.skipif(os.environ.get("CLRENDER_TEST_ALL_VARIANTS") != "1", reason="set CLRENDER_TEST_ALL_VARIANTS=1: 86 builds, hours on a cold cache")
def test_every_variant_a_render_can_reach_compiles(device):
    """clrender warmup's list, every one built on the test device (the default, or each of CLRENDER_TEST_DEVICES,
    e.g. portable,intel: tests/conftest.py).  Opt-in: 10-117 s a variant on Intel's runtime on a cold cache, too
    long for CI's budget; seconds on a warm one.  `clrender warmup --jobs N` fills the cache N builds at a time."""
    from clrender.warmup import variants

    chosen = variants(device)
    assert {v.filename for v in chosen} == {"bvh_build.cl", "trace.cl", "path.cl"} and len(chosen) == len({v.key() + (v.filename,) for v in chosen})
    for variant in chosen:
        assert variant.build(device) is not None, variant.label
