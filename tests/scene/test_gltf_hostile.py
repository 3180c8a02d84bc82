"""Hostile glTF files (the red team's cases, issue 23): confinement, hangs, internal errors, memory.

Each bad file must give one `clrender:` line and exit 2 (no traceback, no numpy warning before it,
nothing written); each valid but odd one must load with the answer its numbers give.
"""

import base64
import json
import math
import tracemalloc
import warnings

import numpy as np
import pytest
import trimesh

from clrender.errors import UsageError
from clrender.scene import gltf
from clrender.scene.gltf import Document, node_world_matrix
from clrender.scene.scene import Scene

from tests.clitools import run_cli
from tests.gltftools import gltf_file, quaternion

TRIANGLE = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)


def write_gltf(path, positions=TRIANGLE, *, indices=None, index_type=5123, uri=None, nodes=({"mesh": 0},), **top):
    """A .gltf whose mesh 0 is `positions` (with `indices` of glTF component type `index_type`), its
    buffer a data URI, or the file `uri` (which is then written by the caller)."""
    blob = np.asarray(positions, np.float32).tobytes()
    accessors = [{"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3"}]
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": len(blob)}]
    primitive = {"attributes": {"POSITION": 0}}
    if indices is not None:
        dtype = {5123: np.uint16, 5126: np.float32}[index_type]
        data = np.asarray(indices, dtype).tobytes()
        accessors.append({"bufferView": 1, "componentType": index_type, "count": len(indices), "type": "SCALAR"})
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        primitive["indices"] = 1
        blob += data
    buffer = {"byteLength": len(blob), "uri": uri or "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}
    doc = {
        "asset": {"version": "2.0"},
        "nodes": list(nodes),
        "meshes": [{"primitives": [primitive]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [buffer],
        **top,
    }
    path.write_text(json.dumps(doc))
    return path, blob


def refused(capsys, tmp_path, scene, fragment):
    """Render `scene` from the command line: exit 2, one `clrender:` line naming `fragment`, no warning, nothing written."""
    out = tmp_path / "out.png"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code, stdout, err = run_cli(capsys, "render", str(scene), "--width", "8", "--height", "6", "-o", str(out))
    assert code == 2, err
    assert err.startswith("clrender: ") and err.count("\n") == 1 and "Traceback" not in err, err
    assert fragment in err, err
    assert not caught, [str(w.message) for w in caught]
    assert stdout == "" and not out.exists()
    return err


# ------------------------------------------------------------ confinement
@pytest.fixture
def confined(tmp_path):
    """A scene folder `inner`, and outside it secret.bin: a triangle's bytes."""
    inner = tmp_path / "inner"
    inner.mkdir()
    (tmp_path / "secret.bin").write_bytes(TRIANGLE.tobytes())
    return inner


def secret_uri(kind, inner):
    if kind == "climbing":
        return "../secret.bin"
    if kind == "absolute":
        return str(inner.parent / "secret.bin")
    (inner / "link.bin").symlink_to(inner.parent / "secret.bin")
    return "link.bin"


@pytest.mark.parametrize("kind", ["climbing", "absolute", "symlink"])
@pytest.mark.parametrize("route", ["node", "trimesh"])
def test_a_confined_scene_reads_no_gltf_buffer_outside_its_folder(confined, kind, route):
    write_gltf(confined / "inside.gltf", uri=secret_uri(kind, confined))
    mesh = {"type": "mesh", "file": "inside.gltf", **({"node": 0} if route == "node" else {})}
    with pytest.raises(UsageError) as err:
        Scene.from_dict({"objects": [mesh]}, base_dir=confined, where="s.toml", allow_outside=False)
    assert "outside the scene folder" in str(err.value) and "\n" not in str(err.value)
    if route == "node":  # the same scene for local files reads the buffer: the refusal is the confinement
        (placed,) = Scene.from_dict({"objects": [mesh]}, base_dir=confined).objects
        np.testing.assert_array_equal(placed.vertices, TRIANGLE)


@pytest.mark.parametrize("kind", ["climbing", "absolute", "symlink"])
def test_a_confined_gltf_scene_reads_no_buffer_outside_its_folder(confined, kind):
    path, _ = write_gltf(confined / "inside.gltf", uri=secret_uri(kind, confined))
    with pytest.raises(UsageError, match="outside the scene folder"):
        Scene.from_file(path, allow_outside=False)
    (mesh,) = Scene.from_file(path).objects  # for local files: read
    np.testing.assert_array_equal(mesh.vertices, TRIANGLE)


def test_a_confined_scene_reads_gltf_buffers_inside_its_folder(confined):
    (confined / "data").mkdir()
    _, blob = write_gltf(confined / "inside.gltf", uri="data/tri.bin")
    (confined / "data" / "tri.bin").write_bytes(blob)
    mesh = {"type": "mesh", "file": "inside.gltf", "node": 0}
    (placed,) = Scene.from_dict({"objects": [mesh]}, base_dir=confined, allow_outside=False).objects
    np.testing.assert_array_equal(placed.vertices, TRIANGLE)


@pytest.mark.parametrize("looping", ["mesh file", "buffer"])
def test_a_symlink_loop_is_refused_in_one_line(confined, looping):
    (confined / "loop").symlink_to(confined / "loop")
    if looping == "mesh file":
        mesh = {"type": "mesh", "file": "loop"}
    else:
        write_gltf(confined / "inside.gltf", uri="loop")
        mesh = {"type": "mesh", "file": "inside.gltf", "node": 0}
    with pytest.raises(UsageError) as err:
        Scene.from_dict({"objects": [mesh]}, base_dir=confined, where="s.toml", allow_outside=False)
    assert "symlink loop" in str(err.value) and "\n" not in str(err.value)


# ------------------------------------------------------------ the node tree
@pytest.mark.slow
def test_every_node_of_a_deep_hierarchy_is_placed_once(monkeypatch):
    """100,000 nodes, mostly one long chain: each local matrix is computed once (the old reader walked
    every chain again and rebuilt the parent map per node: about 20 minutes), and every world matrix
    equals the product along its chain, built here parent first in float64."""
    rng = np.random.default_rng(23)
    n = 100_000
    parent = np.maximum(np.arange(n) - rng.integers(1, 4, n), -1)  # mostly a chain: depth about n / 2
    parent[0] = -1
    axes = rng.normal(size=(n, 3))
    angles = rng.uniform(0, 360, n)
    shifts = rng.uniform(-1, 1, (n, 3))
    nodes = [{"rotation": quaternion(axes[i], angles[i]), "translation": shifts[i].tolist(), "children": []} for i in range(n)]
    for i in range(1, n):
        if parent[i] >= 0:
            nodes[parent[i]]["children"].append(i)
    doc = Document(None, {"nodes": nodes}, [])
    calls = []
    original = gltf.local_matrix

    def counted(doc, index):
        calls.append(index)
        assert len(calls) <= n, "a node's local matrix was computed twice"
        return original(doc, index)

    monkeypatch.setattr(gltf, "local_matrix", counted)
    order = rng.permutation(n)
    worlds = {int(i): node_world_matrix(doc, int(i)) for i in order}
    assert sorted(calls) == list(range(n))

    reference = np.empty((n, 4, 4))
    for i in range(n):  # parents come first: parent[i] < i
        local = trimesh.transformations.rotation_matrix(math.radians(angles[i]), axes[i])
        local[:3, 3] = shifts[i]
        reference[i] = local if parent[i] < 0 else reference[parent[i]] @ local
    for i in rng.choice(n, 500, replace=False):
        np.testing.assert_allclose(worlds[int(i)], reference[i], atol=1e-6)


def test_a_file_of_many_mesh_nodes_loads_each_node_once(tmp_path, monkeypatch):
    """2,000 mesh nodes in a chain, each one unit further along x: every object is placed, and no local
    matrix is computed twice (scene_dict and each object's node_mesh share them)."""
    n = 2000
    nodes = [{"mesh": 0, "translation": [1, 0, 0], **({"children": [i + 1]} if i + 1 < n else {})} for i in range(n)]
    path = gltf_file(tmp_path, nodes, name="chain.gltf")
    calls = []
    original = gltf.local_matrix
    monkeypatch.setattr(gltf, "local_matrix", lambda doc, index: calls.append(index) or original(doc, index))
    scene = Scene.load(path)
    assert len(scene.objects) == n and sorted(calls) == list(range(n))
    quad = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]])
    for k in (0, 1, n // 2, n - 1):
        np.testing.assert_allclose(scene.objects[k].vertices, quad + [k + 1, 0, 0])


# ------------------------------------------------------------ bad input: one line, exit 2
@pytest.mark.parametrize(
    "case, fragment",
    [
        ("nan indices", "componentType"),
        ("tiny aspect ratio", "aspectRatio"),
        ("nested json", "nested too deeply"),
        ("inf positions", "NaN or infinite"),
        ("overflowing node chain", "overflows"),
        ("zero camera matrix", "nodes[1]"),
        ("huge accessor count", "10000000"),
    ],
)
def test_a_hostile_gltf_is_refused_in_one_line(tmp_path, capsys, case, fragment):
    path = tmp_path / "bad.gltf"
    if case == "nan indices":
        write_gltf(path, indices=[0, 1, np.nan], index_type=5126)
    elif case == "tiny aspect ratio":
        write_gltf(path, nodes=[{"mesh": 0}, {"camera": 0}], cameras=[{"type": "perspective", "perspective": {"yfov": 1, "aspectRatio": 5e-324}}])
    elif case == "nested json":
        write_gltf(path)
        path.write_text(path.read_text()[:-1] + ', "extras": ' + "[" * 5000 + "]" * 5000 + "}")
    elif case == "inf positions":
        write_gltf(path, positions=[[0, 0, 0], [np.inf, 0, 0], [0, 1, 0]])
    elif case == "overflowing node chain":
        write_gltf(path, nodes=[{"children": [1], "scale": [1e200] * 3}, {"mesh": 0, "scale": [1e200] * 3}])
    elif case == "zero camera matrix":
        write_gltf(path, nodes=[{"mesh": 0}, {"camera": 0, "matrix": [0] * 16}], cameras=[{"type": "perspective", "perspective": {"yfov": 1}}])
    else:  # 468 bytes asking for 3e8 zeros (9.5 GB): refused before anything is allocated
        doc = {
            "asset": {"version": "2.0"},
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
            "accessors": [{"componentType": 5126, "count": 300_000_000, "type": "VEC3"}],
        }
        path.write_text(json.dumps(doc))
        tracemalloc.start()
        try:
            refused(capsys, tmp_path, path, fragment)
            assert tracemalloc.get_traced_memory()[1] < 50e6
        finally:
            tracemalloc.stop()
        return
    refused(capsys, tmp_path, path, fragment)


def test_a_deeply_nested_gltf_named_by_a_toml_scene_is_refused_in_one_line(tmp_path, capsys):
    path, _ = write_gltf(tmp_path / "deep.gltf")
    path.write_text(path.read_text()[:-1] + ', "extras": ' + '{"a": ' * 5000 + "0" + "}" * 5000 + "}")
    (tmp_path / "s.toml").write_text('[[objects]]\ntype = "mesh"\nfile = "deep.gltf"\nnode = 0\n')
    refused(capsys, tmp_path, tmp_path / "s.toml", "nested too deeply")


# ------------------------------------------------------------ odd but valid files load
def test_a_huge_quaternion_is_a_rotation_like_any_other(tmp_path):
    """(0, 1e300, 0, 1e300) is 90 degrees about y once normalised: its norm must not overflow."""
    path, _ = write_gltf(tmp_path / "q.gltf", nodes=[{"mesh": 0, "rotation": [0, 1e300, 0, 1e300]}])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        (mesh,) = Scene.load(path).objects
    np.testing.assert_allclose(mesh.vertices, [[0, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)


def test_a_node_scaled_to_zero_draws_nothing_and_its_neighbours_load(tmp_path):
    """Files hide nodes by scaling them to zero; with normals the old reader refused them (LinAlgError)."""
    nodes = [{"mesh": 0, "scale": [0, 0, 0]}, {"mesh": 0, "translation": [0, 0, -5]}]
    path = gltf_file(tmp_path, nodes, normals=[0, 0, 1])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        (mesh,) = Scene.load(path).objects
    assert mesh.source.endswith("node 1")
    np.testing.assert_allclose(mesh.vertices[:, 2], -5)
    # named on its own by a scene file it is refused, naming the node
    (tmp_path / "s.toml").write_text('[[objects]]\ntype = "mesh"\nfile = "scene.gltf"\nnode = 0\n')
    with pytest.raises(UsageError, match=r"nodes\[0\].*zero area"):
        Scene.load(tmp_path / "s.toml")


def test_a_node_flattened_along_its_normal_keeps_its_normals(tmp_path):
    """Scale (2, 1, 0) leaves a flat quad flat: its normals stay +z (the inverse transpose is the limit
    of the cofactor matrix, which exists where the inverse does not)."""
    path = gltf_file(tmp_path, [{"mesh": 0, "scale": [2, 1, 0]}], normals=[0, 0, 1])
    (mesh,) = Scene.load(path).objects
    assert mesh.smooth
    np.testing.assert_allclose(mesh.vertex_normals, np.broadcast_to([0, 0, 1], (4, 3)), atol=1e-12)
    np.testing.assert_allclose(np.ptp(mesh.vertices, axis=0), [4, 2, 0])


def test_many_instances_of_a_huge_accessor_are_refused_before_they_are_read(tmp_path, capsys, monkeypatch):
    """Every node reads its mesh's POSITION again: 100 nodes naming one accessor of 100 vertices read
    10,000.  With the budget lowered to 1,000 the file is refused at the tenth node, before it reads more
    (at the real budget, 3e8, a 1 KB file of nodes naming a 3e7-vertex accessor would otherwise take hours)."""
    monkeypatch.setattr(gltf, "MAX_VERTICES_READ", 1000)
    doc = {
        "asset": {"version": "2.0"},
        "nodes": [{"mesh": 0, "translation": [i, 0, 0]} for i in range(100)],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"componentType": 5126, "count": 102, "type": "VEC3"}],  # zeros: no bufferView
    }
    path = tmp_path / "instances.gltf"
    path.write_text(json.dumps(doc))
    reads = []
    original = gltf.primitive_triangles
    monkeypatch.setattr(gltf, "primitive_triangles", lambda *args: reads.append(args[1]) or original(*args))
    err = refused(capsys, tmp_path, path, "nodes[9]: the nodes up to this one read more than 1000 vertices")
    assert len(reads) == 9, err
