"""Optics the renderer must get right, each checked against its textbook answer.

Every test renders a tiny scene through the public API (Scene.from_dict +
Renderer, aa="none") and compares with geometry computed here in float64:
the camera rays come from the camera definition in docs/scene-format.md
(tests/reference/whitted.camera_rays, not clrender's Camera), and the answers
from the physics (mirror images, Snell's law, Schlick's formula, Lambert's
cosine law, the Blinn-Phong half-vector, projections of shadows).  Pixels
whose ray passes within a hair of a boundary (a silhouette, a shadow edge, a
stripe edge) are left out, since there float32 may fall either side.
"""

from pathlib import Path

import numpy as np
import pytest
import trimesh
from scipy.spatial import Delaunay

import clrender

from tests.reference.whitted import camera_rays

HAIR = 2e-3  # distance (scene units) within which a ray counts as grazing a boundary


def render(data, width, height, base_dir=".", **settings):
    scene = clrender.Scene.from_dict(data, base_dir=base_dir)
    return clrender.Renderer(scene, aa="none", width=width, height=height, **settings).run()


def rays(data, width, height):
    eye, d = camera_rays(data["cameras"][0], width, height)
    return eye, d.reshape(height, width, 3)


def big_quad(z=None, y=None, x=None, half=50.0, material="default", outward=1):
    """A square of side 2*half in the plane z=, y= or x=, its normal (edge_a x edge_b) along +axis*outward."""
    if z is not None:
        corner, a, b = [-half, -half, z], [2 * half, 0, 0], [0, 2 * half, 0]
    elif y is not None:
        corner, a, b = [-half, y, half], [2 * half, 0, 0], [0, 0, -2 * half]
    else:
        corner, a, b = [x, -half, -half], [0, 2 * half, 0], [0, 0, 2 * half]
    if outward < 0:
        a, b = b, a
    return {"type": "quad", "corner": corner, "edge_a": a, "edge_b": b, "material": material}


def hit_plane(eye, d, axis, value):
    """Points and distances where rays from eye along d meet the plane x[axis] = value."""
    t = (value - eye[..., axis]) / d[..., axis]
    return eye + t[..., None] * d, t


def sphere_t(o, d, centre, radius):
    """Nearest positive distance to a sphere (inf on a miss), and how far the ray's line passes from its rim."""
    oc = o - np.asarray(centre, float)
    b = (oc * d).sum(-1)
    closest = np.linalg.norm(oc - b[..., None] * d, axis=-1)
    disc = b * b - ((oc * oc).sum(-1) - radius**2)
    root = np.sqrt(np.maximum(disc, 0))
    t = np.where(-b - root > 0, -b - root, -b + root)
    return np.where((disc >= 0) & (t > 0), t, np.inf), np.abs(closest - radius)


def stripes(x0, width, count, z, height=60.0, prefix="stripe"):
    """Vertical stripes (one object each) side by side along x in the plane z."""
    return [
        {
            "type": "quad",
            "corner": [x0 + i * width, -height / 2, z],
            "edge_a": [width, 0, 0],
            "edge_b": [0, height, 0],
            "material": f"{prefix}{i % 2}",
        }
        for i in range(count)
    ]


STRIPE_MATERIALS = {"stripe0": {"diffuse": [0.9, 0.2, 0.2]}, "stripe1": {"diffuse": [0.2, 0.2, 0.9]}}


