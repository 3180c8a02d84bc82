"""Pinhole camera: position, look-at point, up vector and vertical field of view."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Camera:
    position: tuple = (0.0, 0.0, 0.0)  # eye point; the seed's canonical camera sits at the origin
    look_at: tuple = (0.0, 0.0, -1.0)  # point the centre of the image looks at (canonical: down -z)
    up: tuple = (0.0, 1.0, 0.0)  # world direction that appears upward
    fov: float = 60.0  # vertical field of view in degrees

    def frame(self, width: int, height: int) -> np.ndarray:
        """(origin, forward, right * half-width, up * half-height) as float4 rows, at unit distance."""
        eye = np.asarray(self.position, np.float64)
        forward = np.asarray(self.look_at, np.float64) - eye
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, np.asarray(self.up, np.float64))
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        half_h = math.tan(math.radians(self.fov) / 2.0)
        half_w = half_h * width / height
        rows = [eye, forward, right * half_w, up * half_h]
        return np.array([[*r, 0.0] for r in rows], dtype=np.float32)

    def rays(self, width: int, height: int, offset=(0.5, 0.5)):
        """Origins and unit directions (H, W, 3) through each pixel at `offset` (numpy; for tests and tools)."""
        o, f, r, u = (row[:3].astype(np.float64) for row in self.frame(width, height))
        ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
        sx = 2.0 * (xs + offset[0]) / width - 1.0
        sy = 1.0 - 2.0 * (ys + offset[1]) / height
        d = f + sx[..., None] * r + sy[..., None] * u
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        return np.broadcast_to(o, d.shape).copy(), d
