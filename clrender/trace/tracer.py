"""The scene on the device: BVH, primitive records and the ray kernels.

`Tracer(scene)` flattens the scene, builds the BVH on the host (unless
use_bvh=False, where every ray tests every primitive), uploads everything
once and answers ray queries with the same traversal code the renderer
uses, as one would use Embree:

    tracer = Tracer(scene)
    t, prim, obj = tracer.intersect(origins, directions)
    blocked = tracer.occluded(origins, directions, t_max)

Distances are in units of the directions as given (a hit is origin + t * direction,
as in Embree); t_min (default 0) excludes hits at t <= t_min.  A ray that starts
on a surface may find that surface again at a tiny t: offset its origin off the
surface (the renderer moves it just past the hit point's float32 error bound) or
pass a t_min.  Exact answers (docs/bvh.md, "Exact ray queries"): the slab test
holds for every direction, the triangle test is watertight, and of hits at the
same float32 t the lowest primitive id wins, whatever the BVH.

Tracer(scene, instancing=True) stores a mesh that several objects place once and meets each copy in
object space (clrender/trace/instancing.py; docs/bvh.md, "Instancing"), for ray queries and renders.
"""

from __future__ import annotations

import math
import os
import threading
import time

import numpy as np
import pyopencl as cl

from ..arena import pack
from ..device import Device, get_device
from ..errors import UsageError, real_array, shown, value_shown
from ..launch import Kernel
from ..layout import (
    BVH_NODE_DTYPE,
    INSTANCE_DTYPE,
    PRIM_SLOT_DTYPE,
    QUERY_PARAMS_DTYPE,
    SCENE_TABLES_DTYPE,
    VERTEX_ATTRIBUTES_DTYPE,
    VERTEX_NORMALS_DTYPE,
)
from ..scene.scene import Mesh, Scene
from ..scene.textures import pack as pack_textures
from .bvh import BUILDERS
from .geometry import Primitives, flatten, pack_slots
from .instancing import find_instances, flat_part, instanced_object_flags, shape_meshes, two_level
from .knobs import DEFAULT_KNOBS, TraceKnobs
from .ray_buffers import INTERSECT_IN, INTERSECT_OUT, OCCLUDED_IN, OCCLUDED_OUT, RayBuffers
from .variant import DEFAULT_BVH_WIDTH, Variant
from .work_layout import WorkLayout, global_size, work_layout

QUERY_KERNELS = {"intersect": "intersect_rays", "occluded": "occluded_rays"}  # trace.cl's kernel of each ray query


TRACER_TAKES = "a Tracer takes a Scene, a scene name, path or dict, a trimesh.Trimesh or a (vertices, faces) pair"


def as_scene(scene_or_mesh) -> Scene:
    """A Scene from a Scene, a scene name/path/dict, a trimesh.Trimesh or a (vertices, faces) pair."""
    if isinstance(scene_or_mesh, Scene):
        return scene_or_mesh
    if isinstance(scene_or_mesh, (tuple, list)) and len(scene_or_mesh) == 2:
        return Scene(objects=[Mesh(*mesh_arrays(*scene_or_mesh))])
    if hasattr(scene_or_mesh, "vertices") and hasattr(scene_or_mesh, "faces"):
        return as_scene((scene_or_mesh.vertices, scene_or_mesh.faces))
    if isinstance(scene_or_mesh, (str, os.PathLike, dict)):
        return Scene.load(scene_or_mesh)
    raise UsageError(f"{TRACER_TAKES}; got {_kind(scene_or_mesh)}")


def _kind(value) -> str:
    """What a refused argument is, in a few words (never its whole contents)."""
    if isinstance(value, np.ndarray):
        return f"a numpy array of shape {value.shape}"
    if isinstance(value, (tuple, list)):
        return f"a {type(value).__name__} of {len(value)} items"
    return "None" if value is None else f"{type(value).__name__} {shown(value)}"


