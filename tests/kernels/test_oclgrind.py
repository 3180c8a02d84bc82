"""Every kernel in kernels/*.cl run under Oclgrind, the OpenCL simulator that checks each memory access.

Each case runs in its own process (Oclgrind reports on that process's stderr) on tiny inputs, with
Oclgrind's checks on: out-of-bounds reads and writes (always), API misuse (OCLGRIND_CHECK_API) and
data races between work-items (OCLGRIND_DATA_RACES).  Every case runs twice:
  * optimised, as the renderer builds it (where this Oclgrind cannot interpret what its optimiser
    made of `render`, optimised with -fno-inline instead; see OCLGRIND_LIMITS);
  * with -cl-opt-disable, where the uninitialised-value checker (OCLGRIND_UNINITIALIZED) runs too:
    on optimised builds it aborts with "Unsupported instruction: freeze".
PYOPENCL_NO_CACHE=1 builds every program fresh under Oclgrind.

Each case also checks its results against an independent answer, so a kernel that Oclgrind
silently skipped would fail.  A canary kernel with a deliberate out-of-bounds read proves the
error reports are seen.  Run: pytest -m oclgrind tests/kernels/test_oclgrind.py
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
ERROR_MARKERS = (
    "Invalid read",
    "Invalid write",
    "data race",
    "Uninitialized",
    "Uninitialised",
    "runtime error",
    "FATAL",
    "divergence",
    "Unsupported",
    "out of bounds",
    "Oclgrind - ",
)


def oclgrind_present() -> bool:
    """Installed here: each case's process asks for it (CLRENDER_DEVICE=oclgrind, which makes the loader see it)."""
    from clrender.drivers import oclgrind_installed

    return oclgrind_installed()


pytestmark = [
    pytest.mark.oclgrind,
    pytest.mark.slow,
    pytest.mark.skipif(not oclgrind_present(), reason="the Oclgrind OpenCL platform is not installed"),
]

# Device.adopt's buffers are copies here: Oclgrind's uninitialised-value checker takes a CL_MEM_USE_HOST_PTR
# buffer's memory, which it never saw written, for uninitialised (a one-line kernel branching on such a host-filled
# buffer is reported, the same on a COPY_HOST_PTR one is not), so every read of the BVH's nodes would be reported.
PRELUDE = """
import numpy as np
from clrender.device import Device, get_device
Device.adopt = Device.to_device
dev = get_device("oclgrind")
assert "Oclgrind" in dev.name, dev.name
rng = np.random.default_rng(7)
"""

SCENE = """
from clrender.scene.scene import Scene
scene = Scene.from_dict({
    "background": [0.2, 0.3, 0.4], "ambient": [0.05, 0.05, 0.05],
    "materials": {"glass": {"transparency": 0.7, "ior": 1.5, "specular": [1, 1, 1], "shininess": 50},
                  "mirror": {"mirror": 0.8}, "matte": {"diffuse": [0.7, 0.5, 0.3]}},
    "lights": [{"type": "area", "corner": [-1, 3, -3], "edge_a": [1, 0, 0], "edge_b": [0, 0, 1], "samples": 2,
                "falloff": "inverse_square", "intensity": 10},
               {"type": "point", "position": [2, 2, 0], "intensity": 0.5},
               {"type": "directional", "direction": [0, -1, -1], "intensity": 0.3}],
    "objects": [{"type": "sphere", "center": [0.4, 0, -3], "radius": 0.8, "material": "glass"},
                {"type": "quad", "corner": [-3, -1, -6], "edge_a": [6, 0, 0], "edge_b": [0, 0, 6], "material": "mirror"},
                {"type": "mesh", "generator": "wizard_hat", "params": {"segments": 5}, "translate": [-0.8, -0.6, -2.5],
                 "smooth": True, "material": "matte"},
                {"type": "triangle", "vertices": [[-2, 1, -4], [-1, 1, -4], [-1.5, 2, -4]], "material": "matte"}]})
"""

# the path tracer's two schedules on a tiny Cornell box: a, the megakernel; b, the wavefront (docs/lanes.md)
PATH_RENDERS = """
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.wavefront import Wavefront
from tests.reference import path_scenes
scene = Scene.from_dict(path_scenes.cornell_box(6))
kw = dict(integrator="path", spp=2, max_depth=3, seed=3, width=6, height=6, aovs=("depth",))
a = Renderer(scene, path_schedule="megakernel", tile_size=6, device="oclgrind", **kw)
b = Renderer(scene, path_schedule="wavefront", tile_size=4, tracer=a.tracer, device="oclgrind", **kw)
assert isinstance(b.kernel, Wavefront) and not isinstance(a.kernel, Wavefront)
"""

