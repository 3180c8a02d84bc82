"""Instancing (clrender/trace/instancing.py, kernels/intersect.h walk_instances): objects that place the
same mesh are stored once and rays meet them in object space.  Two independent answers: the same scene
flattened (Tracer without instancing, the world vertices scene.py computes in float64) and brute force
(tests/reference/whitted.py's Moller-Trumbore in float64 over the world triangles)."""

import numpy as np
import pytest
import trimesh

from clrender.scene.scene import Scene
from clrender.trace.instancing import find_instances, inverse_affine
from clrender.trace.tracer import Tracer

from tests.reference.whitted import moller_trumbore

# t of one hit found two ways in float32: the flat scene's world vertices are rounded once, the
# instanced ray is rounded through the 3x4 transform; both within a few ulps of |o| + |t d| (~10 here)
T_RTOL = 2e-5
# rays that pass within rounding of a triangle's edge may hit in one answer and miss in the other
MAX_DISAGREE = 2e-3


def bunnies(copies: int = 5, extra_flat: bool = True) -> dict:
    """`copies` low-resolution bunnies turned, scaled (one non-uniformly, one mirrored) and moved, a
    sphere and a floor that stay flat."""
    rng = np.random.default_rng(3)
    objects = []
    for i in range(copies):
        scale = [0.5, 1.4, 0.8] if i == 1 else ([-0.9, 0.9, 0.9] if i == 2 else float(rng.uniform(0.6, 1.2)))
        objects.append(
            {
                "type": "mesh",
                "generator": "bunny",
                "params": {"resolution": 16},
                "translate": [1.7 * i - 3.4, float(rng.uniform(-0.2, 0.2)), float(rng.uniform(-1, 1))],
                "rotate": [float(rng.uniform(-30, 30)), float(rng.uniform(0, 360)), 0.0],
                "scale": scale,
            }
        )
    if extra_flat:
        objects += [
            {"type": "sphere", "center": [0.0, 2.5, 0.0], "radius": 0.5},
            {"type": "quad", "corner": [-5, -0.3, -3], "edge_a": [10, 0, 0], "edge_b": [0, 0, 6]},
        ]
    return {"objects": objects}


def random_rays(n: int, seed: int = 1):
    rng = np.random.default_rng(seed)
    o = np.column_stack([rng.uniform(-5, 5, n), rng.uniform(-0.5, 3, n), rng.uniform(-3, 3, n)])
    targets = np.column_stack([rng.uniform(-4, 4, n), rng.uniform(0, 1.5, n), rng.uniform(-1, 1, n)])
    return o, targets - o  # toward the bunnies, directions of any length


def test_objects_naming_one_mesh_share_its_arrays_and_place_it_by_their_matrices():
    scene = Scene.from_dict(bunnies(4))
    inst = find_instances(scene)
    assert len(inst.shapes) == 1 and inst.shapes[0].objects == [0, 1, 2, 3]
    assert inst.flat_objects == [4, 5]
    meshes = scene.objects[:4]
    assert all(np.shares_memory(m.local_vertices, meshes[0].local_vertices) for m in meshes)
    for m in meshes:  # the world vertices are the shared ones placed by to_world, as the loader made them
        np.testing.assert_array_equal(m.local_vertices @ m.to_world[:3, :3].T + m.to_world[:3, 3], m.vertices)
        back = m.vertices @ inverse_affine(m.to_world)[:3, :3].T + inverse_affine(m.to_world)[:3, 3]
        np.testing.assert_allclose(back, m.local_vertices, atol=1e-12)
    np.testing.assert_array_equal(inst.records["object"], [0, 1, 2, 3])


def test_a_point_along_a_world_ray_is_at_the_same_t_along_the_object_ray():
    """Why the direction is not renormalised: M^-1 (o + t d) = M^-1 o + t (M^-1 d)."""
    m = Scene.from_dict(bunnies(2)).objects[1].to_world  # non-uniform scale
    inv = inverse_affine(m)
    o, d, t = np.array([0.3, -1.0, 2.0]), np.array([0.2, 0.7, -0.4]), 1.7
    np.testing.assert_allclose(inv[:3, :3] @ (o + t * d) + inv[:3, 3], (inv[:3, :3] @ o + inv[:3, 3]) + t * (inv[:3, :3] @ d), atol=1e-14)


