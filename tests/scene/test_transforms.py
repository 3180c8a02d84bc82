"""Object transforms with non-uniform scales and rotations: a TOML mesh's translate/rotate/scale and
glTF's node TRS, for the vertices and for the smooth-shading normals.

The references are written here in float64 from the numbers put into the scene: rotations by
Rodrigues' formula about each axis, the order the formats define (TOML: scale, then rotate about x,
then y, then z, then translate; glTF: each node's T * R * S, parent * child), and the normal of the
transformed surface as the cross product of its transformed edges, which is what the inverse
transpose must give.  A uniform scale or a rotation alone cannot tell S·R from R·S, nor M from M⁻ᵀ;
every case here has both, and a tilted surface whose normal is no axis of the stretch.
"""

import base64
import json
import math

import numpy as np

from clrender.scene.gltf import node_mesh
from clrender.scene.scene import Scene

# A tilted planar quad (two triangles), not through the origin: its normal (1, 2, 2)/3 is no axis.
QUAD = np.array([[-0.5, 0.0, 0.25], [1.5, -1.0, 0.25], [2.5, 1.0, -2.25], [0.5, 2.0, -2.25]])  # sides (2, -1, 0), (1, 2, -2.5)
QUAD_FACES = np.array([[0, 1, 2], [0, 2, 3]])
QUAD_NORMAL = np.array([1.0, 2.0, 2.0]) / 3.0


def rotation(axis, degrees):
    """Rodrigues: cos θ I + sin θ [a]x + (1 - cos θ) a aᵀ, a right-handed turn about the unit axis a."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    th = math.radians(degrees)
    cross = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return math.cos(th) * np.eye(3) + math.sin(th) * cross + (1 - math.cos(th)) * np.outer(a, a)


def affine(linear, shift):
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = linear, shift
    return m


def apply(m, points):
    return points @ m[:3, :3].T + m[:3, 3]


def surface_normal(vertices, faces):
    """Unit normal of each face from its edges (right-hand winding)."""
    p = vertices[faces]
    n = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def test_the_quad_is_planar_with_the_stated_normal():
    np.testing.assert_allclose(surface_normal(QUAD, QUAD_FACES), [QUAD_NORMAL, QUAD_NORMAL], atol=1e-15)


# ------------------------------------------------------------------ TOML meshes: T · Rz Ry Rx · S
def toml_quad(tmp_path, **transform):
    lines = ["o quad"] + [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in QUAD] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in QUAD_FACES]
    (tmp_path / "quad.obj").write_text("\n".join(lines) + "\n")
    obj = {"type": "mesh", "file": "quad.obj", "smooth": True, **transform}
    (mesh,) = Scene.from_dict({"objects": [obj]}, base_dir=tmp_path).objects
    return mesh


SCALE, ROTATE, TRANSLATE = (3.0, 0.5, 1.5), (30.0, -50.0, 70.0), (0.25, -1.0, -6.0)


def toml_rotation():
    """About x first, then y, then z."""
    return rotation([0, 0, 1], ROTATE[2]) @ rotation([0, 1, 0], ROTATE[1]) @ rotation([1, 0, 0], ROTATE[0])


def toml_reference():
    """Scale first, then rotate, then translate."""
    return affine(toml_rotation() @ np.diag(SCALE), TRANSLATE)


def test_a_mesh_is_scaled_before_it_is_rotated(tmp_path):
    mesh = toml_quad(tmp_path, scale=list(SCALE), rotate=list(ROTATE), translate=list(TRANSLATE))
    np.testing.assert_allclose(mesh.vertices, apply(toml_reference(), QUAD), rtol=0, atol=1e-12)
    # scaled after the rotation the same numbers put the corners elsewhere (by more than 1 unit)
    rotated_then_scaled = apply(affine(np.diag(SCALE) @ toml_rotation(), TRANSLATE), QUAD)
    assert np.abs(rotated_then_scaled - mesh.vertices).max() > 1.0


def test_smooth_normals_of_a_stretched_turned_mesh_are_the_normals_of_its_surface(tmp_path):
    """A planar patch's vertex normals are its face normal; after a non-uniform scale they must still be
    the normal of the transformed surface (M⁻ᵀ n), which M n is not."""
    mesh = toml_quad(tmp_path, scale=list(SCALE), rotate=list(ROTATE), translate=list(TRANSLATE))
    assert mesh.smooth
    expected = surface_normal(apply(toml_reference(), QUAD), QUAD_FACES)[0]
    np.testing.assert_allclose(mesh.vertex_normals, np.broadcast_to(expected, (4, 3)), rtol=0, atol=1e-12)
    wrong = toml_reference()[:3, :3] @ QUAD_NORMAL
    assert np.degrees(np.arccos(np.dot(wrong / np.linalg.norm(wrong), expected))) > 10  # the case tells them apart


# ------------------------------------------------------------------ glTF nodes: parent · (T R S)
def quaternion(axis, degrees):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    half = math.radians(degrees) / 2
    return [*(a * math.sin(half)).tolist(), math.cos(half)]


PARENT = {"translation": [1.0, -2.0, -8.0], "rotation": ([0.2, 1.0, -0.3], 40.0), "scale": [0.5, 2.0, 1.25]}
CHILD = {"translation": [0.5, 0.25, -1.0], "rotation": ([1.0, -0.4, 0.6], -65.0), "scale": [2.5, 0.75, 1.5]}


def gltf_quad(tmp_path):
    """Node 0 (PARENT) holds node 1 (CHILD), which draws the quad with its normal in a NORMAL attribute."""
    positions = QUAD.astype(np.float32)
    indices = QUAD_FACES.astype(np.uint16).ravel()
    normals = np.broadcast_to(QUAD_NORMAL, QUAD.shape).astype(np.float32)
    blob = positions.tobytes() + normals.tobytes() + indices.tobytes()

    def node(spec, **more):
        axis, degrees = spec["rotation"]
        return {"translation": spec["translation"], "rotation": quaternion(axis, degrees), "scale": spec["scale"], **more}

    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [node(PARENT, children=[1]), node(CHILD, mesh=0)],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 12},
        ],
        "buffers": [{"byteLength": len(blob), "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    }
    path = tmp_path / "quad.gltf"
    path.write_text(json.dumps(doc))
    return path


def gltf_world():
    """glTF 2.0 §5.25: a node's matrix is T * R * S, and a child's world matrix is parent * child."""

    def trs(spec):
        return affine(rotation(*spec["rotation"]) @ np.diag(spec["scale"]), spec["translation"])

    return trs(PARENT) @ trs(CHILD)


def test_gltf_nodes_scale_then_rotate_then_translate_under_their_parent(tmp_path):
    path = gltf_quad(tmp_path)
    expected = apply(gltf_world(), QUAD.astype(np.float32).astype(np.float64))
    mesh = node_mesh(path, 1)
    np.testing.assert_allclose(mesh.vertices, expected, rtol=0, atol=1e-9)
    (placed,) = Scene.load(path).objects
    np.testing.assert_allclose(placed.vertices, expected, rtol=0, atol=1e-9)


def test_gltf_normals_under_stretched_turned_nodes_are_the_normals_of_the_surface(tmp_path):
    path = gltf_quad(tmp_path)
    expected = surface_normal(apply(gltf_world(), QUAD), QUAD_FACES)[0]
    (placed,) = Scene.load(path).objects
    assert placed.smooth
    np.testing.assert_allclose(placed.vertex_normals, np.broadcast_to(expected, (4, 3)), rtol=0, atol=1e-6)  # float32 normals in the file