# name -> (kernels it runs, code)
CASES = {
    "render_bvh_edges": (
        ("render",),
        SCENE
        + """
from clrender.trace.renderer import Renderer
r = Renderer(scene, width=6, height=4, aa="edge_detect", samples=2, max_depth=3, device="oclgrind").run()
assert np.isfinite(r.image).all() and r.image.max() > 0.05
assert len(set(np.unique(r.ids)) - {-1}) >= 2  # the sphere and something else are in view
assert r.edge_mask.any()  # the edge pass (a compacted pixel list) ran too
""",
    ),
    "render_no_bvh_full_aa": (
        ("render",),
        SCENE
        + """
from clrender.trace.renderer import Renderer
kw = dict(width=5, height=3, aa="full", samples=2, sampler="sobol", pixel_filter="gaussian", fresnel=True,
          light_sampler="random", max_depth=4)
from clrender.trace.tracer import Tracer
a = Renderer(scene, bvh=False, device="oclgrind", **kw).run().image
b = Renderer(scene, tracer=Tracer(scene, bvh_width=2, device=dev), device="oclgrind", **kw).run().image
assert np.isfinite(a).all()
np.testing.assert_allclose(a, b, atol=1e-4)  # the (binary) BVH changes the order of tests, not the answer
""",
    ),
    "render_aov_variant": (
        ("render",),
        SCENE
        + """
from clrender.trace.renderer import Renderer
# -DWRITE_AOV=1: the kernel also writes the primary hit's depth, normal and albedo
r = Renderer(scene, width=5, height=4, aa="none", aovs=("depth", "normal", "albedo"), device="oclgrind").run()
hit = r.ids >= 0
assert hit.any() and np.isfinite(r.aovs["depth"][hit]).all() and (r.aovs["depth"][hit] > 0).all()
np.testing.assert_allclose(np.linalg.norm(r.aovs["normal"][hit], axis=-1), 1, atol=1e-4)  # unit normals
""",
    ),
    "sample_offsets": (
        ("sample_offsets",),
        """
from clrender.trace.sampling import sample_offsets
for sampler in ("uniform", "random", "stratified", "sobol"):
    o = sample_offsets([0, 5, 17], sampler, 3, seed=1, device=dev)
    assert o.shape == (3, 9, 2) and (o >= 0).all() and (o < 1).all(), sampler
s = sample_offsets([4], "stratified", 3, device=dev)[0]
cells = np.floor(s * 3).astype(int)
assert len({tuple(c) for c in cells}) == 9  # one sample in each of the 3 x 3 cells
""",
    ),
    "intersect_and_occluded_rays": (
        ("intersect_rays", "occluded_rays"),
        """
from clrender.trace.tracer import Tracer
spheres = [{"type": "sphere", "center": [0, 0, -5], "radius": 1}, {"type": "sphere", "center": [3, 0, -5], "radius": 0.5}]
tri = {"type": "triangle", "vertices": [[-1, -1, -8], [1, -1, -8], [0, 1, -8]]}
from clrender.scene.scene import Scene
# the binary and the 4-wide BVH, no BVH, and the variant that counts primitive tests
for use_bvh, width, count in ((True, 8, False), (True, 4, False), (True, 2, False), (False, 4, False), (True, 4, True)):
    tracer = Tracer(Scene.from_dict({"objects": spheres + [tri]}), use_bvh=use_bvh, bvh_width=width,
                    count_prim_tests=count, device=dev)
    o = np.zeros((4, 3)); d = np.array([[0, 0, -1], [3, 0, -5], [0, 5, -1], [0, -0.5, -8]], float)
    t, prim, obj = tracer.intersect(o, d)
    np.testing.assert_allclose(t[:2], [4.0, 1 - 0.5 / np.linalg.norm([3, 0, -5])], rtol=1e-5)  # t in units of d
    assert obj[2] == -1 and t[2] == np.inf
    assert np.array_equal(tracer.intersect(o[:3], d[:3])[0], t[:3])  # an odd count: the last pair repeats a ray
    blocked = tracer.occluded(o, d, [3.0, 100.0, 100.0, 100.0])
    assert blocked.tolist() == [False, True, False, True]
    # eight rays in one octant: a packet, whose leaves hold the spheres (tested ray by ray)
    d8 = np.c_[np.linspace(0, 0.1, 8), np.linspace(0, 0.05, 8), -np.ones(8)]
    u = d8 / np.linalg.norm(d8, axis=1, keepdims=True)
    b = u @ [0, 0, -5.0]
    t_sphere = (b - np.sqrt(b * b - 24.0)) / np.linalg.norm(d8, axis=1)  # |c|^2 - r^2 = 25 - 1
    np.testing.assert_allclose(tracer.intersect(np.zeros((8, 3)), d8)[0], t_sphere, rtol=1e-5)
    assert tracer.occluded(np.zeros((8, 3)), d8, t_sphere * 1.01).all()
# rays that go the same way walk in packets of eight (kernels/packet.h); 19 rays: a partial last packet
import trimesh
slab = trimesh.creation.box(extents=(2.0, 2.0, 0.5))
o = np.stack([np.linspace(-1.2, 1.2, 19), np.linspace(-0.9, 0.9, 19), np.full(19, 3.0)], axis=1)
d = np.tile([0.01, 0.02, -1.0], (19, 1))
for width in (8, 4):
    tracer = Tracer(slab, bvh_width=width, device=dev)
    t, prim, obj = tracer.intersect(o, d)
    inside = (np.abs(o[:, 0] + 2.75 * 0.01) < 1.0) & (np.abs(o[:, 1] + 2.75 * 0.02) < 1.0)
    np.testing.assert_allclose(t[inside], 2.75, rtol=1e-5)  # the top face at z = 0.25 (t in units of d)
    assert inside.sum() == 15 and np.isinf(t[~inside]).all()
    assert tracer.occluded(o, d, 2.0).tolist() == [False] * 19
    assert tracer.occluded(o, d, 10.0).tolist() == inside.tolist()
""",
    ),
    "refract_rays": (
        ("refract_rays",),
        """
import math
from clrender.trace.tracer import trace_defines
knl = dev.kernel("trace.cl", "refract_rays", trace_defines())
angles = np.radians([0.0, 30.0, 60.0, 80.0])
d = np.stack([np.sin(angles), np.zeros(4), -np.cos(angles), np.zeros(4)], 1).astype(np.float32)
normals = np.tile(np.float32([0, 0, 1, 0]), (4, 1))
eta = np.full(4, 1.5, np.float32)  # glass to air: the two steep rays are totally reflected
out = dev.empty(64)
knl(dev.queue, (4,), None, n=4, d=dev.to_device(d), normals=dev.to_device(normals), eta=dev.to_device(eta), out=out)
import pyopencl as cl
res = np.empty((4, 4), np.float32); cl.enqueue_copy(dev.queue, res, out)
assert res[:, 3].tolist() == [1, 1, 0, 0]
np.testing.assert_allclose(np.hypot(res[1, 0], res[1, 1]), 1.5 * math.sin(angles[1]), rtol=1e-5)  # Snell
""",
    ),
    "specular_power": (
        ("specular_power",),
        """
from clrender.trace.tracer import trace_defines
knl = dev.kernel("trace.cl", "specular_power", trace_defines())
x = np.float32([1.0, 0.5, 0.9, 1e-30, 0.25]); s = np.float32([3.0, 2.0, 150.0, 8.0, 0.5])
out = dev.empty(20)
knl(dev.queue, (5,), None, n=5, x=dev.to_device(x), s=dev.to_device(s), out=out)
import pyopencl as cl
res = np.empty(5, np.float32); cl.enqueue_copy(dev.queue, res, out)
np.testing.assert_allclose(res, np.power(x.astype(np.float64), s), rtol=1e-5, atol=1e-37)
""",
    ),
    "splat_gauss": (
        ("splat_prepare", "splat_bin_count", "splat_bin_fill", "splat_forward", "splat_backward"),
        """
from clrender.splat.gauss import GaussParams, GaussRenderer
W, H = 20, 17  # partial tiles on two sides
n = 4
p = dict(xy=np.array([[3, 4], [10, 9], [19, 16], [0.5, 15]], float), log_scale=np.log(rng.uniform(1, 5, (n, 2))),
         theta=rng.uniform(-3, 3, n), color=rng.uniform(0.1, 0.9, (n, 3)), lum=np.ones(n), opacity=rng.uniform(0.5, 1, n))
for blend in ("sum", "normalized"):
    params = GaussParams(**p, width=W, height=H, blend=blend, background=(0.1, 0.2, 0.3))
    renderer = GaussRenderer(dev, W, H, blend, background=(0.1, 0.2, 0.3))
    frame = renderer.forward(params)
    assert np.isfinite(frame.image).all() and frame.weight.max() > 0.3
    grads = renderer.backward(frame, np.ones((H, W, 3), np.float32))
    assert all(np.isfinite(g).all() for g in grads.values())
    assert np.abs(grads["color"]).sum() > 0
""",
    ),
    "bvh_build": (
        ("load_prims", "split_level", "build_subtree", "place_subtrees", "prim_order"),
        """
import clrender.trace.bvh as bvh
lo = rng.random((300, 3)).astype(np.float32)
hi = lo + rng.random((300, 3)).astype(np.float32) * 0.05
one = bvh.build_bvh(lo, hi, max_leaf_size=2, top_min=10**9)  # the whole tree in one build_subtree work-item
top = bvh.build_bvh(lo, hi, max_leaf_size=2, top_min=16)  # nodes of more than 16 primitives split by split_level, one launch per level
assert top.nodes.tobytes() == one.nodes.tobytes() and (top.prim_order == one.prim_order).all()
nodes, leaf = top.nodes, top.nodes["count"] > 0
slots = np.concatenate([np.arange(o, o + k) for o, k in zip(nodes["offset"][leaf], nodes["count"][leaf])])
assert np.array_equal(np.sort(slots), np.arange(300)) and np.array_equal(np.sort(top.prim_order), np.arange(300))
owner, ids = np.repeat(np.flatnonzero(leaf), nodes["count"][leaf]), top.prim_order[slots]
assert (nodes["bmin"][owner] <= lo[ids]).all() and (nodes["bmax"][owner] >= hi[ids]).all()
assert top.sah_cost() < bvh.build_bvh(lo, hi, "median", max_leaf_size=2).sah_cost()
""",
    ),
    "voronoi_nearest": (
        ("nearest_naive", "nearest_grid"),
        """
from clrender.splat.voronoi import nearest_site
from clrender.testing import nearest_site_reference
sites = np.vstack([rng.uniform(0, [23, 13], (9, 2)), [[0.0, 0.0], [22.9, 12.9]]]).astype(np.float32)
ref = nearest_site_reference(sites, 23, 13)
for method in ("naive", "grid"):
    assert (nearest_site(dev, sites, 23, 13, method) == ref).all(), method
""",
    ),
    "voronoi_soft": (
        ("soft_forward", "soft_backward"),
        """
from clrender.splat.voronoi_soft import SoftVoronoi
from clrender.testing import soft_loss_reference
sites = rng.uniform(0, [12, 9], (6, 2)).astype(np.float32)
colors = rng.uniform(0, 1, (6, 3)).astype(np.float32)
target = rng.uniform(0, 1, (9, 12, 3)).astype(np.float32)
loss, g_sites, g_colors, image = SoftVoronoi(dev, 12, 9, 4).loss_and_grads(sites, colors, target, 0.5)
assert abs(loss - soft_loss_reference(sites, colors, target, 0.5, 4)) <= 1e-4 * abs(loss)
assert np.isfinite(g_sites).all() and np.isfinite(g_colors).all()
""",
    ),
    "mathf_probe": (
        ("mathf_probe",),
        """
from clrender.mathf_probe import FUNCTIONS, evaluate
x = np.array([0.5, -2.0, 300.0, 1e30, 0.0, 3.0], np.float32)
for name, ref in (("sin", np.sin), ("cos", np.cos), ("exp", np.exp), ("atan2", lambda v: np.arctan2(v, 1.5))):
    v = x[np.abs(x) < 80] if name == "exp" else x
    got = evaluate(name, v, 1.5 if name == "atan2" else None, device=dev)
    assert np.allclose(got, ref(v.astype(np.float64)), rtol=1e-6, atol=1e-7), (name, got)
assert evaluate("log", np.float32([1.0, np.e]), device=dev).tolist() == [0.0, np.float32(1.0)]
assert len(FUNCTIONS) == 10
""",
    ),
    "sobol_probe": (
        ("sobol_probe",),
        """
from clrender.trace.sampling import sequence_points
pts = sequence_points([0, 5, 77], 8, [0, 1, 2, 9, 1 << 21], seed=3, device=dev)
assert pts.shape == (3, 8, 5) and len(np.unique(pts[0, :, 0] >> 29)) == 8
assert sequence_points([0], 4, [0, 1], scrambled=False, device=dev)[0, :, 1].tolist() == [0, 1 << 31, 3 << 30, 1 << 30]
""",
    ),
    "path_draws_probe": (
        ("path_draws_probe",),
        """
from clrender.trace.sampling import path_draws
one = path_draws([0, 3, 7], 3, 2, seed=1, device=dev)
assert ((one >= 0) & (one < 1)).all()
""",
    ),
    "lane_math_probe": (
        ("lane_math_probe",),
        """
from clrender.mathf_probe import lane_functions
x = np.linspace(-80, 80, 37).astype(np.float32)  # e^x finite
assert np.isfinite(lane_functions(x, x / 250, 1, dev)).all()
""",
    ),
    "texture_probe": (
        ("texture_probe",),
        """
import pyopencl as cl
from clrender.layout import MATERIAL_DTYPE, TEXTURE_DTYPE, VERTEX_ATTRIBUTES_DTYPE, WRAP_MODES
from clrender.trace.tracer import trace_defines
from clrender.trace.work_layout import launch_items
tex = np.zeros(1, TEXTURE_DTYPE)
tex["width"], tex["height"], tex["wrap_s"], tex["wrap_t"] = 2, 2, WRAP_MODES["repeat"], WRAP_MODES["mirrored_repeat"]
mat = np.zeros(2, MATERIAL_DTYPE)
mat["textures"] = -1
mat["textures"][1, 0] = 0
mat["tex_transform"][:, :, 0] = mat["tex_transform"][:, :, 4] = 1
attr = np.zeros(3, VERTEX_ATTRIBUTES_DTYPE)
attr["uv"] = np.random.default_rng(1).normal(0, 2, (3, 3, 2))
n = 11
query = np.zeros((n, 4), np.int32)
query[:, 0], query[:, 2] = np.arange(n) % 2, np.arange(n) % 3
bary = np.full((n, 2), 0.25, np.float32)
inputs = dict(query=query, bary=bary, attributes=attr, textures=tex, materials=mat, texels=np.arange(16, dtype=np.float32).reshape(4, 4))
def lookups(lanes):
    knl = dev.kernel("texture_probe.cl", "texture_probe", {**trace_defines(), "LANES": lanes})
    outs = {name: dev.empty(n * 16) for name in ("out", "uv_out", "colour_out")}
    launch_items(dev, knl, -(-n // lanes), n=n, **{k: dev.to_device(v) for k, v in inputs.items()}, **outs)
    result = np.empty((3, n, 4), np.float32)
    for k, buf in enumerate(outs.values()):
        cl.enqueue_copy(dev.queue, result[k], buf)
    return result
assert np.isfinite(lookups(1)).all()
""",
    ),
    "bsdf_probes": (
        ("bsdf_eval_probe", "bsdf_pdf_probe", "bsdf_sample_probe", "frame_probe"),
        """
from clrender.trace.bsdf import BsdfProbe, params
probe = BsdfProbe(dev)
albedo = np.array([0.8, 0.5, 0.2])
rec = params(colour=albedo)
wo = np.array([0.0, 0.6, 0.8])
wi = np.array([[0, 0, 1], [0.6, 0, 0.8], [0.8, 0, 0.6]])
# Lambert: f cos = albedo cos / pi, pdf = cos / pi, and its samples' weight is the albedo
np.testing.assert_allclose(probe.eval("lambert", rec, wo, wi), np.outer(wi[:, 2], albedo) / np.pi, rtol=1e-5)
np.testing.assert_allclose(probe.pdf("lambert", rec, wo, wi), wi[:, 2] / np.pi, rtol=1e-5)
d, weight, pdf, delta = probe.sample("lambert", rec, wo, rng.random((5, 3)))
np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, atol=1e-5)
np.testing.assert_allclose(weight, np.tile(albedo, (5, 1)), rtol=1e-5)
np.testing.assert_allclose(pdf, d[:, 2] / np.pi, rtol=1e-4)
assert (d[:, 2] > 0).all() and not delta.any()
d, weight, pdf, delta = probe.sample("mirror", params(colour=albedo), wo, rng.random((2, 3)))  # the mirror direction
np.testing.assert_allclose(d, np.tile([0.0, -0.6, 0.8], (2, 1)), atol=1e-6)
assert delta.all()
normals = rng.normal(size=(4, 3)); normals /= np.linalg.norm(normals, axis=1, keepdims=True)
v = rng.normal(size=(4, 3))
frames, local, back = probe.frame(normals, v)
np.testing.assert_allclose(frames @ frames.transpose(0, 2, 1), np.tile(np.eye(3), (4, 1, 1)), atol=1e-5)  # orthonormal
np.testing.assert_allclose(frames[:, 2], normals, atol=1e-6)
np.testing.assert_allclose(local, np.einsum("nij,nj->ni", frames, v), atol=1e-5)
np.testing.assert_allclose(back, v, atol=1e-5)
""",
    ),
    "env_probes": (
        ("env_sample_probe", "env_eval_probe"),
        """
from clrender.scene.environment import EnvironmentMap
from clrender.trace.envmap import EnvProbe
texels = np.full((4, 6, 3), 0.5, np.float32)
texels[1, 2] = (4.0, 2.0, 1.0)  # one bright texel: a density that is not uniform
probe = EnvProbe(dev, EnvironmentMap(texels))
d, radiance, pdf = probe.sample(rng.random((6, 2)))
np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1, atol=1e-5)
assert np.isfinite(radiance).all() and (radiance >= 0.5 - 1e-6).all() and (pdf > 0).all()
again, pdf_again = probe.eval(d)  # the lookup's density in the sampled directions is the sampler's
np.testing.assert_allclose(pdf_again, pdf, rtol=1e-3)
np.testing.assert_allclose(again, radiance, rtol=1e-6)
flat, flat_pdf = EnvProbe(dev, EnvironmentMap(np.full((4, 6, 3), 0.5, np.float32))).eval(d)
np.testing.assert_allclose(flat, 0.5, rtol=1e-6)  # a constant map: its value everywhere
""",
    ),
    "light_pick_probe": (
        ("light_pick_probe",),
        """
from clrender.trace.light_choice import choices, picks
records = choices(np.array([1.0, 0.0, 3.0]))
got = picks(dev, records, 40, seed=2)
assert set(got.tolist()) == {0, 2}  # never the light without power
assert picks(dev, choices(np.array([2.0])), 8).tolist() == [0] * 8
""",
    ),
    "render_path": (
        ("render_path",),
        PATH_RENDERS
        + """
r = a.run()
assert np.isfinite(r.image).all() and (r.image >= 0).all() and r.image.mean() > 0.01  # lit
assert (r.image.sum(axis=-1) > 0).mean() > 0.5  # most pixels see the lit room
""",
    ),
    "render_path_instanced": (
        ("render_path",),
        """
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
hat = {"type": "mesh", "generator": "wizard_hat", "params": {"segments": 5}, "smooth": True, "scale": 2.5, "material": "m"}
scene = Scene.from_dict({
    "cameras": [{"position": [0, 0.3, 3], "look_at": [0, 0.2, 0], "fov": 50}],
    "materials": {"m": {"diffuse": [0.8, 0.6, 0.4]}, "lamp": {"diffuse": [0, 0, 0], "emission": [4, 4, 4]}},
    "lights": [{"type": "point", "position": [1, 2, 2]}], "environment": {"color": [0.3, 0.3, 0.3]},
    "objects": [{**hat, "translate": [-0.6, -0.3, 0]}, {**hat, "translate": [0.6, -0.3, 0], "rotate": [0, 40, 0]},
                {"type": "quad", "corner": [-0.4, -0.5, -1], "edge_a": [0.8, 0, 0], "edge_b": [0, 1.2, 0], "material": "lamp"}]})
# instances among flat primitives, camera rays past hidden emitters: an emitter's lookup for each hit (path.cl emitter_of)
r = Renderer(scene, integrator="path", instancing=True, hide_emitters=True, path_schedule="megakernel", spp=2, max_depth=3,
             seed=3, width=6, height=6, device="oclgrind").run()
assert np.isfinite(r.image).all() and r.image.max() > 0 and set(np.unique(r.ids)) >= {0, 1}  # both copies in view
""",
    ),
    "path_wavefront": (
        ("wave_start", "wave_extend", "wave_shade", "wave_occlude", "wave_advance"),
        PATH_RENDERS
        + """
ra, rb = a.run(), b.run()
assert np.isfinite(rb.image).all() and rb.image.mean() > 0.01
assert ra.image.tobytes() == rb.image.tobytes()  # the two schedules: the same bits (docs/lanes.md)
assert ra.aovs["depth"].tobytes() == rb.aovs["depth"].tobytes() and (ra.rays, ra.node_visits) == (rb.rays, rb.node_visits)
""",
    ),
    "shade_probe": (
        ("shade_probe",),
        """
from bench.lanes import run
one, sixteen = (run(dev, lanes, lanes > 1, 32, 2, 3, 1)[0] for lanes in (1, 16))
assert np.isfinite(one).all() and (one >= 0).all() and one.max() > 0
assert one.tobytes() == sixteen.tobytes()  # lanes, refilled, change the order of work, not the bits
""",
    ),
}

