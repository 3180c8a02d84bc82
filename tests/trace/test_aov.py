"""AOVs: depth, normal, albedo, id and edges of the primary hit, checked against analytic geometry.

The references are computed here in numpy float64 from the scene's numbers
alone: the pinhole camera's ray through each pixel centre, the sphere's and
the plane's intersection formulas, and the materials' colours.
"""

import math

import numpy as np
import OpenImageIO as oiio
import pytest

from clrender.trace.aov import CHANNELS
from clrender.trace.renderer import Renderer

from tests.clitools import run_cli

W, H, FOV = 32, 24, 60.0
CENTER, RADIUS = np.array([0.3, 0.2, -4.0]), 1.0
FLOOR_Y = -1.0
RED, GREEN = (0.9, 0.2, 0.1), (0.1, 0.7, 0.3)
SCENE = {
    "width": W,
    "height": H,
    "background": [0.2, 0.3, 0.4],
    "cameras": [{"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": FOV}],
    "materials": {"red": {"diffuse": list(RED)}, "green": {"diffuse": list(GREEN), "mirror": 0.3}},
    "lights": [{"type": "point", "position": [2, 4, 0]}],
    "objects": [
        {"type": "sphere", "center": CENTER.tolist(), "radius": RADIUS, "material": "red"},  # object 0
        {"type": "plane", "point": [0, FLOOR_Y, -4], "normal": [0, 1, 0], "size": 40, "material": "green"},  # object 1
    ],
}
ALL = ("depth", "normal", "albedo", "id", "edges")


