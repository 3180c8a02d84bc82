"""The display transform: scene-linear radiance to the sRGB values an 8-bit PNG or JPEG stores.

    linear RGB  --x 2^exposure-->  --tone curve-->  display-linear [0, 1]  --sRGB OETF-->  [0, 1]

`clamp` (the default) is the identity curve: values above 1 clip, which is what every PNG and JPEG
written before there was a choice got, bit for bit (the sRGB OETF clamps to [0, 1] itself).  `aces`
and `agx` roll highlights off instead of clipping them.  Float outputs (EXR, HDR, PFM) take none of
this: they keep the renderer's scene-linear values, exposure included, for a compositor to grade
(docs/display.md).  The sRGB encoding itself, and `display_srgb` / `srgb8` which end the chain, are in
clrender/image/files.py beside the writers.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from ..errors import UsageError


class Tonemap(enum.StrEnum):
    CLAMP = "clamp"  # identity: values above 1 clip (the output before tone mapping existed)
    ACES = "aces"  # Stephen Hill's fit of the ACES RRT + sRGB ODT
    AGX = "agx"  # Troy Sobotka's AgX base, as in Blender 4, by its polynomial sigmoid


TONEMAPS = tuple(t.value for t in Tonemap)


@dataclass(frozen=True)
class DisplaySettings:
    exposure: float = 0.0  # stops: linear RGB is multiplied by 2**exposure before the curve
    tonemap: Tonemap = Tonemap.CLAMP  # the curve; clamp keeps the historic output bit for bit

    def __post_init__(self):
        real = isinstance(self.exposure, (int, float, np.integer, np.floating)) and not isinstance(self.exposure, (bool, np.bool_))
        if not real or not np.isfinite(self.exposure) or abs(self.exposure) > 64:
            raise UsageError(f"exposure {self.exposure!r} is not allowed; allowed: a number of stops from -64 to 64")
        if not isinstance(self.tonemap, str) or self.tonemap not in TONEMAPS:
            raise UsageError(f"tonemap {self.tonemap!r} is not allowed; allowed: {'|'.join(TONEMAPS)}")
        object.__setattr__(self, "tonemap", Tonemap(self.tonemap))


# Stephen Hill's fit (github.com/TheRealMJP/BakingLab, ACES.hlsl, MIT), rows applied to RGB columns:
# sRGB -> XYZ -> D65 to D60 -> AP1 -> RRT_SAT
ACES_INPUT = np.array([[0.59719, 0.35458, 0.04823], [0.07600, 0.90834, 0.01566], [0.02840, 0.13383, 0.83777]])
# ODT_SAT -> XYZ -> D60 to D65 -> sRGB
ACES_OUTPUT = np.array([[1.60475, -0.53108, -0.07367], [-0.10208, 1.10813, -0.00605], [-0.00327, -0.07276, 1.07602]])


def aces_curve(v: np.ndarray) -> np.ndarray:
    """Hill's RRTAndODTFit: (v (v + 0.0245786) - 0.000090537) / (v (0.983729 v + 0.4329510) + 0.238081)."""
    return (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.4329510) + 0.238081)


def aces(rgb: np.ndarray) -> np.ndarray:
    """ACES filmic (Hill's RRT+ODT fit): linear sRGB in, display-linear sRGB in [0, 1] out."""
    return np.clip(_mat(aces_curve(_mat(rgb, ACES_INPUT)), ACES_OUTPUT), 0.0, 1.0)


