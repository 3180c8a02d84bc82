"""pbrt-v4 materials and textures as clrender scene-dict materials (docs/scene-formats-pbrt.md's table).

`conductor`, `coateddiffuse` and `thindielectric` map onto the `type = "conductor" | "coated_diffuse" |
"thin_dielectric"` materials of the lobes work (their keys: eta, k, roughness, tint; diffuse, ior,
roughness, tint, nonlinear; ior, tint).  Roughness is clrender's perceptual r (GGX α = r²) of pbrt's α
(pbrt_values.perceptual_roughness).
"""

from __future__ import annotations

from .pbrt_parse import Directive, fail
from .pbrt_values import GLASS_IOR, conductor_k_from_reflectance, named_spectrum, perceptual_roughness

ROUGH = ("roughness", "uroughness", "vroughness", "remaproughness")


def material(reader, d: Directive, kind: str) -> dict:
    return _MATERIALS[kind](reader, d)


def _diffuse(reader, d) -> dict:
    p = reader.params(d, ("reflectance", "displacement", "normalmap"))
    _no_maps(reader, d, p)
    out = {"diffuse": [0.5, 0.5, 0.5]}
    _colour_or_texture(reader, d, p.get("reflectance"), out, "diffuse", "diffuse_texture")
    return out


def _dielectric(reader, d) -> dict:
    p = reader.params(d, ("eta", *ROUGH, "displacement", "normalmap"))
    _no_maps(reader, d, p)
    ior = _ior(reader, p.get("eta"))
    r = _roughness(reader, d, p)
    if r == 0:  # smooth: the path tracer's smooth dielectric of `ior` (docs/materials.md)
        return {"diffuse": [0.0, 0.0, 0.0], "transparency": 1.0, "ior": ior}
    return {"base_color": [1.0, 1.0, 1.0], "metallic": 0.0, "roughness": r, "transmission": 1.0, "ior": ior}


def _thindielectric(reader, d) -> dict:
    p = reader.params(d, ("eta", "displacement", "normalmap"))
    _no_maps(reader, d, p)
    return {"type": "thin_dielectric", "ior": _ior(reader, p.get("eta")), "tint": [1.0, 1.0, 1.0]}


def _conductor(reader, d) -> dict:
    p = reader.params(d, ("eta", "k", "reflectance", *ROUGH, "displacement", "normalmap"))
    _no_maps(reader, d, p)
    if "reflectance" in p:
        if "eta" in p or "k" in p:
            fail(d.where, 'Material "conductor": give "reflectance" or "eta" and "k", not both')
        r = reader.colour(_constant(reader, p["reflectance"]), (0, 0, 0))
        eta, k = [1.0, 1.0, 1.0], conductor_k_from_reflectance(r)
    else:  # pbrt-v4's default metal is copper
        eta = reader.colour(_constant(reader, p.get("eta")), named_spectrum("metal-Cu-eta"))
        k = reader.colour(_constant(reader, p.get("k")), named_spectrum("metal-Cu-k"))
    return {"type": "conductor", "eta": eta, "k": k, "roughness": _roughness(reader, d, p), "tint": [1.0, 1.0, 1.0]}


def _coateddiffuse(reader, d) -> dict:
    p = reader.params(d, ("reflectance", *ROUGH, "thickness", "eta", "albedo", "g", "maxdepth", "nsamples", "displacement", "normalmap"))
    _no_maps(reader, d, p)
    albedo = reader.colour(_constant(reader, p.get("albedo")), (0, 0, 0))
    if any(albedo):
        reader.unsupported(d, 'Material "coateddiffuse" with a scattering layer ("albedo" > 0)', ('"albedo" 0',), "a clear coat")
    out = {"type": "coated_diffuse", "diffuse": [0.5, 0.5, 0.5], "ior": _ior(reader, p.get("eta")), "roughness": _roughness(reader, d, p)}
    _colour_or_texture(reader, d, p.get("reflectance"), out, "diffuse", "diffuse_texture")
    out.update(tint=[1.0, 1.0, 1.0], nonlinear=False)
    return out


_MATERIALS = {
    "diffuse": _diffuse,
    "dielectric": _dielectric,
    "thindielectric": _thindielectric,
    "conductor": _conductor,
    "coateddiffuse": _coateddiffuse,
}


def _no_maps(reader, d, p):
    for key in ("displacement", "normalmap"):
        if key in p:
            reader.unsupported(d, f'Material "{d.args[0]}" parameter "{key}"', ("materials without displacement or normal maps",), "ignored")


