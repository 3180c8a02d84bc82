"""glTF 2.0 scenes: meshes with their node transforms, cameras, punctual lights and base colours.

`scene_dict(path)` reads a .gltf or .glb file into the dict `Scene.from_dict`
takes (plain data: this module imports nothing from scene.py, which imports it), so `clrender render model.glb` renders the file with its own cameras,
lights and materials; `node_mesh(path, node, primitive)` gives the triangles
one mesh object of that dict refers to (`{"type": "mesh", "file": "model.glb",
"node": 2, "primitive": 0}`), in world space.  The reader is written from the
glTF 2.0 specification (JSON, GLB chunks, accessors, the node hierarchy), so
nothing in the file is dropped without being listed here:

- meshes: triangle primitives (modes 4, 5, 6; points and lines are skipped),
  positions and normals (a primitive with normals is shaded smooth), each
  node's world transform (its matrix, or translation x rotation x scale,
  times its parents');
- cameras: perspective ones (yfov, aspectRatio for the default image size) and
  orthographic ones (2 ymag the image's height, xmag / ymag the default image's
  aspect), looking down the node's -z with +y up, all pinholes (glTF has no lens),
  named by the camera's or else its node's name (for `render --list`); a file
  without a camera gets framing.py's camera, the one a bare mesh file gets (its
  whole bounding sphere in view);
- lights (KHR_lights_punctual): point and directional; a spot light is
  rendered as a point light (its cone is ignored), `range` is ignored.
  glTF intensities are photometric (candela, lux) for a Lambertian BRDF
  base_colour / pi.  Point lights fall off with the inverse square, which
  selects clrender's physical model (BRDF kd / pi); directional lights use the
  unnormalised model, whose Lambert term has no 1/pi, so their intensity is divided
  by pi: either way a surface shows (base_colour / pi) * E, as the glTF
  specification defines.
  A file without lights gets the lights a bare mesh file gets (framing.py: a key
  light over the first camera's left shoulder and a uniform fill, ambient for
  Whitted and a constant environment for the path tracer);
- materials: the metallic-roughness model as the file gives it: baseColorFactor
  (linear RGB, as glTF stores it), metallicFactor, roughnessFactor,
  emissiveFactor times KHR_materials_emissive_strength, KHR_materials_ior and
  KHR_materials_transmission (the path tracer's lobes; the Whitted integrator
  draws the base colour as its diffuse colour); baseColorTexture,
  metallicRoughnessTexture, emissiveTexture, occlusionTexture and normalTexture (with TANGENT, or tangents
  generated per vertex from the UVs) with their texCoord and
  KHR_texture_transform, as scene `textures` entries that name the file's
  image (`image_bytes`: a uri beside the file, a data URI or a GLB
  bufferView); COLOR_0 vertex colours and TEXCOORD_0/1 per vertex; alphaMode
  MASK (alphaCutoff) and BLEND (path: stochastic, Whitted: blended); doubleSided
  (false, the default: camera rays cull back faces; both sides are shaded).  Primitives without a material get
  clrender's default grey.

Anything malformed is a UsageError naming the file and what was wrong.  Counts
(accessor elements, triangles, vertices read) are checked against the limits
before anything is read or allocated, every buffer file is found through
confine.scene_file (a confined scene reads nothing outside its folder) and is a
regular file whose size fits memory before it is read, the mesh objects the drawn
nodes make are counted from the node list (node_order) against checks.MAX_OBJECTS
before any node's matrix or mesh is read, node transforms are computed once
per file (doc.worlds) and each primitive's accessors are read once (doc.primitives),
so loading is linear.
"""

from __future__ import annotations

import base64
import functools
import json
import math
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UsageError
from ..layout import TEXTURE_SLOT_TABLE
from . import framing
from .checks import COORD_LIMIT, MAX_NAME, MAX_OBJECTS, MAX_SIDE, MAX_TRIANGLES, MIN_LENGTH, UV_LIMIT, escape, shorten, show
from .confine import file_size, regular_file, scene_file

GLB_MAGIC = b"glTF"
CHUNK_JSON, CHUNK_BIN = 0x4E4F534A, 0x004E4942
COMPONENT_TYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
NORMALIZED_DIVISOR = {np.int8: 127.0, np.uint8: 255.0, np.int16: 32767.0, np.uint16: 65535.0}
TYPE_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN = 4, 5, 6
# required extensions whose absence would not change what clrender draws
UNDERSTOOD_EXTENSIONS = {
    "KHR_lights_punctual",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_materials_emissive_strength",
    "KHR_materials_unlit",
}
IMAGE_WIDTH = 640  # default image width; the height follows the first camera's aspect ratio
# Elements of one accessor, checked before any is read or allocated (a 468-byte file can ask for 3e8
# zeros): the triangle limit's three vertices (or indices) a triangle.
MAX_ACCESSOR_COUNT = 3 * MAX_TRIANGLES
# Vertices a whole file's nodes read together (a node reads its mesh's POSITION again for each instance):
# generous for instancing and shared accessors, and it keeps a small file of many nodes that each name one
# huge accessor from taking hours.
MAX_VERTICES_READ = 10 * MAX_ACCESSOR_COUNT
INDEX_TYPES = (5121, 5123, 5125)  # unsigned byte, short, int: the only component types glTF allows for indices
SUFFIXES = (".gltf", ".glb")


def is_gltf(path) -> bool:
    return Path(str(path)).suffix.lower() in SUFFIXES


@dataclass
class Document:
    path: Path
    json: dict
    buffers: list  # bytes of each buffer
    root: Path | None = None  # a confined scene's folder: every file the document reads must lie inside it
    parents: dict | None = None  # node -> its parent, built once (see node_world_matrix)
    worlds: dict = field(default_factory=dict)  # node -> 4x4 world transform, each computed once
    # (mesh, primitive) -> what its accessors hold, read once however many nodes place it (_read_primitive)
    primitives: dict = field(default_factory=dict)
    drawn: set = field(default_factory=set)  # (node, primitive) that scene_dict found to have area (has_area)
    # (node, primitive) -> the world triangles scene_dict(keep=True) read, until node_mesh takes them: a node is read once
    triangles: dict = field(default_factory=dict)

    def fail(self, message: str):
        raise UsageError(f"{self.path}: {message}")

    def item(self, kind: str, index):
        """json[kind][index], checked."""
        items = self.json.get(kind)
        if isinstance(index, bool) or not isinstance(index, int) or not isinstance(items, list) or not 0 <= index < len(items):
            self.fail(f"{kind}[{index!r}] does not exist")
        if not isinstance(items[index], dict):
            self.fail(f"{kind}[{index}] is not an object")
        return items[index]