# AgX base (Troy Sobotka; Blender 4's "AgX" view) in the minimal form of Benjamin Wrensch's
# "Minimal AgX Implementation" (iolite-engine.com, 2023): the inset matrix, a log2 encoding over
# [AGX_MIN_EV, AGX_MAX_EV], a 6th-order polynomial fit of the AgX sigmoid, the outset matrix, and
# the display's 2.2 power back to display-linear.  The GLSL mat3s there are column-major; these are rows.
AGX_INSET = np.array(
    [
        [0.842479062253094, 0.0784335999999992, 0.0792237451477643],
        [0.0423282422610123, 0.878468636469772, 0.0791661274605434],
        [0.0423756549057051, 0.0784336, 0.879142973793104],
    ]
)
AGX_OUTSET = np.array(
    [
        [1.19687900512017, -0.0980208811401368, -0.0990297440797205],
        [-0.0528968517574562, 1.15190312990417, -0.0989611768448433],
        [-0.0529716355144438, -0.0980434501171241, 1.15107367264116],
    ]
)
AGX_MIN_EV = -12.47393  # log2 of the darkest value the sigmoid tells apart: 10 stops under middle grey 0.18
AGX_MAX_EV = 4.026069  # ... and of the brightest: 6.5 stops over it
# the sigmoid fit's coefficients, x^6 down to x^0 (mean squared error 3.67e-6 against the LUT)
AGX_POLY = (15.5, -40.14, 31.96, -6.868, 0.4298, 0.1191, -0.00232)


def agx_sigmoid(x: np.ndarray) -> np.ndarray:
    """The polynomial AgX contrast curve on the normalised log encoding x in [0, 1]."""
    return np.polyval(AGX_POLY, x)


def agx(rgb: np.ndarray) -> np.ndarray:
    """AgX base: linear sRGB in, display-linear sRGB in [0, 1] out."""
    inset = np.maximum(_mat(rgb, AGX_INSET), 1e-10)  # log2 of 0 is -inf; it clips to AGX_MIN_EV anyway
    encoded = (np.clip(np.log2(inset), AGX_MIN_EV, AGX_MAX_EV) - AGX_MIN_EV) / (AGX_MAX_EV - AGX_MIN_EV)
    display = np.clip(_mat(agx_sigmoid(encoded), AGX_OUTSET), 0.0, 1.0)
    return display**2.2


# `--exposure auto` (the default of path-traced PNG/JPEG): never brighter than as rendered; darker, by the stops
# that bring the AUTO_PERCENTILE-th percentile of luminance down to AUTO_WHITE, when more of the image than the
# rest would clip (docs/display.md, "Automatic exposure").
AUTO_PERCENTILE = 97.0  # at most 3% of the pixels (light sources, highlights, the brightest sky) reach white
AUTO_WHITE = 1.0  # where the clamp curve clips
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 / sRGB primaries


def auto_exposure(linear_rgb: np.ndarray) -> float:
    """The stops of `--exposure auto` for an (H, W, 3) scene-linear image: min(0, -log2(P / AUTO_WHITE)), P the
    AUTO_PERCENTILE-th percentile of the finite pixels' luminance (0 for an image with none), at least -64."""
    luminance = np.asarray(linear_rgb, np.float64).reshape(-1, 3) @ LUMINANCE
    luminance = luminance[np.isfinite(luminance)]
    if not luminance.size:
        return 0.0
    p = float(np.percentile(luminance, AUTO_PERCENTILE))
    return 0.0 if not p > AUTO_WHITE else max(-64.0, -float(np.log2(p / AUTO_WHITE)))


def _mat(rgb: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Each pixel's RGB times the 3x3 matrix m (m @ rgb per pixel), in float64."""
    return np.asarray(rgb, np.float64) @ m.T


def display_linear(linear_rgb: np.ndarray, display: DisplaySettings | None = None) -> np.ndarray:
    """Exposure and the tone curve: (H, W, 3) scene-linear in, display-linear out (float32; clamp may exceed 1)."""
    d = display or DisplaySettings()
    rgb = np.asarray(linear_rgb, np.float32)
    if d.exposure != 0.0:  # an exact power of two: only the exponent changes
        rgb = rgb * np.float32(2.0**d.exposure)
    if d.tonemap is Tonemap.CLAMP:
        return rgb
    curve = aces if d.tonemap is Tonemap.ACES else agx
    return curve(np.nan_to_num(rgb, nan=0.0, posinf=np.finfo(np.float32).max)).astype(np.float32)