def mesh_arrays(vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """(V, 3) float64 vertices and (F, 3) int64 faces, checked: finite positions, every index a vertex."""
    v = real_array(vertices, "vertices")
    if v.ndim != 2 or v.shape[1] != 3:
        raise UsageError(f"vertices of shape {v.shape} are not allowed; allowed: (V, 3), one (x, y, z) per vertex")
    with np.errstate(over="ignore"):  # beyond float32: inf, refused below
        if not np.isfinite(v.astype(np.float32)).all():
            raise UsageError("vertices must be finite and within float32's range")
    f = real_array(faces, "faces")
    if f.dtype.kind not in "iu":
        raise UsageError(f"faces must be whole numbers (vertex indices); got an array of {f.dtype}")
    if f.ndim != 2 or f.shape[1] != 3:
        raise UsageError(f"faces of shape {f.shape} are not allowed; allowed: (F, 3), three vertex indices per triangle")
    if f.size:
        bad = f.max() if f.max() >= len(v) else f.min()
        if not 0 <= bad < len(v):
            allowed = f"0 to {len(v) - 1} (the {len(v)} vertices)" if len(v) else "none (there are no vertices)"
            raise UsageError(f"face index {int(bad)} is not a vertex; allowed: {allowed}")
    return v.astype(np.float64, copy=False), f.astype(np.int64, copy=False)  # the caller's arrays when they are already so


def trace_defines(**switches) -> dict:
    """The -D defines of kernels/trace.cl for a Tracer's switches (variant.Variant's fields: use_bvh, bvh_width,
    count_prim_tests, shadow_shafts, ray_packets, knobs, instanced, top_wide, rays_per_item)."""
    return Variant(**switches).defines()


def _check_switches(builder, bvh_width, device, knobs, flags: dict) -> None:
    """Refuse a Tracer's switches that are not allowed (UsageError naming the value)."""
    from .bvh_wide import WIDTHS

    if not isinstance(builder, str) or builder not in BUILDERS:
        raise UsageError(f"unknown BVH builder {value_shown(builder)}; allowed: {', '.join(BUILDERS)}")
    if isinstance(bvh_width, (bool, np.bool_)) or not isinstance(bvh_width, (int, np.integer)) or bvh_width not in WIDTHS:
        raise UsageError(f"BVH width {value_shown(bvh_width)}; allowed: {', '.join(map(str, WIDTHS))}")
    for name, flag in flags.items():
        if not isinstance(flag, (bool, np.bool_)):
            raise UsageError(f"{name} {value_shown(flag)} must be True or False")
    if not (device is None or isinstance(device, (Device, str))):
        raise UsageError(f"device {value_shown(device)} must be a Device, a device name (a string) or None")
    if not isinstance(knobs, TraceKnobs):
        raise UsageError(f"knobs {value_shown(knobs)}; allowed: a clrender.trace.knobs.TraceKnobs")


class Tracer:
    """The scene's geometry on the device and the ray queries.  The shading's records (vertex normals and attributes,
    objects, materials, textures) are uploaded only when a render first asks for them (upload_shading): a query-only
    Tracer holds none."""

    def __init__(
        self,
        scene_or_mesh,
        *,
        use_bvh: bool = True,
        builder: str = "sah",
        device: Device | str | None = None,
        bvh_width: int = DEFAULT_BVH_WIDTH,
        count_prim_tests: bool = False,
        shadow_shafts: bool = True,
        ray_packets: bool = True,
        knobs: TraceKnobs = DEFAULT_KNOBS,
        instancing: bool = False,  # meshes placed by several objects stored once (queries and renders; renderer.py decides for renders)
    ):
        flags = dict(use_bvh=use_bvh, count_prim_tests=count_prim_tests, shadow_shafts=shadow_shafts, ray_packets=ray_packets, instancing=instancing)
        _check_switches(builder, bvh_width, device, knobs, flags)
        self.bvh_width = int(bvh_width)
        self.count_prim_tests = bool(count_prim_tests)  # last_visits then counts primitive tests, not nodes
        self.shadow_shafts = bool(shadow_shafts)  # False: every area-light shadow ray traverses the tree (the reference)
        self.ray_packets = bool(ray_packets)  # False: every query ray walks the tree alone (the reference)
        self.knobs = knobs  # stack and list sizes of the kernels and the build's depth cap
        self.wide = None
        self.scene = as_scene(scene_or_mesh)
        self.device = device if isinstance(device, Device) else get_device(device)
        # rays per work-item and work-group size, from what the device reports (work_layout.py)
        self.layout: WorkLayout = work_layout(self.device.device)
        self.use_bvh = bool(use_bvh)
        self.builder = builder
        setup_start = time.perf_counter()
        self.instances = find_instances(self.scene) if instancing else None
        if self.instances is not None and not self.instances.shapes:
            self.instances = None  # no mesh is placed twice: the flat scene, as without instancing
        self.bvh = None
        self.bvh_seconds = 0.0
        self.setup_seconds = {}  # seconds of each other setup phase: "attributes", "textures", "geometry" (the rest)
        self.top_wide = False  # _top: the instances' top tree in wide nodes (kernels' TOP_WIDE)
        self._upload_geometry(*self._trees())
        self._shading = None  # upload_shading's buffers, once a render asks for them
        # the ray queries' input and output buffers, kept and grown from call to call (ray_buffers.py)
        dev = self.device
        self._ray_buffers = {"intersect": RayBuffers(dev, INTERSECT_IN, INTERSECT_OUT), "occluded": RayBuffers(dev, OCCLUDED_IN, OCCLUDED_OUT)}
        self._query_lock = threading.Lock()
        self._bound = {}  # the query kernels' own copies, arguments kept between calls (launch.BoundKernel)
        named = self.bvh_seconds + sum(self.setup_seconds.values())
        # the rest: flattening the scene, packing and uploading the buffers
        self.setup_seconds["geometry"] = max(time.perf_counter() - setup_start - named, 0.0)

    def _trees(self):
        """The flat scene's tree buffer and slots, or (instancing.py) the flat part's tree, then each unique mesh's
        after it; the Instance records in the top tree's leaf order and the top tree (BvhNode or wide records)."""
        if self.instances is None:
            self.primitives: Primitives = flatten(self.scene)
            nodes, slots = self._tree(self.primitives)
            return nodes, slots, np.zeros(1, INSTANCE_DTYPE), np.zeros(1, BVH_NODE_DTYPE)  # never read: n_instances is 0
        self.primitives = flatten(flat_part(self.scene, self.instances))
        nodes, slots = self._tree(self.primitives)
        flat_trees = self.bvh, self.wide
        nodes, slots, records = two_level(self.instances, nodes, slots, self.primitives.count, self._tree)
        top, records = self._top(records)
        self.bvh, self.wide = flat_trees  # bvh and wide describe the flat part
        return nodes, slots, records, top

    def _upload_geometry(self, nodes, slots, records, top) -> None:
        """What the ray queries read: the tree, the slots, each primitive's object, and the query tables (instances and
        the top tree).  Peak memory (docs/bvh.md, "Memory"): on a CPU device the slots and the tree buffer are the
        arrays themselves (Device.adopt)."""
        dev = self.device
        self.n_prims = self.primitives.count  # the flat part's; instances' primitive ids follow (instancing.py)
        self.n_instances = len(records) if self.instances is not None else 0
        self.instance_records = records
        self._top_nodes = top
        self.prims = dev.adopt(slots)  # on a CPU device the buffer is the array itself
        self.nodes = dev.adopt(nodes)
        self._adopted = (slots, nodes)  # the buffers' memory on a CPU device (Device.adopt)
        self.prim_object = dev.to_device(self.primitives.object_of)
        self._query_tables = pack(dev, SCENE_TABLES_DTYPE, self._tables(shading=False))

    def _tables(self, shading: bool) -> dict:
        """The scene tables' arrays (SceneTables): instances and the top tree, and for shading the objects, materials
        and textures' records (empty for the ray queries, which read none)."""
        tables = dict(instances=self.instance_records, top=self._top_nodes)
        if not shading:
            return {**tables, "objects": np.zeros(0, np.uint8), "materials": np.zeros(0, np.uint8), "textures": np.zeros(0, np.uint8)}
        start = time.perf_counter()
        records, self._texels_host = pack_textures(self.primitives.textures or [])
        self.setup_seconds["textures"] = time.perf_counter() - start
        return {**tables, "objects": self.primitives.objects, "materials": self.primitives.materials, "textures": records}

    def _shape_primitives(self) -> Primitives | None:
        """Each instanced shape's primitives once, in object space (instancing.shape_meshes; their instances'
        data_base), with the objects' flags for instanced shapes set (instanced_object_flags); None when flat."""
        if self.instances is None:
            return None
        instanced_object_flags(self.primitives.objects, self.scene, self.instances)
        return flatten(Scene(objects=shape_meshes(self.scene, self.instances)))

    def _vertex_normals(self, shapes: Primitives | None, n_data: int) -> np.ndarray:
        """VertexNormals per primitive (the flat part's, then the shapes'), or one record when no mesh is smooth (the
        kernels read them only for smooth objects)."""
        any_smooth = self.primitives.any_smooth or (shapes is not None and shapes.any_smooth)
        normals = np.zeros(max(n_data, 1) if any_smooth else 1, VERTEX_NORMALS_DTYPE)
        for part, at in ((self.primitives, 0), (shapes, self.n_prims)):
            if part is not None and any_smooth:
                part.triangle_normals_into(normals["normal"][at:])
        return normals

    def _vertex_attributes(self, shapes: Primitives | None, n_data: int) -> np.ndarray:
        """VertexAttributes per primitive (uvs, colours, the normal maps' tangents), or one record when no material
        is textured and no mesh has vertex colours."""
        any_attributes = self.primitives.any_attributes or (shapes is not None and self.scene.has_vertex_attributes)
        attributes = np.zeros(max(n_data, 1) if any_attributes else 1, VERTEX_ATTRIBUTES_DTYPE)
        attributes["colour"] = 1.0
        start = time.perf_counter()
        for part, at, tangents in ((self.primitives, 0, None), (shapes, self.n_prims, self._shape_tangents())):
            if part is not None and any_attributes:
                part.triangle_attributes_into(attributes[at:], tangents)
        self.setup_seconds["attributes"] = time.perf_counter() - start
        return attributes

    def upload_shading(self) -> None:
        """Upload what a render's shading reads, once: per-primitive vertex normals and attributes, the textures'
        texels, and the scene tables with the objects, materials and textures (setup phases "attributes", "textures";
        the rest adds to "geometry")."""
        if self._shading is not None:
            return
        start = time.perf_counter()
        before = sum(self.setup_seconds.get(k, 0.0) for k in ("attributes", "textures"))
        dev = self.device
        shapes = self._shape_primitives()
        n_data = self.n_prims + (shapes.count if shapes is not None else 0)
        normals = dev.to_device(self._vertex_normals(shapes, n_data))
        attributes = dev.to_device(self._vertex_attributes(shapes, n_data))
        tables = pack(dev, SCENE_TABLES_DTYPE, self._tables(shading=True))
        texels, self._texels_host = dev.to_device(self._texels_host), None
        self._shading = dict(normals=normals, attributes=attributes, texels=texels, tables=tables)
        named = sum(self.setup_seconds.get(k, 0.0) for k in ("attributes", "textures")) - before
        self.setup_seconds["geometry"] = self.setup_seconds.get("geometry", 0.0) + max(time.perf_counter() - start - named, 0.0)

    @property
    def tables(self):
        """The render kernels' scene tables (an Arena: objects, materials, textures, instances, the top tree)."""
        self.upload_shading()
        return self._shading["tables"]

    @property
    def normals(self):
        self.upload_shading()
        return self._shading["normals"]

    @property
    def attributes(self):
        self.upload_shading()
        return self._shading["attributes"]

    @property
    def texels(self):
        self.upload_shading()
        return self._shading["texels"]

    def _shape_tangents(self) -> list | None:
        """Per instanced shape, whether a normal map reads its tangents: when any object placing it has a normal-mapped material."""
        if self.instances is None:
            return None
        mapped = {name for name, m in self.scene.materials.items() if m.normal_texture is not None}
        return [any(self.scene.objects[o].material in mapped for o in shape.objects) for shape in self.instances.shapes]

    top_wide_leaf_size = 1  # instances per leaf lane of a wide top tree: one, whose lane box is its own

    def _top(self, records: np.ndarray):
        """The top level: a binary tree (BvhNode records) over the instances' world boxes, and the
        records in its leaf order (a leaf's instances are records[offset:offset + count]).  With wide
        mesh trees it is collapsed to the same width (a leaf lane's child the first record, its count
        how many; kernels/ray_walks.h top_walk): one vector box test for up to 8 boxes, not one per box
        of a binary walk (docs/benchmarks.md has the instancing measurements)."""
        from .bvh import build_bvh

        # two instances are cheaper tested as one binary leaf than as a wide node's lanes
        self.top_wide = self.use_bvh and self.bvh_width >= 4 and len(records) > 2
        top = build_bvh(
            records["bmin"],
            records["bmax"],
            builder=self.builder,
            max_leaf_size=self.top_wide_leaf_size if self.top_wide else 2,
            max_levels=self.knobs.max_tree_levels,
            device=self.device,
        )
        nodes = top.nodes
        if self.top_wide:
            from .bvh_wide import collapse

            nodes = collapse(top, self.bvh_width).nodes
        return nodes, records[np.asarray(top.prim_order, np.int64)]

    def _tree(self, prims: Primitives):
        """The tree's buffer (BvhNode records, or WideNode records then LeafBlocks) and the slots in its
        leaf order, over `prims` (the whole scene, or one mesh in object space)."""
        n = prims.count
        self.device.check_fits(n * PRIM_SLOT_DTYPE.itemsize, f"{n} primitives")
        if not (self.use_bvh and n > 0):
            return np.zeros(1, BVH_NODE_DTYPE), pack_slots(prims, np.arange(n, dtype=np.int64))  # nodes never read
        from .bvh import build_bvh

        lo, hi = prims.bounds()
        knobs = self.knobs
        start = time.perf_counter()
        self.bvh = build_bvh(
            lo, hi, builder=self.builder, max_leaf_size=knobs.leaf_size(self.bvh_width), max_levels=knobs.max_tree_levels, device=self.device
        )
        del lo, hi
        slots = pack_slots(prims, np.asarray(self.bvh.prim_order, np.int64))
        if self.bvh_width == 2:
            nodes = self.bvh.nodes  # BvhNode records
        else:
            from .bvh_wide import collapse, tree_buffer

            self.wide = collapse(self.bvh, self.bvh_width)
            nodes = tree_buffer(self.wide, slots)  # WideNode records, then LeafBlocks
        self.bvh_seconds += time.perf_counter() - start
        return nodes, slots

    @property
    def variant(self) -> Variant:
        """The build of trace.cl this Tracer's queries use (variant.py)."""
        return Variant.of_tracer(self)

    @property
    def defines(self) -> dict:
        return self.variant.defines()

    def kernel(self, name: str) -> Kernel:
        return self.device.kernel("trace.cl", name, self.defines)

    # ------------------------------------------------------------ ray queries
    def _rays(self, origins, directions):
        """The rays' leading shape, their count n and the arrays as given, checked: (..., 3) arrays of
        real numbers whose leading shapes broadcast together (`_fill_rays` then converts and checks values)."""
        o, d = real_array(origins, "origins"), real_array(directions, "directions")
        for name, a in (("origins", o), ("directions", d)):
            if a.ndim == 0 or a.shape[-1] != 3:
                raise UsageError(f"{name} of shape {a.shape} are not allowed; allowed: (N, 3) or (..., 3), one (x, y, z) per ray")
        try:
            shape = np.broadcast_shapes(o.shape[:-1], d.shape[:-1])
        except ValueError:
            raise UsageError(
                f"origins {o.shape} and directions {d.shape} do not go together; allowed: the same shape, "
                "or leading shapes that broadcast (one (3,) origin for many directions)"
            ) from None
        n = math.prod(shape)
        self.device.check_fits(n * 12, f"{n} rays")  # before any buffer is made
        return shape, n, o, d

    @staticmethod
    def _fill_rays(host: dict, shape, o, d) -> None:
        """Write the rays into the mapped input buffer as packed float32 (x, y, z) triples (conversion,
        broadcast and copy in one assignment each), then refuse non-finite rays and zero directions."""
        with np.errstate(over="ignore"):  # beyond float32: inf, refused below with the message
            host["origins"].reshape(*shape, 3)[...] = o
            host["directions"].reshape(*shape, 3)[...] = d
        o, d = host["origins"], host["directions"]
        # a float32 direction is zero exactly when its three components are +-0: their bits or'ed
        # together, less the sign bit, are zero (a third of the float64 dot product's time)
        bits = d.view(np.uint32)
        nonzero = bits[:, 0] | bits[:, 1]
        nonzero |= bits[:, 2]
        nonzero <<= 1
        if np.isfinite(o).all() and np.isfinite(d).all() and nonzero.all():
            return
        good = np.isfinite(o).all(1) & np.isfinite(d).all(1) & (nonzero != 0)
        i = int(np.argmin(good))
        where = tuple(int(k) for k in np.unravel_index(i, shape)) if len(shape) != 1 else i
        raise UsageError(
            f"ray origins and directions must be finite, and directions nonzero; ray {where} has origin "
            f"{tuple(o[i].tolist())} and direction {tuple(d[i].tolist())}"
        )

    @staticmethod
    def _fill_per_ray(host: dict, shape, value, name) -> None:
        """Write a number, or an array that broadcasts to the rays' leading shape, into the mapped
        input buffer's per-ray float32 `name` (t_min, t_max), checked."""
        a = real_array(value, name)
        with np.errstate(over="ignore"):  # a distance beyond float32 is inf, as the kernels see it
            a = a.astype(np.float32, copy=False)
        try:
            np.broadcast_to(a, shape)
        except ValueError:
            raise UsageError(
                f"{name} of shape {a.shape} does not fit rays of shape {shape}; allowed: a number or an array that broadcasts to {shape}"
            ) from None
        if np.isnan(a).any():
            raise UsageError(f"{name} must not be NaN")
        host[name].reshape(shape)[...] = a

    def _query(self, kind: str, origins, directions, distances: dict):
        """Run query `kind` ("intersect" or "occluded") on host rays through the Tracer's kept buffers
        (ray_buffers.py): checked rays and distances written in, the kernel, then fresh host copies of
        its outputs, by parameter name, and the rays' leading shape."""
        shape, n, o, d = self._rays(origins, directions)
        queue = self.device.queue
        with self._query_lock:  # the kept buffers serve one call at a time
            inputs, outputs = self._ray_buffers[kind].blocks(n)
            with inputs.mapped(queue, n, cl.map_flags.WRITE_INVALIDATE_REGION) as host:
                self._fill_rays(host, shape, o, d)
                for name, value in distances.items():
                    self._fill_per_ray(host, shape, value, name)
            knl = self._bound.get(kind)
            if knl is None:  # the scene's arguments set once, the buffers' only when they are new
                knl = self._bound[kind] = self.kernel(QUERY_KERNELS[kind]).bound()
                knl.set(**self._geometry())
            knl.set(params=self._query_params(n), **inputs.args, **outputs.args)
            layout = self.layout
            knl.enqueue(queue, global_size(-(-n // layout.rays_per_item), layout.local_size), (layout.local_size,))
            with outputs.mapped(queue, n, cl.map_flags.READ) as host:  # waits for the kernel (in-order queue)
                answers = {name: a != 0 if name == "occluded_out" else a.copy() for name, a in host.items()}
        return shape, answers

    def _geometry(self) -> dict:
        """The scene's buffers, as every ray-query kernel takes them (the scene tables' regions: _query_params)."""
        return dict(nodes=self.nodes, prims=self.prims, prim_object=self.prim_object, tables=self._query_tables.buffer)

    def _query_params(self, n: int) -> np.ndarray:
        """The ray-query kernels' QueryParams record for n rays."""
        params = np.zeros((), QUERY_PARAMS_DTYPE)
        params["tables"], params["n_prims"], params["n_instances"], params["n_rays"] = self._query_tables.record, self.n_prims, self.n_instances, n
        return params

    def render_buffers(self) -> dict:
        """The scene's arguments, as the render kernels take them (trace.cl render, path.cl render_path): the ray
        queries' (_geometry) with the shading's tables, per-primitive normals and attributes and the textures' texels."""
        return {**self._geometry(), "tables": self.tables.buffer, "normals": self.normals, "attributes": self.attributes, "texels": self.texels}

    def _launch(self, name: str, n: int, **args) -> cl.Event:
        """Kernel `name` of trace.cl over n rays (self.layout.rays_per_item per work-item) with the
        scene's geometry, as every ray kernel takes it."""
        layout = self.layout
        size = global_size(-(-n // layout.rays_per_item), layout.local_size)
        return self.kernel(name)(self.device.queue, size, (layout.local_size,), params=self._query_params(n), **self._geometry(), **args)

    def launch_intersect(self, n, origins, directions, t_min, outputs) -> cl.Event:
        """Closest-hit kernel on device buffers (for benchmarks); t_min a per-ray buffer;
        outputs = (t, prim, object, visits) buffers."""
        t, prim, obj, visits = outputs
        return self._launch(
            "intersect_rays", n, origins=origins, directions=directions, t_min=t_min, t_out=t, prim_out=prim, object_out=obj, visits_out=visits
        )

    def launch_occluded(self, n, origins, directions, t_min, t_max, outputs) -> cl.Event:
        """Any-hit kernel on device buffers; t_min, t_max per-ray buffers; outputs = (occluded, visits) buffers."""
        occluded, visits = outputs
        return self._launch(
            "occluded_rays",
            n,
            origins=origins,
            directions=directions,
            t_min=t_min,
            t_max=t_max,
            occluded_out=occluded,
            visits_out=visits,
        )

    def intersect(self, origins, directions, t_min=0.0):
        """Closest hits at origin + t * direction, t > t_min: (t, primitive id, object id); inf, -1, -1 on a miss.

        origins and directions are (..., 3) arrays whose leading shapes broadcast together (the same
        shape, or one (3,) origin for many directions); t_min a number or an array that broadcasts to
        that shape; the three results have that shape.

        t is in units of each direction as given (not normalised).  Of hits at the same float32 t, the
        lowest primitive id is returned, with the BVH on or off and for every builder."""
        shape, out = self._query("intersect", origins, directions, {"t_min": t_min})
        self.last_visits = out["visits_out"]  # flat, one per ray
        return out["t_out"].reshape(shape), out["prim_out"].reshape(shape), out["object_out"].reshape(shape)

    def occluded(self, origins, directions, t_max, t_min=0.0):
        """True where any surface lies at origin + t * direction with t_min < t < t_max (t in units of
        the direction as given), in the rays' leading shape; shapes as for `intersect`."""
        shape, out = self._query("occluded", origins, directions, {"t_min": t_min, "t_max": t_max})
        self.last_visits = out["visits_out"]
        return out["occluded_out"].reshape(shape)
