"""Mitsuba 3's texture plugins as clrender image textures (`[textures.NAME]` and a material's reference).

`bitmap`: `filename`, `filter_type` (bilinear -> "linear", nearest), `wrap_mode` (repeat, mirror ->
"mirrored_repeat", clamp -> "clamp_to_edge"), `raw` (a colour texture is sRGB-decoded, as Mitsuba decodes an
8-bit image unless raw; raw = true on a colour is refused), `to_uv` (scale and offset: KHR_texture_transform's).
`checkerboard` (`color0`, `color1`, `to_uv`): clrender has no procedural texture, so it is baked at load into
a 2 x 2 PNG (nearest filter, repeat) in the user cache folder (~/.cache/clrender/mitsuba), 8-bit sRGB: each
colour to within half an sRGB code.  Mitsuba's rule: color0 where frac(u) > 0.5 equals frac(v) > 0.5.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

WRAP = {"repeat": "repeat", "mirror": "mirrored_repeat", "clamp": "clamp_to_edge"}
FILTER = {"bilinear": "linear", "nearest": "nearest"}


def texture_ref(reader, t, srgb: bool):
    """A material's texture value (a name, or a table with a transform) for texture plugin t."""
    if t.type not in ("bitmap", "checkerboard"):
        reader.refuse(t, f'texture "{t.type}" is not supported (supported: bitmap, checkerboard)', "white")
        return None
    key = (id(t), srgb)
    if key not in reader.texture_names:
        spec = _bitmap(reader, t, srgb) if t.type == "bitmap" else _checkerboard(reader, t)
        name = t.id or f"texture{len(reader.texture_names) + 1}"
        while name in reader.out["textures"]:
            name += "_"
        reader.out["textures"][name] = spec
        reader.texture_names[key] = name
    name = reader.texture_names[key]
    m = t.get("to_uv", np.eye(4))
    reader.check_used(t)
    if np.allclose(m, np.eye(4)):
        return name
    if abs(m[0, 1]) > 1e-9 or abs(m[1, 0]) > 1e-9:
        reader.refuse(t, f'texture "{t.type}" to_uv with a rotation or shear is not supported (supported: scale and translate)', "its scale")
    return {"texture": name, "offset": [float(m[0, 3]), float(m[1, 3])], "scale": [float(m[0, 0]), float(m[1, 1])]}


def _bitmap(reader, t, srgb: bool) -> dict:
    name = t.get("filename")
    if not isinstance(name, str):
        t.fail('texture "bitmap" needs a filename')
    wrap = t.get("wrap_mode", "repeat")
    filt = t.get("filter_type", "bilinear")
    if wrap not in WRAP:
        t.fail(f'texture "bitmap" wrap_mode {wrap!r} is not one of {", ".join(WRAP)}')
    if filt not in FILTER:
        t.fail(f'texture "bitmap" filter_type {filt!r} is not one of {", ".join(FILTER)}')
    if t.get("raw", False) and srgb:
        reader.refuse(t, 'texture "bitmap" raw = true as a colour is not supported (clrender decodes colour textures from sRGB)', "sRGB-decoded")
    t.get("format")
    return {"file": name, "wrap_s": WRAP[wrap], "wrap_t": WRAP[wrap], "filter": FILTER[filt]}


def _checkerboard(reader, t) -> dict:
    from PIL import Image

    from .textures import srgb_to_linear

    c0, _ = reader.colour(t, "color0", 0.4, texture=False)
    c1, _ = reader.colour(t, "color1", 0.2, texture=False)
    if max(c0 + c1) > 1 or min(c0 + c1) < 0:
        reader.refuse(t, 'texture "checkerboard" colours outside [0, 1] are not supported', "clamped")
    codes = lambda c: [int(np.argmin(np.abs(srgb_to_linear(np.arange(256) / 255.0) - min(max(v, 0.0), 1.0)))) for v in c]
    a, b = codes(c0), codes(c1)
    pixels = np.array([[a, b], [b, a]], np.uint8)  # row 0 is v in [0, 0.5): color0 at (u, v) both below or both above 0.5
    folder = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache")) / "clrender" / "mitsuba"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"checkerboard_{'_'.join(map(str, a + b))}.png"
    if not path.exists():
        tmp = path.with_suffix(f".{os.getpid()}.tmp.png")
        Image.fromarray(pixels, "RGB").save(tmp)
        os.replace(tmp, path)
    return {"file": str(path), "wrap_s": "repeat", "wrap_t": "repeat", "filter": "nearest"}
