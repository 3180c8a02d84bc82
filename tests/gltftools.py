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


def png_bytes(texels) -> bytes:
    """A PNG of uint8 texels (H, W) or (H, W, C), C = 1 to 4, encoded in memory."""
    import io

    from PIL import Image

    texels = np.asarray(texels, np.uint8)
    buffer = io.BytesIO()
    Image.fromarray(texels if texels.ndim == 2 or texels.shape[2] > 1 else texels[..., 0]).save(buffer, format="PNG")
    return buffer.getvalue()


# a camera 2 above the quad looking down -z that sees x, y in [-0.9, 0.9] of it, and a directional light along -z
# whose glTF intensity pi gives an irradiance of pi: a Lambert surface then shows its base colour exactly
HALF_VIEW = 0.9
CAMERA_NODE = {"camera": 0, "translation": [0, 0, 2]}
CAMERA = {"type": "perspective", "perspective": {"yfov": 2 * math.atan(HALF_VIEW / 2), "aspectRatio": 1.0}}
LIGHT_NODE = {"extensions": {"KHR_lights_punctual": {"light": 0}}}
LIGHT = {"type": "directional", "intensity": math.pi}


def textured_quad(tmp_path, material, images, *, uv_scale=1.0, colours=None, samplers=None, textures=None, name="textured.gltf"):
    """The quad of gltf_file with TEXCOORD_0 laying the image upright over it (UV (0, 0) at its top-left corner
    (-1, 1), uv_scale times the image across it), optional COLOR_0 (4 x 3), the material, images (PNG bytes as
    data URIs, or dicts taken as they are), textures (default: texture i shows image i with sampler i if given)."""
    uv = np.stack([(QUAD[:, 0] + 1) / 2, (1 - QUAD[:, 1]) / 2], 1).astype(np.float32) * uv_scale
    path = gltf_file(tmp_path, [{"mesh": 0}, CAMERA_NODE, LIGHT_NODE], cameras=[CAMERA], lights=[LIGHT], materials=[material], name=name)
    doc = json.loads(path.read_text())
    blob = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    attributes = doc["meshes"][0]["primitives"][0]["attributes"]
    for key, values, kind in (("TEXCOORD_0", uv, "VEC2"), ("COLOR_0", colours, "VEC3")):
        if values is None:
            continue
        values = np.asarray(values, np.float32)
        doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob), "byteLength": values.nbytes})
        doc["accessors"].append({"bufferView": len(doc["bufferViews"]) - 1, "componentType": 5126, "count": 4, "type": kind})
        attributes[key] = len(doc["accessors"]) - 1
        blob += values.tobytes()
    doc["buffers"] = [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}]
    doc["images"] = [i if isinstance(i, dict) else {"uri": "data:image/png;base64," + base64.b64encode(i).decode()} for i in images]
    doc["samplers"] = samplers or [{"magFilter": 9728, "minFilter": 9728}]
    doc["textures"] = textures or [{"source": i, "sampler": min(i, len(doc["samplers"]) - 1)} for i in range(len(images))]
    doc["extensionsUsed"] = sorted({*doc.get("extensionsUsed", []), "KHR_texture_transform"})
    path.write_text(json.dumps(doc))
    return path


def quad_hits(n: int, offset=(0.5, 0.5)) -> np.ndarray:
    """(n, n, 2) x, y where the ray through each pixel's point `offset` (its centre by default) of an n x n render
    of textured_quad meets the quad (z = 0)."""
    c = (np.arange(n) + offset[0]) / n * 2 - 1
    r = (np.arange(n) + offset[1]) / n * 2 - 1
    return np.stack(np.meshgrid(c * HALF_VIEW, -r * HALF_VIEW, indexing="xy"), -1)
