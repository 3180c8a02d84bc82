"""Rendering instances (kernels/intersect.h instance_surface, hit_object, hit_data; clrender/trace/instancing.py):
a mesh that several objects place, stored once, shades as the same scene flattened does, with normals carried to
world space by the inverse transpose.  Independent answers: the flat scene (world vertices and vertex normals
that scene.py placed in float64) and, for normals, the analytic ellipsoid in float64 numpy."""

import numpy as np
import pytest
import trimesh

from clrender.errors import UsageError
from clrender.scene.scene import Scene
from clrender.trace.instancing import AUTO_MIN_TRIANGLES, find_instances
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests.scenetools import CARD_OBJ, copies_scene, write_checker

# Per-pixel agreement of an instanced render with the flat one.  The two differ only by float32 rounding: the
# flat scene's vertices are rounded once in world space, the instance's ray goes through a 3x4 transform.  A
# camera ray that passes within rounding of an edge may meet the neighbouring triangle or object in one render
# and not in the other, and a shadow ray that grazes a silhouette may be blocked in one only: such pixels may
# differ by anything, and are at most EDGE_FRACTION of the image (at 96 x 72, 0.3% is 20 pixels; none seen: 0 ids
# and 0 colours differ, the largest difference 4e-5 Whitted and 3e-4 path, 2026-11-25).
# Every other pixel agrees within COLOUR_ATOL (a few float32 ulps of the shading, which reads normals and points
# that went through different rounding).
COLOUR_ATOL = 1e-3
EDGE_FRACTION = 0.003
SIZE = dict(width=96, height=72)


def bunny_row(smooth_mirrored: bool = False, resolution: int = 24) -> dict:
    """Five bunnies in a row, turned, scaled (one non-uniformly, one mirrored) and moved, one shiny, one glass; a sphere and
    a floor that stay flat; a point and an area light.  Smooth, but for the mirrored one unless asked (its flat
    copy shades by its winding, not its normals: see test_a_mirrored_instance_...)."""
    objects = []
    for i, (scale, turn) in enumerate([(1.3, 20), ([0.9, 1.8, 1.1], -35), ([-1.3, 1.3, 1.3], 60), (1.1, 150), (1.5, 250)]):
        bunny = {"type": "mesh", "generator": "bunny", "params": {"resolution": resolution}, "smooth": i != 2 or smooth_mirrored}
        objects.append({**bunny, "translate": [1.05 * i - 2.1, -0.25, 0.3 * (i % 2)], "rotate": [0, turn, 0], "scale": scale})
    objects[3]["material"], objects[4]["material"] = "shiny", "glass"
    objects += [
        {"type": "sphere", "center": [0.4, 1.6, -1.0], "radius": 0.4},
        {"type": "quad", "corner": [-5, -0.3, -3], "edge_a": [10, 0, 0], "edge_b": [0, 0, 6]},
    ]
    return {
        "cameras": [{"position": [0, 1.0, 4.0], "look_at": [0, 0.4, 0], "fov": 60}],
        "materials": {
            "shiny": {"diffuse": [0.7, 0.6, 0.5], "specular": [0.3, 0.3, 0.3], "shininess": 30, "mirror": 0.2},
            "glass": {"diffuse": [0.2, 0.3, 0.2], "transparency": 0.6, "ior": 1.4},  # refracts; dims the shadows it casts
        },
        "lights": [
            {"type": "point", "position": [1, 8, 6]},
            {"type": "area", "corner": [-2, 5, 2], "edge_a": [1, 0, 0], "edge_b": [0, 0, 1], "samples": 2},
        ],
        "objects": objects,
    }


def disagreement(a, b):
    """The fraction of pixels whose colours differ by more than COLOUR_ATOL."""
    return float((np.abs(a - b).max(axis=-1) > COLOUR_ATOL).mean())


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_an_instanced_render_is_the_flat_render(device, integrator):
    scene = Scene.from_dict(bunny_row())
    kw = dict(SIZE, integrator=integrator, max_depth=3, seed=5, **({"spp": 2} if integrator == "path" else {}))
    flat, inst = (Renderer(scene, tracer=Tracer(scene, device=device, instancing=i), **kw) for i in (False, True))
    assert flat.tracer.n_instances == 0 and inst.tracer.n_instances == 5
    a, b = flat.run(), inst.run()
    assert np.isin(a.ids, range(5)).mean() > 0.1  # the bunnies fill a good part of the picture
    assert (a.ids != b.ids).mean() <= EDGE_FRACTION
    assert disagreement(a.image, b.image) <= EDGE_FRACTION


