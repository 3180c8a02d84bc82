"""Small shading rules the bigger scenes do not reach (found by `python -m tools.mutants`)."""

import numpy as np

from clrender.scene.scene import Mesh, Scene
from clrender.trace.renderer import render

KD = np.array([0.6, 0.5, 0.4])


def triangle_with_normals(vertex_normals):
    """One large triangle in the plane z = 0, facing the camera on +z, lit head-on by a directional light."""
    scene = Scene.from_dict(
        {
            "width": 16,
            "height": 16,
            "ambient": [0.05, 0.05, 0.05],
            "cameras": [{"position": [0, 0, 3], "look_at": [0, 0, 0], "fov": 30}],
            "materials": {"matte": {"diffuse": KD.tolist()}},
            "lights": [{"type": "directional", "direction": [0, 0, -1]}],
        }
    )
    vertices = np.array([[-4.0, -4, 0], [4, -4, 0], [0, 4, 0]])
    normals = np.asarray(vertex_normals, float)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    scene.objects.append(Mesh(vertices, np.array([[0, 1, 2]]), vertex_normals=normals, material="matte", smooth=True))
    return scene


def test_smooth_normals_are_interpolated_across_the_triangle(device):
    # all three vertex normals tilted alike: the shading normal is that tilt everywhere, n.l = cos(tilt)
    tilt = np.radians(30)
    n = [np.sin(tilt), 0, np.cos(tilt)]
    image = render(triangle_with_normals([n, n, n]))
    np.testing.assert_allclose(image[4:12, 4:12], np.broadcast_to(0.05 * KD + np.cos(tilt) * KD, (8, 8, 3)), rtol=1e-5)


def test_an_interpolated_normal_facing_away_falls_back_to_the_face_normal(device):
    # vertex normals that lean past the surface, away from the viewer: shading with them would
    # light nothing (n.l < 0); the renderer shades with the geometric normal (0, 0, 1) instead
    away = [1, 0, -0.2]
    image = render(triangle_with_normals([away, away, away]))
    np.testing.assert_allclose(image[4:12, 4:12], np.broadcast_to(0.05 * KD + KD, (8, 8, 3)), rtol=1e-5)
