"""Objects naming one mesh (scene.py's shapes): the file is read once, every copy shares its object-space
arrays, and a copy's world vertices are made only when read (Mesh.vertices), equal bit for bit to the
float64 placement the loader always made (local @ M[:3, :3].T + M[:3, 3], computed here); the instanced
Tracer never reads them (docs/bvh.md, "Instancing")."""

import tracemalloc

import numpy as np
import pytest
import trimesh

from clrender.errors import UsageError
from clrender.scene import scene as scene_module
from clrender.scene.checks import Checks
from clrender.scene.scene import Mesh, Scene, transform_matrix

COPIES = 30


def ball_objects(copies: int, file: str = "ball.ply") -> list:
    """`copies` objects naming one file, each turned, scaled (one non-uniformly, one mirrored) and moved."""
    rng = np.random.default_rng(5)
    objects = []
    for i in range(copies):
        scale = [0.5, 1.4, 0.8] if i == 1 else ([-0.9, 0.9, 0.9] if i == 2 else float(rng.uniform(0.6, 1.2)))
        rotate = [float(a) for a in rng.uniform(0, 360, 3)]
        objects.append({"type": "mesh", "file": file, "translate": [3.0 * i, float(rng.uniform(-1, 1)), 0.0], "rotate": rotate, "scale": scale})
    return objects


@pytest.fixture
def ball(tmp_path):
    """An icosphere of 20,480 triangles (10,242 vertices: 246 kB of float64 world vertices a copy) in tmp_path."""
    trimesh.creation.icosphere(subdivisions=5).export(tmp_path / "ball.ply")
    return tmp_path


def test_objects_naming_one_file_read_it_once_and_share_its_arrays(ball, monkeypatch):
    reads = []
    read = scene_module.load_mesh_file
    monkeypatch.setattr(scene_module, "load_mesh_file", lambda *a, **k: reads.append(a[0]) or read(*a, **k))
    (ball / "copies.toml").write_text(
        "".join(f'[[objects]]\ntype = "mesh"\nfile = "ball.ply"\ntranslate = [{3 * i}, 0, 0]\nrotate = [0, {7 * i}, 0]\n' for i in range(COPIES))
    )
    scene = Scene.from_file(ball / "copies.toml")
    assert len(reads) == 1 and len(scene.objects) == COPIES
    first = scene.objects[0]
    assert all(m.local_vertices is first.local_vertices and m.faces is first.faces for m in scene.objects)
    assert all(m.world_made == () for m in scene.objects)


def test_a_copys_world_vertices_are_the_float64_placement_bit_for_bit(ball):
    objects = ball_objects(6)
    for o in objects[:3]:
        o["smooth"] = True
    scene = Scene.from_dict({"objects": objects}, base_dir=ball)
    for o, m in zip(objects, scene.objects):
        assert m.world_made == ()
        matrix = transform_matrix(o["translate"], o["rotate"], (o["scale"],) * 3 if np.isscalar(o["scale"]) else o["scale"])
        np.testing.assert_array_equal(m.to_world, matrix)
        expected = np.asarray(trimesh.load(ball / "ball.ply", process=False).vertices, np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
        assert m.vertices.dtype == np.float64 and np.array_equal(m.vertices, expected)
        assert m.world_made == ("vertices",) and m.vertices is m.vertices  # made once, then kept
        if o.get("smooth"):
            n = m.placed[1] @ np.linalg.inv(matrix[:3, :3])  # the shared object-space normals by the inverse transpose
            assert np.array_equal(m.vertex_normals, n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30))
            assert np.allclose(np.linalg.norm(m.vertex_normals, axis=1), 1.0)
        else:
            assert m.vertex_normals is None


def test_a_glTF_nodes_world_vertices_are_its_node_vertices_placed_by_the_object(tmp_path):
    from clrender.scene import gltf

    from tests.gltftools import gltf_file, quaternion

    nodes = [{"mesh": 0, "translation": [1.5, 0.2, -5.0], "rotation": quaternion([0, 1, 0], 30), "scale": [0.5, 1.5, 1.0]}]
    path = gltf_file(tmp_path, nodes)
    placing = {"translate": [1.0, 2.0, 3.0], "rotate": [10.0, 20.0, 30.0], "scale": 2.0}
    scene = Scene.from_dict({"objects": [{"type": "mesh", "file": str(path), "node": 0, **placing}] * 2})
    matrix = transform_matrix(placing["translate"], placing["rotate"], (2.0,) * 3)
    expected = gltf.node_mesh(path, 0, None).vertices @ matrix[:3, :3].T + matrix[:3, 3]
    for m in scene.objects:
        assert m.world_made == () and np.array_equal(m.vertices, expected)