# ------------------------------------------------------------------ mirrors
def test_sphere_seen_in_a_plane_mirror_sits_at_its_mirrored_position():
    W, H = 64, 48
    centre, radius = np.array([1.5, 0.3, -1.0]), 1.0  # outside the view: only its image shows
    data = {
        "cameras": [{"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": 60}],
        "materials": {"mirror": {"mirror": 1.0}, "red": {"diffuse": [0.8, 0.1, 0.1]}},
        "lights": [{"type": "point", "position": [0, 5, 0]}],
        "objects": [big_quad(z=-6.0, material="mirror"), {"type": "sphere", "center": centre.tolist(), "radius": radius, "material": "red"}],
    }
    ids = render(data, W, H).path_ids
    eye, d = rays(data, W, H)
    image_centre = centre * [1, 1, -1] + [0, 0, 2 * -6.0]  # the mirror z = -6 sends z to -12 - z
    t_real, rim_real = sphere_t(eye, d, centre, radius)
    t_image, rim_image = sphere_t(eye, d, image_centre, radius)
    expected = np.isinf(t_real) & np.isfinite(t_image)
    seen = (ids[..., 0] == 0) & (ids[..., 1] == 1)
    clear = (rim_real > HAIR) & (rim_image > HAIR)
    assert expected.sum() > 30
    assert np.array_equal(seen[clear], expected[clear])


def parallel_mirrors(max_depth):
    """Two facing mirrors at x = -1.5 and x = +1.5 and a sphere between them, viewed at a slant."""
    data = {
        "cameras": [{"position": [-0.5, 0.2, 0], "look_at": [1.5, 0, -3], "fov": 70}],
        "materials": {"mirror": {"mirror": 1.0}, "red": {"diffuse": [0.8, 0.1, 0.1]}},
        "lights": [{"type": "point", "position": [0, 3, -2]}],
        "objects": [
            big_quad(x=-1.5, half=100, material="mirror"),
            big_quad(x=1.5, half=100, material="mirror", outward=-1),
            {"type": "sphere", "center": [0.5, 0, -4], "radius": 0.4, "material": "red"},
        ],
    }
    return data


@pytest.mark.parametrize("max_depth", [1, 3, 5])
def test_a_hall_of_two_mirrors_shows_exactly_max_depth_nested_images(max_depth):
    W, H = 64, 48
    data = parallel_mirrors(max_depth)
    ids = render(data, W, H, max_depth=max_depth).path_ids
    # clrender: how many mirrors the path met before the sphere (-1: no sphere on the path)
    on_sphere = ids == 2
    bounces = np.where(on_sphere.any(-1), on_sphere.argmax(-1), -1)
    # unfolded: the ray goes straight through mirror-image rooms; room m holds the sphere reflected |m| times
    eye, d = rays(data, W, H)
    a, (x0, y0, z0) = 1.5, (0.5, 0, -4)
    first_t, first_m, grazing = np.full((H, W), np.inf), np.full((H, W), -1), np.zeros((H, W), bool)
    for m in range(-(max_depth + 3), max_depth + 4):
        centre = (2 * a * m + (-1) ** m * x0, y0, z0)
        t, rim = sphere_t(eye, d, centre, 0.4)
        nearer = t < first_t
        first_t[nearer], first_m[nearer] = t[nearer], abs(m)
        grazing |= rim < HAIR
    expected = np.where(first_m <= max_depth, first_m, -1)
    assert set(np.unique(bounces[bounces >= 0])) == set(range(max_depth + 1))
    assert np.array_equal(bounces[~grazing], expected[~grazing])