# ------------------------------------------------------------------ the file
def _malformed_is_usage_error(function):
    """A glTF whose JSON has the wrong shape somewhere we did not check by hand is still bad input."""

    @functools.wraps(function)
    def wrapper(path, *args, **kwargs):
        try:
            return function(path, *args, **kwargs)
        except UsageError:
            raise
        except (KeyError, IndexError, TypeError, ValueError, AttributeError, struct.error) as exc:
            raise UsageError(f"{path}: not a valid glTF 2.0 file ({type(exc).__name__}: {exc})") from None

    return wrapper


def read_document(path, root=None) -> Document:
    """The parsed JSON and buffers of a .gltf or .glb file (cached while the file is unchanged).
    With a `root` (a confined scene's folder) every buffer file must lie inside it (see confine.py)."""
    path = Path(path)
    if not path.is_file():
        raise UsageError(f"glTF file {str(path)!r} does not exist")
    stat = path.stat()
    key = (str(path), None if root is None else str(root), os.getcwd())  # resolving took a third of a node's loading
    if key not in _RESOLVED:
        if len(_RESOLVED) > 64:
            _RESOLVED.clear()
        _RESOLVED[key] = (path.resolve(), None if root is None else Path(root).resolve())
    return _read_document(_RESOLVED[key][0], stat.st_mtime_ns, stat.st_size, _RESOLVED[key][1])


_RESOLVED: dict = {}  # (path, root, working folder) -> the two resolved


@functools.lru_cache(maxsize=4)
def _read_document(path: Path, mtime_ns: int, size: int, root: Path | None) -> Document:
    data = path.read_bytes()
    binary = None
    if data[:4] == GLB_MAGIC:
        text, binary = _glb_chunks(path, data)
    else:
        text = data
    try:
        gltf = json.loads(text)
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise UsageError(f"{path}: not a glTF file (neither GLB nor JSON: {exc})") from None
    except RecursionError:  # json recurses once per nested array or object; no glTF needs more than a few
        raise UsageError(f"{path}: not a glTF file clrender reads (its JSON is nested too deeply)") from None
    if not isinstance(gltf, dict):
        raise UsageError(f"{path}: not a glTF file (the JSON is not an object)")
    version = str(gltf.get("asset", {}).get("version", "")) if isinstance(gltf.get("asset"), dict) else ""
    if not version.startswith("2."):
        raise UsageError(f"{path}: glTF version {version or 'missing'!s}; clrender reads glTF 2.0")
    unknown = sorted(set(gltf.get("extensionsRequired", [])) - UNDERSTOOD_EXTENSIONS)
    if unknown:
        raise UsageError(f"{path}: requires extension {unknown[0]}, which clrender does not read")
    doc = Document(path, gltf, [], root)
    doc.buffers = [_buffer(doc, i, b, binary) for i, b in enumerate(gltf.get("buffers", []))]
    return doc


def _glb_chunks(path: Path, data: bytes):
    """(JSON text, BIN chunk or None) of a GLB container."""
    if len(data) < 20:
        raise UsageError(f"{path}: truncated GLB header")
    _, version, length = struct.unpack_from("<4sII", data, 0)
    if version != 2:
        raise UsageError(f"{path}: GLB container version {version}; clrender reads version 2")
    if length > len(data):
        raise UsageError(f"{path}: GLB says {length} bytes, the file has {len(data)}")
    chunks, offset = [], 12
    while offset + 8 <= length:
        size, kind = struct.unpack_from("<II", data, offset)
        if offset + 8 + size > length:
            raise UsageError(f"{path}: GLB chunk at byte {offset} runs past the end of the file")
        chunks.append((kind, data[offset + 8 : offset + 8 + size]))
        offset += 8 + size
    if not chunks or chunks[0][0] != CHUNK_JSON:
        raise UsageError(f"{path}: GLB has no JSON chunk first")
    binary = next((c for k, c in chunks[1:] if k == CHUNK_BIN), None)
    return chunks[0][1], binary


def _buffer(doc: Document, index: int, buf, binary) -> bytes:
    if not isinstance(buf, dict):
        doc.fail(f"buffers[{index}] is not an object")
    uri = buf.get("uri")
    if uri is None:
        if binary is None:
            doc.fail(f"buffers[{index}] has no uri and the file has no GLB binary chunk")
        data = binary
    elif not isinstance(uri, str):
        doc.fail(f"buffers[{index}].uri must be a string")
    elif uri.startswith("data:"):
        try:
            data = base64.b64decode(uri.split(",", 1)[1], validate=True)
        except (IndexError, ValueError):
            doc.fail(f"buffers[{index}].uri is not a base64 data URI")
    else:
        from urllib.parse import unquote

        file = scene_file(doc.path.parent, unquote(uri), doc.root, f"{doc.path}: buffers[{index}].uri")
        from .. import memory

        size = file_size(file, f"{doc.path}: buffers[{index}].uri: file")  # missing, or a FIFO: refused
        memory.require(memory.BASE_BYTES + size, f"{doc.path}: buffers[{index}] ({size} bytes)")  # before it is read
        data = file.read_bytes()
    length = buf.get("byteLength")
    if isinstance(length, bool) or not isinstance(length, int) or not 0 <= length <= len(data):
        doc.fail(f"buffers[{index}].byteLength {length!r} does not fit its {len(data)} bytes")
    return data[:length]


def accessor(doc: Document, index: int, what: str, kind: str, component_types=None) -> np.ndarray:
    """Accessor `index` (the `what` of a primitive) as an array (count, width): float64 for floats and normalized
    integers, else int64.  Its type must be `kind` ("VEC3", "SCALAR") and its component type one of
    `component_types` (any when None); those and the count are checked before any element is read."""
    acc = doc.item("accessors", index)
    where = f"accessors[{index}]"
    dtype = COMPONENT_TYPES.get(acc.get("componentType"))
    width = TYPE_WIDTH.get(acc.get("type"))
    count = acc.get("count")
    if dtype is None or width is None or isinstance(count, bool) or not isinstance(count, int) or count < 0:
        doc.fail(f"{where}: componentType {show(acc.get('componentType'))}, type {show(acc.get('type'))} or count {show(count)} is not valid glTF")
    if acc.get("type") != kind or (component_types is not None and acc.get("componentType") not in component_types):
        allowed = f" with componentType {', '.join(map(str, component_types))}" if component_types is not None else ""
        doc.fail(f"{what} ({where}) is {acc.get('type')} of componentType {acc.get('componentType')}; allowed: {kind}{allowed}")
    if count > MAX_ACCESSOR_COUNT:  # before anything is allocated
        doc.fail(f"{where}: count {count}; allowed: at most {MAX_ACCESSOR_COUNT} (three per triangle of the {MAX_TRIANGLES}-triangle limit)")
    if "sparse" in acc:
        doc.fail(f"{where}: sparse accessors are not supported")
    if "bufferView" not in acc:
        values = np.zeros((count, width), dtype)
    else:
        view = doc.item("bufferViews", acc["bufferView"])
        buffer_index = view.get("buffer")
        if isinstance(buffer_index, bool) or not isinstance(buffer_index, int) or not 0 <= buffer_index < len(doc.buffers):
            doc.fail(f"bufferViews[{acc['bufferView']}].buffer {buffer_index!r} does not exist")
        data = doc.buffers[buffer_index]
        item = np.dtype(dtype).itemsize
        element = item * width
        stride = view.get("byteStride") or element
        start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
        view_end = view.get("byteOffset", 0) + view.get("byteLength", 0)
        needed = start + (stride * (count - 1) + element if count else 0)
        if not all(isinstance(v, int) for v in (stride, start, view_end)) or stride < element or needed > min(view_end, len(data)):
            doc.fail(f"{where}: {count} elements of {element} bytes (stride {stride}) from byte {start} do not fit bufferViews[{acc['bufferView']}]")
        values = np.ndarray((count, width), dtype, buffer=data, offset=start, strides=(stride, item)).copy()
    if dtype == np.float32:
        return values.astype(np.float64)
    if acc.get("normalized"):
        return np.maximum(values / NORMALIZED_DIVISOR[dtype], -1.0)
    return values.astype(np.int64)