def _ior(reader, p) -> float:
    if p is None:
        return 1.5
    if p.type == "spectrum" and len(p.values) == 1 and isinstance(p.values[0], str):
        named = named_spectrum(p.values[0])
        if isinstance(named, float):
            return named
        fail(p.where, f'"eta" spectrum "{p.values[0]}" is not a known glass (supported: {", ".join(GLASS_IOR)})')
    if p.type in ("float", "spectrum") and p.values and all(isinstance(v, float) for v in p.values):
        value = p.values[0] if p.type == "float" else sum(p.values[1::2]) / max(len(p.values) // 2, 1)
        if not 0.01 <= value <= 100:
            fail(p.where, f'"eta" {value:g}; allowed: 0.01 to 100')
        return float(value)
    fail(p.where, f'"eta": expected a float or a named spectrum, got {p.type}')


def _roughness(reader, d, p) -> float:
    remap = bool(p["remaproughness"].values[0]) if "remaproughness" in p else True
    u = reader.number(d, _constant(reader, p.get("uroughness", p.get("roughness"))), 0.0)
    v = reader.number(d, _constant(reader, p.get("vroughness", p.get("roughness"))), 0.0)
    if u != v:
        reader.unsupported(d, f'Material "{d.args[0]}" with anisotropic roughness ({u:g}, {v:g})', ("isotropic roughness",), "their geometric mean")
        u = (u * v) ** 0.5
    return perceptual_roughness(u, remap)


def _constant(reader, p):
    """A parameter, with a `texture` reference replaced by the constant it names (a float or RGB texture that
    is a constant); an image texture here is refused: only diffuse colours take image textures."""
    if p is None or p.type != "texture":
        return p
    entry = reader.textures.get(p.values[0])
    if entry is None:
        fail(p.where, f'texture "{p.values[0]}" is not defined')
    if entry[0] == "image":
        fail(p.where, f'parameter "{p.name}": an image texture here is not supported (supported: image textures on reflectance)')
    return type(p)("rgb", p.name, list(entry[1]), p.where)


def _colour_or_texture(reader, d, p, out, colour_key, texture_key):
    if p is not None and p.type == "texture":
        entry = reader.textures.get(p.values[0])
        if entry is None:
            fail(p.where, f'texture "{p.values[0]}" is not defined')
        if entry[0] == "image":
            out[colour_key], out[texture_key] = list(entry[2]), entry[1]
            return
        out[colour_key] = list(entry[1])
        return
    out[colour_key] = reader.colour(p, out[colour_key])


# ------------------------------------------------------------------ textures
def texture(reader, d: Directive):
    """("const", rgb) or ("image", texture name, rgb factor) of a Texture directive."""
    name, _, kind = d.args
    if kind == "constant":
        p = reader.params(d, ("value",))
        return ("const", reader.colour(p.get("value"), (1, 1, 1)))
    if kind == "scale":
        p = reader.params(d, ("tex", "scale"))
        a, b = (_texture_value(reader, p.get(k)) for k in ("tex", "scale"))
        if a[0] == "image" and b[0] == "image":
            reader.unsupported(d, 'Texture "scale" of two image textures', ("an image times a constant",), "the first image")
            return a
        image, const = (a, b) if a[0] == "image" else (b, a)
        if image[0] == "image":
            return ("image", image[1], [x * y for x, y in zip(image[2], const[1], strict=True)])
        return ("const", [x * y for x, y in zip(a[1], b[1], strict=True)])
    if kind == "checkerboard":
        p = reader.params(d, ("tex1", "tex2", "uscale", "vscale", "udelta", "vdelta", "dimension", "mapping"))
        one, two = _texture_value(reader, p.get("tex1"), 1.0), _texture_value(reader, p.get("tex2"), 0.0)
        mean = [(x + y) / 2 for x, y in zip(one[1], two[1], strict=True)] if one[0] == two[0] == "const" else [0.5] * 3
        reader.unsupported(d, 'Texture "checkerboard"', ("imagemap", "scale", "constant"), "its mean colour")
        return ("const", mean)
    if kind == "imagemap":
        return _imagemap(reader, d, name)
    reader.unsupported(d, f'Texture "{kind}"', ("imagemap", "checkerboard", "scale", "constant"), "grey 0.5")
    return ("const", [0.5, 0.5, 0.5])


def _texture_value(reader, p, default=1.0):
    if p is None:
        return ("const", [default] * 3)
    if p.type == "texture":
        entry = reader.textures.get(p.values[0])
        if entry is None:
            fail(p.where, f'texture "{p.values[0]}" is not defined')
        return entry
    return ("const", reader.colour(p, (default,) * 3))


WRAPS = {"repeat": "repeat", "clamp": "clamp_to_edge"}
IMAGE_FILTERS = {"bilinear": "linear", "point": "nearest", "trilinear": "linear", "ewa": "linear"}


IMAGEMAP_PARAMS = ("filename", "wrap", "filter", "scale", "invert", "encoding", "maxanisotropy", "mapping", "uscale", "vscale", "udelta", "vdelta")


def _imagemap(reader, d, name):
    p = reader.params(d, IMAGEMAP_PARAMS)
    file = p.get("filename")
    if file is None or file.type != "string":
        fail(d.where, 'Texture "imagemap" needs a "string filename"')
    reader.resolve(file.values[0], f"{d.where}: Texture {name!r} filename")
    spec = {"file": file.values[0]}
    wrap = p["wrap"].values[0] if "wrap" in p else "repeat"
    if wrap not in WRAPS:
        reader.unsupported(d, f'imagemap "wrap" "{wrap}"', tuple(WRAPS), "repeat")
    spec["wrap_s"] = spec["wrap_t"] = WRAPS.get(wrap, "repeat")
    spec["filter"] = IMAGE_FILTERS.get(p["filter"].values[0] if "filter" in p else "bilinear", "linear")
    for key, default in (("uscale", 1.0), ("vscale", 1.0), ("udelta", 0.0), ("vdelta", 0.0)):
        if reader.number(d, p.get(key), default) != default:
            reader.unsupported(d, f'imagemap "{key}"', ("the mesh's own uv",), "ignored")
    if "invert" in p and p["invert"].values[0]:
        reader.unsupported(d, 'imagemap "invert" true', ("invert false",), "not inverted")
    if "encoding" in p and p["encoding"].values[0] != "sRGB":
        reader.unsupported(d, f'imagemap "encoding" "{p["encoding"].values[0]}"', ("sRGB",), "sRGB")
    texture_name = f"{name}"
    reader.image_textures[texture_name] = spec
    return ("image", texture_name, [reader.number(d, p.get("scale"), 1.0)] * 3)