def test_loading_and_the_instanced_tracer_make_no_world_vertices_and_the_flat_tracer_makes_each(ball, device):
    from clrender.trace.tracer import Tracer

    scene = Scene.from_dict({"objects": ball_objects(4) + [{"type": "sphere", "center": [0.0, 5.0, 0.0], "radius": 1.0}]}, base_dir=ball)
    meshes = [o for o in scene.objects if isinstance(o, Mesh)]
    tracer = Tracer(scene, device=device, instancing=True)
    assert tracer.instances is not None and len(tracer.instances.shapes) == 1
    assert all(m.world_made == () for m in meshes)
    Tracer(scene, device=device)
    assert all(m.world_made == ("vertices",) for m in meshes)


def heap(load) -> tuple[int, int]:
    """(peak, kept) Python-heap bytes of load() (tracemalloc counts numpy's arrays)."""
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        kept = load()
        now, peak = tracemalloc.get_traced_memory()
        return peak - before, now - before
    finally:
        del kept
        tracemalloc.stop()


def test_thirty_copies_take_the_heap_of_one_and_small_records(ball):
    """Eager world vertices would add 246 kB a copy (7 MB for 30); the bound allows 1.5x one copy's load
    and 16 kB a copy (a Mesh, its matrix and tuples take about 2 kB)."""
    one, many = ({"objects": ball_objects(n)} for n in (1, COPIES))
    Scene.from_dict(one, base_dir=ball)  # trimesh's imports and caches, before counting
    one_peak, one_kept = heap(lambda: Scene.from_dict(one, base_dir=ball))
    many_peak, many_kept = heap(lambda: Scene.from_dict(many, base_dir=ball))
    per_copy = 16_000
    assert one_kept > 10 * 10242 * 3 * 8 / 10  # the vertices and faces are in the counted heap at all
    assert many_peak <= 1.5 * one_peak + COPIES * per_copy
    assert many_kept <= 1.5 * one_kept + COPIES * per_copy


@pytest.mark.parametrize("reach", [9.0e6, 9.99999e6, 1.0e7, 1.00001e7, 2e7])
@pytest.mark.parametrize("size", [1e-2, 49.9, 50.0, 50.1, 1e3])
def test_the_box_check_refuses_exactly_what_placing_every_vertex_refuses(reach, size):
    """Near the coordinate limit (10 x COORD_LIMIT) and float32's precision limit (RELATIVE_PRECISION x
    distance: 100 across at 1e7, a size of 50 here) the box check falls back to the vertices; far from them it settles alone."""
    points = trimesh.creation.icosphere(subdivisions=2).vertices
    points = points / np.abs(points).max()
    matrix = transform_matrix((reach - size, 0.0, 0.0), (0.0, 30.0, 0.0), (size, size, size))
    box = (points.min(axis=0), points.max(axis=0))
    checks = Checks("test")

    def answer(check):
        try:
            check()
        except UsageError as exc:
            return str(exc)
        return None

    placed = np.asarray(points, np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
    exact = answer(lambda: scene_module._check_placed(checks, placed, "objects[0]"))
    assert answer(lambda: scene_module._check_placed_box(checks, points, box, matrix, "objects[0]")) == exact


def test_objects_naming_one_textured_obj_share_its_material_and_decode_its_image_once(tmp_path, monkeypatch):
    from PIL import Image

    from clrender.scene import textures

    Image.fromarray(np.array([[[255, 0, 0], [0, 128, 0]]], np.uint8)).save(tmp_path / "tex.png")
    (tmp_path / "m.mtl").write_text("newmtl paint\nKd 0.5 0.6 0.7\nmap_Kd tex.png\n")
    (tmp_path / "q.obj").write_text("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl paint\nf 1/1 2/2 3/3\n")
    decoded = []
    decode = textures.decode
    monkeypatch.setattr(textures, "decode", lambda *a, **k: decoded.append(k.get("what")) or decode(*a, **k))
    scene = Scene.from_dict({"objects": [{"type": "mesh", "file": "q.obj", "translate": [2.0 * i, 0, 0]} for i in range(5)]}, base_dir=tmp_path)
    assert len(decoded) == 1 and len(scene.textures) == 1
    assert {m.material for m in scene.objects} == {"q.obj:paint"}
    assert scene.materials["q.obj:paint"].base_color_texture.index == 0 and scene.materials["q.obj:paint"].diffuse == (0.5, 0.6, 0.7)
    assert all(m.uvs is scene.objects[0].uvs for m in scene.objects)  # made from trimesh's once, shared


def test_a_scene_of_copies_ships_to_workers_as_one_array_and_comes_back_the_same(ball):
    from clrender.distributed.payload import join, split

    scene = Scene.from_dict({"objects": ball_objects(COPIES)}, base_dir=ball)
    one = split(Scene.from_dict({"objects": ball_objects(1)}, base_dir=ball))
    payload = split(scene)
    assert all(m.world_made == () for m in scene.objects)  # shipping made none of them
    # the shared vertices and faces once, the faces reversed once more for the mirrored copy (scene.mirrored_faces),
    # then a matrix a copy
    assert payload.nbytes <= one.nbytes + scene.objects[0].faces.nbytes + COPIES * 1024
    back = join(payload)
    assert all(m.world_made == () for m in back.objects)
    for a, b in zip(scene.objects, back.objects):
        assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.to_world, b.to_world)
    assert split(back).key == payload.key == split(scene).key  # made or not, the same scene ships the same


