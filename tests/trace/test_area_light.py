"""Parallelogram area lights: the kernel's stratified estimate against host quadrature and Lambert's formula."""

import numpy as np

from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer

from tests.reference.polygon_light import lambert_irradiance

SIZE = 24
LIGHT = dict(type="area", corner=[-0.6, 1.5, -0.4], edge_a=[1.2, 0, 0], edge_b=[0, 0.3, 0.8], intensity=2.0)
CAMERA = dict(position=[0, 6, 0], look_at=[0, 0, 0], up=[0, 0, -1], fov=50)


def floor_scene(light=LIGHT, extra=()):
    return Scene.from_dict(
        {
            "width": SIZE,
            "height": SIZE,
            "cameras": [CAMERA],
            "materials": {"white": {"diffuse": [1, 1, 1], "specular": [0, 0, 0]}},
            "lights": [light],
            "objects": [{"type": "quad", "corner": [-5, 0, 5], "edge_a": [10, 0, 0], "edge_b": [0, 0, -10], "material": "white"}, *extra],
        }
    )


def floor_points(scene):
    """Where each pixel's centre ray meets y = 0, for the camera straight above looking down
    (image up = -z, so x grows to the right and z downwards), worked out here rather than taken
    from clrender.Camera, whose frame the kernel uses too."""
    half = np.tan(np.radians(CAMERA["fov"]) / 2) * CAMERA["position"][1]  # half-width of the view on the floor
    centres = (np.arange(SIZE) + 0.5) / SIZE * 2 - 1
    x = np.broadcast_to(centres[None, :] * half, (SIZE, SIZE))
    z = np.broadcast_to(centres[:, None] * half, (SIZE, SIZE))
    return np.stack([x, np.zeros_like(x), z], axis=-1)


def light_grid(light, m=120):  # midpoint rule: 120^2 points agree with Lambert to 1e-5 here
    a, b = np.array(light["edge_a"], float), np.array(light["edge_b"], float)
    u = (np.arange(m) + 0.5) / m
    return np.array(light["corner"], float) + u[:, None, None] * a + u[None, :, None] * b, a, b


def quadrature(points, light, inverse_square=False):
    """Average over the light (midpoint rule) of I * max(0, n.l) [* A cos_l / r^2]."""
    grid, a, b = light_grid(light)
    grid = grid.reshape(-1, 3)
    normal = np.cross(a, b)
    area = np.linalg.norm(normal)
    out = np.empty(points.shape[:2])
    for i, row in enumerate(points):
        v = grid[None, :, :] - row[:, None, :]
        r = np.linalg.norm(v, axis=-1)
        term = np.maximum(v[..., 1] / r, 0.0)  # the floor's normal is +y
        if inverse_square:
            term = term * area * np.abs(v @ normal / area) / r / r**2
        out[i] = light["intensity"] * term.mean(axis=1)
    return out


def render_floor(scene, device, **settings):
    return Renderer(scene, device=None, tracer=None, **settings).run().image[..., 0]


def test_stratified_estimate_matches_quadrature_within_one_percent(device):
    scene = floor_scene()
    image = render_floor(scene, device, light_samples=32, seed=1)
    reference = quadrature(floor_points(scene), LIGHT)
    assert reference.min() > 0.05
    np.testing.assert_allclose(image, reference, rtol=0.01)


def test_inverse_square_light_gives_lamberts_irradiance(device):
    light = dict(LIGHT, falloff="inverse_square")
    scene = floor_scene(light)
    image = render_floor(scene, device, light_samples=32, seed=2)
    points = floor_points(scene)
    exact = lambert_irradiance(points, light)
    np.testing.assert_allclose(quadrature(points, light, inverse_square=True), exact, rtol=2e-3)  # the reference itself
    # the physical model's Lambert BRDF is kd / pi (kd = 1 here): radiance = E / pi
    np.testing.assert_allclose(image, exact / np.pi, rtol=0.01)


def test_stratified_light_samples_beat_random_ones_at_equal_count(device):
    scene = floor_scene()
    reference = quadrature(floor_points(scene), LIGHT)
    errors = {}
    for sampler in ("stratified", "random"):
        image = render_floor(scene, device, light_samples=4, light_sampler=sampler, seed=3)
        errors[sampler] = np.sqrt(np.mean((image / reference - 1) ** 2))
    assert errors["stratified"] < 0.5 * errors["random"], errors


def penumbra_pixels(size, device):
    light = dict(type="area", corner=[-size / 2, 3, -size / 2], edge_a=[size, 0, 0], edge_b=[0, 0, size], samples=8)
    blocker = {"type": "sphere", "center": [0, 1.0, 0], "radius": 0.5}
    scene = floor_scene(light, [blocker])
    result = Renderer(scene, width=64, height=64).run()
    visible = result.shadow[..., 0][result.ids == 0]  # floor pixels
    return int(((visible > 0.02) & (visible < 0.98)).sum()), int((visible <= 0.02).sum())


def test_penumbra_widens_with_the_light(device):
    small, umbra_small = penumbra_pixels(0.2, device)
    large, umbra_large = penumbra_pixels(1.5, device)
    assert large > 2 * small > 0
    assert umbra_large < umbra_small  # a bigger light also shrinks the umbra
