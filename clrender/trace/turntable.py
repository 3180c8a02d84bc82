"""Turntable animations: K cameras orbiting the camera's look-at point.

Frame k moves the eye by the angle 2*pi*k/K about the camera's `up` axis
through `look_at` (counter-clockwise seen from above, i.e. looking down
-up), so the distance to the look-at point and the height along `up` stay
fixed and frame 0 is the camera itself.  `up`, `look_at` and `fov` do not
change.  Files are named by FRAME_PATTERN (frame_0000.png, frame_0001.png, ...).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..errors import UsageError
from ..scene.camera import Camera

FRAME_PATTERN = "frame_{:04d}.png"
MAX_FRAMES = 10_000  # frames are staged as open temporary files until all are done


def orbit(camera: Camera, frames: int) -> list[Camera]:
    """The K cameras of a turntable around `camera.look_at` (frame 0 is `camera` unchanged)."""
    if not 1 <= frames <= MAX_FRAMES:
        raise UsageError(f"turntable frames {frames} must be from 1 to {MAX_FRAMES}")
    centre = np.asarray(camera.look_at, np.float64)
    offset = np.asarray(camera.position, np.float64) - centre
    axis = np.asarray(camera.up, np.float64)
    axis /= np.linalg.norm(axis)
    cameras = [camera]
    for k in range(1, frames):
        angle = 2.0 * math.pi * k / frames
        # Rodrigues: rotate the eye's offset from the centre about the up axis
        rotated = offset * math.cos(angle) + np.cross(axis, offset) * math.sin(angle) + axis * np.dot(axis, offset) * (1.0 - math.cos(angle))
        cameras.append(replace(camera, position=tuple(float(v) for v in centre + rotated)))
    return cameras


def frame_scene(scene, camera: Camera):
    """`scene` seen through `camera` alone (camera 1)."""
    return replace(scene, cameras=[camera])


def render_turntable(scene, settings=None, frames: int = 36, **overrides):
    """Yield (k, linear image) for each frame in order, rendered on this machine."""
    from ..scene.scene import Scene
    from .renderer import Renderer, RenderSettings
    from .tracer import Tracer

    scene = Scene.load(scene)
    settings = replace(settings or RenderSettings(), **overrides).validate(scene)
    tracer = Tracer(scene, use_bvh=settings.bvh, builder=settings.bvh_builder, device=settings.device)
    for k, camera in enumerate(orbit(scene.camera(settings.camera), frames)):
        yield k, Renderer(frame_scene(scene, camera), replace(settings, camera=1), tracer=tracer).run().image