def test_an_instanced_render_makes_no_copys_world_vertices(ball, device):
    """Whitted and path renders with instancing read the shape's object-space arrays: no copy's world vertices
    are made, and of a smooth shape's normals only its first copy's (taken back to object space once)."""
    from clrender.trace.renderer import Renderer

    objects = ball_objects(6)
    for o in objects[3:]:
        o["smooth"] = True
    lights = [{"type": "point", "position": [0.0, 10.0, 10.0]}]
    scene = Scene.from_dict(
        {"objects": objects, "lights": lights, "cameras": [{"position": [7.5, 2.0, 12.0], "look_at": [7.5, 0.0, 0.0]}]}, base_dir=ball
    )
    for integrator in ("whitted", "path"):
        Renderer(scene, width=16, height=12, integrator=integrator, instancing=True).run()
    assert [m.world_made for m in scene.objects] == [()] * 3 + [("vertex_normals",)] + [()] * 2


def test_the_scene_keeps_one_shape_a_key_and_each_mesh_says_which_shape_it_places_and_where(ball, tmp_path):
    """Checks.shapes holds shapes.Shape records only, one per shape key (not a cache entry per derived array); each
    mesh's Instance names its shape, shares the shape's object-space points and carries its own matrix.  Two glTF
    nodes that place one glTF mesh (one mirrored) are two instances of that mesh: its own points, not either node's,
    placed by the node's world matrix and then the object's (here the identity), and the mirrored one's winding
    reversed, as scene.mirrored_faces has it."""
    from clrender.scene import gltf
    from clrender.scene.shapes import Instance, Shape

    from tests.gltftools import gltf_file

    checks = Checks("<dict>", ball)
    scene = scene_module._read_scene(checks, {"objects": ball_objects(4)}, "s")
    assert len(checks.shapes) == 1 and all(isinstance(s, Shape) for s in checks.shapes.values())
    (shape,) = checks.shapes.values()
    for o, m in zip(ball_objects(4), scene.objects):
        assert isinstance(m.instance, Instance) and m.instance.shape_key == shape.key and m.instance.vertices is shape.points
        matrix = transform_matrix(o["translate"], o["rotate"], (o["scale"],) * 3 if np.isscalar(o["scale"]) else o["scale"])
        np.testing.assert_array_equal(m.instance.to_world, matrix)
    nodes = [{"mesh": 0, "translation": [1.0, 0.0, 0.0]}, {"mesh": 0, "translation": [0.0, 2.0, 0.0], "scale": [-1.0, 1.0, 1.0]}]
    path = gltf_file(tmp_path, nodes)
    checks = Checks("<dict>", tmp_path)
    objects = [{"type": "mesh", "file": str(path), "node": n} for n in (0, 1)]
    a, b = scene_module._read_scene(checks, {"objects": objects}, "s").objects
    assert a.instance.shape_key == b.instance.shape_key and a.instance.vertices is b.instance.vertices
    own = gltf.node_shape(path, 0)[1]
    np.testing.assert_array_equal(a.instance.vertices, own)
    np.testing.assert_array_equal(a.instance.to_world[:3, 3], [1.0, 0.0, 0.0])
    np.testing.assert_array_equal(np.diag(b.instance.to_world)[:3], [-1.0, 1.0, 1.0])
    np.testing.assert_array_equal(b.faces, a.faces[:, [0, 2, 1]])
    assert all(isinstance(s, Shape) for s in checks.shapes.values())


def test_a_gltf_scenes_nodes_are_read_once_and_place_the_same_bits(tmp_path, monkeypatch):
    """Loading a glTF scene places each node's triangles once (scene_dict reads them for the bounds, and the
    scene's meshes take them over), not once more per mesh object: 3 nodes of one mesh make 3 world placements
    and the glTF mesh's own vertices once (gltf.node_shape), where it took 7.  The world vertices are the bits
    gltf.node_mesh places on its own."""
    from clrender.scene import gltf

    from tests.gltftools import gltf_file, quaternion

    nodes = [{"mesh": 0, "translation": [float(i), 0.5, -4.0], "rotation": quaternion([0, 1, 0], 20 * i)} for i in range(3)]
    path = gltf_file(tmp_path, nodes)
    calls = []
    placed = gltf.primitive_triangles
    monkeypatch.setattr(gltf, "primitive_triangles", lambda *a: calls.append(a[1:3]) or placed(*a))
    scene = Scene.load(str(path))
    assert len(calls) == len(nodes) + 1
    monkeypatch.undo()
    for i, m in enumerate(scene.objects):
        np.testing.assert_array_equal(m.vertices, gltf.node_mesh(path, i, 0).vertices)