# Ellipsoids: the unit sphere (an icosphere, 5120 faces) placed twice by non-uniform scales, one mirrored.  Shading
# normals are the interpolated vertex normals; the tessellation alone puts them within NORMAL_DEGREES of the
# analytic normal where the surface faces the camera (|cos| > MIN_COS; measured max about 0.6 degrees), while normals
# carried by M instead of M^-T, the usual mistake, are off by tens of degrees on these scales.
NORMAL_DEGREES = 1.5
MIN_COS = 0.3
ELLIPSOIDS = [  # (scale, rotate, translate)
    ([1.6, 0.5, 0.9], [0, 30, 20], [-1.0, 0.3, 0.0]),
    ([-0.7, 1.2, 0.6], [10, -40, 0], [1.1, 0.2, 0.0]),  # mirrored: determinant < 0
]


def ellipsoid_scene(tmp_path, material: dict) -> Scene:
    trimesh.creation.icosphere(subdivisions=4).export(tmp_path / "sphere.obj")
    objects = [
        {"type": "mesh", "file": "sphere.obj", "smooth": True, "scale": s, "rotate": r, "translate": t, "material": "m"} for s, r, t in ELLIPSOIDS
    ]
    data = {
        "width": 96,
        "height": 72,
        "cameras": [{"position": [0, 0.5, 5], "look_at": [0, 0.3, 0], "fov": 45}],
        "lights": [{"type": "point", "position": [0, 0.5, 5]}],
        "materials": {"m": {"diffuse": [1, 1, 1], **material}},
        "objects": objects,
    }
    return Scene.from_dict(data, base_dir=tmp_path)


def analytic_ellipsoids(scene: Scene):
    """Per pixel centre, in float64: the nearest ellipsoid (object id, -1: none), its t and its outward unit normal
    n = M^-T y at object-space point y (for M = R S: R S^-2 R^T (x - c), i.e. (x/a^2, y/b^2, z/c^2) in its frame), and
    the normal M y that carrying normals like points would give."""
    o, d = scene.camera(1).rays(scene.width, scene.height)
    best_t = np.full(d.shape[:2], np.inf)
    ids, normal, wrong = np.full(d.shape[:2], -1), np.zeros(d.shape), np.zeros(d.shape)
    for oid, obj in enumerate(scene.objects):
        m = np.asarray(obj.to_world, np.float64)
        inv = np.linalg.inv(m)
        oo, dd = o @ inv[:3, :3].T + inv[:3, 3], d @ inv[:3, :3].T  # |oo + t dd| = 1 on the unit sphere
        a, b, c = (dd * dd).sum(-1), 2 * (oo * dd).sum(-1), (oo * oo).sum(-1) - 1
        disc = b * b - 4 * a * c
        t = np.where(disc > 0, (-b - np.sqrt(np.maximum(disc, 0))) / (2 * a), np.inf)
        near = (t > 0) & (t < best_t)
        y = oo + np.where(near, t, 0.0)[..., None] * dd  # misses at t = 0: no inf * 0
        n, w = y @ inv[:3, :3], y @ m[:3, :3].T  # (M^-T y) as rows; M y
        best_t[near], ids[near] = t[near], oid
        normal[near] = (n / np.linalg.norm(n, axis=-1, keepdims=True))[near]
        wrong[near] = (w / np.linalg.norm(w, axis=-1, keepdims=True))[near]
    return ids, best_t, normal, wrong, d


def degrees_between(a, b):
    return np.degrees(np.arccos(np.clip((a * b).sum(-1) / np.linalg.norm(a, axis=-1) / np.linalg.norm(b, axis=-1), -1, 1)))


def test_instanced_ellipsoids_shade_with_the_analytic_normals(device, tmp_path):
    scene = ellipsoid_scene(tmp_path, {})
    assert len(find_instances(scene).records) == 2
    result = Renderer(scene, tracer=Tracer(scene, device=device, instancing=True), aovs=("normal", "depth")).run()
    ids, t, normal, wrong, d = analytic_ellipsoids(scene)
    facing = (ids >= 0) & (result.ids == ids) & (np.abs((normal * d).sum(-1)) > MIN_COS)
    for oid in (0, 1):  # both copies, the mirrored one included, fill a good part of the picture
        assert (facing & (ids == oid)).sum() > 300
    assert ((result.ids >= 0) == (ids >= 0)).mean() > 0.98  # silhouettes within the tessellation's
    error = degrees_between(result.aovs["normal"][facing], normal[facing])
    assert error.max() < NORMAL_DEGREES
    assert degrees_between(wrong[facing], normal[facing]).max() > 10 * NORMAL_DEGREES  # the test tells M^-T from M


