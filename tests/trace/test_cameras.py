"""Thin-lens and orthographic cameras (kernels/camera.h) against geometry worked out by hand: the plane in
focus stays as sharp as a pinhole's, an out-of-focus square spreads over the thin lens's circle of
confusion (second moments), an orthographic sphere is 2r / ortho_height x H pixels across at any distance,
a glTF camera's yfov and orthographic ymag give the analytic span, and a lens of radius 0 is the pinhole
bit for bit."""

import math

import numpy as np
import pytest

from clrender.scene.scene import Scene
from clrender.trace.renderer import render

from tests.gltftools import gltf_file
from tests.scenetools import flat_scene, pixels_per_unit, square


# ------------------------------------------------------------------ a pinhole is unchanged
@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_aperture_zero_is_the_default_camera_bit_for_bit(integrator):
    base = {"position": [0.3, 0.2, 2], "look_at": [0, 0, -3]}
    objects = [{"type": "sphere", "center": [0, 0, -3], "radius": 1}, square((0.8, 0.5, -4), 0.7)]
    settings = dict(aa="full", samples=2, integrator=integrator, max_depth=2)
    default = render(flat_scene(objects, base, (24, 18)), **settings)
    pinhole = render(flat_scene(objects, {**base, "aperture": 0, "focus_distance": 1.5}, (24, 18)), **settings)
    assert default.tobytes() == pinhole.tobytes()


# ------------------------------------------------------------------ thin lens
FOV, SIZE, FOCUS, APERTURE = 30.0, 64, 5.0, 0.5


def lens_camera(**extra):
    return {"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": FOV, **extra}


def edge_rows(image):
    """Per row, the pixels strictly between dark and bright: the edge's width in pixels."""
    v = image[..., 0]
    return ((v > 0.02) & (v < 0.98)).sum(axis=1)


def test_the_plane_in_focus_is_as_sharp_as_a_pinhole():
    # a half-plane whose vertical edge crosses the pixels 0.37 of a pixel from their left side, at the focus distance
    x_edge = 4.37 / pixels_per_unit(FOV, SIZE) * FOCUS  # 4.37 pixels right of the centre line
    half_plane = {"type": "quad", "corner": [x_edge, -10, -FOCUS], "edge_a": [20, 0, 0], "edge_b": [0, 20, 0]}
    settings = dict(aa="full", samples=8)
    pinhole = render(flat_scene([half_plane], lens_camera(), (SIZE, SIZE)), **settings)
    lens = render(flat_scene([half_plane], lens_camera(aperture=APERTURE, focus_distance=FOCUS), (SIZE, SIZE)), **settings)
    # the same sub-pixel samples reach the same points of the focal plane: at most a sample or two on the
    # edge may fall on the other side by float rounding
    assert np.abs(lens - pinhole).max() <= 2 / 64 + 1e-6
    assert (edge_rows(lens) == 1).all() and (edge_rows(pinhole) == 1).all()
    # the same plane out of focus (focused at half its distance) is blurred over its circle of confusion
    blurred = render(flat_scene([half_plane], lens_camera(aperture=APERTURE, focus_distance=FOCUS / 2), (SIZE, SIZE)), **settings)
    coc = 2 * APERTURE * abs(FOCUS - FOCUS / 2) / (FOCUS * FOCUS / 2) * pixels_per_unit(FOV, SIZE)  # diameter, pixels
    # a disc's edge profile is within 2 % of 0 or 1 only in the outer 10 % of its radius at each end
    assert coc > 20 and (edge_rows(blurred) >= 0.7 * coc).all()


def second_moment(image):
    """Sum of I r^2 / sum of I about the image centroid, in pixels^2, and the total."""
    v = image[..., 0].astype(np.float64)
    ys, xs = np.mgrid[0 : v.shape[0], 0 : v.shape[1]] + 0.5
    total = v.sum()
    cx, cy = (v * xs).sum() / total, (v * ys).sum() / total
    return (v * ((xs - cx) ** 2 + (ys - cy) ** 2)).sum() / total, total


@pytest.mark.parametrize(
    ("integrator", "depth", "focus"),
    [("whitted", 10.0, 5.0), ("whitted", 5.0, 10.0), ("path", 10.0, 5.0)],
)
def test_an_out_of_focus_square_spreads_over_the_circle_of_confusion(integrator, depth, focus):
    """A square of half-side h at distance d, seen through a lens of radius A focused at f: on the image plane
    at unit distance it is the square (half-side h / d) convolved with a uniform disc of radius
    R = A |d - f| / (f d) (the rays from a lens point L through the focal point of image point s meet the axis
    at depth d where s = L (d - f) / (f d)).  Second moments add under convolution: a disc's is R^2 / 2, the
    square's 2 (h/d)^2 / 3 and the pixel box's 1/6 px^2, so R is measured from the image's second moment
    (256 samples per pixel: about 2,000 samples land on the square; its relative error is about 1 %)."""
    scale = pixels_per_unit(FOV, SIZE)
    half = 1.5 / scale * depth  # 1.5 pixels in focus
    camera = lens_camera(aperture=APERTURE, focus_distance=focus)
    settings = dict(aa="full", samples=16, integrator=integrator, max_depth=0, seed=7)
    image = render(flat_scene([square((0, 0, -depth), half)], camera, (SIZE, SIZE)), **settings)
    moment, total = second_moment(image)
    expected_radius = APERTURE * abs(depth - focus) / (focus * depth) * scale  # pixels
    radius = math.sqrt(2 * (moment - 2 * 1.5**2 / 3 - 1 / 6))
    assert expected_radius > 5
    assert radius == pytest.approx(expected_radius, rel=0.05)
    # the square's light is spread, not lost: about 2,300 of the samples hit it, a Poisson count's 2 % per sigma
    assert total == pytest.approx((2 * 1.5) ** 2, rel=0.09)


