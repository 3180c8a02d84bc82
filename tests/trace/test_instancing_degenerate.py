"""Copies whose placing matrix is (nearly) singular stay flat instead of becoming instances (issue 38, defect 7):
a glTF node scaled by 0 along z gave "internal error: LinAlgError: Singular matrix", and copies scaled by 1e-30
or 1e-200 were lost under instancing (their float32 inverse overflows).  The reference is numpy's singular values
of the node matrices written here (instancing.INSTANCE_SCALE_MIN)."""

import numpy as np
import pytest

from clrender.scene.scene import Scene
from clrender.trace.instancing import find_instances, instanceable

from tests.gltftools import gltf_file


@pytest.mark.parametrize("bad_scale", [[1, 1, 0], [1, 1e-9, 1], [1e-7, 1, 1]])
def test_degenerate_copies_stay_flat(tmp_path, bad_scale):
    nodes = [{"mesh": 0, "translation": [2.0 * i, 0, 0]} for i in range(3)]
    nodes[1]["scale"] = bad_scale
    scene = Scene.from_file(gltf_file(tmp_path, nodes))
    inst = find_instances(scene)  # raised LinAlgError for the zero scale
    placed = {int(o) for o in inst.records["object"]}
    meshes = [i for i, o in enumerate(scene.objects) if getattr(o, "shape_key", None) is not None]
    assert len(meshes) == 3
    bad = [i for i in meshes if not np.linalg.svd(np.asarray(scene.objects[i].to_world)[:3, :3], compute_uv=False).min() >= 1e-6]
    assert len(bad) == 1 and bad[0] not in placed and bad[0] in inst.flat_objects
    assert placed == set(meshes) - set(bad)  # the two good copies are still instances


def test_instanceable_rule():
    assert instanceable(np.diag([2.0, 0.5, 1.0, 1.0]))
    assert not instanceable(np.diag([1.0, 1.0, 0.0, 1.0]))
    assert not instanceable(np.diag([1e7, 1.0, 1.0, 1.0]))
    assert not instanceable(np.full((4, 4), np.nan))