@pytest.mark.parametrize("instancing", [True, False])
def test_a_mirrored_instance_faces_outward(device, tmp_path, instancing):
    """Single-sided material (camera rays cull back faces): the camera sees the near side of both ellipsoids, so
    the front is the outside, by the inverse-transpose normal, for the mirrored copy too (depth = the analytic t),
    flat and instanced alike (issue 38, defect 7: the flat copy's world winding faced in, and was culled)."""
    scene = ellipsoid_scene(tmp_path, {"double_sided": False})
    result = Renderer(scene, tracer=Tracer(scene, device=device, instancing=instancing), aovs=("depth",)).run()
    ids, t, normal, _, d = analytic_ellipsoids(scene)
    facing = (ids >= 0) & (result.ids == ids) & (np.abs((normal * d).sum(-1)) > MIN_COS)
    assert (facing & (ids == 1)).sum() > 300
    # the icosphere lies inside the sphere by at most 1 - cos(half an edge's angle) ~ 1e-3 of the radius
    np.testing.assert_allclose(result.aovs["depth"][facing], t[facing], rtol=3e-3)


DEVICE_BUFFERS = ("nodes", "prims", "prim_object", "normals", "attributes")


def device_bytes(tracer: Tracer) -> int:
    """The scene's device buffers: the geometry's, and the scene tables' arena (objects, materials, instances, top tree)."""
    return sum(getattr(tracer, name).size for name in DEVICE_BUFFERS) + tracer.tables.buffer.size


def test_thirty_instances_render_in_about_one_copys_device_memory(device, tmp_path):
    """The per-primitive records (vertex normals here) are stored once per mesh too: 30 copies keep 1.1 x one
    copy's device bytes + 256 bytes a copy (its Instance record and top-level node)."""
    one = Tracer(copies_scene(tmp_path, 1), device=device)
    scene = copies_scene(tmp_path, 30)
    flat, inst = (Renderer(scene, tracer=Tracer(scene, device=device, instancing=i), width=48, height=32) for i in (False, True))
    assert inst.tracer.n_instances == 30
    assert device_bytes(inst.tracer) <= 1.1 * device_bytes(one) + 256 * 30
    assert device_bytes(flat.tracer) > 20 * device_bytes(one)
    a, b = flat.run(), inst.run()
    assert len(np.unique(a.ids)) == 31  # every copy in the picture, and the background
    assert (a.ids != b.ids).mean() <= EDGE_FRACTION and disagreement(a.image, b.image) <= EDGE_FRACTION


def test_renders_instance_by_themselves_above_the_threshold_and_keep_small_scenes_flat(tmp_path):
    big = copies_scene(tmp_path, 30)  # 29 copies x 1280 triangles beyond the first: 37,120 >= AUTO_MIN_TRIANGLES
    small = copies_scene(tmp_path, 8)  # 8960: below it
    assert 29 * 1280 >= AUTO_MIN_TRIANGLES > 7 * 1280
    assert Renderer(big, width=8, height=8).tracer.n_instances == 30
    assert Renderer(small, width=8, height=8).tracer.n_instances == 0
    assert Renderer(small, width=8, height=8, instancing=True).tracer.n_instances == 8
    assert Renderer(big, width=8, height=8, instancing=False).tracer.n_instances == 0
    with pytest.raises(UsageError, match="instancing 'yes' must be True, False or None"):
        Renderer(small, width=8, height=8, instancing="yes")


def test_emissive_copies_stay_flat_where_the_path_tracer_samples_them(device, tmp_path):
    """Objects of an emissive material are never instanced (instancing.emissive): the path tracer's emitter list
    holds each of their triangles in world space, and the render is the flat one bit for bit."""
    scene = copies_scene(tmp_path, 4, {"diffuse": [0.5, 0.5, 0.5], "emission": [2, 2, 2]})
    assert not find_instances(scene).shapes
    kw = dict(width=24, height=16, integrator="path", spp=2, seed=3)
    a, b = (Renderer(scene, tracer=Tracer(scene, device=device, instancing=i), **kw).run() for i in (False, True))
    assert a.image.max() > 0
    np.testing.assert_array_equal(a.image, b.image)