CANARY = """
import pyopencl as cl
src = "__kernel void canary(__global const float *a, __global float *b) { int i = get_global_id(0); b[i] = a[i + 2]; }"
prg = cl.Program(dev.context, src).build()
b = dev.empty(16)
prg.canary(dev.queue, (4,), None, dev.to_device(np.zeros(4, np.float32)), b)
dev.queue.finish()
"""


# Two builds of every case: the optimised one the renderer really runs (memory, API and race checks),
# and one built with -cl-opt-disable that the uninitialised-value checker can also follow.
MODES = {"optimised": ("", False), "unoptimised": ("-cl-opt-disable", True)}
# Intrinsics this Oclgrind's interpreter lacks, each with the build option that avoids it; a case whose
# build meets one runs again with that option added, until it meets none (a build can meet both, one
# after the other: -fno-inline leaves the sqrt calls that inlining had hidden behind the first).
#  * llvm.experimental.noalias.scope.decl, which its own optimiser emits when it inlines parts of
#    `render` (which variants moves with trace.cl): -fno-inline emits none;
#  * llvm.sqrt.f32, clang's __builtin_sqrtf (common.h's sqrt_f, mathf.h's sqrt_det): defined as the sqrt
#    builtin, which Oclgrind computes correctly rounded too.
OCLGRIND_LIMITS = {
    "Undefined external function: llvm.experimental.noalias.scope.decl": "-fno-inline",
    "Undefined external function: llvm.sqrt.f32": "-D__builtin_sqrtf=sqrt",
}

