"""A glTF TANGENT attribute goes to world space by the node's matrix M (tangents are vectors along the surface:
M t, renormalised), not by the inverse transpose normals take; its w (the bitangent's sign) is kept.  Under a
node scaled (3, 1, 1) the two differ by 53 degrees for t along (1, 1, 0).  Reference: numpy here."""

import base64
import json

import numpy as np
import pytest

from clrender.scene.scene import Scene

QUAD = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)
UV = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], np.float32)
NORMAL = np.tile(np.float32([0, 0, 1]), (4, 1))
IDX = np.array([0, 1, 2, 0, 2, 3], np.uint16)


def tangent_gltf(tmp_path, tangent, node):
    tangents = np.tile(np.asarray(tangent, np.float32), (4, 1))
    arrays = [QUAD, NORMAL, UV, tangents, IDX]
    blob, views, offset = b"", [], 0
    for a in arrays:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": a.nbytes})
        blob += a.tobytes()
        offset += a.nbytes
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC4"},
        {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"},
    ]
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, **node}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "TANGENT": 3}, "indices": 4}]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    }
    path = tmp_path / "tangent.gltf"
    path.write_text(json.dumps(doc))
    return path


def world_tangents(scene):
    (mesh,) = [o for o in scene.objects if getattr(o, "tangents", None) is not None]
    return np.asarray(mesh.tangents, np.float64)


@pytest.mark.parametrize("w", [1.0, -1.0])
def test_tangent_turns_by_the_node_matrix_not_its_inverse_transpose(tmp_path, w):
    t = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    scene = Scene.from_file(tangent_gltf(tmp_path, [*t, w], {"scale": [3, 1, 1]}))
    got = world_tangents(scene)
    want = np.array([3.0, 1.0, 0.0]) / np.sqrt(10)  # M t, renormalised
    wrong = np.array([1 / 3, 1.0, 0.0]) / np.linalg.norm([1 / 3, 1.0, 0.0])  # M^-T t: 53.1 degrees away
    assert np.degrees(np.arccos(want @ wrong)) > 53
    np.testing.assert_allclose(got[:, :3], np.tile(want, (len(got), 1)), atol=1e-6)
    np.testing.assert_array_equal(got[:, 3], w)


def test_tangent_under_a_rotated_node(tmp_path):
    """A node turned 90 degrees about z and scaled (3, 1, 1): M = R S, t = x goes to R (3, 0, 0) -> +y."""
    q = [0, 0, np.sin(np.pi / 4), np.cos(np.pi / 4)]  # (x, y, z, w)
    scene = Scene.from_file(tangent_gltf(tmp_path, [1, 0, 0, 1], {"rotation": q, "scale": [3, 1, 1]}))
    np.testing.assert_allclose(world_tangents(scene)[:, :3], np.tile([0.0, 1.0, 0.0], (4, 1)), atol=1e-6)
