"""Leaf blocks (clrender/trace/bvh_wide.py leaf_blocks, tree_buffer): the wide trees' leaves tested BLOCK_LANES
primitives at a time.  The block holds every leaf's primitives, bit for bit, and tracing through the
blocks answers exactly as the one-primitive test does: in scenes that mix spheres (tested one by one
inside a block) with triangles, with transparent surfaces, and in whole renders."""

import numpy as np
import pytest

import clrender
from clrender.layout import BLOCK_LANES, LEAF_BLOCK_DTYPE
from clrender.scene.meshes import dense_mesh
from clrender.trace.bvh import build_bvh
from clrender.trace.bvh_wide import collapse, tree_buffer
from clrender.trace.geometry import flatten, pack_slots
from clrender.trace.tracer import Tracer

LAYOUTS = ((8, True), (4, True), (2, True), (4, False))  # (BVH width, use_bvh): blocks, blocks, binary, none


def spheres_and_mesh_scene(n_spheres=40, seed=5, glass=False):
    """A lumpy mesh among random spheres, some of them inside or overlapping it."""
    rng = np.random.default_rng(seed)
    objects = [{"type": "mesh", "generator": "dense", "params": {"n_triangles": 600, "seed": seed}, "material": "m"}]
    for c, r in zip(rng.uniform(-1.5, 1.5, (n_spheres, 3)), rng.uniform(0.05, 0.4, n_spheres)):
        objects.append({"type": "sphere", "center": c.tolist(), "radius": float(r), "material": "glass" if glass else "m"})
    return {
        "cameras": [{"position": [0, 0.5, 5], "look_at": [0, 0, 0], "fov": 50}],
        "materials": {"m": {"diffuse": [0.7, 0.6, 0.5]}, "glass": {"diffuse": [0.1, 0.1, 0.1], "transparency": 0.6, "ior": 1.4}},
        "lights": [{"type": "area", "corner": [-1, 4, 1], "edge_a": [2, 0, 0], "edge_b": [0, 0, 2], "samples": 3, "intensity": 1.0}],
        "objects": objects,
    }