# The uninitialised-value checker reports every vector built element by element (float4)(a, b, c, 0)
# as uninitialised, even from a host-filled buffer (checked by hand with a two-line kernel), so it
# stays off for the kernels that store such vectors; their out-of-bounds and race checks still run.
# bvh_build: the checker also calls uninitialised the leaf counts build_subtree writes for far children
# (e.count - n, n from the partition), though each is written before it is read: the trees pass
# tests/trace/test_bvh.py's invariants (every slot in exactly one leaf) and are byte-identical run to run.
# render_aov_variant, render_bvh_edges: the checker itself crashes on these builds of `render` (SIGSEGV in a
# memcpy in Oclgrind 21.10's Uninitialized::instructionExecuted, gdb), where the same build without it runs clean.
# path_wavefront: four reports remain (work-item 0 of wave_extend: a branch on its slot's live and ended flags, and
# make_rng's table lookups of its sample), though wave_start writes every field of each record first and the wavefront
# gives the megakernel's bits; the megakernel (render_path) runs with the checker.
NO_UNINITIALIZED = {"splat_gauss", "bvh_build", "render_aov_variant", "render_bvh_edges", "path_wavefront"}


def run_under_oclgrind(code: str, build_options: str = "", uninitialized: bool = False, timeout: float = 600) -> subprocess.CompletedProcess:
    env = dict(
        os.environ,
        CLRENDER_DEVICE="oclgrind",
        PYOPENCL_NO_CACHE="1",
        OCLGRIND_CHECK_API="1",
        OCLGRIND_DATA_RACES="1",
        OCLGRIND_UNINITIALIZED="1" if uninitialized else "0",
        OCLGRIND_BUILD_OPTIONS=build_options,
        # Oclgrind stops reporting after 1000 errors; the BVH build's false positives alone reach that
        # in the cases that build a tree, which would hide every later kernel's reports
        OCLGRIND_MAX_ERRORS="100000000",
        PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""),
    )
    env.pop("PYOPENCL_CTX", None)
    return subprocess.run([sys.executable, "-c", textwrap.dedent(PRELUDE + code)], env=env, cwd=ROOT, capture_output=True, text=True, timeout=timeout)


