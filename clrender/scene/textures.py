"""Image textures: the scene's `[textures.NAME]` tables, the references materials make to them, decoding
into linear float texels, and packing every texture into the one buffer the kernels read (kernels/texture.h).

A texture is an image file (PNG, JPEG, anything Pillow decodes), or image `image` of a glTF file (its uri,
data URI or GLB bufferView: gltf.image_bytes).  The colour space is decided by the use, as glTF does:
colour textures (base colour, emissive) are sRGB-decoded, data textures (metallic-roughness, occlusion,
normal) are taken as stored; a texture used both ways is decoded twice.  Texels are float4 (16 bytes a texel,
no mip-maps), linear, row 0 the image's top, so UV (0, 0) is the image's top-left (glTF's convention; OBJ's
`vt` are flipped to it when read).  Every texture's bytes are checked against memory.require before it is
decoded (Pillow reads the size from the header alone).
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ..errors import UsageError, shown
from ..layout import TEXTURE_DTYPE, TEXTURE_SLOT_TABLE, TEXTURE_SLOTS, WRAP_MODES
from ..memory import BASE_BYTES, TEXEL_BYTES  # what decoding one texel peaks at (memory.py)
from .checks import Checks, TypeReader, show
from .confine import regular_file
from .image_files import MAX_TEXTURE_SIDE, own_size_limit

MAX_TEXTURES = 1024  # textures of one scene (distinct images times colour spaces)
FILTERS = ("linear", "nearest")  # bilinear, or the nearest texel (glTF magFilter 9729 / 9728)
COLOUR_SLOTS = tuple(slot.name for slot in TEXTURE_SLOT_TABLE if slot.colour)  # sRGB-decoded; the other slots are data
# Pillow's modes and how many channels they hold; palette images are expanded first
CHANNELS = {"L": 1, "I": 1, "I;16": 1, "F": 1, "LA": 2, "RGB": 3, "RGBA": 4}


@dataclass(frozen=True)
class TextureSpec:
    """A `[textures.NAME]` table: where the image is and how it is sampled."""

    file: str  # path relative to the scene file's folder
    image: int | None = None  # a glTF file's image index (file is then the .gltf/.glb)
    wrap_s: str = "repeat"  # WRAP_MODES key, along u
    wrap_t: str = "repeat"  # along v
    filter: str = "linear"  # FILTERS: bilinear, or the nearest texel


@dataclass(frozen=True)
class TextureRef:
    """A material's use of a texture: KHR_texture_transform's offset, rotation (radians) and scale, the UV set,
    and the index of the decoded texture in Scene.textures (filled in when the scene is read; -1 before)."""

    texture: str  # name in the scene's textures table
    tex_coord: int = 0  # 0: TEXCOORD_0, 1: TEXCOORD_1
    offset: tuple = (0.0, 0.0)
    rotation: float = 0.0
    scale: tuple = (1.0, 1.0)
    strength: float = 1.0  # occlusion: occlusion = 1 + strength (R - 1), in [0, 1]; normal map: the scale of x and y
    index: int = -1

    def matrix(self) -> list:
        """The 2 x 3 transform T R S of KHR_texture_transform, row-major (uv' = M (u, v, 1))."""
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        (ox, oy), (sx, sy) = self.offset, self.scale
        return [c * sx, s * sy, ox, -s * sx, c * sy, oy]


@dataclass
class TextureImage:
    """A decoded texture: linear float32 texels (H, W, 4) and its sampler."""

    pixels: np.ndarray
    wrap_s: str = "repeat"
    wrap_t: str = "repeat"
    nearest: bool = False
    source: str = ""  # for messages

    def mean_rgb(self) -> np.ndarray:
        return self.pixels[..., :3].reshape(-1, 3).mean(axis=0, dtype=np.float64)


# ------------------------------------------------------------------ reading
def _build_spec(checks: Checks, t: dict, path: str) -> TextureSpec:
    file = t.get("file")
    if not isinstance(file, str) or not file:
        checks.fail(f"{path}.file", f"expected the image's path, got {show(file)}")
    image = None
    if "image" in t:
        if not file.lower().endswith((".gltf", ".glb")):
            checks.fail(f"{path}.image", "only a .gltf or .glb 'file' has images")
        image = checks.integer(t, "image", path, low=0, high=MAX_TEXTURES * 16)
    wraps = tuple(WRAP_MODES)
    return TextureSpec(
        file=file,
        image=image,
        wrap_s=checks.choice(t, "wrap_s", path, "repeat", wraps),
        wrap_t=checks.choice(t, "wrap_t", path, "repeat", wraps),
        filter=checks.choice(t, "filter", path, "linear", FILTERS),
    )


TEXTURE_READER = TypeReader(("file", "image", "wrap_s", "wrap_t", "filter"), _build_spec)


def read_specs(checks: Checks, table) -> dict:
    table = checks.table(table, "textures")
    if len(table) > MAX_TEXTURES:
        checks.fail("textures", f"{len(table)} textures; allowed: at most {MAX_TEXTURES}")
    return {checks.name(k, "textures"): TEXTURE_READER.read(checks, checks.table(v, f"textures.{k}"), f"textures.{k}") for k, v in table.items()}


def read_ref(checks: Checks, value, path: str) -> TextureRef:
    """A material's texture key: a texture's name, or a table {texture, tex_coord, offset, rotation, scale, strength}."""
    if isinstance(value, str):
        value = {"texture": value}
    checks.table(value, path)
    checks.check_keys(value, path, ("texture", "tex_coord", "offset", "rotation", "scale", "strength"))
    name = value.get("texture")
    if not isinstance(name, str):
        checks.fail(f"{path}.texture", f"expected a texture's name, got {show(name)}")

    def pair(key, default):
        v = value.get(key, default)
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            checks.fail(f"{path}.{key}", f"expected a list of 2 numbers, got {show(v)}")
        return tuple(checks.number({"v": x}, "v", f"{path}.{key}", low=-1e6, high=1e6) for x in v)

    return TextureRef(
        texture=name,
        tex_coord=checks.integer(value, "tex_coord", path, 0, low=0, high=1),
        offset=pair("offset", (0.0, 0.0)),
        rotation=checks.number(value, "rotation", path, 0.0, low=-1e6, high=1e6),
        scale=pair("scale", (1.0, 1.0)),
        strength=checks.number(value, "strength", path, 1.0, low=-1e6, high=1e6),
    )


def resolve(checks: Checks, specs: dict, materials: dict) -> tuple[dict, list]:
    """The materials with each texture reference's `index` filled in, and the decoded textures it points to
    (one per texture and colour space used), every texture's memory checked before it is decoded."""
    from ..memory import require

    images, index_of = [], {}
    out = {}
    for mname, material in materials.items():
        changes = {}
        for slot in TEXTURE_SLOTS:
            ref = getattr(material, f"{slot}_texture", None)
            if ref is None:
                continue
            if ref.texture not in specs:
                defined = ", ".join(sorted(specs)) or "none"
                checks.fail(f"materials.{mname}.{slot}_texture", f"unknown texture {show(ref.texture)}; defined: {defined}")
            key = (ref.texture, slot in COLOUR_SLOTS)
            if key not in index_of:
                spec = specs[ref.texture]
                data, what = _image_source(checks, spec, f"textures.{ref.texture}")
                held = sum(i.pixels.shape[0] * i.pixels.shape[1] for i in images) * TEXEL_BYTES  # the textures before it
                pixels = decode(
                    data,
                    srgb=key[1],
                    what=what,
                    require=_with_held(require, held),
                )
                index_of[key] = len(images)
                images.append(TextureImage(pixels, spec.wrap_s, spec.wrap_t, spec.filter == "nearest", what))
            changes[f"{slot}_texture"] = replace(ref, index=index_of[key])
        out[mname] = replace(material, **changes) if changes else material
    return out, images


def _with_held(require, held: int):
    """memory.require for one more texture, counting the `held` bytes of the textures decoded before it."""

    def check(need: int, what: str) -> None:
        require(held + need, what + (" and the textures before it" if held else ""))

    return check


def _image_source(checks: Checks, spec: TextureSpec, path: str):
    """(bytes or a Path, a name for messages) of a texture's image, found through confine.scene_file."""
    from .confine import scene_file

    file = scene_file(checks.base_dir, spec.file, checks.root, f"{checks.where}: {path}.file")
    if spec.image is not None:
        from . import gltf

        return gltf.image_bytes(file, spec.image, checks.root), f"{spec.file} image {spec.image}"
    return regular_file(file, f"{checks.where}: {path}.file: texture file"), spec.file  # missing, or a FIFO: refused


def decode(data, *, srgb: bool, what: str, require=None) -> np.ndarray:
    """Linear float32 texels (H, W, 4) of an encoded image (bytes or a path): 1 channel is grey, 2 grey and
    alpha, 3 RGB, 4 RGBA (alpha 1 when absent); 8- and 16-bit values are normalised, sRGB-decoded when `srgb`
    (alpha never).  UsageError for what cannot be decoded, an unsupported mode, or a size past the limits."""
    from PIL import Image, UnidentifiedImageError

    with own_size_limit(Image):
        return _decode(Image, UnidentifiedImageError, data, srgb=srgb, what=what, require=require)


def _decode(Image, UnidentifiedImageError, data, *, srgb: bool, what: str, require) -> np.ndarray:
    try:
        image = Image.open(io.BytesIO(data) if isinstance(data, bytes) else Path(data))
        width, height = image.size
        if not (1 <= width <= MAX_TEXTURE_SIDE and 1 <= height <= MAX_TEXTURE_SIDE):
            raise UsageError(f"texture {shown(what)} is {width} x {height}; allowed: 1 to {MAX_TEXTURE_SIDE} texels a side")
        if require is not None:
            require(BASE_BYTES + width * height * TEXEL_BYTES, f"texture {shown(what)} ({width} x {height})")
        if image.mode in ("P", "PA", "1"):
            image = image.convert("RGBA")
        if image.mode not in CHANNELS:
            raise UsageError(f"texture {shown(what)} has mode {image.mode}; allowed: 1 to 4 channels of grey, grey+alpha, RGB or RGBA")
        image.load()
        raw = np.asarray(image)
    except UsageError:
        raise
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError, Image.DecompressionBombError) as exc:
        raise UsageError(f"texture {shown(what)} cannot be decoded ({type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''})") from None
    with np.errstate(all="ignore"):  # a float image's NaN or inf is refused just below, not warned about
        rgba = _linear_rgba(raw, srgb)
    check_texels(rgba, what)
    return rgba