@pytest.mark.parametrize(
    "integrator, alpha",
    [
        ("whitted", {"mode": "mask"}),
        ("whitted", {"mode": "blend", "factor": 0.7}),
        pytest.param("path", {"mode": "mask"}, marks=pytest.mark.slow),  # two kernel builds, ~2 min cold
    ],
)
def test_alpha_tested_instances_let_rays_through_their_holes_as_flat_copies_do(device, tmp_path, integrator, alpha):
    """Two copies of a card (.obj with uvs) whose base colour texture's alpha is a checker (tests/trace/
    test_alpha.py's), MASK or BLEND: camera, bounce and shadow rays pass its holes (BLEND: blend and dim through
    the rest), read through the instance's uvs (hit_data) and object (hit_object, hit_transparency)."""
    write_checker(tmp_path)
    (tmp_path / "card.obj").write_text(CARD_OBJ)
    card = {"type": "mesh", "file": "card.obj", "material": "card"}
    data = {
        "width": 64,
        "height": 48,
        "cameras": [{"position": [0, 0, 10], "look_at": [0, 0, 0], "fov": 30}],
        "textures": {"checker": {"file": "checker.png", "filter": "nearest"}},
        "materials": {"card": {"diffuse": [1, 0, 0], "diffuse_texture": "checker", "alpha": alpha}, "floor": {"diffuse": [1, 1, 1]}},
        "lights": [{"type": "point", "position": [0.3, 0.2, 4.0]}],
        "objects": [
            {**card, "translate": [-1.2, 0, 1]},
            {**card, "translate": [1.3, 0.2, 1.5], "rotate": [0, 0, 30], "scale": [0.8, 1.1, 1]},
            {"type": "quad", "corner": [-5, -4, 0], "edge_a": [10, 0, 0], "edge_b": [0, 8, 0], "material": "floor"},
        ],
    }
    scene = Scene.from_dict(data, base_dir=tmp_path)
    assert len(find_instances(scene).records) == 2 and scene.objects[0].uvs is not None
    kw = dict(integrator=integrator, max_depth=2, seed=1, **({"spp": 2} if integrator == "path" else {}))
    a, b = (Renderer(scene, tracer=Tracer(scene, device=device, instancing=i), **kw).run() for i in (False, True))
    on_cards = np.isin(a.ids, (0, 1))
    assert 0.1 < on_cards.mean() and (a.ids == 2).mean() > 0.3  # cards, and the floor through their holes and around
    assert (a.ids != b.ids).mean() <= EDGE_FRACTION and disagreement(a.image, b.image) <= EDGE_FRACTION


def test_the_command_line_sets_instancing():
    from clrender.cli import build_parser
    from clrender.commands.render import settings_from_args

    def settings(*argv):
        return settings_from_args(build_parser().parse_args(["render", "bunny", *argv]))

    assert settings().instancing is None
    assert settings("--instancing").instancing is True
    assert settings("--no-instancing").instancing is False


def test_normal_mapped_instances_turn_their_tangents_to_world_space(device, tmp_path):
    """Two copies of a uv-mapped card with a uniform normal map tilted 30 degrees towards +u, one turned about its
    normal and stretched: the instance's tangents are the mesh's, turned by object_to_world per hit
    (kernels/surface.h tangent_frame), and shade as the flat copies' world tangents do.  Without the turn the turned
    copy's shading would differ (checked below by its brightness range)."""
    import math

    from PIL import Image

    n = np.array([math.sin(math.radians(30)), 0.0, math.cos(math.radians(30))])
    Image.fromarray(np.broadcast_to(np.round((n + 1) / 2 * 255).astype(np.uint8), (2, 2, 3)).copy()).save(tmp_path / "n.png")
    (tmp_path / "card.obj").write_text(CARD_OBJ)
    card = {"type": "mesh", "file": "card.obj", "material": "m"}
    data = {
        "width": 64,
        "height": 32,
        "cameras": [{"position": [0, 0, 8], "look_at": [0, 0, 0], "fov": 35}],
        "textures": {"n": {"file": "n.png"}},
        "materials": {"m": {"base_color": [0.5, 0.5, 0.5], "normal_texture": "n"}},
        "lights": [{"type": "directional", "direction": [-0.6, -0.2, -1.0]}],
        "objects": [{**card, "translate": [-1.5, 0, 0]}, {**card, "translate": [1.5, 0, 0], "rotate": [0, 0, 90], "scale": [1.2, 0.8, 1]}],
    }
    scene = Scene.from_dict(data, base_dir=tmp_path)
    assert len(find_instances(scene).records) == 2
    a, b = (Renderer(scene, tracer=Tracer(scene, device=device, instancing=i)).run() for i in (False, True))
    left, right = a.image[a.ids == 0][:, 0], a.image[a.ids == 1][:, 0]
    assert len(left) > 100 and len(right) > 100
    assert abs(np.median(left) - np.median(right)) > 0.05  # the turned copy's tilt points elsewhere: another shade
    assert (a.ids != b.ids).mean() <= EDGE_FRACTION and disagreement(a.image, b.image) <= EDGE_FRACTION