# Two host-side probes of pyopencl's own, which CHECK_API reports; exactly these are set aside, every other
# report counts:
#  * its C++ layer asks clGetDeviceInfo for a parameter newer than Oclgrind's OpenCL 1.2 when it creates a
#    kernel object (no Python-level get_info fails);
#  * cl.Kernel(program, name) asks the program for its `_source` attribute, which a Program wrapped from a
#    kernel's own (kernel.program, as launch.BoundKernel passes) lacks, and Program.__getattr__ takes any
#    missing attribute for a kernel name: clCreateKernel(program, "_source") (pyopencl 2026.1).
PYOPENCL_PROBE = re.compile(
    r"Oclgrind - OpenCL runtime error detected\s+"
    r"(Function: clGetDeviceInfo\s+Error:\s+CL_INVALID_VALUE\s+For argument 'param_name'"
    r"|Function: clCreateKernel\s+Error:\s+CL_INVALID_KERNEL_NAME\s+Kernel '_source' not found)\s*"
)


# Every case that builds a Tracer runs the BVH build kernels too (the build is on the device); their
# uninitialised-value reports are the false positives NO_UNINITIALIZED describes for bvh_build, whose
# own case covers them, so they are left out of the other cases' reports (their memory and race
# reports are kept).
BVH_BUILD_KERNELS = ("split_level", "build_subtree", "load_prims", "prim_order", "place_subtrees")
UNINITIALIZED_REPORT = re.compile(r"^(Uninitialized|Controlflow depends on uninitialized)", re.IGNORECASE)