@pytest.mark.parametrize("kw", [{}, {"bvh_width": 4}, {"bvh_width": 2}, {"use_bvh": False}], ids=["wide8", "wide4", "binary", "no-bvh"])
def test_instanced_hits_are_the_flat_scenes_hits(device, kw):
    scene = Scene.from_dict(bunnies(5))
    flat, inst = Tracer(scene, device=device, **kw), Tracer(scene, device=device, instancing=True, **kw)
    assert inst.n_instances == 5 and flat.n_instances == 0
    o, d = random_rays(4000)
    t0, p0, o0 = flat.intersect(o, d)
    t1, p1, o1 = inst.intersect(o, d)
    agree = np.isfinite(t0) == np.isfinite(t1)
    assert np.mean(~agree) <= MAX_DISAGREE and np.isfinite(t0).sum() > 1000
    both = np.isfinite(t0) & np.isfinite(t1)
    np.testing.assert_allclose(t1[both], t0[both], rtol=T_RTOL)
    assert np.mean(o1[both] != o0[both]) <= MAX_DISAGREE  # a different object only where two lie within rounding
    # the primitive: a flat-part id is below n_prims; an instance's is its prim_base + the mesh's face index
    rec = np.sort(inst.instance_records, order="prim_base")  # the records come in the top tree's leaf order
    first_face = np.cumsum([0] + [len(ob.faces) for ob in scene.objects[:5]])
    hit_inst = both & (p1 >= inst.n_prims) & (o1 == o0)
    k = np.searchsorted(rec["prim_base"], p1[hit_inst], side="right") - 1
    np.testing.assert_array_equal(rec["object"][k], o1[hit_inst])
    face = p1[hit_inst] - rec["prim_base"][k]
    same = face == p0[hit_inst] - first_face[o0[hit_inst]]
    assert same.mean() >= 1 - MAX_DISAGREE
    assert (p1[both & (o1 >= 5)] < inst.n_prims).all()  # the sphere and the floor stay flat


def test_instanced_hits_match_brute_force_in_float64(device):
    scene = Scene.from_dict(bunnies(3, extra_flat=False))
    tri = np.concatenate([ob.vertices[ob.faces] for ob in scene.objects])
    obj = np.concatenate([np.full(len(ob.faces), i) for i, ob in enumerate(scene.objects)])
    o, d = random_rays(600, seed=5)
    t_ref = moller_trumbore(o, d, tri)[0]
    k = t_ref.argmin(axis=1)
    best = t_ref[np.arange(len(o)), k]
    t, _, ob = Tracer(scene, device=device, instancing=True).intersect(o, d)
    agree = np.isfinite(best) == np.isfinite(t)
    assert np.mean(~agree) <= MAX_DISAGREE * 3 and np.isfinite(best).sum() > 50
    both = np.isfinite(best) & np.isfinite(t)
    np.testing.assert_allclose(t[both], best[both], rtol=T_RTOL)
    assert np.mean(ob[both] != obj[k[both]]) <= MAX_DISAGREE * 3


@pytest.mark.parametrize("kw", [{}, {"bvh_width": 2}], ids=["wide8", "binary"])
def test_instanced_occlusion_is_the_flat_scenes(device, kw):
    scene = Scene.from_dict(bunnies(5))
    flat, inst = Tracer(scene, device=device, **kw), Tracer(scene, device=device, instancing=True, **kw)
    o, d = random_rays(3000, seed=9)
    t, _, _ = flat.intersect(o, d)
    # segments ending just short of the first hit (clear) and just past it (blocked), or 2 units long
    for t_max in (np.where(np.isfinite(t), t * 0.999, 2.0), np.where(np.isfinite(t), t * 1.001, 2.0)):
        a, b = flat.occluded(o, d, t_max), inst.occluded(o, d, t_max)
        assert np.mean(a != b) <= MAX_DISAGREE