# --------------------------------------------------------------- refraction
def test_a_glass_slab_shifts_a_ray_sideways_by_t_sin_theta_minus_theta_t_over_cos_theta_t():
    W, H, n, thickness = 48, 32, 1.5, 1.0
    count, width, x0, z_back = 80, 0.25, -18.0, -8.0
    data = {
        "cameras": [{"position": [0, 0, 0], "look_at": [-1, 0, -1], "fov": 40}],
        "materials": {"glass": {"transparency": 1.0, "ior": n}, **STRIPE_MATERIALS},
        "lights": [{"type": "point", "position": [0, 5, 0]}],
        "objects": [
            big_quad(z=-2.0, material="glass"),
            big_quad(z=-2.0 - thickness, material="glass", outward=-1),
            *stripes(x0, width, count, z_back),
        ],
    }
    ids = render(data, W, H).path_ids
    eye, d = rays(data, W, H)
    cos_theta = -d[..., 2]
    theta = np.arccos(cos_theta)
    theta_t = np.arcsin(np.sin(theta) / n)
    shift = thickness * np.sin(theta - theta_t) / np.cos(theta_t)
    # the ray leaves parallel to itself, moved by `shift` towards the slab's normal line, in the plane of d and z
    sideways = np.stack([d[..., 0], d[..., 1], np.zeros_like(cos_theta)], -1)
    towards_normal = sideways - (sideways * d).sum(-1, keepdims=True) * d
    towards_normal /= -np.linalg.norm(towards_normal, axis=-1, keepdims=True)
    exit_line = eye + shift[..., None] * towards_normal
    point, _ = hit_plane(exit_line, d, 2, z_back)
    cell = (point[..., 0] - x0) / width
    expected = np.floor(cell).astype(int) + 2  # stripes come after the two slab faces
    clear = (np.abs(cell - np.round(cell)) * width > HAIR) & (cell > 0) & (cell < count)
    assert clear.sum() > 0.8 * W * H
    assert (ids[..., :2] == [0, 1]).all()
    assert np.abs(shift).max() > 2 * width  # the shift moves the view by several stripes
    assert np.array_equal(ids[..., 2][clear], expected[clear])


def test_the_exit_direction_through_a_glass_sphere_is_the_two_refraction_deviation():
    W, H, n, R = 48, 48, 1.5, 1.0
    centre = np.array([0.0, 0.0, -4.0])
    cells, size, z_back = 24, 0.5, -7.0
    board = [
        {
            "type": "quad",
            "corner": [-6 + i * size, -6 + j * size, z_back],
            "edge_a": [size, 0, 0],
            "edge_b": [0, size, 0],
            "material": f"stripe{(i + j) % 2}",
        }
        for j in range(cells)
        for i in range(cells)
    ]
    data = {
        "cameras": [{"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": 34}],
        "materials": {"glass": {"transparency": 1.0, "ior": n}, **STRIPE_MATERIALS},
        "lights": [{"type": "point", "position": [0, 5, 0]}],
        "objects": [{"type": "sphere", "center": centre.tolist(), "radius": R, "material": "glass"}, *board],
    }
    ids = render(data, W, H).path_ids
    eye, d = rays(data, W, H)
    t, rim = sphere_t(eye, d, centre, R)
    through = np.isfinite(t) & (rim > HAIR)
    entry = eye + np.where(through, t, 0)[..., None] * d
    to_axis = centre - entry - ((centre - entry) * d).sum(-1, keepdims=True) * d  # towards the line through the centre
    b = np.linalg.norm(to_axis, axis=-1)
    e = to_axis / np.maximum(b, 1e-300)[..., None]
    theta = np.arcsin(np.clip(b / R, 0, 1))
    theta_t = np.arcsin(np.sin(theta) / n)
    inside = np.cos(theta - theta_t)[..., None] * d + np.sin(theta - theta_t)[..., None] * e
    exit_point = entry + (2 * R * np.cos(theta_t))[..., None] * inside
    deviation = 2 * (theta - theta_t)
    out = np.cos(deviation)[..., None] * d + np.sin(deviation)[..., None] * e
    point, _ = hit_plane(exit_point, out, 2, z_back)
    col, row = (point[..., 0] + 6) / size, (point[..., 1] + 6) / size
    on_board = through & (col > 0) & (col < cells) & (row > 0) & (row < cells)
    clear = on_board & (np.abs(col - np.round(col)) * size > HAIR) & (np.abs(row - np.round(row)) * size > HAIR)
    expected = 1 + np.floor(row).astype(int) * cells + np.floor(col).astype(int)
    assert clear.sum() > 200 and deviation[clear].max() > 0.5
    assert (ids[..., 0][clear] == 0).all() and (ids[..., 1][clear] == 0).all()
    assert np.array_equal(ids[..., 2][clear], expected[clear])