def error_reports(stderr: str) -> list[str]:
    stderr = PYOPENCL_PROBE.sub("", stderr)
    blocks = re.split(r"\n\s*\n", stderr)  # Oclgrind separates its reports by blank lines
    kept = [b for b in blocks if not (UNINITIALIZED_REPORT.match(b.strip()) and re.search(rf"Kernel: ({'|'.join(BVH_BUILD_KERNELS)})\b", b))]
    return [line for line in "\n\n".join(kept).splitlines() if any(m.lower() in line.lower() for m in ERROR_MARKERS)]


# Optimised builds this Oclgrind cannot run, and why: no build option avoids them.
NOT_OPTIMISED = {
    "shade_probe": "clang makes lanes_probe.cl's shift-and-mask bit reversal llvm.bitreverse.i32, which this Oclgrind lacks",
}


def run_case(case: str, mode: str) -> subprocess.CompletedProcess:
    """CASES[case] under Oclgrind in MODES[mode], with the options OCLGRIND_LIMITS calls for."""
    options, uninitialized = MODES[mode]
    uninitialized = uninitialized and case not in NO_UNINITIALIZED
    while True:
        result = run_under_oclgrind(CASES[case][1], options, uninitialized)
        fixes = [fix for limit, fix in OCLGRIND_LIMITS.items() if limit in result.stderr and fix not in options]
        if not fixes:
            return result
        options = " ".join([options, *fixes]).strip()


