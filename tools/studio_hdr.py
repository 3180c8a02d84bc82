"""Writes scenes/studio.hdr, the bundled studio environment map (`clrender render model.glb --env studio`).

    python -m tools.studio_hdr            # rewrites scenes/studio.hdr (the same bytes each time)

An equirectangular map (docs/scene-format.md, "Environment maps": the top row is +y, u = 0.5 looks along +z,
toward a framing camera) of a photographer's studio, made from a few analytic shapes rather than a photograph,
so that the repository can ship it small (128 x 64 texels, Radiance RGBE):
- a neutral grey cyclorama: 0.6 overhead fading to 0.35 at the horizon and 0.2 below it;
- a large key softbox (radiance 8) up and to the camera's left, a fill (2.5) to its right, a strip (4) behind.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

WIDTH, HEIGHT = 128, 64
# (toward the light: right/up/back as world x, y, z; half sizes in degrees (azimuth, elevation); radiance)
SOFTBOXES = (((-0.8, 0.7, 1.0), (22.0, 16.0), 8.0), ((1.0, 0.35, 0.6), (18.0, 14.0), 2.5), ((0.2, 0.6, -1.0), (8.0, 24.0), 4.0))


def studio(width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    """(H, W, 3) float32 radiance of the studio map, each texel evaluated at its centre."""
    v = (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    theta, phi = np.meshgrid(v * np.pi, u * 2 * np.pi, indexing="ij")  # polar angle from +y; azimuth from -z toward +x
    elevation = np.degrees(np.pi / 2 - theta)
    sky = np.where(elevation >= 0, 0.35 + 0.25 * np.sin(np.radians(elevation)), 0.2)
    out = np.repeat(sky[..., None], 3, axis=2)
    for toward, (half_az, half_el), radiance in SOFTBOXES:
        x, y, z = np.asarray(toward) / np.linalg.norm(toward)
        az0, el0 = np.arctan2(x, -z), np.degrees(np.arcsin(y))
        d_az = np.degrees(np.angle(np.exp(1j * (phi - az0))))  # wrapped to [-180, 180)
        inside = (np.abs(d_az) <= half_az) & (np.abs(elevation - el0) <= half_el)
        out[inside] = radiance
    return out.astype(np.float32)


def main() -> None:
    import OpenImageIO as oiio

    path = Path(__file__).resolve().parents[1] / "scenes" / "studio.hdr"
    pixels = studio()
    spec = oiio.ImageSpec(WIDTH, HEIGHT, 3, "float")
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), spec)
    out.write_image(pixels)
    out.close()
    print(path)


if __name__ == "__main__":
    main()
