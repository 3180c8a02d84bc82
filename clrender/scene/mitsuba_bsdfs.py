"""Mitsuba 3's BSDF and texture plugins as clrender materials: one function per plugin.

Each function takes the plugin (mitsuba_xml.Plugin) and the reader (mitsuba_plugins.Reader: colours,
textures, refusals) and returns the material dict a `[materials.NAME]` table holds.  What maps onto today's
materials (docs/materials.md) does so directly; the lobes a Mitsuba scene needs beyond them (a conductor from
η and k, the coated diffuse of plastic/roughplastic, the thin dielectric, Mitsuba's separable Smith term) are
written with the keys of the material contract those lobes take (`type`, `eta`, `k`, `tint`, `smith`, ...:
docs/scene-formats.md), and `fit_to_build` says what this build of clrender cannot render yet.

Roughness: Mitsuba's `alpha` is GGX's (or Beckmann's) α; clrender's `roughness` is the perceptual r with
α = r², so r = sqrt(alpha).  Beckmann is drawn as GGX with the same α (documented approximation).
"""

from __future__ import annotations

import math

from .materials import MATERIAL_READER
from .mitsuba_data import CONDUCTORS, IORS

WHITE = (1.0, 1.0, 1.0)


def _ior(p, reader, name: str, default: str) -> float:
    value = p.get(name, default)
    if isinstance(value, str):
        if value not in IORS:
            reader.refuse(p, f'{p.tag} "{p.type}" {name} {value!r} is not a named index of refraction (named: {", ".join(IORS)})')
            return IORS[default]
        return IORS[value]
    return float(value)


def _eta(p, reader) -> float:
    return _ior(p, reader, "int_ior", "bk7" if p.type in ("dielectric", "roughdielectric", "thindielectric") else "polypropylene") / _ior(
        p, reader, "ext_ior", "air"
    )


def _alpha(p, reader) -> tuple[float, bool]:
    """(GGX alpha, rough) of a rough plugin: `alpha` (or equal `alpha_u`/`alpha_v`), `distribution` beckmann or ggx."""
    distribution = p.get("distribution", "beckmann")
    if distribution not in ("beckmann", "ggx"):
        reader.refuse(p, f'{p.tag} "{p.type}" distribution {distribution!r} is not supported (supported: beckmann, ggx)')
    p.get("sample_visible")
    if p.has("alpha_u") or p.has("alpha_v"):
        au, av = p.get("alpha_u", 0.1), p.get("alpha_v", 0.1)
        if au != av:
            reader.refuse(p, f'{p.tag} "{p.type}" is anisotropic (alpha_u {au:g}, alpha_v {av:g}); supported: isotropic roughness')
        alpha = (au + av) / 2
    else:
        alpha = reader.scalar(p, "alpha", 0.1)
    return alpha, True


def _roughness(alpha: float) -> float:
    return min(1.0, math.sqrt(max(alpha, 0.0)))


def diffuse(p, reader) -> dict:
    rgb, tex = reader.colour(p, "reflectance", 0.5)
    return {"diffuse": list(WHITE), "diffuse_texture": tex} if tex else {"diffuse": rgb}


def dielectric(p, reader) -> dict:
    """Smooth or rough glass: glTF transmission 1 (KHR_materials_transmission) with η = int_ior / ext_ior."""
    eta = _eta(p, reader)
    reader.expect_white(p, "specular_reflectance")
    tint, _ = reader.colour(p, "specular_transmittance", 1.0, texture=False)
    m = {"base_color": tint, "metallic": 0.0, "roughness": 0.0, "transmission": 1.0, "ior": eta}
    if p.type == "roughdielectric":
        alpha, _ = _alpha(p, reader)
        m.update(roughness=_roughness(alpha), smith="separable")
    return m


def thindielectric(p, reader) -> dict:
    reader.expect_white(p, "specular_reflectance")
    tint, _ = reader.colour(p, "specular_transmittance", 1.0, texture=False)
    return {"type": "thin_dielectric", "ior": _eta(p, reader), "tint": tint}