@pytest.mark.parametrize("mode", sorted(MODES))
@pytest.mark.parametrize("case", sorted(CASES))
def test_kernel_runs_clean_under_oclgrind(case, mode):
    if mode == "optimised" and case in NOT_OPTIMISED:
        pytest.skip(NOT_OPTIMISED[case])
    result = run_case(case, mode)
    assert result.returncode == 0, result.stderr[-3000:]
    assert not error_reports(result.stderr), result.stderr[-3000:]


# Kernels with no case, and why.  render_path_lanes: under Oclgrind 21.10 its lane builds fail (clCreateKernel
# INVALID_KERNEL_NAME for the optimised one; uninitialised-value reports on every field of its lane structs, built
# member by member, in the unoptimised one); its bits are held to render_path's by tests/trace/test_lane_schedule.py
# on both CPU drivers, and render_path runs here.  The probes above run their width-1 builds for the same reason.
NO_CASE = {"render_path_lanes"}


def test_every_kernel_has_an_oclgrind_case():
    declared = set()
    for path in (ROOT / "kernels").glob("*.cl"):
        declared |= set(re.findall(r"__kernel\s+(?:__attribute__\s*\(\(.*?\)\)\s+)?void\s+(\w+)", path.read_text()))
    covered = {k for kernels, _ in CASES.values() for k in kernels} | NO_CASE
    assert declared and declared <= covered, f"kernels without an Oclgrind case: {sorted(declared - covered)}"


def test_the_checker_sees_an_out_of_bounds_read():
    """The canary reads past its input: if this passes, the cases above would have shown such errors."""
    result = run_under_oclgrind(CANARY)
    assert any("Invalid read" in line for line in error_reports(result.stderr)), result.stderr[-2000:]