def pixel_rays():
    """Unit directions (H, W, 3) through the pixel centres of the canonical camera (eye at the origin, looking down -z)."""
    half_h = math.tan(math.radians(FOV) / 2)
    half_w = half_h * W / H
    ys, xs = np.mgrid[0:H, 0:W] + 0.5
    d = np.stack([(2 * xs / W - 1) * half_w, (1 - 2 * ys / H) * half_h, -np.ones((H, W))], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def analytic_hits():
    """Distance, object (0 sphere, 1 floor, -1 none) and a mask of pixels far from any silhouette."""
    d = pixel_rays()
    b = d @ CENTER  # ray o + t d from the origin: t^2 - 2 b t + |c|^2 - r^2 = 0
    disc = b * b - (CENTER @ CENTER - RADIUS**2)
    t_sphere = np.where(disc > 0, b - np.sqrt(np.maximum(disc, 0)), np.inf)
    t_floor = np.where(d[..., 1] < 0, FLOOR_Y / np.minimum(d[..., 1], -1e-300), np.inf)
    with np.errstate(invalid="ignore"):  # inf * 0
        x, z = d[..., 0] * t_floor, d[..., 2] * t_floor + 4  # floor coordinates about its centre (0, -1, -4)
    outside = np.nan_to_num(np.maximum(np.abs(x), np.abs(z)), nan=np.inf) - 20  # the plane is a 40 x 40 square
    t_floor[outside > 0] = np.inf
    t = np.minimum(t_sphere, t_floor)
    obj = np.where(np.isinf(t), -1, np.where(t_sphere <= t_floor, 0, 1))
    clear = (np.abs(disc) > 0.05) & (np.abs(outside) > 0.5)  # not grazing the sphere, nor near the floor's far edge
    return d, t, obj, clear


@pytest.fixture(scope="module")
def result():
    return Renderer(SCENE, aovs=ALL).run()


def test_depth_is_the_distance_along_the_primary_ray(result):
    _, t, obj, clear = analytic_hits()
    depth = result.aovs["depth"]
    assert depth.shape == (H, W) and depth.dtype == np.float32
    hit = clear & (obj >= 0)
    assert (obj[clear] == 0).sum() > 20 and (obj[clear] == 1).sum() > 20  # both surfaces are seen
    np.testing.assert_allclose(depth[hit], t[hit], rtol=1e-5)
    assert (depth[clear & (obj < 0)] == 0).all()  # escaped rays: 0, as Mitsuba writes them, never inf


def test_normals_are_the_world_space_normals_of_the_surfaces(result):
    d, t, obj, clear = analytic_hits()
    normal = result.aovs["normal"]
    on_sphere = clear & (obj == 0)
    p = d[on_sphere] * t[on_sphere, None]
    np.testing.assert_allclose(normal[on_sphere], (p - CENTER) / RADIUS, atol=2e-5)
    np.testing.assert_allclose(normal[clear & (obj == 1)], np.broadcast_to([0, 1, 0], normal[clear & (obj == 1)].shape), atol=1e-6)
    assert (normal[clear & (obj < 0)] == 0).all()


def test_albedo_is_the_diffuse_colour_of_the_first_hit(result):
    _, _, obj, clear = analytic_hits()
    table = np.array([RED, GREEN, (0, 0, 0)], np.float32)  # index -1: a miss has no albedo
    np.testing.assert_array_equal(result.aovs["albedo"][clear], table[obj[clear]])


def test_id_is_the_object_id_of_the_primary_hit(result):
    _, _, obj, clear = analytic_hits()
    np.testing.assert_array_equal(result.aovs["id"], result.ids)
    np.testing.assert_array_equal(result.aovs["id"][clear], obj[clear])


def test_edges_without_edge_aa_are_the_mask_edge_aa_resamples(result):
    edge_aa = Renderer(SCENE, aa="edge_detect", samples=2, aovs=("edges",)).run()
    assert result.edge_mask is None  # this render did not run the edge pass; the AOV computed the mask itself
    assert 0 < result.aovs["edges"].sum() < H * W
    np.testing.assert_array_equal(result.aovs["edges"], edge_aa.edge_mask)
    np.testing.assert_array_equal(edge_aa.aovs["edges"], edge_aa.edge_mask)


def test_aovs_come_from_the_centre_ray_not_the_filtered_samples(result):
    """Edge-only AA resamples the silhouettes, but its AOVs are those of the pixel centre, as with no AA."""
    edge_aa = Renderer(SCENE, aa="edge_detect", samples=3, aovs=ALL).run()
    assert not np.array_equal(edge_aa.image, result.image)  # the colours were filtered ...
    for name in ("depth", "normal", "albedo", "id"):  # ... the AOVs were not
        np.testing.assert_array_equal(edge_aa.aovs[name], result.aovs[name])


def test_asking_for_aovs_leaves_the_image_unchanged(result):
    plain = Renderer(SCENE).run()
    np.testing.assert_array_equal(plain.image, result.image)
    assert plain.aovs == {}


def read_channels(path):
    """Channel name -> plane, read with OpenImageIO directly."""
    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    pixels = inp.read_image(0, 0, 0, spec.nchannels, "float").reshape(spec.height, spec.width, spec.nchannels)
    inp.close()
    return {name: pixels[..., i] for i, name in enumerate(spec.channelnames)}, str(spec.format)


@pytest.fixture
def scene_file(tmp_path):
    def vec(v):
        return "[" + ", ".join(repr(float(x)) for x in v) + "]"

    text = f"""width = {W}
height = {H}
background = [0.2, 0.3, 0.4]
[[cameras]]
position = [0, 0, 0]
look_at = [0, 0, -1]
fov = {FOV}
[materials.red]
diffuse = {vec(RED)}
[materials.green]
diffuse = {vec(GREEN)}
mirror = 0.3
[[lights]]
position = [2, 4, 0]
[[objects]]
type = "sphere"
center = {vec(CENTER)}
radius = {RADIUS}
material = "red"
[[objects]]
type = "plane"
point = [0, {FLOOR_Y}, -4]
normal = [0, 1, 0]
size = 40
material = "green"
"""
    path = tmp_path / "scene.toml"
    path.write_text(text)
    return path


def test_exr_output_carries_the_beauty_and_every_aov_as_named_channels(tmp_path, capsys, scene_file, result):
    out = tmp_path / "r.exr"
    code, stdout, err = run_cli(capsys, "render", str(scene_file), "--aov", ",".join(ALL), "-o", str(out))
    assert code == 0, err
    assert stdout.split() == [str(out)]
    planes, fmt = read_channels(out)
    assert fmt == "float"
    expected = {"R", "G", "B", "Z", "N.x", "N.y", "N.z", "albedo.R", "albedo.G", "albedo.B", "id", "edges"}
    assert set(planes) == expected and len(planes) == len(expected)
    np.testing.assert_array_equal(np.stack([planes[c] for c in "RGB"], -1), result.image)
    np.testing.assert_array_equal(planes["Z"], result.aovs["depth"])
    np.testing.assert_array_equal(np.stack([planes[f"N.{a}"] for a in "xyz"], -1), result.aovs["normal"])
    np.testing.assert_array_equal(np.stack([planes[f"albedo.{c}"] for c in "RGB"], -1), result.aovs["albedo"])
    np.testing.assert_array_equal(planes["id"], result.ids.astype(np.float32))
    np.testing.assert_array_equal(planes["edges"], result.aovs["edges"].astype(np.float32))


def test_png_output_gets_its_aovs_in_an_exr_beside_it(tmp_path, capsys, scene_file, result):
    out = tmp_path / "r.png"
    code, stdout, err = run_cli(capsys, "render", str(scene_file), "--aov", "depth,id", "-o", str(out))
    assert code == 0, err
    aov_file = tmp_path / "r.aov.exr"
    assert stdout.split() == [str(out), str(aov_file)]
    planes, _ = read_channels(aov_file)
    assert sorted(planes) == sorted(CHANNELS["depth"] + CHANNELS["id"]) == ["Z", "id"]
    np.testing.assert_array_equal(planes["Z"], result.aovs["depth"])
    # --aov-out names the file instead
    named = tmp_path / "passes.exr"
    code, stdout, err = run_cli(capsys, "render", str(scene_file), "--aov", "normal", "--aov-out", str(named), "-o", str(tmp_path / "s.png"))
    assert code == 0, err
    assert sorted(read_channels(named)[0]) == ["N.x", "N.y", "N.z"]


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["--aov", "depth,colour"], "unknown AOV 'colour'"),
        (["--aov", "depth,depth"], "twice"),
        (["--aov", ","], "names no AOV"),
        (["--aov", "depth", "--aov-out", "passes.png"], "must be an .exr"),
        (["--aov-out", "passes.exr"], "needs --aov"),
    ],
)
def test_bad_aov_options_are_refused_with_one_line(tmp_path, capsys, argv, fragment, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, stdout, err = run_cli(capsys, "render", "refract1", "--width", "8", "--height", "6", *argv, "-o", "x.png")
    assert code == 2
    assert err.startswith("clrender: ") and err.count("\n") == 1 and fragment in err
    assert not list(tmp_path.iterdir())  # nothing written


def nearest_triangles(origin, directions, vertices, faces):
    """Möller-Trumbore in float64 against every triangle: the nearest hit's (t, face, u, v) per ray,
    t = inf and face -1 where a ray meets none (u, v: the weights of the face's second and third vertex)."""
    p0, p1, p2 = (vertices[faces[:, k]] for k in range(3))
    e1, e2 = p1 - p0, p2 - p0
    d = directions.reshape(-1, 1, 3)
    pvec = np.cross(d, e2)
    det = np.einsum("rfk,fk->rf", pvec, e1)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / det
        s = origin - p0
        u = np.einsum("rfk,fk->rf", pvec, s) * inv
        qvec = np.cross(s, e1)
        v = np.einsum("rk,fk->rf", d[:, 0], qvec) * inv
        t = np.einsum("fk,fk->f", qvec, e2) * inv
    hit = (np.abs(det) > 1e-12) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    t = np.where(hit, t, np.inf)
    face = np.argmin(t, axis=1)
    rows = np.arange(len(face))
    nearest = t[rows, face]
    return nearest, np.where(np.isfinite(nearest), face, -1), u[rows, face], v[rows, face]


def test_normals_of_a_smooth_mesh_are_its_interpolated_vertex_normals(tmp_path):
    """A smooth-shaded icosphere (320 faces): the normal AOV is the hit's barycentric blend of the face's
    vertex normals, renormalised, which differs from the flat face normal by up to ~10 degrees here."""
    import trimesh

    from clrender.scene.scene import Scene

    ico = trimesh.creation.icosphere(subdivisions=2)
    obj = ["o ico"] + [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in ico.vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in ico.faces]
    (tmp_path / "ico.obj").write_text("\n".join(obj) + "\n")
    data = {**SCENE, "objects": [{"type": "mesh", "file": "ico.obj", "smooth": True, "translate": CENTER.tolist(), "material": "red"}]}
    scene = Scene.from_dict(data, base_dir=tmp_path)
    (mesh,) = scene.objects
    normal = Renderer(scene, aovs=("normal",)).run().aovs["normal"]

    d = pixel_rays()
    t, face, u, v = nearest_triangles(np.zeros(3), d.reshape(-1, 3), mesh.vertices, mesh.faces)
    inside = (face >= 0) & (np.minimum(np.minimum(u, v), 1 - u - v) > 0.02)  # clear of every edge
    assert inside.sum() > 80
    vn = mesh.vertex_normals[mesh.faces[face[inside]]]  # (n, 3 vertices, 3)
    w = np.stack([1 - u - v, u, v], axis=1)[inside]
    blend = np.einsum("nv,nvk->nk", w, vn)
    blend /= np.linalg.norm(blend, axis=1, keepdims=True)
    np.testing.assert_allclose(normal.reshape(-1, 3)[inside], blend, atol=1e-4)
    # the case tells the two apart: the flat normals are on average degrees away from the blend
    p = mesh.vertices[mesh.faces[face[inside]]]
    flat = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    flat /= np.linalg.norm(flat, axis=1, keepdims=True)
    assert np.degrees(np.arccos(np.clip((flat * blend).sum(1), -1, 1))).mean() > 2
    rays = d.reshape(-1, 3)
    far = np.linalg.norm(CENTER - (rays @ CENTER)[:, None] * rays, axis=1) > 1.05  # rays that pass the sphere by
    assert far.sum() > 200 and (normal.reshape(-1, 3)[far] == 0).all()