def conductor(p, reader) -> dict:
    """η and k per channel: explicit `eta`/`k`, or `material` from Mitsuba's table (mitsuba_data.CONDUCTORS)."""
    name = p.get("material", "none")
    if p.has("eta") or p.has("k"):
        eta, _ = reader.colour(p, "eta", 0.0, texture=False)
        k, _ = reader.colour(p, "k", 1.0, texture=False)
    elif name in CONDUCTORS:
        eta, k = (list(v) for v in CONDUCTORS[name])
    else:
        reader.refuse(p, f'{p.tag} "{p.type}" material {name!r} is not one of Mitsuba\'s conductors ({", ".join(CONDUCTORS)})')
        eta, k = (list(v) for v in CONDUCTORS["none"])
    tint, _ = reader.colour(p, "specular_reflectance", 1.0, texture=False)
    m = {"type": "conductor", "eta": eta, "k": k, "roughness": 0.0, "tint": tint}
    if p.type == "roughconductor":
        alpha, _ = _alpha(p, reader)
        m.update(roughness=_roughness(alpha), smith="separable")
    return m


def plastic(p, reader) -> dict:
    """plastic / roughplastic: a diffuse base under a dielectric coat (the coated_diffuse lobe)."""
    rgb, _ = reader.colour(p, "diffuse_reflectance", 0.5, texture=False)
    tint, _ = reader.colour(p, "specular_reflectance", 1.0, texture=False)
    m = {
        "type": "coated_diffuse",
        "diffuse": rgb,
        "ior": _eta(p, reader),
        "roughness": 0.0,
        "tint": tint,
        "nonlinear": bool(p.get("nonlinear", False)),
    }
    if p.type == "roughplastic":
        alpha, _ = _alpha(p, reader)
        m.update(roughness=_roughness(alpha), smith="separable")
    return m


PRINCIPLED_SUPPORTED = ("base_color", "roughness", "metallic", "spec_trans", "eta")


def principled(p, reader) -> dict:
    """The parameters glTF's metallic-roughness model covers (Mitsuba's principled uses α = roughness² too)."""
    for name in sorted(set(p.props) | {n for n, _ in p.children if n}):
        if name not in PRINCIPLED_SUPPORTED:
            reader.refuse(p, f'bsdf "principled" parameter {name!r} is not supported (supported: {", ".join(PRINCIPLED_SUPPORTED)})')
            p.used.add(name)
    rgb, tex = reader.colour(p, "base_color", 0.5)
    m = {
        "base_color": list(WHITE) if tex else rgb,
        "metallic": reader.scalar(p, "metallic", 0.0),
        "roughness": min(1.0, reader.scalar(p, "roughness", 0.5)),
        "transmission": reader.scalar(p, "spec_trans", 0.0),
        "ior": reader.scalar(p, "eta", 1.5),
    }
    if tex:
        m["base_color_texture"] = tex
    return m


def twosided(p, reader) -> dict:
    inner = p.nested("bsdf")
    if len(inner) not in (1, 2):
        p.fail('bsdf "twosided" needs one or two nested bsdfs')
    if len(inner) == 2 and inner[0] is not inner[1]:
        reader.refuse(p, 'bsdf "twosided" with a different bsdf on each side is not supported (supported: one bsdf for both sides)')
    return dict(reader.bsdf_dict(inner[0]))


def _one_inner(p, reader) -> dict:
    inner = p.nested("bsdf")
    if len(inner) != 1:
        p.fail(f'bsdf "{p.type}" needs one nested bsdf')
    return dict(reader.bsdf_dict(inner[0]))


def mask(p, reader) -> dict:
    """Mitsuba's stochastic opacity: clrender's alpha blend (coverage = opacity)."""
    m = _one_inner(p, reader)
    opacity = reader.scalar(p, "opacity", 0.5)
    m["alpha"] = {"mode": "blend", "factor": min(max(opacity, 0.0), 1.0)}
    return m


def normalmap(p, reader) -> dict:
    m = _one_inner(p, reader)
    tex = reader.texture_child(p, "normalmap", srgb=False)
    if "diffuse" in m and "type" not in m:  # a Whitted Lambert takes no normal map: the same Lambert as glTF's rough dielectric
        reader.refuse(p, 'bsdf "normalmap" over "diffuse": clrender\'s Lambert material takes no normal map (supported: over dielectric, principled)')
        return m
    if tex:
        m["normal_texture"] = tex
    return m