def check_texels(rgba: np.ndarray, what: str) -> None:
    """Refuse decoded texels outside [0, 1]: a float or 32-bit integer image (TIFF "F" or "I") is taken as it
    is stored, so its NaN, inf, negative or huge values would reach the shading (a colour texture multiplies a
    base colour that is at most 1, a data texture a factor in [0, 1] or a normal's components)."""
    bad = ~((rgba >= 0.0) & (rgba <= 1.0))  # NaN fails both
    if bad.any():
        value = rgba[bad][0]
        raise UsageError(f"texture {shown(what)} holds the value {value:g} after decoding; allowed: 0 to 1 (8- and 16-bit images always are)")


def _linear_rgba(raw: np.ndarray, srgb: bool) -> np.ndarray:
    """(H, W, 4) float32 of Pillow's (H, W[, C]) values: integers through a lookup table of their 2^8 or 2^16
    values (normalised, sRGB-decoded in float64 when `srgb`: a 2048^2 image in a fraction of a second)."""
    raw = raw[..., None] if raw.ndim == 2 else raw
    n = raw.shape[2]
    if raw.dtype == np.uint8 or (raw.dtype.kind in "iu" and raw.max(initial=0) <= 65535 and raw.min(initial=0) >= 0):
        top = 255 if raw.dtype == np.uint8 else 65535
        codes = raw.astype(np.uint8 if top == 255 else np.int64, copy=False)
        plain = (np.arange(top + 1) / top).astype(np.float32)
        colour = srgb_to_linear(np.arange(top + 1) / top).astype(np.float32) if srgb else plain
    else:  # float images ("F"): linear values as they are
        codes, plain, colour = None, None, None
    rgba = np.ones((*raw.shape[:2], 4), np.float32)
    rgb = raw[..., :1] if n <= 2 else raw[..., :3]
    rgba[..., :3] = colour[rgb] if codes is not None else rgb
    if n in (2, 4):
        rgba[..., 3] = plain[raw[..., n - 1]] if codes is not None else raw[..., n - 1]
    return rgba


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """The sRGB transfer function inverted (IEC 61966-2-1), in float64."""
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def pack(images: list) -> tuple[np.ndarray, np.ndarray]:
    """Texture records (layout.TEXTURE_DTYPE) and the texel buffer (N, 4) float32 they index (one zero texel
    when there are none, so the buffer is never empty)."""
    records = np.zeros(len(images), TEXTURE_DTYPE)
    offset = 0
    for record, image in zip(records, images):
        h, w = image.pixels.shape[:2]
        record["offset"], record["width"], record["height"] = offset, w, h
        record["wrap_s"], record["wrap_t"] = WRAP_MODES[image.wrap_s], WRAP_MODES[image.wrap_t]
        record["nearest"] = image.nearest
        offset += w * h
    texels = np.concatenate([i.pixels.reshape(-1, 4) for i in images]) if images else np.zeros((1, 4), np.float32)
    return (records if len(records) else np.zeros(1, TEXTURE_DTYPE)), np.ascontiguousarray(texels, np.float32)


