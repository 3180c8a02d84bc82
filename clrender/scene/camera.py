"""The camera: position, look-at point, up vector, a perspective or orthographic projection and a thin lens.

A pinhole (aperture 0, the default) sees everything sharp.  A thin lens of radius `aperture` focuses
the plane `focus_distance` ahead (default: the look-at point's distance): a point at distance d along
the view is spread over a disc of diameter 2 aperture |d - focus_distance| / (focus_distance d) on the
image plane at unit distance (its height spans 2 tan(fov / 2)).  An orthographic camera sends parallel rays along the
view from a rectangle `ortho_height` world units high (default: the height the perspective view spans
at the look-at point, so switching projection keeps that plane framed alike).  docs/scene-format.md
lists the keys; kernels/camera.h makes the rays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError
from ..layout import CAMERA_DTYPE, PROJECTIONS
from .checks import COORD_LIMIT, FOV_RANGE, MIN_LENGTH, Checks, TypeReader


@dataclass(frozen=True)
class Camera:
    position: tuple = (0.0, 0.0, 0.0)  # eye point; the canonical camera sits at the origin
    look_at: tuple = (0.0, 0.0, -1.0)  # point the centre of the image looks at (canonical: down -z)
    up: tuple = (0.0, 1.0, 0.0)  # world direction that appears upward
    fov: float = 60.0  # vertical field of view in degrees (perspective)
    aperture: float = 0.0  # lens radius in world units; 0: a pinhole, everything sharp
    focus_distance: float | None = None  # distance along the view to the plane in focus; None: the look-at point's
    projection: str = "perspective"  # "perspective" or "orthographic" (parallel rays)
    ortho_height: float | None = None  # orthographic: world units the image's height spans; None: 2 tan(fov/2) x look-at distance

    def __post_init__(self):
        # a Camera made in Python gets the scene file's limits on the lens and projection (one line, exit 2)
        if not (_number(self.aperture) and 0.0 <= self.aperture <= COORD_LIMIT):
            raise UsageError(f"camera aperture {self.aperture!r} must be a lens radius from 0 (a pinhole) to {COORD_LIMIT:g}")
        for name in ("focus_distance", "ortho_height"):
            value = getattr(self, name)
            if value is not None and not (_number(value) and MIN_LENGTH <= value <= COORD_LIMIT):
                raise UsageError(f"camera {name} {value!r} must be > 0 ({MIN_LENGTH:g} to {COORD_LIMIT:g}), or None for its default")
        if self.projection not in PROJECTIONS:
            raise UsageError(f"camera projection {self.projection!r} is not one of {', '.join(map(repr, PROJECTIONS))}")

    @property
    def look_distance(self) -> float:
        return float(np.linalg.norm(np.subtract(self.look_at, self.position)))

    @property
    def focus(self) -> float:
        """The distance to the plane in focus (focus_distance, or the look-at point's distance)."""
        return self.look_distance if self.focus_distance is None else float(self.focus_distance)

    @property
    def view_height(self) -> float:
        """Orthographic: world units the image's height spans."""
        if self.ortho_height is not None:
            return float(self.ortho_height)
        return 2.0 * math.tan(math.radians(self.fov) / 2.0) * self.look_distance

    def frame(self, width: int, height: int) -> np.ndarray:
        """The kernels' `Camera` record (layout.CAMERA_DTYPE) for a width x height image: origin, unit forward,
        right * half-width and up * half-height of the image plane (perspective: at unit distance; orthographic:
        in world units), the lens's axes times its radius, its focus distance and the projection's code."""
        eye = np.asarray(self.position, np.float64)
        forward = np.asarray(self.look_at, np.float64) - eye
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, np.asarray(self.up, np.float64))
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        half_h = self.view_height / 2.0 if self.projection == "orthographic" else math.tan(math.radians(self.fov) / 2.0)
        half_w = half_h * width / height
        record = np.zeros((), CAMERA_DTYPE)
        record["origin"], record["forward"], record["right"], record["up"] = eye, forward, right * half_w, up * half_h
        record["lens_right"], record["lens_up"] = right * self.aperture, up * self.aperture
        record["aperture"], record["focus_distance"] = self.aperture, self.focus
        record["projection"] = PROJECTIONS[self.projection]
        return record

    def rays(self, width: int, height: int, offset=(0.5, 0.5), lens=(0.0, 0.0)):
        """Origins and unit directions (H, W, 3) through each pixel at `offset`, from the point `lens` of the
        unit lens disc (its centre: the pinhole ray) in numpy float64, as kernels/camera.h makes them (for tests
        and tools)."""
        frame = self.frame(width, height)
        o, f, r, u, lr, lu = (frame[n].astype(np.float64) for n in ("origin", "forward", "right", "up", "lens_right", "lens_up"))
        ys, xs = np.mgrid[0:height, 0:width].astype(np.float64)
        sx = (2.0 * (xs + offset[0]) / width - 1.0)[..., None]
        sy = (1.0 - 2.0 * (ys + offset[1]) / height)[..., None]
        if self.projection == "orthographic":
            origin, d = o + sx * r + sy * u, np.broadcast_to(f, sx.shape[:2] + (3,))
        else:
            origin, d = np.broadcast_to(o, sx.shape[:2] + (3,)), f + sx * r + sy * u
        start = origin
        if self.aperture > 0.0 and tuple(lens) != (0.0, 0.0):  # the lens centre's ray is the pinhole's
            start = origin + lens[0] * lr + lens[1] * lu
            d = origin + float(frame["focus_distance"]) * d - start
        d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        return np.array(start), d


def _number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, bool) and math.isfinite(value)


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
        aperture=checks.number(c, "aperture", path, d.aperture, low=0.0, high=COORD_LIMIT),
        focus_distance=_optional_length(checks, c, "focus_distance", path),
        projection=checks.choice(c, "projection", path, d.projection, tuple(PROJECTIONS)),
        ortho_height=_optional_length(checks, c, "ortho_height", path),
    )
    forward = np.subtract(cam.look_at, cam.position)
    if np.linalg.norm(forward) < MIN_LENGTH:
        checks.fail(f"{path}.look_at", f"must differ from position by at least {MIN_LENGTH:g}")
    if np.linalg.norm(np.cross(forward, cam.up)) < 1e-6 * np.linalg.norm(forward) * np.linalg.norm(cam.up):
        checks.fail(f"{path}.up", "must not be parallel to the viewing direction")
    return cam


def _optional_length(checks: Checks, c: dict, key: str, path: str):
    return None if key not in c else checks.number(c, key, path, low=MIN_LENGTH, high=COORD_LIMIT, positive=True)


# A `[[cameras]]` table: its keys, with the defaults of Camera's fields; `name` is only shown by --list.
CAMERA_READER = TypeReader(("position", "look_at", "up", "fov", "aperture", "focus_distance", "projection", "ortho_height", "name"), _build_camera)


def read_camera(checks: Checks, c, path: str) -> Camera:
    checks.table(c, path)
    return CAMERA_READER.read(checks, c, path)
