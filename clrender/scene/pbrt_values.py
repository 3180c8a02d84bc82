"""pbrt-v4's parameter values read as clrender's: colours and spectra, named metals, roughness, transforms.

Named spectra.  pbrt-v4 (src/pbrt/util/spectrum.cpp) tabulates measured η and k of metals; clrender renders in
linear sRGB, so each is reduced to an RGB triple.  The triples below are the ones Mitsuba 3's `conductor`
plugin derives from the same measured data in its RGB variants (printed by `mi.traverse` of
`{"type": "conductor", "material": M}` in `scalar_rgb`: the spectrum integrated against the CIE 1931
observer and taken to linear sRGB), so a pbrt and a Mitsuba scene naming one metal get the same colour.
Brass (pbrt's metal-CuZn), which Mitsuba lacks, uses the widely quoted RGB fit η (0.444, 0.527, 1.094),
k (3.695, 2.765, 1.829).  Named glasses are their refractive index at the d line (587.6 nm, the
catalogue's n_d); pbrt's dispersion is not modelled.  A spectrum given as (wavelength, value) pairs is the
mean of its values; `blackbody T` is white of luminance 1 (pbrt-v4 normalises a light's spectrum to 1 nit
per unit `scale`; the temperature's tint is dropped).
"""

from __future__ import annotations

import math

import numpy as np

from .mitsuba_xml import rotate as axis_rotation

METAL_ETA_K = {
    "Ag": ((0.1553, 0.1167, 0.1384), (4.8284, 3.1222, 2.1469)),
    "Al": ((1.6575, 0.8804, 0.5212), (9.2238, 6.2695, 4.837)),
    "Au": ((0.143, 0.3753, 1.442), (3.983, 2.3856, 1.6034)),
    "Cu": ((0.201, 0.9237, 1.1022), (3.9133, 2.453, 2.1421)),
    "CuZn": ((0.444, 0.527, 1.094), (3.695, 2.765, 1.829)),
    "MgO": ((2.0896, 1.6507, 1.5949), (0.0, 0.0, 0.0)),
    "TiO2": ((3.4566, 2.8017, 2.9052), (0.0001, 0.0, 0.0007)),
}
GLASS_IOR = {
    "glass-BK7": 1.5168,
    "glass-BAF10": 1.6700,
    "glass-FK51A": 1.4866,
    "glass-LASF9": 1.8503,
    "glass-F5": 1.6034,
    "glass-F10": 1.7283,
    "glass-F11": 1.7847,
}


def named_spectrum(name: str):
    """An RGB triple of a named spectrum, a float for a named glass, or None when clrender does not know it."""
    if name in GLASS_IOR:
        return GLASS_IOR[name]
    if name.startswith("metal-") and name.endswith(("-eta", "-k")):
        metal, part = name[6:].rsplit("-", 1)
        if metal in METAL_ETA_K:
            return METAL_ETA_K[metal][0 if part == "eta" else 1]
    if name.startswith("stdillum-") or name == "canon_eos_100d_r":  # illuminants: white in RGB rendering
        return (1.0, 1.0, 1.0)
    return None


def perceptual_roughness(value: float, remap: bool) -> float:
    """clrender's perceptual roughness r (GGX α = r²) of a pbrt-v4 roughness: pbrt's α is
    TrowbridgeReitzDistribution::RoughnessToAlpha(x) = sqrt(x) when `remaproughness` (its default), else x."""
    alpha = math.sqrt(max(value, 0.0)) if remap else max(value, 0.0)
    return min(math.sqrt(alpha), 1.0)


def conductor_k_from_reflectance(r):
    """pbrt-v4's conductor given `reflectance` instead of η, k: η = 1, k = 2·sqrt(r)/sqrt(1 − r) (r clamped
    below 0.9999), so that normal-incidence Fresnel reflectance is r (materials.cpp, ConductorMaterial)."""
    return [2 * math.sqrt(c) / math.sqrt(1 - c) for c in (min(max(x, 0.0), 0.9999) for x in r)]


# ------------------------------------------------------------------ transforms (pbrt-v4 util/transform.cpp)
def translate(x, y, z) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def scale(x, y, z) -> np.ndarray:
    return np.diag([x, y, z, 1.0])


def rotate(degrees, x, y, z) -> np.ndarray | None:
    """Rotation by `degrees` about the axis (x, y, z), as pbrt's Rotate (Mitsuba's, the same Rodrigues formula);
    None for a zero axis."""
    if not any((x, y, z)):
        return None
    return axis_rotation((x, y, z), degrees)


def look_at(eye, look, up) -> np.ndarray | None:
    """pbrt's LookAt: camera-from-world, where the camera looks down +z with +y up and +x = up × dir; None when
    degenerate (up parallel to the view, or eye at look)."""
    eye, look, up = (np.asarray(v, np.float64) for v in (eye, look, up))
    d = look - eye
    if np.linalg.norm(d) == 0 or np.linalg.norm(up) == 0:
        return None
    d = d / np.linalg.norm(d)
    right = np.cross(up / np.linalg.norm(up), d)
    if np.linalg.norm(right) == 0:
        return None
    right /= np.linalg.norm(right)
    new_up = np.cross(d, right)
    world_from_camera = np.eye(4)
    world_from_camera[:3, 0], world_from_camera[:3, 1], world_from_camera[:3, 2], world_from_camera[:3, 3] = right, new_up, d, eye
    return np.linalg.inv(world_from_camera)


def matrix16(values) -> np.ndarray:
    """pbrt's Transform/ConcatTransform: 16 numbers in column-major order (the transpose of row-major reading)."""
    return np.array(values, np.float64).reshape(4, 4).T