# ------------------------------------------------------------ the node tree
def _quaternion_matrix(q) -> np.ndarray:
    q = q / max(np.abs(q).max(), 1e-300)  # first to at most 1, so that the norm of a huge one cannot overflow
    x, y, z, w = q / max(np.linalg.norm(q), 1e-300)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _numbers(doc, value, n, where):
    if not isinstance(value, list) or len(value) != n or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value):
        doc.fail(f"{where} must be a list of {n} numbers, got {show(value)}")
    out = np.array(value, np.float64)
    if not np.isfinite(out).all():
        doc.fail(f"{where} must be finite, got {show(value)}")
    return out


def local_matrix(doc: Document, index: int) -> np.ndarray:
    """A node's 4x4 transform relative to its parent: its matrix, or T * R * S."""
    node = doc.item("nodes", index)
    where = f"nodes[{index}]"
    if "matrix" in node:
        return _numbers(doc, node["matrix"], 16, f"{where}.matrix").reshape(4, 4).T  # glTF stores columns
    m = np.eye(4)
    scale = _numbers(doc, node.get("scale", [1, 1, 1]), 3, f"{where}.scale")
    rotation = _numbers(doc, node.get("rotation", [0, 0, 0, 1]), 4, f"{where}.rotation")
    m[:3, :3] = _quaternion_matrix(rotation) @ np.diag(scale)
    m[:3, 3] = _numbers(doc, node.get("translation", [0, 0, 0]), 3, f"{where}.translation")
    return m


def world_matrices(doc: Document, order: list | None = None) -> dict:
    """Node index -> 4x4 world transform, for every node of the default scene (or of all root nodes), in
    `node_order`'s order (given, or walked here)."""
    out = {}
    for index, parent in node_order(doc) if order is None else order:
        out[index] = doc.worlds[index] = _times(doc, index, np.eye(4) if parent is None else out[parent])
    return out


def node_order(doc: Document) -> list:
    """(node, its parent or None) for every node of the default scene (or of all root nodes), depth first,
    parents before children: the tree walked and checked without a matrix computed, so that limits on what
    the nodes draw are checked before the work they bound (scene_dict).  Linear in the number of nodes."""
    nodes = _nodes(doc)
    scenes = doc.json.get("scenes")
    if scenes:
        roots = doc.item("scenes", doc.json.get("scene", 0)).get("nodes", [])
    else:  # no scenes: every node that is nobody's child is a root
        parents = _parents(doc)
        roots = [i for i in range(len(nodes)) if i not in parents]
    if not isinstance(roots, list):
        doc.fail("scenes[].nodes must be a list of node indices")
    order, seen = [], set()
    stack = [(r, None) for r in reversed(roots)]
    while stack:
        index, parent = stack.pop()
        if index in seen:
            doc.fail(f"nodes[{index}] is reached twice (the node hierarchy must be a tree)")
        doc.item("nodes", index)
        seen.add(index)
        order.append((index, parent))
        stack.extend((c, index) for c in reversed(_children(doc, index)))
    return order


def _times(doc: Document, index: int, parent: np.ndarray) -> np.ndarray:
    """parent @ the node's local matrix, refused when it overflows (a chain of large scales)."""
    with np.errstate(over="ignore", invalid="ignore"):  # checked just below
        m = parent @ local_matrix(doc, index)
    if not np.isfinite(m).all():
        doc.fail(f"nodes[{index}]: its world transform (its own times its parents') overflows float64; allowed: finite products")
    return m


def _nodes(doc: Document) -> list:
    nodes = doc.json.get("nodes", [])
    if not isinstance(nodes, list):
        doc.fail("nodes must be a list")
    return nodes


def _children(doc: Document, index: int) -> list:
    children = doc.item("nodes", index).get("children", [])
    if not isinstance(children, list):
        doc.fail(f"nodes[{index}].children must be a list of node indices, got {show(children)}")
    return children


def _parents(doc: Document) -> dict:
    """Child -> parent over all nodes, built once per document (rebuilding it for every node made loading quadratic)."""
    if doc.parents is None:
        parents = {}
        for i, n in enumerate(_nodes(doc)):
            for c in _children(doc, i) if isinstance(n, dict) else []:
                if not isinstance(c, int) or isinstance(c, bool):
                    doc.fail(f"nodes[{i}].children holds {show(c)}; allowed: node indices")
                if c in parents:
                    doc.fail(f"nodes[{c}] is a child of both nodes[{parents[c]}] and nodes[{i}] (the node hierarchy must be a tree)")
                parents[c] = i
        doc.parents = parents
    return doc.parents


def node_world_matrix(doc: Document, index: int) -> np.ndarray:
    """World transform of any node, through its chain of parents.  Each node's is computed once per
    document (doc.worlds), so loading every node of a file is linear in its size, however deep its chains."""
    doc.item("nodes", index)
    parents = _parents(doc)  # first, so that a file whose nodes are not a tree is refused every time
    if index in doc.worlds:
        return doc.worlds[index]
    chain, on_chain, i = [], set(), index  # up to the first node already known, or the root
    while i is not None and i not in doc.worlds:
        if i in on_chain:
            doc.fail(f"nodes[{index}]: its parents form a cycle")
        on_chain.add(i)
        chain.append(i)
        i = parents.get(i)
    m = np.eye(4) if i is None else doc.worlds[i]
    for i in reversed(chain):
        m = doc.worlds[i] = _times(doc, i, m)
    return m