def test_a_scene_without_repeated_meshes_is_the_flat_scene_bit_for_bit(device):
    scene = Scene.from_dict(bunnies(1))
    inst = Tracer(scene, device=device, instancing=True)
    assert inst.instances is None and "INSTANCED" not in inst.defines
    o, d = random_rays(500)
    for a, b in zip(Tracer(scene, device=device).intersect(o, d), inst.intersect(o, d)):
        np.testing.assert_array_equal(a, b)


def test_objects_naming_one_mesh_file_are_read_once_and_stored_once(device, tmp_path):
    """Device memory: each shape's slots and tree once, plus a record per instance."""
    mesh = trimesh.creation.icosphere(subdivisions=3)
    mesh.export(tmp_path / "ball.obj")
    objects = [{"type": "mesh", "file": "ball.obj", "translate": [3.0 * i, 0, 0], "scale": [1, 1 + 0.1 * i, 1]} for i in range(12)]
    scene = Scene.from_dict({"objects": objects}, base_dir=tmp_path)
    one = Tracer(Scene.from_dict({"objects": objects[:1]}, base_dir=tmp_path), device=device)
    flat, inst = Tracer(scene, device=device), Tracer(scene, device=device, instancing=True)

    def stored(tr):
        return tr.nodes.size + tr.prims.size + tr.tables.buffer.size  # the tables: instance records, top tree, objects, materials

    assert len(inst.instances.shapes) == 1
    assert stored(inst) <= 1.1 * stored(one) + 12 * 256  # one copy, then small records per instance
    assert stored(flat) > 10 * stored(one)
    o = np.column_stack([np.linspace(-1, 35, 400), np.full(400, 0.3), np.full(400, 5.0)])
    d = np.tile([0.0, 0.0, -1.0], (400, 1))
    t0, _, o0 = flat.intersect(o, d)
    t1, _, o1 = inst.intersect(o, d)
    np.testing.assert_array_equal(np.isfinite(t0), np.isfinite(t1))
    np.testing.assert_allclose(t1[np.isfinite(t0)], t0[np.isfinite(t0)], rtol=T_RTOL)
    np.testing.assert_array_equal(o0, o1)


def test_gltf_nodes_sharing_a_mesh_are_one_shape_placed_twice(device, tmp_path):
    from tests.gltftools import gltf_file, quaternion

    nodes = [
        {"mesh": 0, "translation": [-1.5, 0.0, -4.0]},
        {"mesh": 0, "translation": [1.5, 0.2, -5.0], "rotation": quaternion([0, 1, 0], 30), "scale": [0.5, 1.5, 1.0]},
    ]
    scene = Scene.load(gltf_file(tmp_path, nodes))
    inst = find_instances(scene)
    assert len(inst.shapes) == 1 and inst.shapes[0].objects == [0, 1] and inst.unique_triangles == 2
    for m in scene.objects:  # the node's world vertices are the mesh's own placed by the node's matrix
        np.testing.assert_allclose(m.local_vertices @ m.to_world[:3, :3].T + m.to_world[:3, 3], m.vertices, atol=1e-6)
    tracer = Tracer(scene, device=device, instancing=True)
    assert tracer.n_prims == 0 and tracer.prims.size == 2 * 48  # the quad's two slots, once
    ys, xs = np.mgrid[-1:1:40j, -3:3:80j]
    d = np.stack([xs, ys, np.full_like(xs, -4.5)], -1).reshape(-1, 3)
    t0, _, o0 = Tracer(scene, device=device).intersect(np.zeros(3), d)
    t1, _, o1 = tracer.intersect(np.zeros(3), d)
    assert np.isfinite(t0).sum() > 500 and set(o0[np.isfinite(t0)]) == {0, 1}
    assert np.mean(np.isfinite(t0) != np.isfinite(t1)) <= 0.01  # rays along the quads' edges
    both = np.isfinite(t0) & np.isfinite(t1)
    np.testing.assert_allclose(t1[both], t0[both], rtol=T_RTOL)
    np.testing.assert_array_equal(o1[both], o0[both])