# ------------------------------------------------------------------ OBJ materials
def mtl_material(tm, maps=False) -> dict | None:
    """The material a mesh file brings through trimesh (an OBJ's .mtl), as Material keyword arguments plus the
    `image` trimesh decoded for map_Kd (a PIL image) under "image"; None when it brings none.  The rule: Kd is
    the diffuse colour, Ks the specular colour, Ns the Blinn-Phong exponent, 1 - d the transparency, Ke the
    emission (all linear, as clrender's colours are), map_Kd a diffuse texture (sRGB-decoded)."""
    material = getattr(getattr(tm, "visual", None), "material", None)
    raw = getattr(material, "kwargs", None)
    if not isinstance(raw, dict):
        return None

    def floats(key, n):
        value = raw.get(key)
        value = [value] if isinstance(value, (int, float, str)) else value
        try:
            out = [float(v) for v in value][:n]
        except (TypeError, ValueError):
            return None
        return out if len(out) == n and all(math.isfinite(v) for v in out) else None

    keys = {}
    for key, name, n in (("kd", "diffuse", 3), ("ks", "specular", 3), ("ke", "emission", 3), ("ns", "shininess", 1), ("d", "transparency", 1)):
        value = floats(key, n)
        if value is not None:
            top = 1.0 if name in ("diffuse", "specular") else 1e6  # checks.py's ALBEDO_LIMIT and RADIANCE_LIMIT
            if name in ("diffuse", "specular") and max(value) > top:
                from ..errors import warn

                name_shown = shown(str(getattr(material, "name", "")))
                warn(f"material {name_shown}: {key.capitalize()} {max(value):g} clamped to {top:g} (a reflectance is at most 1)")
            value = [min(max(v, 0.0), top) for v in value]
            keys[name] = value[0] if n == 1 else tuple(value)
    if "transparency" in keys:
        keys["transparency"] = 1.0 - min(keys["transparency"], 1.0)
    image = getattr(material, "image", None)
    name = str(getattr(material, "name", "") or "material")
    if maps is not False:  # an OBJ (obj_mtl.mtl_maps): no .mtl, no material; map_Kd from the file clrender checked
        if maps is None:
            return None
        # the named material's checked file; else trimesh's own image only when the .mtl has map_Kd files (an atlas
        # of several), never its placeholder for a material without one
        image = maps.maps.get(name) or (image if maps.maps else None)
    if not keys and image is None:
        return None
    return {**keys, "image": image, "name": name}