# ------------------------------------------------------------------ orthographic
@pytest.mark.parametrize("depth", [3.0, 40.0])
def test_an_orthographic_sphere_is_2r_over_ortho_height_pixels_across_at_any_distance(depth):
    radius, ortho_height, width, height = 1.0, 4.0, 80, 64
    camera = {"position": [0, 0, 0], "look_at": [0, 0, -1], "projection": "orthographic", "ortho_height": ortho_height}
    image = render(flat_scene([{"type": "sphere", "center": [0.0, 0.0, -depth], "radius": radius}], camera, (width, height)))
    inside = image[..., 0] > 0.5
    expected = 2 * radius / ortho_height * height  # 32 pixels
    assert abs(2 * math.sqrt(inside.sum() / math.pi) - expected) <= 1.0
    assert abs(inside.any(axis=0).sum() - expected) <= 1 and abs(inside.any(axis=1).sum() - expected) <= 1  # round
    assert inside[:, : (width - height) // 2 + 1].sum() == 0  # centred: nothing in the left margin


def test_orthographic_rays_are_parallel_and_leave_the_image_rectangle():
    from clrender.scene.camera import Camera

    camera = Camera(position=(1, 2, 3), look_at=(1, 2, 0), projection="orthographic", ortho_height=6.0)
    origins, directions = camera.rays(8, 4)
    assert np.allclose(directions, [0, 0, -1])
    assert np.allclose(origins[..., 2], 3)
    # pixel centres: 12 world units wide (aspect 2), 6 high
    assert np.allclose(origins[0, :, 0] - 1, (np.arange(8) + 0.5) * 12 / 8 - 6)
    assert np.allclose(origins[:, 0, 1] - 2, 3 - (np.arange(4) + 0.5) * 6 / 4)


# ------------------------------------------------------------------ glTF cameras
def test_gltf_yfov_gives_the_analytic_span(tmp_path):
    """glTF's 2 x 2 quad at the origin, seen from distance D with yfov: it spans H / (D tan(yfov / 2)) pixels."""
    yfov, distance, size = 0.5, 8.0, 64
    nodes = [{"mesh": 0}, {"camera": 0, "translation": [0, 0, distance]}]
    path = gltf_file(tmp_path, nodes, cameras=[{"type": "perspective", "perspective": {"yfov": yfov, "aspectRatio": 1.0}}])
    image = render(Scene.from_file(path), width=size, height=size, aa="full", samples=8)
    row = image[size // 2, :, 0] / image[size // 2, :, 0].max()
    assert row.sum() == pytest.approx(size / (distance * math.tan(yfov / 2)), abs=0.1)  # 31.33 pixels


def test_gltf_orthographic_camera_spans_2_ymag(tmp_path):
    nodes = [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 50]}]
    path = gltf_file(tmp_path, nodes, cameras=[{"type": "orthographic", "orthographic": {"xmag": 3.0, "ymag": 1.5, "znear": 0.1, "zfar": 100}}])
    scene = Scene.from_file(path)
    assert (scene.width, scene.height) == (640, 320)  # the default image has aspect xmag / ymag
    camera = scene.cameras[0]
    assert (camera.projection, camera.ortho_height, camera.aperture) == ("orthographic", 3.0, 0.0)
    image = render(scene, width=60, height=30, aa="full", samples=4)
    row = image[15, :, 0] / image[15, :, 0].max()
    assert row.sum() == pytest.approx(2 / 3.0 * 30, abs=0.05)  # the quad's 2 units of a 3-unit-high view


# ------------------------------------------------------------------ the host's users of cameras
def test_turntables_and_dask_payloads_keep_the_lens_and_projection():
    from clrender.distributed.payload import join, split
    from clrender.trace.turntable import orbit

    lens = {"position": [0, 0, 4], "look_at": [0, 0, 0], "aperture": 0.2, "projection": "orthographic", "ortho_height": 3}
    scene = flat_scene([{"type": "sphere", "center": [0, 0, 0], "radius": 1}], lens, (16, 16))
    frames = orbit(scene.cameras[0], 4)
    assert all((c.aperture, c.projection, c.ortho_height) == (0.2, "orthographic", 3.0) for c in frames)
    assert all(c.focus == pytest.approx(4.0) for c in frames)  # the orbit keeps the look-at distance in focus
    assert join(split(scene)).cameras == scene.cameras
