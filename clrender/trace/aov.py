"""AOVs (arbitrary output variables): per-pixel facts about the primary hit, beside the beauty image.

As Mitsuba's `aov` integrator and pbrt's G-buffer film give them, for
compositing and denoising tools:

| AOV      | EXR channels                 | value                                                          |
|----------|------------------------------|----------------------------------------------------------------|
| `depth`  | `Z`                          | distance from the eye along the primary ray (Mitsuba's `depth`, |
|          |                              | not camera-space z); 0 where the ray escapes                   |
| `normal` | `N.x`, `N.y`, `N.z`          | world-space unit shading normal (interpolated on smooth        |
|          |                              | meshes), turned to face the camera; 0 on a miss                |
| `albedo` | `albedo.R`, `albedo.G`, `albedo.B` | the material's diffuse colour kd (linear); 0 on a miss   |
| `id`     | `id`                         | object id, as `RenderResult.ids`; -1 on a miss (float32 in EXR, exact) |
| `edges`  | `edges`                      | 1 where edge-only AA resamples (the edge mask), else 0         |

The render kernel writes depth, normal and albedo into one record per pixel (clrender/layout.py's
AOV_DTYPE, the kernels' `AovRecord`), read back by field name; ids and edges come from the id records.

Every AOV comes from the one ray the object ids come from, never averaged:
the pixel centre with `--aa none` or `edge_detect`, the first sample with
`--aa full`.  That is the usual choice for ids (an averaged id names no
object), and an averaged depth or normal across a silhouette would be a
surface that is not there.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..errors import UsageError

# Channel names of each AOV in a multi-channel EXR, in the order they are written.
CHANNELS = {
    "depth": ("Z",),
    "normal": ("N.x", "N.y", "N.z"),
    "albedo": ("albedo.R", "albedo.G", "albedo.B"),
    "id": ("id",),
    "edges": ("edges",),
}
AOV_NAMES = tuple(CHANNELS)
BEAUTY_CHANNELS = ("R", "G", "B")


def parse_aov_list(text: str) -> tuple:
    """'depth,normal' -> ('depth', 'normal'); UsageError for an unknown or repeated name."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if not names:
        raise UsageError(f"--aov {text!r} names no AOV; allowed: {','.join(AOV_NAMES)}")
    for n in names:
        if n not in AOV_NAMES:
            raise UsageError(f"unknown AOV {n!r} in --aov {text!r}; allowed: {','.join(AOV_NAMES)}")
    if len(set(names)) != len(names):
        raise UsageError(f"--aov {text!r} names an AOV twice")
    return names


def channels(aovs: dict, beauty: np.ndarray | None = None):
    """(H, W, C) float32 pixels and their channel names: the beauty RGB first when given, then each AOV."""
    planes, names = [], []
    if beauty is not None:
        planes.append(np.asarray(beauty, np.float32).reshape(*beauty.shape[:2], 3))
        names += BEAUTY_CHANNELS
    for name, values in aovs.items():
        values = np.asarray(values, np.float32)
        planes.append(values.reshape(*values.shape[:2], -1))
        names += CHANNELS[name]
    return np.concatenate(planes, axis=-1), tuple(names)


def write_exr(path: str | os.PathLike, aovs: dict, beauty: np.ndarray | None = None) -> Path:
    """Write the AOVs (and the beauty image, when given) as float channels of one EXR, atomically."""
    from ..image.files import write_image

    pixels, names = channels(aovs, beauty)
    return write_image(path, pixels, format="float", channel_names=names)


def read_exr(path: str | os.PathLike) -> dict:
    """Channel name -> (H, W) float32 plane of an EXR, whatever order the file keeps them in."""
    from ..image.files import read_image

    image = read_image(path)
    return {name: image.pixels[..., i] for i, name in enumerate(image.channel_names)}


def default_aov_path(output: str | os.PathLike) -> Path:
    """Where the AOVs of a non-EXR render go by default: OUT.png -> OUT.aov.exr beside it."""
    output = Path(output)
    return output.with_name(f"{output.stem}.aov.exr")


def check_aov_path(path: str | os.PathLike) -> Path:
    path = Path(path)
    if path.suffix.lower() != ".exr":
        raise UsageError(f"--aov-out {str(path)!r} must be an .exr file (AOVs are named float channels)")
    return path


def aov_output(output: Path, aov_out: str | None, aovs: tuple, overwrite: bool) -> Path | None:
    """The separate EXR the AOVs go to, or None when they ride in `output` (an EXR) or none were asked for.

    Compositing tools (Nuke, Blender, oiiotool) expect the passes as layers of
    the beauty EXR, so an .exr output carries them; a PNG or JPEG cannot, so
    they go to OUT.aov.exr beside it unless --aov-out names another file.
    """
    from ..image.files import check_output_path

    if not aovs:
        if aov_out is not None:
            raise UsageError("--aov-out needs --aov LIST (which AOVs to write)")
        return None
    if aov_out is None:
        if Path(output).suffix.lower() == ".exr":
            return None
        aov_out = default_aov_path(output)
    path = check_output_path(check_aov_path(aov_out), overwrite=overwrite)
    if path.resolve() == Path(output).resolve():
        return None
    return path
