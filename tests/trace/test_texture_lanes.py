"""Texture lookups in lanes: kernels/texture.h built for 8 and 16 lookups a work-item (one in each lane: each its own
material, slot, texture, wrap modes and filter) gives the same bits as built for one, the width both renderers run,
for the texel of every slot, both UV sets and the vertex colour; and the texel agrees with a float64 bilinear lookup
written here from glTF's sampler rules."""

import numpy as np
import pyopencl as cl
import pytest

from clrender.layout import MATERIAL_DTYPE, TEXTURE_DTYPE, TEXTURE_SLOTS, VERTEX_ATTRIBUTES_DTYPE, WRAP_MODES
from clrender.trace.tracer import trace_defines
from clrender.trace.work_layout import launch_items

N = 2999  # lookups: no multiple of 16
WRAPS = list(WRAP_MODES.values())


@pytest.fixture(scope="module")
def scene():
    """Random textures (sizes, wrap modes, nearest or bilinear), materials (a texture or none per slot, either UV set,
    a texture transform), primitives' UVs (far outside [0, 1] too) and colours, and lookups with NaN coordinates."""
    rng = np.random.default_rng(36)
    n_tex = 12
    tex = np.zeros(n_tex, TEXTURE_DTYPE)
    tex["width"], tex["height"] = rng.integers(1, 9, n_tex), rng.integers(1, 9, n_tex)
    tex["offset"] = np.concatenate([[0], np.cumsum(tex["width"] * tex["height"])[:-1]])
    tex["wrap_s"], tex["wrap_t"] = rng.choice(WRAPS, n_tex), rng.choice(WRAPS, n_tex)
    tex["nearest"] = rng.integers(0, 2, n_tex)
    texels = rng.uniform(0, 1, (int((tex["width"] * tex["height"]).sum()), 4)).astype(np.float32)
    n_mat = 9
    mat = np.zeros(n_mat, MATERIAL_DTYPE)
    mat["textures"] = np.where(rng.uniform(size=(n_mat, len(TEXTURE_SLOTS))) < 0.8, rng.integers(0, n_tex, (n_mat, len(TEXTURE_SLOTS))), -1)
    mat["textures"][0] = -1  # an untextured material
    mat["tex_coord"] = rng.integers(0, 2, (n_mat, len(TEXTURE_SLOTS)))
    mat["tex_transform"] = rng.normal(0, 1.5, (n_mat, len(TEXTURE_SLOTS), 6))
    n_prim = 50
    attr = np.zeros(n_prim, VERTEX_ATTRIBUTES_DTYPE)
    attr["uv"], attr["uv1"] = rng.normal(0, 3, (n_prim, 3, 2)), rng.normal(0, 3, (n_prim, 3, 2))
    attr["colour"] = rng.uniform(0, 1, (n_prim, 3, 3))
    query = np.zeros((N, 4), np.int32)
    filled = np.argwhere(mat["textures"] >= 0)  # (material, slot) pairs with a texture: what a renderer looks up
    query[:, :2], query[:, 2] = filled[rng.integers(0, len(filled), N)], rng.integers(0, n_prim, N)
    query[::10, 0] = 0  # the untextured material: its slots read nothing kept (material_textured 0)
    bary = rng.dirichlet((1, 1, 1), N)[:, 1:].astype(np.float32)
    attr["uv"][7, 0] = np.nan  # a NaN coordinate reads as 0
    return dict(tex=tex, texels=texels, mat=mat, attr=attr, query=query, bary=bary)


def lookups(dev, scene, lanes):
    """kernels/texture_probe.cl's three outputs, (N, 4) each, built for `lanes` lookups a work-item."""
    knl = dev.kernel("texture_probe.cl", "texture_probe", {**trace_defines(), "LANES": lanes})
    outs = {name: dev.empty(N * 16) for name in ("out", "uv_out", "colour_out")}
    inputs = (("query", "query"), ("bary", "bary"), ("attributes", "attr"), ("textures", "tex"), ("materials", "mat"), ("texels", "texels"))
    launch_items(dev, knl, -(-N // lanes), n=N, **{name: dev.to_device(scene[key]) for name, key in inputs}, **outs)
    result = {name: np.empty((N, 4), np.float32) for name in outs}
    for name, buf in outs.items():
        cl.enqueue_copy(dev.queue, result[name], buf)
    return result


@pytest.fixture(scope="module")
def width_one(device, scene):
    return lookups(device, scene, 1)


@pytest.mark.parametrize("lanes", [8, 16])
def test_lookups_in_lanes_give_the_scalar_bits(device, scene, width_one, lanes):
    got = lookups(device, scene, lanes)
    for name, want in width_one.items():
        assert np.array_equal(got[name].view(np.uint32), want.view(np.uint32)), name


def wrap(i, n, mode):
    if mode == WRAP_MODES["clamp_to_edge"]:
        return np.clip(i, 0, n - 1)
    if mode == WRAP_MODES["mirrored_repeat"]:
        m = np.mod(i, 2 * n)
        return np.where(m < n, m, 2 * n - 1 - m)
    return np.mod(i, n)


def reference_texel(scene, k):
    """Item k's texel in float64: the slot's UV set, its transform, the wrap modes and the bilinear (or nearest) rule."""
    (mi, slot, prim, _), (u, v) = scene["query"][k], scene["bary"][k].astype(np.float64)
    m, a = scene["mat"][mi], scene["attr"][prim]
    uvs = a["uv1"] if m["tex_coord"][slot] else a["uv"]
    st = (1 - u - v) * uvs[0] + u * uvs[1] + v * uvs[2]
    x6 = m["tex_transform"][slot].astype(np.float64)
    s, t = x6[0] * st[0] + x6[1] * st[1] + x6[2], x6[3] * st[0] + x6[4] * st[1] + x6[5]
    tex = scene["tex"][max(m["textures"][slot], 0)]  # an empty slot reads texture 0 (and nothing keeps it)
    w, h = int(tex["width"]), int(tex["height"])
    image = scene["texels"][tex["offset"] : tex["offset"] + w * h].reshape(h, w, 4).astype(np.float64)
    s, t = (0.0 if np.isnan(s) else s), (0.0 if np.isnan(t) else t)
    x, y = s * w, t * h
    at = lambda i, j: image[wrap(j, h, tex["wrap_t"]), wrap(i, w, tex["wrap_s"])]
    if tex["nearest"]:
        return at(int(np.floor(x)), int(np.floor(y)))
    x, y = x - 0.5, y - 0.5
    i, j = int(np.floor(x)), int(np.floor(y))
    ax, ay = x - i, y - j
    return (1 - ay) * ((1 - ax) * at(i, j) + ax * at(i + 1, j)) + ay * ((1 - ax) * at(i, j + 1) + ax * at(i + 1, j + 1))


def test_the_texel_is_the_bilinear_lookup_of_gltfs_sampler(scene, width_one):
    """Within float32 rounding of the coordinates (a coordinate near a texel boundary may round to the other side:
    at most a few lookups in a thousand), the kernel's texel is the float64 one."""
    got = width_one["out"]
    close = np.array([np.allclose(got[k], reference_texel(scene, k), atol=2e-4) for k in range(N)])
    assert close.mean() > 0.99, close.mean()
