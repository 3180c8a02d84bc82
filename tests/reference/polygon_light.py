"""The exact irradiance a uniform parallelogram light gives (Lambert's polygon formula), float64, for the area-light
tests; imports nothing from clrender."""

import numpy as np


def lambert_irradiance(points, light):
    """Exact irradiance from a uniform polygon of radiance I (Lambert's formula)."""
    a, b = np.array(light["edge_a"], float), np.array(light["edge_b"], float)
    c = np.array(light["corner"], float)
    corners = [c, c + a, c + a + b, c + b]
    total = np.zeros(points.shape[:2])
    for k in range(4):
        u = corners[k] - points
        w = corners[(k + 1) % 4] - points
        u /= np.linalg.norm(u, axis=-1, keepdims=True)
        w /= np.linalg.norm(w, axis=-1, keepdims=True)
        cr = np.cross(u, w)
        gamma = np.arccos(np.clip((u * w).sum(-1), -1, 1))
        total += gamma * cr[..., 1] / np.linalg.norm(cr, axis=-1)
    return light["intensity"] * np.abs(total) / 2