@pytest.mark.parametrize("width", [8, 2], ids=["wide-top", "binary-top"])
def test_a_full_top_level_stack_visits_every_instance_and_finds_the_same_hits(device, width):
    """A stack of one entry fills up in the top tree and in every mesh's (kernels/walk.h's fallback: every item,
    any-hit again from where it started): the same closest hits and the same occlusion as with the default stacks."""
    from clrender.trace.knobs import TraceKnobs

    scene = Scene.from_dict(bunnies(5))
    o, d = random_rays(1500, seed=4)
    full, small = (Tracer(scene, device=device, instancing=True, bvh_width=width, **kw) for kw in ({}, {"knobs": TraceKnobs(stack_size=1)}))
    t0, p0, o0 = full.intersect(o, d)
    t1, p1, o1 = small.intersect(o, d)
    assert np.isfinite(t0).mean() > 0.2
    for a, b in ((t0, t1), (p0, p1), (o0, o1)):
        np.testing.assert_array_equal(a, b)
    t_max = np.where(np.isfinite(t0), t0 * 0.999, 8.0)  # just short of each hit: blocked only by another surface
    np.testing.assert_array_equal(small.occluded(o, d, t_max), full.occluded(o, d, t_max))
    np.testing.assert_array_equal(small.occluded(o, d, np.where(np.isfinite(t0), t0 * 1.001, 8.0)), np.isfinite(t0))


def coherent_rays(groups: int, seed: int):
    """Groups of 8 rays from one origin toward points near one spot: most groups share their directions'
    signs (the query kernels walk them as packets, kernels/packet.h), some not in an instance's object space."""
    rng = np.random.default_rng(seed)
    o = np.repeat(np.column_stack([rng.uniform(-5, 5, groups), rng.uniform(-0.5, 3, groups), rng.uniform(-3, 3, groups)]), 8, axis=0)
    spots = np.column_stack([rng.uniform(-4, 4, groups), rng.uniform(0, 1.5, groups), rng.uniform(-1, 1, groups)])
    targets = np.repeat(spots, 8, axis=0) + rng.normal(scale=0.15, size=(8 * groups, 3))
    return o, targets - o


@pytest.mark.parametrize("copies, stack", [(2, None), (5, None), (5, 2)], ids=["binary-top", "wide-top", "small-stack"])
def test_instanced_packets_give_the_one_ray_walks_answers_bit_for_bit(device, copies, stack):
    """The instanced query kernels' packets (top tree and meshes walked by 8 rays together, the rays taken
    into each object space one by one) find each ray's one-ray answer: t, primitive and object, occlusion."""
    from clrender.trace.knobs import TraceKnobs

    scene = Scene.from_dict(bunnies(copies))
    kw = {} if stack is None else {"knobs": TraceKnobs(stack_size=stack)}  # packets that fill it fall back
    packets, single = (Tracer(scene, device=device, instancing=True, ray_packets=p, **kw) for p in (True, False))
    o, d = coherent_rays(400, seed=11)
    signs = np.signbit(d).reshape(-1, 8, 3)
    assert (signs == signs[:, :1]).all(axis=(1, 2)).mean() > 0.5  # most groups can go as packets
    hits = single.intersect(o, d)
    assert np.isfinite(hits[0]).mean() > 0.3
    for a, b in zip(packets.intersect(o, d), hits):
        np.testing.assert_array_equal(a, b)
    for t_max in (np.where(np.isfinite(hits[0]), hits[0] * 0.999, 2.0), np.where(np.isfinite(hits[0]), hits[0] * 1.001, 8.0)):
        np.testing.assert_array_equal(packets.occluded(o, d, t_max), single.occluded(o, d, t_max))
