"""Pinhole camera: position, look-at point, up vector and vertical field of view."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..layout import CAMERA_DTYPE
from .checks import FOV_RANGE, MIN_LENGTH, Checks, TypeReader


@dataclass(frozen=True)
class Camera:
    position: tuple = (0.0, 0.0, 0.0)  # eye point; the seed's canonical camera sits at the origin
    look_at: tuple = (0.0, 0.0, -1.0)  # point the centre of the image looks at (canonical: down -z)
    up: tuple = (0.0, 1.0, 0.0)  # world direction that appears upward
    fov: float = 60.0  # vertical field of view in degrees

    def frame(self, width: int, height: int) -> np.ndarray:
        """The kernels' `Camera` record (layout.CAMERA_DTYPE) for a width x height image: origin, unit forward,
        right * half-width and up * half-height of the image plane at unit distance."""
        eye = np.asarray(self.position, np.float64)
        forward = np.asarray(self.look_at, np.float64) - eye
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, np.asarray(self.up, np.float64))
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        half_h = math.tan(math.radians(self.fov) / 2.0)
        half_w = half_h * width / height
        record = np.zeros((), CAMERA_DTYPE)
        record["origin"], record["forward"], record["right"], record["up"] = eye, forward, right * half_w, up * half_h
        return record

    def rays(self, width: int, height: int, offset=(0.5, 0.5)):
        """Origins and unit directions (H, W, 3) through each pixel at `offset` (numpy; for tests and tools)."""
        frame = self.frame(width, height)
        o, f, r, u = (frame[name].astype(np.float64) for name in ("origin", "forward", "right", "up"))
        ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
        sx = 2.0 * (xs + offset[0]) / width - 1.0
        sy = 1.0 - 2.0 * (ys + offset[1]) / height
        d = f + sx[..., None] * r + sy[..., None] * u
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        return np.broadcast_to(o, d.shape).copy(), d


# ------------------------------------------------------------------ reading
def _build_camera(checks: Checks, c: dict, path: str) -> Camera:
    if "name" in c:
        checks.name(c["name"], f"{path}.name")
    d = Camera()
    cam = Camera(
        position=checks.vec3(c, "position", path, d.position),
        look_at=checks.vec3(c, "look_at", path, d.look_at),
        up=checks.vec3(c, "up", path, d.up, kind="vector"),
        fov=checks.number(c, "fov", path, d.fov, low=FOV_RANGE[0], high=FOV_RANGE[1]),
    )
    forward = np.subtract(cam.look_at, cam.position)
    if np.linalg.norm(forward) < MIN_LENGTH:
        checks.fail(f"{path}.look_at", f"must differ from position by at least {MIN_LENGTH:g}")
    if np.linalg.norm(np.cross(forward, cam.up)) < 1e-6 * np.linalg.norm(forward) * np.linalg.norm(cam.up):
        checks.fail(f"{path}.up", "must not be parallel to the viewing direction")
    return cam


# A `[[cameras]]` table: its keys, with the defaults of Camera's fields; `name` is only shown by --list.
CAMERA_READER = TypeReader(("position", "look_at", "up", "fov", "name"), _build_camera)


def read_camera(checks: Checks, c, path: str) -> Camera:
    checks.table(c, path)
    return CAMERA_READER.read(checks, c, path)