# ---------------------------------------------------------------- geometry
def _faces(doc: Document, prim: dict, n_vertices: int, where: str):
    """(F, 3) triangle indices of a primitive, or None when it draws points or lines."""
    mode = prim.get("mode", TRIANGLES)
    if mode not in (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN):
        return None
    if "indices" in prim:
        idx = accessor(doc, prim["indices"], f"{where}.indices", "SCALAR", INDEX_TYPES).ravel()
    else:
        idx = np.arange(n_vertices)
    if len(idx) and idx.max() >= n_vertices:
        doc.fail(f"{where}.indices refer to vertex {int(idx.max())}, but POSITION has {n_vertices}")
    triangles = len(idx) // 3 if mode == TRIANGLES else max(len(idx) - 2, 0)
    if triangles > MAX_TRIANGLES:  # before a strip or fan is unrolled
        doc.fail(f"{where}: {triangles} triangles; allowed: at most {MAX_TRIANGLES}")
    if mode == TRIANGLES:
        if len(idx) % 3:
            doc.fail(f"{where}: {len(idx)} indices is not a whole number of triangles")
        return idx.reshape(-1, 3)
    k = np.arange(max(len(idx) - 2, 0))
    if mode == TRIANGLE_STRIP:  # every other triangle is wound the other way
        even = k % 2 == 0
        return np.stack([idx[k], np.where(even, idx[k + 1], idx[k + 2]), np.where(even, idx[k + 2], idx[k + 1])], 1)
    return np.stack([np.full_like(k, idx[0]) if len(idx) else k, idx[k + 1], idx[k + 2]], 1)


def primitive_triangles(doc: Document, mesh_index: int, prim_index: int, matrix: np.ndarray):
    """(vertices, faces, normals or None) of one primitive in world space, or None for points and lines.  The
    accessors are read once per primitive (_read_primitive); each node only multiplies them by its matrix."""
    read = _read_primitive(doc, mesh_index, prim_index)
    if read is None:
        return None
    positions, faces, n = read
    where = f"meshes[{mesh_index}].primitives[{prim_index}]"
    linear, shift = matrix[:3, :3], matrix[:3, 3]
    with np.errstate(over="ignore", invalid="ignore"):  # checked just below
        vertices = positions @ linear.T + shift
    if not np.isfinite(vertices).all():
        doc.fail(f"{where}: positions times the node's transform overflow float64; allowed: finite products")
    normals = None
    if n is not None:
        with np.errstate(invalid="ignore", over="ignore"):  # NaN/inf normals: replaced by meshes.shading_normals
            n = n @ _normal_matrix(linear)
            normals = n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
    return vertices, faces, normals


def _read_primitive(doc: Document, mesh_index: int, prim_index: int):
    """(POSITION, faces, NORMAL or None) of a triangle primitive as the file holds them, checked; None for
    points and lines.  Kept in doc.primitives: 100,000 nodes placing one mesh read it once, not 300,000 times."""
    key = (mesh_index, prim_index)
    if key not in doc.primitives:
        doc.primitives[key] = _read_primitive_once(doc, mesh_index, prim_index)
    return doc.primitives[key]


def _read_primitive_once(doc: Document, mesh_index: int, prim_index: int):
    mesh = doc.item("meshes", mesh_index)
    prims = mesh.get("primitives")
    where = f"meshes[{mesh_index}].primitives[{prim_index}]"
    if not isinstance(prims, list) or not 0 <= prim_index < len(prims) or not isinstance(prims[prim_index], dict):
        doc.fail(f"{where} does not exist")
    prim = prims[prim_index]
    attributes = prim.get("attributes")
    if not isinstance(attributes, dict) or "POSITION" not in attributes:
        doc.fail(f"{where} has no POSITION attribute")
    if prim.get("mode", TRIANGLES) not in (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN):
        return None
    positions = accessor(doc, attributes["POSITION"], f"{where}.attributes.POSITION", "VEC3")
    if not np.isfinite(positions).all():  # before any arithmetic: inf x 0 would warn and give NaN
        doc.fail(f"{where}: POSITION holds NaN or infinite values; allowed: finite numbers")
    faces = _faces(doc, prim, len(positions), where)
    n = None
    if "NORMAL" in attributes:
        n = accessor(doc, attributes["NORMAL"], f"{where}.attributes.NORMAL", "VEC3")
        if n.shape != positions.shape:
            doc.fail(f"{where}: NORMAL must be VEC3 with one normal per position")
    for array in (positions, faces, n):
        if array is not None:
            array.flags.writeable = False  # shared by every node that places the primitive
    return positions, faces, n


def _normal_matrix(linear: np.ndarray) -> np.ndarray:
    """R with normals = n @ R: the inverse of `linear` (normals transform by the inverse transpose), or,
    where that does not exist or overflows, the same up to a positive factor: the transposed cofactor matrix,
    signed by the determinant.  That exists for a singular transform too (a node scaled to zero along one axis
    flattens its mesh, whose normals are still defined), and from entries scaled to <= 1 it cannot overflow.
    The inverse comes first so that every file that loaded before gives the same normals, bit for bit."""
    try:
        inverse = np.linalg.inv(linear)
        if np.isfinite(inverse).all():
            return inverse
    except np.linalg.LinAlgError:  # singular
        pass
    top = np.abs(linear).max()
    a = linear / top if top > 0 else linear
    # columns a0, a1, a2 of `a`: the inverse's rows are (a1 x a2, a2 x a0, a0 x a1) / det
    cofactor_t = np.stack([np.cross(a[:, 1], a[:, 2]), np.cross(a[:, 2], a[:, 0]), np.cross(a[:, 0], a[:, 1])])
    return cofactor_t if np.linalg.det(a) >= 0 else -cofactor_t


@dataclass
class NodeMesh:
    """Triangles of one glTF node in world space, with what Scene needs of a trimesh.Trimesh (no trimesh import)."""

    vertices: np.ndarray  # (V, 3) float64
    faces: np.ndarray  # (F, 3) int64
    normals: np.ndarray | None = None  # (V, 3) unit normals from the file, if it has them
    uv0: np.ndarray | None = None  # (V, 2) TEXCOORD_0, where every primitive has it (else zeros where missing)
    uv1: np.ndarray | None = None  # (V, 2) TEXCOORD_1
    colours: np.ndarray | None = None  # (V, 3) COLOR_0's RGB (ones where a primitive has none)
    tangents: np.ndarray | None = None  # (V, 4) TANGENT in world space, where every primitive has it

    @property
    def vertex_normals(self) -> np.ndarray:
        """The file's normals, else the area-weighted mean of the faces' normals around each vertex."""
        if self.normals is not None:
            return self.normals
        tri = self.vertices[self.faces]
        face_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])  # length = twice the area
        n = np.zeros_like(self.vertices)
        for k in range(3):
            np.add.at(n, self.faces[:, k], face_n)
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)

    @property
    def face_normals(self) -> np.ndarray:
        tri = self.vertices[self.faces]
        n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)