@pytest.mark.parametrize("ior, reflected", [(1.5, True), (1.3, False)])
def test_a_right_angle_prism_reflects_totally_only_past_the_critical_angle(ior, reflected, tmp_path):
    """Light entering a 45-degree prism square-on meets the hypotenuse at 45 degrees: totally
    reflected when asin(1/n) < 45 degrees (n > sqrt 2), refracted out otherwise."""
    corners = np.array([[-1, -2], [1, -2], [1, -4]])  # (x, z): legs on z = -2 and x = 1, hypotenuse at 45 degrees
    points = np.array([[x, y, z] for x, z in corners for y in (-3, 3)], float)
    prism = trimesh.convex.convex_hull(points)  # outward-facing triangles
    file = write_obj(tmp_path / "prism.obj", prism.vertices, prism.faces)
    data = {
        "ambient": [1, 1, 1],  # no lights: every opaque surface shows exactly its diffuse colour
        "cameras": [{"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": 8}],
        "materials": {"glass": {"transparency": 1.0, "ior": ior}, "side": {"diffuse": [0.2, 0.9, 0.3]}, "back": {"diffuse": [0.9, 0.1, 0.1]}},
        "objects": [{"type": "mesh", "file": file, "material": "glass"}, big_quad(x=3.0, material="side"), big_quad(z=-6.0, material="back")],
    }
    result = render(data, 9, 9, base_dir=tmp_path)
    through = 1 if reflected else 2
    assert (result.path_ids[..., :2] == 0).all()
    assert (result.path_ids[..., 3 if reflected else 2] == through).all()
    assert np.allclose(result.image, data["materials"]["side" if reflected else "back"]["diffuse"], atol=1e-6)


# ------------------------------------------------------------------ Fresnel
def fresnel_scene(ior, tilt_degrees):
    """A clear glass sheet in front of a black wall under a white sky: a pixel shows exactly the reflectance."""
    tilt = np.radians(tilt_degrees)
    normal = np.array([np.sin(tilt), 0, np.cos(tilt)])
    a = np.cross([0, 1.0, 0], normal) * 40
    b = np.array([0, 40.0, 0])
    corner = np.array([0, 0, -3.0]) - (a + b) / 2
    behind = corner - 0.5 * normal  # a black sheet just behind the glass takes every refracted ray, none reflected
    return {
        "background": [1, 1, 1],
        "cameras": [{"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": 10}],
        "materials": {"glass": {"transparency": 1.0, "ior": ior}, "black": {"diffuse": [0, 0, 0]}},
        "objects": [
            {"type": "quad", "corner": corner.tolist(), "edge_a": a.tolist(), "edge_b": b.tolist(), "material": "glass"},
            {"type": "quad", "corner": behind.tolist(), "edge_a": a.tolist(), "edge_b": b.tolist(), "material": "black"},
        ],
    }, normal


@pytest.mark.parametrize("ior", [1.33, 1.5, 2.4])
def test_schlick_at_normal_incidence_is_the_square_of_n_minus_1_over_n_plus_1(ior):
    data, _ = fresnel_scene(ior, 0)
    image = render(data, 9, 9, fresnel=True).image
    assert image[4, 4] == pytest.approx(np.full(3, ((ior - 1) / (ior + 1)) ** 2), abs=1e-6)


@pytest.mark.parametrize("tilt", [60, 75])
def test_schlick_at_an_angle_adds_one_minus_r0_times_one_minus_cos_to_the_fifth(tilt):
    ior = 1.5
    data, normal = fresnel_scene(ior, tilt)
    W, H = 9, 9
    image = render(data, W, H, fresnel=True).image
    _, d = rays(data, W, H)
    cos_i = np.abs(d @ normal)
    r0 = ((ior - 1) / (ior + 1)) ** 2
    expected = r0 + (1 - r0) * (1 - cos_i) ** 5
    assert expected.max() > 2 * r0  # far enough from normal incidence to tell
    assert np.allclose(image, expected[..., None], atol=2e-5)


