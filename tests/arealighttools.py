"""A floor under a large parallelogram area light, seen from straight above, and its exact picture (Lambert's
polygon irradiance): the scene of tests/trace/test_area_light_mis.py and test_light_choice.py."""

import numpy as np

SIZE = 24  # pixels a side

# A large light high above (behind the camera, which looks down from under it): its solid-angle pdf dist^2 / (A cos)
# is small, so BSDF sampling takes most of the MIS weight, and dist (4 and more) is far from dist^2: the wrong pdf
# puts 49 % more light on the floor.
LIGHT = dict(type="area", corner=[-5.0, 4.0, -5.0], edge_a=[10.0, 0, 0], edge_b=[0, 0, 10.0], intensity=2.0, falloff="inverse_square")
CAMERA = dict(position=[0, 2, 0], look_at=[0, 0, 0], up=[0, 0, -1], fov=50)
SUB = 4  # sub-pixel grid of the reference


def floor_points(sub):
    """Floor points (y = 0) under the camera straight above (image up = -z) at pixel positions (i + s) / SIZE."""
    half = np.tan(np.radians(CAMERA["fov"]) / 2) * CAMERA["position"][1]
    s = (np.arange(SIZE * sub) + 0.5) / (SIZE * sub) * 2 - 1
    x = np.broadcast_to(s[None, :] * half, (SIZE * sub, SIZE * sub))
    z = np.broadcast_to(s[:, None] * half, (SIZE * sub, SIZE * sub))
    return np.stack([x, np.zeros_like(x), z], axis=-1)


def light_seen(points):
    """Whether the ray from the camera to each floor point crosses the light's parallelogram."""
    eye = np.array(CAMERA["position"], float)
    c, a, b = (np.array(LIGHT[k], float) for k in ("corner", "edge_a", "edge_b"))
    n = np.cross(a, b)
    d = points - eye
    t = ((c - eye) @ n) / (d @ n)
    q = eye + t[..., None] * d - c
    # q = u a + v b: solve in the plane by least squares on the 3 components
    m = np.stack([a, b], axis=1)
    uv = np.linalg.lstsq(m, q.reshape(-1, 3).T, rcond=None)[0].T.reshape(*q.shape[:-1], 2)
    return (t > 0) & (t < 1) & (uv >= 0).all(-1) & (uv <= 1).all(-1)


FLOOR = {"type": "quad", "corner": [-5, 0, 5], "edge_a": [10, 0, 0], "edge_b": [0, 0, -10], "material": "white"}
SCENE = {
    "width": SIZE,
    "height": SIZE,
    "cameras": [CAMERA],
    "materials": {"white": {"diffuse": [1, 1, 1], "specular": [0, 0, 0]}},
    "lights": [LIGHT],
    "objects": [FLOOR],
}