@_malformed_is_usage_error
def node_mesh(path, node: int, primitive: int | None = None, root=None) -> NodeMesh:
    """Node `node`'s mesh (one primitive, or all its triangle primitives) in world space.  With a `root`
    (a confined scene's folder) every file it reads must lie inside it."""
    doc = read_document(path, root)
    mesh_index = doc.item("nodes", node).get("mesh")
    if mesh_index is None:
        doc.fail(f"nodes[{node}] has no mesh")
    matrix = node_world_matrix(doc, node)
    count = len(doc.item("meshes", mesh_index).get("primitives", []))
    chosen = [primitive] if primitive is not None else range(count)
    triangles = sum(_triangle_count(doc, mesh_index, p) for p in chosen)
    if triangles > MAX_TRIANGLES:  # before any is read
        doc.fail(f"nodes[{node}]: its mesh has {triangles} triangles; allowed: at most {MAX_TRIANGLES}")
    parts = [doc.triangles.pop((node, p), None) or primitive_triangles(doc, mesh_index, p, matrix) for p in chosen]
    parts = [p for p in parts if p is not None]
    if not parts or not sum(len(f) for _, f, _ in parts):
        doc.fail(f"nodes[{node}]: its mesh has no triangles")
    drawn = any((node, p) in doc.drawn for p in chosen)  # scene_dict's has_area, not computed again
    if not drawn and not any(has_area(v, f) for v, f, _ in parts):
        doc.fail(f"nodes[{node}]: all its triangles have zero area (its world transform is scaled to zero); allowed: a node that is drawn")
    offsets = np.cumsum([0] + [len(v) for v, _, _ in parts])
    vertices = np.concatenate([v for v, _, _ in parts])
    faces = np.concatenate([f + o for (_, f, _), o in zip(parts, offsets)])
    normals = None
    if all(n is not None for _, _, n in parts):
        normals = np.concatenate([n for _, _, n in parts])
    kept = [p for p in chosen if _triangle_primitive(doc, mesh_index, p) is not None]
    attrs = [primitive_attributes(doc, mesh_index, p, len(v)) for p, (v, _, _) in zip(kept, parts)]
    joined = []
    for k, fill in enumerate((0.0, 0.0, 1.0)):
        given = [a[k] for a in attrs]
        if all(g is None for g in given):
            joined.append(None)
            continue
        width = 3 if k == 2 else 2
        joined.append(np.concatenate([g if g is not None else np.full((len(v), width), fill) for g, (v, _, _) in zip(given, parts)]))
    given = [a[3] for a in attrs]
    joined.append(np.concatenate(given) if all(g is not None for g in given) else None)
    if joined[-1] is not None:  # tangents turn with the node's linear transform (not its inverse transpose)
        t = joined[-1]
        xyz = t[:, :3] @ matrix[:3, :3].T
        t[:, :3] = xyz / np.maximum(np.linalg.norm(xyz, axis=1, keepdims=True), 1e-30)
    return NodeMesh(vertices, faces, normals, *joined)


def primitive_attributes(doc: Document, mesh_index: int, prim_index: int, n_vertices: int):
    """(TEXCOORD_0, TEXCOORD_1, COLOR_0 RGB, TANGENT) of a triangle primitive, each (n_vertices, 2, 3 or 4) float64
    or None; read once per primitive (doc.primitives), read-only."""
    key = (mesh_index, prim_index, "attributes")
    if key not in doc.primitives:
        doc.primitives[key] = _primitive_attributes(doc, mesh_index, prim_index, n_vertices)
        for array in doc.primitives[key]:
            if array is not None:
                array.flags.writeable = False
    return doc.primitives[key]


def _primitive_attributes(doc: Document, mesh_index: int, prim_index: int, n_vertices: int):
    prim = doc.item("meshes", mesh_index)["primitives"][prim_index]
    attributes = prim["attributes"]
    where = f"meshes[{mesh_index}].primitives[{prim_index}].attributes"
    out = []
    for name in ("TEXCOORD_0", "TEXCOORD_1"):
        if name not in attributes:
            out.append(None)
            continue
        uv = accessor(doc, attributes[name], f"{where}.{name}", "VEC2", (5126, 5121, 5123))
        if len(uv) != n_vertices or not np.isfinite(uv).all():
            doc.fail(f"{where}.{name}: {len(uv)} finite coordinates needed, one per POSITION ({n_vertices})")
        if np.abs(uv).max(initial=0.0) > UV_LIMIT:  # times a texture transform's scale it would overflow float32
            doc.fail(f"{where}.{name}: a coordinate of {np.abs(uv).max():.6g}; allowed: -{UV_LIMIT:g} to {UV_LIMIT:g}")
        out.append(uv)
    colours = None
    if "COLOR_0" in attributes:
        kind = doc.item("accessors", attributes["COLOR_0"]).get("type")
        kind = kind if kind in ("VEC3", "VEC4") else "VEC3"
        c = accessor(doc, attributes["COLOR_0"], f"{where}.COLOR_0", kind, (5126, 5121, 5123))
        if len(c) != n_vertices or not np.isfinite(c).all():
            doc.fail(f"{where}.COLOR_0: {len(c)} finite colours needed, one per POSITION ({n_vertices})")
        colours = np.clip(c[:, :3], 0.0, 1.0)
    out.append(colours)
    tangents = None
    if "TANGENT" in attributes:
        tangents = accessor(doc, attributes["TANGENT"], f"{where}.TANGENT", "VEC4", (5126, 5120, 5122))
        if len(tangents) != n_vertices or not np.isfinite(tangents).all():
            doc.fail(f"{where}.TANGENT: {len(tangents)} finite tangents needed, one per POSITION ({n_vertices})")
        tangents[:, 3] = np.where(tangents[:, 3] < 0, -1.0, 1.0)
    out.append(tangents)
    return out


def node_shape(path, node: int, primitive: int | None = None, root=None) -> tuple[int, np.ndarray, np.ndarray]:
    """(mesh index, its vertices in the mesh's own space, the node's world matrix) of node_mesh's mesh:
    nodes that share a mesh place the same vertices (instancing, clrender/trace/instancing.py)."""
    doc = read_document(path, root)
    mesh_index = doc.item("nodes", node).get("mesh")
    count = len(doc.item("meshes", mesh_index).get("primitives", []))
    chosen = [primitive] if primitive is not None else range(count)
    key = (mesh_index, primitive, "own")  # the same array for every node of this mesh
    if key not in doc.primitives:
        parts = [primitive_triangles(doc, mesh_index, p, np.eye(4)) for p in chosen]
        doc.primitives[key] = np.concatenate([v for v, _, _ in (p for p in parts if p is not None)])
    return mesh_index, doc.primitives[key], node_world_matrix(doc, node)