def blendbsdf(p, reader) -> dict:
    """A blend of two Lambert materials is the Lambert of the blended albedo (exact); other blends are refused."""
    inner = p.nested("bsdf")
    if len(inner) != 2:
        p.fail('bsdf "blendbsdf" needs two nested bsdfs')
    w = reader.scalar(p, "weight", 0.5)
    a, b = (reader.bsdf_dict(q) for q in inner)
    if set(a) == {"diffuse"} and set(b) == {"diffuse"}:
        return {"diffuse": [(1 - w) * x + w * y for x, y in zip(a["diffuse"], b["diffuse"])]}
    reader.refuse(p, 'bsdf "blendbsdf" of materials other than two untextured diffuse ones is not supported')
    return dict(b if w >= 0.5 else a)


def null(p, reader) -> dict:
    """An invisible surface (Mitsuba uses it to bound media): every point masked out."""
    return {"diffuse": [0.0, 0.0, 0.0], "alpha": {"mode": "mask", "cutoff": 0.5, "factor": 0.0}}


BSDFS = {
    "diffuse": diffuse,
    "dielectric": dielectric,
    "roughdielectric": dielectric,
    "thindielectric": thindielectric,
    "conductor": conductor,
    "roughconductor": conductor,
    "plastic": plastic,
    "roughplastic": plastic,
    "principled": principled,
    "twosided": twosided,
    "mask": mask,
    "normalmap": normalmap,
    "blendbsdf": blendbsdf,
    "null": null,
}
STAND_IN = {"diffuse": [0.5, 0.5, 0.5]}  # --approximate: an unsupported bsdf is Mitsuba's default grey diffuse


# ---------------------------------------------------------------------- what this build renders
def _reflectance_at_normal(eta, k) -> list:
    return [((n - 1) ** 2 + kk**2) / ((n + 1) ** 2 + kk**2) for n, kk in zip(eta, k)]


def fit_to_build(m: dict, p, reader) -> dict:
    """The material as this build of clrender reads it.  Contract keys its material reader does not know yet:
    a `type` (conductor, coated_diffuse, thin_dielectric) is refused (--approximate: a glTF stand-in), and
    `smith = "separable"` is dropped (clrender's height-correlated term is drawn; docs/scene-formats.md)."""
    keys = MATERIAL_READER.keys
    if "smith" in m and "smith" not in keys:
        m = {k: v for k, v in m.items() if k != "smith"}
    if "type" not in m or "type" in keys:
        return m
    if _perfect_mirror(m):  # Mitsuba's material "none" (η 0): reflectance 1 at every angle, today's Whitted mirror exactly
        return {"diffuse": [0.0, 0.0, 0.0], "mirror": 1.0}
    reader.refuse(p, f'bsdf "{p.type}" needs the {m["type"]} lobe, which this build of clrender does not have yet')
    kind = m["type"]
    if kind == "conductor":
        return {
            "base_color": [min(1.0, f * t) for f, t in zip(_reflectance_at_normal(m["eta"], m["k"]), m["tint"])],
            "metallic": 1.0,
            "roughness": m["roughness"],
        }
    if kind == "coated_diffuse":
        return {"diffuse": m["diffuse"], "specular": [0.04] * 3, "shininess": min(1e5, 2 / _roughness_alpha(m["roughness"]) ** 2 - 2)}
    return {"base_color": m["tint"], "metallic": 0.0, "roughness": 0.0, "transmission": 1.0, "ior": 1.0}


def _perfect_mirror(m: dict) -> bool:
    """A smooth conductor of η 0 and k > 0 with a white tint: the Fresnel term is 1 at every angle."""
    return m["type"] == "conductor" and m["roughness"] == 0 and m["tint"] == [1.0] * 3 and all(e == 0 and k > 0 for e, k in zip(m["eta"], m["k"]))


def _roughness_alpha(r: float) -> float:
    return max(r * r, 1e-3)
