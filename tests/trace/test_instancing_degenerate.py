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


@pytest.mark.parametrize("scale", [[-1, 1, 1], [1, -2, 1], [-1, -1, -1], [1, 1, 1]])
def test_a_mirrored_copy_keeps_its_front_in_the_flat_scene(tmp_path, scale):
    """glTF: "the determinant of the node's global transform defines the winding order".  The flat scene's world
    winding normal of every face is the object-space one carried by the inverse transpose (as the instanced
    kernels carry it), mirrored or not; the object-space faces instancing stores are the file's own."""
    nodes = [{"mesh": 0}, {"mesh": 0, "translation": [3.0, 0, 0], "scale": scale}]
    scene = Scene.from_file(gltf_file(tmp_path, nodes))
    local = np.asarray(scene.objects[0].vertices)[scene.objects[0].faces]
    obj_n = np.cross(local[:, 1] - local[:, 0], local[:, 2] - local[:, 0])  # node 0 is the identity
    mesh = scene.objects[1]
    m = np.asarray(mesh.to_world, np.float64)[:3, :3]
    world = np.asarray(mesh.vertices)[mesh.faces]
    world_n = np.cross(world[:, 1] - world[:, 0], world[:, 2] - world[:, 0])
    assert ((obj_n @ np.linalg.inv(m)) * world_n).sum(-1).min() > 0  # M^-T n, as rows: n @ M^-1
    inst = find_instances(scene)
    np.testing.assert_array_equal(inst.shapes[0].faces, scene.objects[0].faces)


@pytest.mark.parametrize("tiny", [1e-30, 1e-200])
def test_a_copy_scaled_by_a_tiny_factor_is_kept_flat_or_dropped_in_both_layouts(tmp_path, tiny):
    """A node scaled by 1e-30 at the origin still has area in float64 (1e-60): it is kept, and stays flat (its
    float32 inverse would overflow); at 1e-200 its area (1e-400) underflows, so it draws nothing, in the flat and
    the instanced scene alike (gltf.has_area: files hide nodes by scaling them to zero).  No copy is in one only."""
    nodes = [{"mesh": 0, "scale": [tiny] * 3}] + [{"mesh": 0, "translation": [3.0 * i, 0, 0]} for i in (1, 2)]
    scene = Scene.from_file(gltf_file(tmp_path, nodes))
    inst = find_instances(scene)
    placed = {int(o) for o in inst.records["object"]}
    assert placed | set(inst.flat_objects) == set(range(len(scene.objects))) and not placed & set(inst.flat_objects)
    for o in scene.objects:
        tri = np.asarray(o.vertices)[o.faces]
        assert np.abs(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])).max() > 0  # every object kept has area
    assert len(scene.objects) == (3 if tiny * tiny > 0 else 2)
    if len(scene.objects) == 3:
        assert 0 in inst.flat_objects and placed == {1, 2}