def has_area(vertices: np.ndarray, faces: np.ndarray) -> bool:
    """Whether any triangle has an area: a node scaled to zero (as files hide nodes) draws nothing."""
    tri = vertices[faces]
    a, b = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]  # np.cross's products, without its per-call overhead
    return bool(np.any(a[:, [1, 2, 0]] * b[:, [2, 0, 1]] - a[:, [2, 0, 1]] * b[:, [1, 2, 0]]))


def _triangle_count(doc: Document, mesh_index: int, prim_index: int) -> int:
    """Triangles a primitive will give, from its accessors' counts alone (nothing is read); 0 for points and lines."""
    prim = _triangle_primitive(doc, mesh_index, prim_index)
    if prim is None:
        return 0
    count = _count(doc, prim["indices"] if "indices" in prim else prim["attributes"].get("POSITION"))
    return count // 3 if prim.get("mode", TRIANGLES) == TRIANGLES else max(count - 2, 0)


def _vertex_count(doc: Document, mesh_index: int, prim_index: int) -> int:
    """Vertices a triangle primitive will read (its POSITION count), nothing read; 0 for points and lines."""
    prim = _triangle_primitive(doc, mesh_index, prim_index)
    return 0 if prim is None else _count(doc, prim["attributes"].get("POSITION"))


def _triangle_primitive(doc: Document, mesh_index: int, prim_index: int):
    """The primitive, when it draws triangles and has attributes; else None (primitive_triangles says what is wrong)."""
    prims = doc.item("meshes", mesh_index).get("primitives")
    prim = prims[prim_index] if isinstance(prims, list) and 0 <= prim_index < len(prims) else None
    if not isinstance(prim, dict) or not isinstance(prim.get("attributes"), dict):
        return None
    return prim if prim.get("mode", TRIANGLES) in (TRIANGLES, TRIANGLE_STRIP, TRIANGLE_FAN) else None


def _count(doc: Document, index) -> int:
    """An accessor's count as the file states it (0 when absent or not a whole number: accessor() refuses those)."""
    count = doc.item("accessors", index).get("count") if index is not None else 0
    return count if isinstance(count, int) and not isinstance(count, bool) else 0


# ------------------------------------------------------------ the scene dict
def _material_names(doc: Document) -> list:
    names, used = [], {"default"}
    for i, m in enumerate(doc.json.get("materials", [])):
        name = m.get("name") if isinstance(m, dict) else None
        if not isinstance(name, str) or not name or name in used:
            name = f"material_{i}"
        used.add(name)
        names.append(name)
    return names


def _material(doc: Document, index: int) -> dict:
    item = doc.item("materials", index)
    where = f"materials[{index}]"
    pbr = item.get("pbrMetallicRoughness", {})
    factor = _numbers(doc, pbr.get("baseColorFactor", [1, 1, 1, 1]), 4, f"{where}.pbrMetallicRoughness.baseColorFactor")
    metallic = _numbers(doc, [pbr.get("metallicFactor", 1.0)], 1, f"{where}.pbrMetallicRoughness.metallicFactor")
    roughness = _numbers(doc, [pbr.get("roughnessFactor", 1.0)], 1, f"{where}.pbrMetallicRoughness.roughnessFactor")
    emissive = _numbers(doc, item.get("emissiveFactor", [0, 0, 0]), 3, f"{where}.emissiveFactor")

    def extension(name: str, key: str, default: float) -> float:
        table = item.get("extensions", {})
        table = table.get(name, {}) if isinstance(table, dict) else None
        if not isinstance(table, dict):
            doc.fail(f"{where}.extensions.{name} must be an object, got {show(table)}")
        return float(_numbers(doc, [table.get(key, default)], 1, f"{where}.extensions.{name}.{key}")[0])

    strength = extension("KHR_materials_emissive_strength", "emissiveStrength", 1.0)
    ior = extension("KHR_materials_ior", "ior", 1.5)
    transmission = extension("KHR_materials_transmission", "transmissionFactor", 0.0)
    out = {
        "base_color": [float(c) for c in factor[:3]],
        "metallic": float(metallic[0]),
        "roughness": float(roughness[0]),
        "emission": [float(c) * strength for c in emissive],
        "ior": ior,
        "transmission": transmission,
    }
    double_sided = item.get("doubleSided", False)
    if not isinstance(double_sided, bool):
        doc.fail(f"{where}.doubleSided {show(double_sided)}; allowed: true, false")
    out["double_sided"] = double_sided
    mode = item.get("alphaMode", "OPAQUE")
    if mode not in ("OPAQUE", "MASK", "BLEND"):
        doc.fail(f"{where}.alphaMode {show(mode)}; allowed: OPAQUE, MASK, BLEND")
    if mode != "OPAQUE":
        cutoff = float(_numbers(doc, [item.get("alphaCutoff", 0.5)], 1, f"{where}.alphaCutoff")[0])
        out["alpha"] = {"mode": mode.lower(), "cutoff": min(max(cutoff, 0.0), 1.0), "factor": min(max(float(factor[3]), 0.0), 1.0)}
    for slot in TEXTURE_SLOT_TABLE:  # each slot's textureInfo, at the key path layout's table gives
        *tables, name = slot.gltf.split(".")
        table = item
        for key in tables:
            table = table.get(key, {}) if isinstance(table, dict) else {}
        if slot.gltf and isinstance(table, dict) and name in table:
            key = f"{slot.name}_texture"
            out[key], extra = _texture_info(doc, table[name], f"{where}.{name}")
            if slot.strength:
                out[key]["strength"] = extra.get(slot.strength, 1.0)
    occlusion = out.get("occlusion_texture")
    if occlusion is not None:  # glTF: strength in [0, 1]
        occlusion["strength"] = min(max(occlusion["strength"], 0.0), 1.0)
    return out


