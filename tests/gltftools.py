"""glTF 2.0 files written by hand for tests (scene/): a quad as mesh 0 in a data-URI buffer, with the nodes,
lights, cameras and materials a test gives, and glTF rotations as quaternions."""

import base64
import json
import math

import numpy as np


def quaternion(axis, degrees):
    """glTF rotation (x, y, z, w) about `axis`."""
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    half = math.radians(degrees) / 2
    return [*(axis * math.sin(half)), math.cos(half)]


QUAD = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]], np.float32)  # 2 x 2, facing +z


def gltf_file(tmp_path, nodes, *, mode=4, indices=(0, 1, 2, 0, 2, 3), lights=(), cameras=(), materials=None, normals=None, name="scene.gltf", **top):
    """A .gltf with the quad as mesh 0 (data-URI buffer), the given nodes, lights and cameras."""
    idx = np.asarray(indices, np.uint16)
    blob = QUAD.tobytes() + idx.tobytes()
    attributes = {"POSITION": 0}
    if normals is not None:
        attributes["NORMAL"] = 2
        normals = np.broadcast_to(np.asarray(normals, np.float32), QUAD.shape)
        blob += normals.tobytes()
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [i for i in range(len(nodes)) if not any(i in n.get("children", []) for n in nodes)]}],
        "nodes": nodes,
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 1, "mode": mode, **({"material": 0} if materials else {})}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5123, "count": len(idx), "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": QUAD.nbytes},
            {"buffer": 0, "byteOffset": QUAD.nbytes, "byteLength": idx.nbytes},
        ],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    }
    if normals is not None:
        doc["accessors"].append({"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC3"})
        doc["bufferViews"].append({"buffer": 0, "byteOffset": QUAD.nbytes + idx.nbytes, "byteLength": normals.nbytes})
    if materials:
        doc["materials"] = materials
    if cameras:
        doc["cameras"] = list(cameras)
    if lights:
        doc["extensionsUsed"] = ["KHR_lights_punctual"]
        doc["extensions"] = {"KHR_lights_punctual": {"lights": list(lights)}}
    doc.update(top)
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path