# ------------------------------------------------------------ Blinn-Phong
def test_the_blinn_phong_highlight_peaks_where_the_half_vector_meets_the_normal():
    W, H, shininess = 33, 25, 20
    eye, light = np.array([0, 1.5, 0.0]), np.array([1.0, 2.0, -4.0])
    mirrored_light = light * [1, -1, 1]
    peak = eye + eye[1] / (eye[1] - mirrored_light[1]) * (mirrored_light - eye)  # where the view ray meets y = 0
    data = {
        "cameras": [{"position": eye.tolist(), "look_at": peak.tolist(), "fov": 50}],
        "materials": {"gloss": {"diffuse": [0, 0, 0], "specular": [1, 1, 1], "shininess": shininess}},
        "lights": [{"type": "point", "position": light.tolist()}],
        "objects": [big_quad(y=0.0, material="gloss")],
    }
    image = render(data, W, H).image[..., 0]
    assert image[H // 2, W // 2] == pytest.approx(1.0, abs=1e-5)  # n.h = 1 at the peak: ks * I
    assert np.unravel_index(image.argmax(), image.shape) == (H // 2, W // 2)
    _, d = rays(data, W, H)
    p, _ = hit_plane(eye, d, 1, 0.0)
    l = light - p
    l /= np.linalg.norm(l, axis=-1, keepdims=True)
    h = l - d
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    assert np.allclose(image, h[..., 1] ** shininess, atol=1e-5)  # (n.h)^p everywhere, n = +y


def test_blinn_phong_adds_lambert_and_specular_terms():
    W, H = 16, 12
    data = {
        "cameras": [{"position": [0, 2, 1], "look_at": [0, 0, -2], "fov": 60}],
        "materials": {"plastic": {"diffuse": [0.5, 0.3, 0.1], "specular": [0.2, 0.4, 0.6], "shininess": 8}},
        "lights": [{"type": "point", "position": [-1, 3, -1], "intensity": 0.7, "color": [1, 0.5, 0.25]}],
        "objects": [big_quad(y=0.0, material="plastic")],
    }
    image = render(data, W, H).image
    eye, d = rays(data, W, H)
    p, _ = hit_plane(eye, d, 1, 0.0)
    l = np.array([-1, 3, -1.0]) - p
    l /= np.linalg.norm(l, axis=-1, keepdims=True)
    h = l - d
    h /= np.linalg.norm(h, axis=-1, keepdims=True)
    expected = 0.7 * np.array([1, 0.5, 0.25]) * (np.array([0.5, 0.3, 0.1]) * l[..., 1:2] + np.array([0.2, 0.4, 0.6]) * h[..., 1:2] ** 8)
    assert np.allclose(image, expected, atol=1e-5)


def test_a_light_below_the_horizon_gives_no_highlight():
    """The specular term needs n.l > 0: a light under the surface lights nothing, however h leans."""
    data = {
        "cameras": [{"position": [0, 1, 0], "look_at": [0, 0, -4], "fov": 50}],
        "materials": {"gloss": {"diffuse": [0.5, 0.5, 0.5], "specular": [1, 1, 1], "shininess": 1}},
        "lights": [{"type": "point", "position": [0, -0.3, -30]}],
        "objects": [big_quad(y=0.0, material="gloss")],
    }
    result = render(data, 16, 12)
    floor = result.ids == 0
    assert floor.sum() > 50 and (result.image[floor] == 0).all()


# ------------------------------------------------------ Lambert, directional
@pytest.mark.parametrize("theta", [0, 30, 60, 85])
def test_a_directional_light_lights_a_floor_by_the_cosine_of_its_angle(theta):
    t = np.radians(theta)
    data = {
        "ambient": [0.05, 0.05, 0.05],
        "cameras": [{"position": [0, 2, 1], "look_at": [0, 0, -3], "fov": 40}],
        "materials": {"floor": {"diffuse": [0.7, 0.6, 0.5]}},
        "lights": [{"type": "directional", "direction": [np.sin(t), -np.cos(t), 0], "intensity": 0.8}],
        "objects": [big_quad(y=0.0, material="floor")],
    }
    image = render(data, 12, 8).image
    expected = np.array([0.7, 0.6, 0.5]) * (0.05 + 0.8 * np.cos(t))
    assert np.allclose(image, expected, atol=1e-6)


def test_a_directional_light_from_below_leaves_only_ambient():
    data = {
        "ambient": [0.1, 0.1, 0.1],
        "cameras": [{"position": [0, 2, 1], "look_at": [0, 0, -3]}],
        "lights": [{"type": "directional", "direction": [0.2, 1, 0]}],
        "objects": [big_quad(y=0.0)],
    }
    result = render(data, 8, 6)
    floor = result.ids == 0
    assert floor.sum() > 10 and np.allclose(result.image[floor], 0.08, atol=1e-7)


def write_obj(path: Path, vertices, faces):
    lines = [f"v {x!r} {y!r} {z!r}" for x, y, z in np.asarray(vertices, float).tolist()]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in np.asarray(faces).tolist()]
    path.write_text("\n".join(lines) + "\n")
    return path.name


def lambert_sphere_errors(tmp_path, smooth):
    """Largest and mean |mesh - exact sphere| of Lambert shading, for an icosphere (320 faces) and the analytic sphere."""
    W, H = 48, 48
    centre, direction = np.array([0, 0, -3.0]), np.array([-1.0, -1.0, -1.5])
    s = trimesh.creation.icosphere(subdivisions=2)
    file = write_obj(tmp_path / "ico.obj", s.vertices, s.faces)
    light = {"type": "directional", "direction": direction.tolist()}
    camera = [{"position": [0, 0, 0], "look_at": centre.tolist(), "fov": 45}]
    mesh = {"cameras": camera, "lights": [light], "objects": [{"type": "mesh", "file": file, "translate": centre.tolist(), "smooth": smooth}]}
    sphere = {"cameras": camera, "lights": [light], "objects": [{"type": "sphere", "center": centre.tolist(), "radius": 1.0}]}
    got = render(mesh, W, H, base_dir=tmp_path)
    exact_sphere = render(sphere, W, H).image[..., 0]
    # the exact answer: 0.8 * max(0, n.l) on the true sphere
    eye, d = rays(sphere, W, H)
    t, _ = sphere_t(eye, d, centre, 1.0)
    n = eye + np.where(np.isfinite(t), t, 0)[..., None] * d - centre
    analytic = 0.8 * np.maximum(0, n @ (-direction / np.linalg.norm(direction)))
    both = np.isfinite(t) & (got.ids == 0) & (analytic > 0.1)
    assert both.sum() > 500
    assert np.abs(exact_sphere - analytic)[np.isfinite(t)].max() < 1e-5  # the analytic sphere obeys the cosine law
    error = np.abs(got.image[..., 0] - analytic)[both]
    return error.max(), error.mean()


def test_a_smooth_tessellated_sphere_shades_like_the_true_sphere(tmp_path):
    worst, mean = lambert_sphere_errors(tmp_path, smooth=True)
    assert mean < 0.01  # within about 1% of the 0.8 peak (measured 0.0054)


def test_a_flat_tessellated_sphere_shows_its_facets(tmp_path):
    worst, mean = lambert_sphere_errors(tmp_path, smooth=False)
    assert mean > 0.02 and worst > 0.08  # measured 0.029 and 0.116


# ------------------------------------------------------------------ shadows
def test_a_triangles_shadow_under_a_point_light_is_its_projection_onto_the_floor():
    W, H = 64, 48
    light = np.array([0.3, 4.0, -2.5])
    tri = np.array([[-0.5, 1.0, -3.0], [0.7, 1.2, -3.4], [0.0, 0.9, -2.2]])
    data = {
        "ambient": [0.1, 0.1, 0.1],
        "cameras": [{"position": [0, 3, 1], "look_at": [0, 0, -3], "fov": 50}],
        "lights": [{"type": "point", "position": light.tolist()}],
        "objects": [big_quad(y=0.0), {"type": "triangle", "vertices": tri.tolist()}],
    }
    result = render(data, W, H)
    eye, d = rays(data, W, H)
    p, _ = hit_plane(eye, d, 1, 0.0)
    footprint = light + (tri - light) * (light[1] / (light[1] - tri[:, 1]))[:, None]  # central projection to y = 0
    in_shadow, near_edge = inside_triangle_xz(p, footprint)
    floor = result.ids == 0
    assert (in_shadow & floor).sum() > 30
    clear = floor & ~near_edge
    assert np.array_equal((result.shadow[..., 0] < 0.5)[clear], in_shadow[clear])
    shadowed = clear & in_shadow
    assert np.allclose(result.image[shadowed], 0.08, atol=1e-7)  # ambient * kd only


def inside_triangle_xz(p, tri):
    """Whether points lie inside a triangle in the xz-plane, and whether they are within HAIR of its edges."""
    a, b, c = tri[:, [0, 2]]
    q = p[..., [0, 2]]
    inside = np.ones(q.shape[:-1], bool)
    near = np.zeros(q.shape[:-1], bool)
    orientation = np.sign((b - a)[0] * (c - a)[1] - (b - a)[1] * (c - a)[0])
    for u, v in ((a, b), (b, c), (c, a)):
        edge = v - u
        side = orientation * (edge[0] * (q[..., 1] - u[1]) - edge[1] * (q[..., 0] - u[0])) / np.linalg.norm(edge)
        inside &= side > 0
        near |= np.abs(side) < HAIR
    return inside, near


def test_a_mesh_casts_the_shadow_of_its_projection_along_a_directional_light(tmp_path):
    W, H = 64, 48
    box = trimesh.creation.box(extents=[0.8, 0.6, 0.7])
    box.apply_transform(trimesh.transformations.rotation_matrix(0.5, [0.3, 1, 0.2]))
    box.apply_translation([0, 1.0, -3])
    file = write_obj(tmp_path / "box.obj", box.vertices, box.faces)
    direction = np.array([0.4, -1.0, 0.3])
    data = {
        "ambient": [0.1, 0.1, 0.1],
        "cameras": [{"position": [0, 3, 1], "look_at": [0, 0, -3], "fov": 50}],
        "lights": [{"type": "directional", "direction": direction.tolist()}],
        "objects": [big_quad(y=0.0), {"type": "mesh", "file": file}],
    }
    result = render(data, W, H, base_dir=tmp_path)
    eye, d = rays(data, W, H)
    p, _ = hit_plane(eye, d, 1, 0.0)
    # the shadow of a convex solid is the convex hull of its vertices slid along the light to the floor
    footprint = box.vertices - direction * (box.vertices[:, 1:2] / direction[1])
    hull = Delaunay(footprint[:, [0, 2]])
    in_shadow = hull.find_simplex(p[..., [0, 2]]) >= 0
    nudged = [hull.find_simplex(p[..., [0, 2]] + [dx, dz]) >= 0 for dx in (-HAIR, HAIR) for dz in (-HAIR, HAIR)]
    near_edge = np.any([n != in_shadow for n in nudged], axis=0)
    floor = result.ids == 0
    clear = floor & ~near_edge
    assert (in_shadow & clear).sum() > 30
    assert np.array_equal((result.shadow[..., 0] < 0.5)[clear], in_shadow[clear])
    assert np.allclose(result.image[clear & in_shadow], 0.08, atol=1e-7)


@pytest.mark.parametrize("fresnel", [False, True])
def test_a_glass_sphere_passes_its_transparency_squared_into_its_shadow(fresnel):
    """Shadow rays are not bent; each of the two crossings passes `transparency` (docs/shading.md, Shading)."""
    W, H, tau, kd, ambient = 48, 36, 0.6, 0.8, 0.05
    centre, radius, light = np.array([0.2, 1.0, -3.0]), 0.5, np.array([0.0, 4.0, -3.2])
    data = {
        "ambient": [ambient] * 3,
        "cameras": [{"position": [0, 3, 2], "look_at": [0, 0, -3], "fov": 45}],
        "materials": {"glass": {"transparency": tau, "ior": 1.5}},
        "lights": [{"type": "point", "position": light.tolist()}],
        "objects": [big_quad(y=0.0), {"type": "sphere", "center": centre.tolist(), "radius": radius, "material": "glass"}],
    }
    result = render(data, W, H, fresnel=fresnel)
    eye, d = rays(data, W, H)
    p, _ = hit_plane(eye, d, 1, 0.0)
    l = light - p
    dist = np.linalg.norm(l, axis=-1)
    l /= dist[..., None]
    t, rim = sphere_t(p, l, centre, radius)
    crosses = np.isfinite(t) & (t < dist)
    expected = kd * (ambient + np.where(crosses, tau**2, 1.0) * l[..., 1])
    clear = (result.ids == 0) & (rim > HAIR)
    assert (crosses & clear).sum() > 20
    assert np.allclose(result.image[..., 0][clear], expected[clear], rtol=1e-5, atol=1e-6)


def test_a_transparent_sheet_passes_its_transparency_once():
    W, H, tau = 32, 24, 0.35
    light = np.array([0.0, 4.0, -3.0])
    data = {
        "cameras": [{"position": [0, 3, 2], "look_at": [0, 0, -3], "fov": 45}],
        "materials": {"film": {"transparency": tau}},
        "lights": [{"type": "point", "position": light.tolist()}],
        "objects": [big_quad(y=0.0), {"type": "quad", "corner": [-0.5, 2, -3.5], "edge_a": [1, 0, 0], "edge_b": [0, 0, 1], "material": "film"}],
    }
    result = render(data, W, H)
    eye, d = rays(data, W, H)
    p, _ = hit_plane(eye, d, 1, 0.0)
    l = light - p
    l /= np.linalg.norm(l, axis=-1, keepdims=True)
    q, _ = hit_plane(p, l, 1, 2.0)  # where the shadow ray meets the sheet's plane
    u, v = q[..., 0] + 0.5, q[..., 2] + 3.5
    under = (u > 0) & (u < 1) & (v > 0) & (v < 1)
    clear = (result.ids == 0) & (np.minimum(np.abs(u - np.round(u)), np.abs(v - np.round(v))) > HAIR)
    expected = 0.8 * np.where(under, tau, 1.0) * l[..., 1]
    assert (under & clear).sum() > 10
    assert np.allclose(result.image[..., 0][clear], expected[clear], rtol=1e-5, atol=1e-6)


def test_a_surface_beyond_a_point_light_casts_no_shadow():
    """Shadow rays stop at the light: a ceiling above the lamp does not darken the floor."""
    W, H, light = 24, 16, np.array([0.0, 2.0, -3.0])
    data = {
        "cameras": [{"position": [0, 1.5, 1], "look_at": [0, 0, -3], "fov": 40}],
        "lights": [{"type": "point", "position": light.tolist()}],
        "objects": [big_quad(y=0.0), big_quad(y=3.0)],
    }
    result = render(data, W, H)
    eye, d = rays(data, W, H)
    p, _ = hit_plane(eye, d, 1, 0.0)
    l = light - p
    expected = 0.8 * l[..., 1] / np.linalg.norm(l, axis=-1)
    assert (result.ids == 0).all()
    assert np.allclose(result.image[..., 0], expected, rtol=1e-5, atol=1e-6)