def _texture_info(doc: Document, info, where: str):
    """A textureInfo as a scene material's texture table, and its strength/scale values."""
    if not isinstance(info, dict):
        doc.fail(f"{where} must be an object, got {show(info)}")
    index = info.get("index")
    doc.item("textures", index)
    tex_coord = info.get("texCoord", 0)
    ext = info.get("extensions", {}).get("KHR_texture_transform") if isinstance(info.get("extensions"), dict) else None
    ref = {"texture": f"texture_{index}"}
    if isinstance(ext, dict):
        tex_coord = ext.get("texCoord", tex_coord)
        ref["offset"] = _numbers(doc, ext.get("offset", [0, 0]), 2, f"{where}.extensions.KHR_texture_transform.offset").tolist()
        ref["rotation"] = float(_numbers(doc, [ext.get("rotation", 0.0)], 1, f"{where}.extensions.KHR_texture_transform.rotation")[0])
        ref["scale"] = _numbers(doc, ext.get("scale", [1, 1]), 2, f"{where}.extensions.KHR_texture_transform.scale").tolist()
    if tex_coord not in (0, 1) or isinstance(tex_coord, bool):
        doc.fail(f"{where}.texCoord {show(tex_coord)}; allowed: 0 or 1 (TEXCOORD_0, TEXCOORD_1)")
    ref["tex_coord"] = tex_coord
    extra = {k: float(_numbers(doc, [info[k]], 1, f"{where}.{k}")[0]) for k in ("strength", "scale") if k in info}
    return ref, extra


WRAPS = {10497: "repeat", 33071: "clamp_to_edge", 33648: "mirrored_repeat"}
NEAREST = 9728


def _textures(doc: Document, path: Path, materials: dict) -> dict:
    """The scene `textures` entries of the glTF textures the materials use, named texture_<index>."""
    used = sorted({int(v["texture"].split("_")[1]) for m in materials.values() for k, v in m.items() if k.endswith("_texture")})
    out = {}
    for t in used:
        tex = doc.item("textures", t)
        source = tex.get("source")
        if source is None:
            doc.fail(f"textures[{t}] has no source image (an image only an extension names is not read)")
        doc.item("images", source)
        sampler = doc.item("samplers", tex["sampler"]) if "sampler" in tex else {}
        entry = {"file": path.name, "image": source}
        for key, name in (("wrapS", "wrap_s"), ("wrapT", "wrap_t")):
            code = sampler.get(key, 10497)
            if code not in WRAPS:
                doc.fail(f"samplers[{tex['sampler']}].{key} {show(code)}; allowed: {', '.join(map(str, WRAPS))}")
            entry[name] = WRAPS[code]
        entry["filter"] = "nearest" if sampler.get("magFilter") == NEAREST else "linear"
        out[f"texture_{t}"] = entry
    return out


@_malformed_is_usage_error
def image_bytes(path, index: int, root=None) -> bytes | Path:
    """The encoded bytes of images[index] of a glTF file (a data URI, a GLB bufferView), or the path of a file
    beside it, unread (found through confine.scene_file: a confined scene reads none outside its folder)."""
    doc = read_document(path, root)
    image = doc.item("images", index)
    where = f"images[{index}]"
    if "uri" in image:
        uri = image["uri"]
        if not isinstance(uri, str):
            doc.fail(f"{where}.uri must be a string")
        if uri.startswith("data:"):
            try:
                return base64.b64decode(uri.split(",", 1)[1], validate=True)
            except (IndexError, ValueError):
                doc.fail(f"{where}.uri is not a base64 data URI")
        from urllib.parse import unquote

        file = scene_file(doc.path.parent, unquote(uri), doc.root, f"{doc.path}: {where}.uri")
        return regular_file(file, f"{doc.path}: {where}.uri: image file")  # the path: the decoder reads its header before its pixels
    if "bufferView" not in image:
        doc.fail(f"{where} has neither a uri nor a bufferView")
    view = doc.item("bufferViews", image["bufferView"])
    buffer_index = view.get("buffer")
    if isinstance(buffer_index, bool) or not isinstance(buffer_index, int) or not 0 <= buffer_index < len(doc.buffers):
        doc.fail(f"bufferViews[{image['bufferView']}].buffer {buffer_index!r} does not exist")
    start, length = view.get("byteOffset", 0), view.get("byteLength", 0)
    data = doc.buffers[buffer_index]
    if not isinstance(start, int) or not isinstance(length, int) or start < 0 or start + length > len(data):
        doc.fail(f"{where}: bufferViews[{image['bufferView']}] runs past its buffer")
    return bytes(data[start : start + length])


def _camera(doc: Document, index: int, matrix: np.ndarray, node: int):
    """A scene-dict camera looking down node `node`'s -z, and the aspect ratio of the default image (or None).
    Perspective: yfov is the vertical field of view, aspectRatio the default image's aspect.  Orthographic:
    the image spans 2 ymag vertically (ortho_height) and xmag / ymag is the default image's aspect.  glTF has
    no lens, so every camera is a pinhole; znear and zfar are not modelled."""
    cam = doc.item("cameras", index)
    kind = cam.get("type")
    if kind not in ("perspective", "orthographic"):
        doc.fail(f"cameras[{index}].type {show(kind)} is not perspective or orthographic")
    params = cam.get(kind)
    if not isinstance(params, dict):
        doc.fail(f"cameras[{index}].{kind} is missing")
    eye = matrix[:3, 3]
    forward = _unit(matrix[:3, :3] @ [0.0, 0.0, -1.0])
    up = _unit(matrix[:3, :3] @ [0.0, 1.0, 0.0])
    if forward is None or up is None:
        doc.fail(f"nodes[{node}]: the transform of its camera is scaled to zero, so it looks nowhere; allowed: a transform that keeps -z and +y")
    camera = {"position": eye.tolist(), "look_at": (eye + forward).tolist(), "up": up.tolist()}
    for name in (cam.get("name"), doc.item("nodes", node).get("name")):  # shown by `render --list`: the camera's name, else its node's
        if isinstance(name, str) and name.strip():
            camera["name"] = shorten(escape(name.strip()), MAX_NAME)  # one printable line, as the camera reader requires
            break
    if kind == "orthographic":
        mags = []
        for key in ("xmag", "ymag"):
            mag = params.get(key)
            # the spec: not zero, should not be negative (a negative one is read by its size)
            if isinstance(mag, bool) or not isinstance(mag, (int, float)) or not MIN_LENGTH / 2 <= abs(mag) <= COORD_LIMIT / 2:
                doc.fail(f"cameras[{index}].orthographic.{key} {show(mag)}; allowed: a half-size of {MIN_LENGTH / 2:g} to {COORD_LIMIT / 2:g}")
            mags.append(abs(float(mag)))
        camera.update(projection="orthographic", ortho_height=2.0 * mags[1])
        aspect, lowest = mags[0] / mags[1], IMAGE_WIDTH / MAX_SIDE
        if aspect < lowest:
            doc.fail(f"cameras[{index}].orthographic: xmag / ymag = {aspect:.6g}; allowed: >= {lowest:g} (a default image <= {MAX_SIDE} high)")
        return camera, aspect
    yfov = params.get("yfov")
    if isinstance(yfov, bool) or not isinstance(yfov, (int, float)) or not 0 < yfov < math.pi:
        doc.fail(f"cameras[{index}].perspective.yfov must be an angle in radians in (0, pi), got {show(yfov)}")
    aspect = params.get("aspectRatio")
    # the default image is IMAGE_WIDTH wide and IMAGE_WIDTH / aspect high, at most MAX_SIDE
    if aspect is not None and (isinstance(aspect, bool) or not isinstance(aspect, (int, float)) or not aspect >= IMAGE_WIDTH / MAX_SIDE):
        lowest = IMAGE_WIDTH / MAX_SIDE
        doc.fail(f"cameras[{index}].perspective.aspectRatio {show(aspect)}; allowed: >= {lowest:g} (a default image <= {MAX_SIDE} high)")
    camera["fov"] = min(math.degrees(yfov), 179.0)
    return camera, aspect