def test_gltf_nodes_sharing_a_smooth_mesh_render_as_the_flat_nodes(device, tmp_path):
    """Two glTF nodes naming one quad whose NORMALs lean away from the face (so the interpolated normal is not the
    facet's), the second node turned and stretched: the instance's vertex normals, taken back to the mesh's space
    (shape_meshes) and out again per hit, shade as scene.py's world normals of the flat nodes."""
    from tests.gltftools import CAMERA, LIGHT, LIGHT_NODE, gltf_file, quaternion

    nodes = [
        {"mesh": 0, "translation": [-1.2, 0.0, -1.0]},
        {"mesh": 0, "translation": [1.2, 0.1, -1.5], "rotation": quaternion([0.3, 1, 0], 35), "scale": [0.6, 1.3, 1.0]},
        {"camera": 0, "translation": [0, 0, 3]},
        {**LIGHT_NODE, "rotation": quaternion([1, 0.5, 0], 25)},
    ]
    tilted = [[0.4, 0.2, 1.0], [-0.3, 0.3, 1.0], [0.1, -0.4, 1.0], [-0.2, -0.1, 1.0]]
    path = gltf_file(tmp_path, nodes, cameras=[{**CAMERA, "perspective": {"yfov": 1.2, "aspectRatio": 1.5}}], lights=[LIGHT], normals=tilted)
    scene = Scene.load(path)
    assert len(find_instances(scene).records) == 2 and all(o.smooth for o in scene.objects)
    a, b = (Renderer(scene, tracer=Tracer(scene, device=device, instancing=i), width=48, height=32).run() for i in (False, True))
    assert (a.ids == 0).sum() > 100 and (a.ids == 1).sum() > 40 and np.ptp(a.image[a.ids == 1][:, 0]) > 0.05  # shading varies across it
    assert (a.ids != b.ids).mean() <= EDGE_FRACTION and disagreement(a.image, b.image) <= EDGE_FRACTION


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_single_sided_gltf_copies_mirrored_or_not_render_the_same_picture_flat_and_instanced(device, tmp_path, integrator):
    """Issue 38, defect 7: three glTF nodes of one single-sided quad (doubleSided false, the glTF default) facing the
    camera, one mirrored in x and one in y (the glTF front stays the camera's side: the determinant reverses the
    winding).  Flat and instanced renders at 32 x 24 show all three quads (ids against the analytic layout), and are
    the same picture within EDGE_FRACTION (the old flat render culled the mirrored quads: 2 x ~60 of 768 pixels)."""
    from tests.gltftools import CAMERA, LIGHT, LIGHT_NODE, gltf_file

    nodes = [
        {"mesh": 0, "translation": [-2.3, 0.0, 0.0]},
        {"mesh": 0, "translation": [0.0, 0.0, 0.0], "scale": [-1, 1, 1]},
        {"mesh": 0, "translation": [2.3, 0.0, 0.0], "scale": [1, -1, 1]},
        {"camera": 0, "translation": [0, 0, 6]},
        LIGHT_NODE,
    ]
    material = {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1]}, "doubleSided": False}
    camera = {**CAMERA, "perspective": {"yfov": 0.9, "aspectRatio": 32 / 24}}
    scene = Scene.load(gltf_file(tmp_path, nodes, cameras=[camera], lights=[LIGHT], materials=[material]))
    assert not scene.materials[scene.objects[0].material].double_sided
    kw = dict(width=32, height=24, integrator=integrator, max_depth=2, seed=3, **({"spp": 4} if integrator == "path" else {}))
    flat, inst = (Renderer(scene, tracer=Tracer(scene, device=device, instancing=i), **kw) for i in (False, True))
    assert inst.tracer.n_instances == 3
    a, b = flat.run(), inst.run()
    # the quads span x in [-3.3, -1.3], [-1, 1], [1.3, 3.3], y in [-1, 1]: each covers about 60 pixels
    for oid in range(3):
        assert (a.ids == oid).sum() > 40 and (b.ids == oid).sum() > 40, (oid, (a.ids == oid).sum(), (b.ids == oid).sum())
    assert (a.ids != b.ids).mean() <= EDGE_FRACTION and disagreement(a.image, b.image) <= EDGE_FRACTION
