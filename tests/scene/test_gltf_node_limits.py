"""glTF files of many nodes (issue 38, defect 5): the 100,000-object limit is checked from the node list before
any node's matrix or mesh is read, and reading nodes is linear work.  Work is counted (calls), not timed."""

import cProfile
import json
import pstats

import pytest

from clrender.errors import UsageError
from clrender.scene import gltf
from clrender.scene.checks import MAX_OBJECTS
from clrender.scene.scene import Scene

from tests.gltftools import gltf_file


def many_nodes(tmp_path, n: int, name="many.gltf"):
    """The test quad as mesh 0 under `n` nodes side by side, all roots of a file without `scenes`."""
    path = gltf_file(tmp_path, [{"mesh": 0}], name=name)
    doc = json.loads(path.read_text())
    doc["nodes"] = [{"mesh": 0, "translation": [3 * (i % 1000), 3 * (i // 1000), 0]} for i in range(n)]
    del doc["scenes"], doc["scene"]
    path.write_text(json.dumps(doc))
    return path


def test_one_node_past_the_object_limit_is_refused_before_any_node_is_read(tmp_path, monkeypatch):
    """MAX_OBJECTS + 1 nodes of one mesh: refused naming the limit, with no node's matrix computed and no
    accessor read (the 1,000,000-node file was still reading nodes after 120 s)."""
    path = many_nodes(tmp_path, MAX_OBJECTS + 1)
    work = {"local_matrix": 0, "accessor": 0}
    for name in work:
        real = getattr(gltf, name)

        def counted(*args, _real=real, _name=name, **kwargs):
            work[_name] += 1
            return _real(*args, **kwargs)

        monkeypatch.setattr(gltf, name, counted)
    with pytest.raises(UsageError, match=rf"nodes\[{MAX_OBJECTS}\]: .*more than {MAX_OBJECTS} mesh objects.*allowed: at most {MAX_OBJECTS}"):
        Scene.from_file(path)
    assert work == {"local_matrix": 0, "accessor": 0}


def test_the_object_limit_counts_triangle_primitives_of_drawn_nodes(tmp_path, monkeypatch):
    """The check refuses only past the limit: 1,000 nodes pass a limit of 1,000 and are refused at node 999 under 999."""
    path = many_nodes(tmp_path, 1000)
    doc = gltf.read_document(path)
    monkeypatch.setattr(gltf, "MAX_OBJECTS", 1000)
    gltf._check_object_count(doc, gltf.node_order(doc))
    monkeypatch.setattr(gltf, "MAX_OBJECTS", 999)
    with pytest.raises(UsageError, match=r"nodes\[999\]: .*more than 999 mesh objects"):
        gltf._check_object_count(doc, gltf.node_order(doc))


def calls_to_load(path) -> int:
    profile = cProfile.Profile()
    profile.enable()
    Scene.from_file(path)
    profile.disable()
    return pstats.Stats(profile).total_calls


def test_loading_nodes_is_linear_work(tmp_path):
    """Function calls to load 100, 200 and 400 nodes: each doubling adds twice the calls of the one before
    (within 2 %: the per-file constant differs by rounding only), so loading 100k nodes is 1,000 x 100 nodes' work."""
    gltf.read_document(many_nodes(tmp_path, 1, "warm.gltf"))  # imports and caches outside the count
    calls = [calls_to_load(many_nodes(tmp_path, n, f"n{n}.gltf")) for n in (100, 200, 400)]
    first, second = calls[1] - calls[0], calls[2] - calls[1]
    assert second == pytest.approx(2 * first, rel=0.02), calls


def test_each_primitive_is_read_once_however_many_nodes_place_it(tmp_path, monkeypatch):
    """200 nodes of one mesh read its accessors (POSITION and indices) once each, not three times a node
    (scene_dict, node_shape and node_mesh each read every node's primitive: 1 ms a node, 100 s for 100k)."""
    path = many_nodes(tmp_path, 200)
    reads = []
    real = gltf.accessor
    monkeypatch.setattr(gltf, "accessor", lambda doc, index, *a, **k: reads.append(index) or real(doc, index, *a, **k))
    scene = Scene.from_file(path)
    assert len(scene.objects) == 200
    assert sorted(reads) == [0, 1]
