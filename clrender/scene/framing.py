"""The camera and lights a scene without its own gets: a bare mesh file (`clrender render teapot.obj`),
and the camera and lights of a glTF file that has none (the lights then follow its first camera).

Camera: it looks at the centre of the bounding box from `direction` (default: in front, +z, a little to
the right, +x, and above, +y: a three-quarter view), with +y up, from the distance at which the bounding
sphere, its radius times `margin`, just fits the narrower of the image's two fields of view.  A sphere
centred on the view axis projects to a circle of radius tan(asin(R/d)), so d = margin R / sin(half the
narrower angle) puts all of it in the frame.  Every length follows the bounds, so a mesh scaled by 1e-3 or
1e3 gives the same image.

Lights: a directional key light (its `none` falloff does not depend on the scale) coming from over the
camera's left shoulder, and a uniform fill of the same value in both integrators: the Whitted ambient term
and the path tracer's constant environment, so both show kd (fill + key cos) on a convex object.  A surface
facing the key gets 0.8 (fill + key) = 0.8 of the default grey: bright, never clipped; one facing away
still gets 0.8 fill.  The Whitted background stays black (the scene default); the path tracer's camera rays that
miss see the environment.

Plain data in, plain data out (lists, as a scene dict holds them): gltf.py uses it too, and it imports
nothing from scene.py.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Framing:
    direction: tuple = (0.5, 0.5, 1.0)  # from the bounds' centre toward the eye: +z front, +x right, +y above (three-quarter view)
    up: tuple = (0.0, 1.0, 0.0)  # world direction shown upward: +y, the convention of OBJ, PLY and glTF
    fov: float = 40.0  # vertical field of view in degrees: a normal lens, little perspective distortion
    margin: float = 1.1  # the bounding sphere's radius times this fills the narrower field of view: a 10% border
    width: int = 640  # default image size; its aspect ratio decides which field of view is the narrower
    height: int = 480
    key_from: tuple = (-0.5, 0.7, 1.0)  # toward the key light in the camera's axes (right, up, back toward the viewer): over the left shoulder
    key_intensity: float = 0.75  # the key light (`none` falloff): a surface facing it gets kd x this
    fill: float = 0.25  # uniform fill: Whitted ambient and the path tracer's constant environment (kd x this everywhere)
    smooth: bool = False  # a bare mesh's shading: flat faces, since computed normals would round a cube whose corners share vertices


FRAMING = Framing()
CAMERA_NAME = "framing: a three-quarter view (from +z, +x, +y) of the whole bounding sphere"  # shown by `render --list`


def bounding_sphere(lo, hi) -> tuple[np.ndarray, float]:
    """(centre, radius) of the sphere through the corners of the box lo..hi."""
    lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
    return (lo + hi) / 2, float(np.linalg.norm(hi - lo)) / 2


def camera_distance(radius: float, aspect: float, settings: Framing = FRAMING) -> float:
    """Eye to centre: the sphere of radius `radius` x margin just fits the narrower field of view of an
    image `aspect` (width / height) wide."""
    tan_half = math.tan(math.radians(settings.fov) / 2) * min(1.0, aspect)  # the horizontal half-angle is the narrower below 1
    return settings.margin * radius / math.sin(math.atan(tan_half))


def framing_camera(lo, hi, aspect: float | None = None, settings: Framing = FRAMING) -> dict:
    """A scene-dict camera (position, look_at, up, fov) that sees the whole bounding sphere of the box
    lo..hi in an image `aspect` wide (default: the settings' width / height)."""
    aspect = settings.width / settings.height if aspect is None else aspect
    centre, radius = bounding_sphere(lo, hi)
    direction = np.asarray(settings.direction, np.float64)
    eye = centre + camera_distance(radius, aspect, settings) * direction / np.linalg.norm(direction)
    return {"position": eye.tolist(), "look_at": centre.tolist(), "up": list(settings.up), "fov": settings.fov, "name": CAMERA_NAME}


def key_light(camera: dict, settings: Framing = FRAMING) -> dict:
    """A scene-dict directional light travelling from `key_from` (in `camera`'s axes) toward the scene."""
    back = np.subtract(camera["position"], camera["look_at"])
    back /= np.linalg.norm(back)
    right = np.cross(camera["up"], back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    toward_light = np.asarray(settings.key_from, np.float64) @ np.array([right, up, back])
    toward_light /= np.linalg.norm(toward_light)
    return {"type": "directional", "direction": (-toward_light).tolist(), "intensity": settings.key_intensity}


def lighting(camera: dict, settings: Framing = FRAMING) -> dict:
    """The top-level keys of a scene dict that light it for `camera`: the key light over its shoulder and the
    fill (ambient and environment).  A bare mesh gets them, and so does a glTF file that brings no lights."""
    fill = [settings.fill] * 3
    return {"lights": [key_light(camera, settings)], "ambient": fill, "environment": {"color": fill}}


def rig(lo, hi, settings: Framing = FRAMING) -> dict:
    """The top-level keys of a scene dict for the bounds lo..hi: image size, the framing camera, the key
    light and the fill (ambient and environment)."""
    camera = framing_camera(lo, hi, settings=settings)
    return {"width": settings.width, "height": settings.height, "cameras": [camera], **lighting(camera, settings)}