def test_every_leaf_primitive_sits_in_its_blocks_bit_for_bit():
    scene = clrender.Scene.from_dict(spheres_and_mesh_scene())
    prims = flatten(scene)
    lo, hi = prims.bounds()
    bvh = build_bvh(lo, hi, max_leaf_size=6)
    slots = pack_slots(prims, np.asarray(bvh.prim_order, np.int64))
    slot_vertices = np.stack([slots["v0"], slots["v1"], slots["v2"]], axis=1)  # (slot, vertex, axis)
    for width in (4, 8):
        wide = collapse(bvh, width)
        buffer = tree_buffer(wide, slots)
        size = LEAF_BLOCK_DTYPE.itemsize
        base = -(-wide.nodes.nbytes // size)  # the blocks start at the first whole block after the nodes
        assert len(buffer) % size == 0
        nodes, blocks = buffer[: wide.nodes.nbytes].view(wide.nodes.dtype), buffer[base * size :].view(LEAF_BLOCK_DTYPE)
        leaf = wide.count > 0
        np.testing.assert_array_equal(nodes["bounds"].view(np.int32), wide.nodes["bounds"].view(np.int32))  # the lanes' boxes as they were
        assert np.array_equal(nodes["child"][~leaf], wide.child[~leaf])  # interior lanes as they were
        assert np.array_equal(nodes["count"], wide.count)  # counts unchanged
        seen = np.zeros(len(slots), np.int64)
        for first_block, first_slot, count in zip(nodes["child"][leaf], wide.child[leaf], wide.count[leaf]):
            n_blocks = -(-count // BLOCK_LANES)
            assert first_block >= base
            block = blocks[first_block - base : first_block - base + n_blocks]
            lane_slot = block["slot"].ravel()
            real = lane_slot != -1
            assert real.sum() == count and (lane_slot[count:] == -1).all()  # the leaf's slots, in order, then padding
            slot = np.where(lane_slot[real] < -1, -2 - lane_slot[real], lane_slot[real])
            assert np.array_equal(slot, np.arange(first_slot, first_slot + count))
            seen[slot] += 1
            sphere = slots["sphere"][slot] != 0
            assert np.array_equal(lane_slot[real] < -1, sphere)  # spheres flagged as -2 - slot
            verts = np.stack([block["v0"], block["v1"], block["v2"]], axis=1)  # (block, vertex, axis, lane)
            verts = verts.transpose(0, 3, 1, 2).reshape(-1, 3, 3)[real]  # (lane, vertex, axis)
            tri = ~sphere
            np.testing.assert_array_equal(verts[tri].view(np.int32), slot_vertices[slot[tri]].view(np.int32))
            assert not verts[sphere].any()  # a sphere's lane holds no vertices
        assert (seen == 1).all()  # every primitive in exactly one block lane


def answers(scene, o, d, t_max, device):
    out = []
    for width, use_bvh in LAYOUTS:
        tracer = Tracer(scene, bvh_width=width, use_bvh=use_bvh, device=device)
        t, prim, obj = tracer.intersect(o, d)
        out.append((t, prim, obj, tracer.occluded(o, d, t_max)))
    return out


@pytest.mark.parametrize("seed", [5, 6])
def test_blocks_with_spheres_give_the_one_by_one_answers(device, seed):
    scene = clrender.Scene.from_dict(spheres_and_mesh_scene(seed=seed))
    rng = np.random.default_rng(seed)
    o = rng.uniform(-3, 3, (4000, 3))
    d = rng.uniform(-1.5, 1.5, (4000, 3)) - o  # towards the middle, where the spheres and the mesh are
    *trees, (t0, p0, ob0, b0) = answers(scene, o, d, 0.8, device)
    assert np.isfinite(t0).mean() > 0.3 and (p0 >= 600).any()  # spheres (ids after the triangles) are hit
    for (t, p, ob, b), (width, _) in zip(trees, LAYOUTS):
        np.testing.assert_array_equal(p, p0, err_msg=f"width {width}: primitive")
        np.testing.assert_array_equal(t, t0, err_msg=f"width {width}: t")
        np.testing.assert_array_equal(ob, ob0, err_msg=f"width {width}: object")
        np.testing.assert_array_equal(b, b0, err_msg=f"width {width}: occluded")


def test_renders_through_glass_spheres_and_area_light_are_the_same_with_every_layout(device):
    """Shadow rays through transparent spheres multiply their transparency per crossing; through the
    blocks or one primitive at a time, every pixel comes out the same (to float32 rounding of the
    product's order, which a block may change in a leaf holding spheres and triangles)."""
    scene = clrender.Scene.from_dict(spheres_and_mesh_scene(glass=True))
    images, ids = [], []
    for width, use_bvh in LAYOUTS:
        tracer = Tracer(scene, bvh_width=width, use_bvh=use_bvh, device=device)
        result = clrender.Renderer(scene, tracer=tracer, aa="none", width=48, height=36).run()
        images.append(result.image)
        ids.append(result.path_ids)
    assert images[-1].std() > 0.01  # a picture, not a blank
    for image, id_map, layout in zip(images[:-1], ids[:-1], LAYOUTS):
        np.testing.assert_array_equal(id_map, ids[-1], err_msg=f"{layout}: ids")
        np.testing.assert_allclose(image, images[-1], rtol=1e-6, atol=1e-7, err_msg=f"{layout}: image")


def test_the_bundled_wizard_cat_renders_the_same_through_blocks_and_one_by_one(device):
    scene = clrender.Scene.load("wizard_cat")
    images = []
    for width, use_bvh in ((8, True), (2, True)):
        tracer = Tracer(scene, bvh_width=width, use_bvh=use_bvh, device=device)
        images.append(clrender.Renderer(scene, tracer=tracer, aa="none", width=64, height=64, camera=3).run().image)
    np.testing.assert_allclose(images[0], images[1], rtol=1e-6, atol=1e-7)


def test_leaves_larger_than_a_block_span_several_blocks(device):
    """Leaves of up to 4 x max_leaf_size primitives (SAH leaves) fill several blocks; answers still match."""
    mesh = dense_mesh(3000, seed=2)
    rng = np.random.default_rng(2)
    v = np.asarray(mesh.vertices)
    o = rng.uniform(v.min(0) - 1, v.max(0) + 1, (3000, 3))
    d = rng.normal(size=(3000, 3))
    tracer = Tracer(mesh, bvh_width=8, device=device)
    assert (tracer.wide.count > BLOCK_LANES).any()
    t, p, _ = tracer.intersect(o, d)
    t0, p0, _ = Tracer(mesh, use_bvh=False, device=device).intersect(o, d)
    np.testing.assert_array_equal(p, p0)
    np.testing.assert_array_equal(t, t0)