def _unit(v: np.ndarray):
    """v / |v|, or None for a zero vector; scaled to at most 1 first, so that the norm cannot overflow or underflow."""
    top = np.abs(v).max()
    if not top > 0:
        return None
    v = v / top
    return v / np.linalg.norm(v)


def _light(doc: Document, index: int, matrix: np.ndarray) -> dict:
    lights = doc.json.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    if not isinstance(lights, list) or isinstance(index, bool) or not isinstance(index, int) or not 0 <= index < len(lights):
        doc.fail(f"KHR_lights_punctual light {index!r} does not exist")
    light = lights[index]
    where = f"extensions.KHR_lights_punctual.lights[{index}]"
    kind = light.get("type")
    if kind not in ("point", "spot", "directional"):
        doc.fail(f"{where}.type {kind!r} is not point, spot or directional")
    color = _numbers(doc, light.get("color", [1, 1, 1]), 3, f"{where}.color")
    intensity = light.get("intensity", 1.0)
    if isinstance(intensity, bool) or not isinstance(intensity, (int, float)) or not intensity >= 0:
        doc.fail(f"{where}.intensity must be >= 0, got {intensity!r}")
    out = {"color": color.tolist(), "intensity": float(intensity)}
    if kind == "directional":  # the unnormalised light model: its Lambert term has no 1/pi
        out.update(type="directional", direction=(matrix[:3, :3] @ [0.0, 0.0, -1.0]).tolist(), intensity=float(intensity) / math.pi)
    else:  # a spot light is drawn as a point light: its cone is not modelled
        # inverse-square falloff selects the physical model, whose Lambert BRDF is kd / pi already
        out.update(type="point", position=matrix[:3, 3].tolist(), falloff="inverse_square")
    return out


def _check_object_count(doc: Document, order: list) -> None:
    """Refuse a file whose drawn nodes make more mesh objects (one per triangle primitive) than a scene may hold
    (checks.MAX_OBJECTS), from the node list alone: nothing is read or multiplied for a file that is refused."""
    count = 0
    for index, _ in order:
        mesh = doc.json["nodes"][index].get("mesh")
        if mesh is not None:
            prims = doc.item("meshes", mesh).get("primitives", [])
            count += sum(_triangle_primitive(doc, mesh, p) is not None for p in range(len(prims) if isinstance(prims, list) else 0))
            if count > MAX_OBJECTS:
                made = f"the nodes up to this one make more than {MAX_OBJECTS} mesh objects (one per triangle primitive)"
                doc.fail(f"nodes[{index}]: {made}; allowed: at most {MAX_OBJECTS}")


@_malformed_is_usage_error
def scene_dict(path, root=None, keep: bool = False) -> dict:
    """The `Scene.from_dict` structure of a glTF file; mesh files are named relative to its folder.
    With a `root` every file it reads must lie inside that folder.  keep=True (a scene about to be read): each
    drawn node's world triangles stay in the document for node_mesh, which then does not compute them again."""
    path = Path(path)
    doc = read_document(path, root)
    names = _material_names(doc)
    materials = {names[i]: _material(doc, i) for i in range(len(names))}
    objects, cameras, lights = [], [], []
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    aspect = None
    triangles = vertices = 0
    order = node_order(doc)
    _check_object_count(doc, order)  # before any node's matrix or mesh is read
    for index, matrix in world_matrices(doc, order).items():
        node = doc.item("nodes", index)
        if "mesh" in node:
            mesh = doc.item("meshes", node["mesh"])
            for p in range(len(mesh.get("primitives", []))):
                triangles += _triangle_count(doc, node["mesh"], p)
                vertices += _vertex_count(doc, node["mesh"], p)
                if triangles > MAX_TRIANGLES:  # before the primitive is read
                    doc.fail(f"nodes[{index}]: the scene has more than {MAX_TRIANGLES} triangles up to this node; allowed: at most {MAX_TRIANGLES}")
                if vertices > MAX_VERTICES_READ:
                    doc.fail(
                        f"nodes[{index}]: the nodes up to this one read more than {MAX_VERTICES_READ} vertices "
                        f"(each instance reads its mesh again); allowed: at most {MAX_VERTICES_READ}"
                    )
                tri = primitive_triangles(doc, node["mesh"], p, matrix)
                if tri is None or not len(tri[1]) or not has_area(tri[0], tri[1]):
                    continue  # points and lines; a node scaled to zero (files hide nodes that way) draws nothing
                doc.drawn.add((index, p))
                if keep:
                    doc.triangles[(index, p)] = tri
                lo, hi = np.minimum(lo, tri[0].min(axis=0)), np.maximum(hi, tri[0].max(axis=0))
                material = mesh["primitives"][p].get("material")
                if material is not None:
                    doc.item("materials", material)  # checked: the index exists
                objects.append(
                    {
                        "type": "mesh",
                        "file": path.name,
                        "node": index,
                        "primitive": p,
                        "material": "default" if material is None else names[material],
                        "smooth": tri[2] is not None,
                    }
                )
        if "camera" in node:
            camera, camera_aspect = _camera(doc, node["camera"], matrix, index)
            cameras.append(camera)
            aspect = camera_aspect if len(cameras) == 1 else aspect
        light = node.get("extensions", {}).get("KHR_lights_punctual") if isinstance(node.get("extensions"), dict) else None
        if isinstance(light, dict):
            lights.append(_light(doc, light.get("light"), matrix))
    if not objects:
        doc.fail("the scene has no triangle meshes")
    if not cameras:
        cameras.append(framing.framing_camera(lo, hi))  # the same view a bare mesh file gets
    # a file that brings no lights gets a bare mesh's: the key light over the first camera's shoulder and the fill
    lighting = framing.lighting(cameras[0]) if not lights else {"lights": lights}
    height = max(1, round(IMAGE_WIDTH / aspect)) if aspect else IMAGE_WIDTH * 3 // 4
    return {
        "name": path.stem,
        "width": IMAGE_WIDTH,
        "height": height,
        "cameras": cameras,
        "materials": materials,
        **lighting,
        "objects": objects,
        "textures": _textures(doc, path, materials),
    }
