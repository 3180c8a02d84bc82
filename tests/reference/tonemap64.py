"""Tone curves in float64, written from their published formulas (imports nothing from clrender).

- ACES, Stephen Hill's fit of the RRT + sRGB ODT (BakingLab's ACES.hlsl): the input matrix
  (sRGB -> AP1 with the RRT's saturation), the rational curve, the output matrix, clipped to [0, 1];
- AgX base (Troy Sobotka) in Benjamin Wrensch's minimal form: inset matrix, log2 over
  [-12.47393, 4.026069], the 6th-order polynomial sigmoid, outset matrix, the 2.2 display power.

The matrices are written out per pixel as sums (r, g, b components), not as a matrix product, so a
transposed matrix in the code under test shows.
"""

from __future__ import annotations

import numpy as np


def srgb_oetf(x):
    """IEC 61966-2-1, on values clipped to [0, 1]."""
    x = np.clip(np.asarray(x, np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def hill_curve(v):
    v = np.asarray(v, np.float64)
    return (v * v + 0.0245786 * v - 0.000090537) / (0.983729 * v * v + 0.4329510 * v + 0.238081)


def aces_hill(rgb):
    r, g, b = (np.asarray(rgb, np.float64)[..., i] for i in range(3))
    a = hill_curve(0.59719 * r + 0.35458 * g + 0.04823 * b)
    c = hill_curve(0.07600 * r + 0.90834 * g + 0.01566 * b)
    d = hill_curve(0.02840 * r + 0.13383 * g + 0.83777 * b)
    out = np.stack(
        [1.60475 * a - 0.53108 * c - 0.07367 * d, -0.10208 * a + 1.10813 * c - 0.00605 * d, -0.00327 * a - 0.07276 * c + 1.07602 * d], axis=-1
    )
    return np.clip(out, 0.0, 1.0)


def agx_sigmoid(x):
    x = np.asarray(x, np.float64)
    return 15.5 * x**6 - 40.14 * x**5 + 31.96 * x**4 - 6.868 * x**3 + 0.4298 * x**2 + 0.1191 * x - 0.00232


def agx_base(rgb):
    r, g, b = (np.asarray(rgb, np.float64)[..., i] for i in range(3))
    inset = [
        0.842479062253094 * r + 0.0784335999999992 * g + 0.0792237451477643 * b,
        0.0423282422610123 * r + 0.878468636469772 * g + 0.0791661274605434 * b,
        0.0423756549057051 * r + 0.0784336 * g + 0.879142973793104 * b,
    ]
    lo, hi = -12.47393, 4.026069
    s = [agx_sigmoid((np.clip(np.log2(np.maximum(x, 1e-10)), lo, hi) - lo) / (hi - lo)) for x in inset]
    out = [
        1.19687900512017 * s[0] - 0.0980208811401368 * s[1] - 0.0990297440797205 * s[2],
        -0.0528968517574562 * s[0] + 1.15190312990417 * s[1] - 0.0989611768448433 * s[2],
        -0.0529716355144438 * s[0] - 0.0980434501171241 * s[1] + 1.15107367264116 * s[2],
    ]
    return np.clip(np.stack(out, axis=-1), 0.0, 1.0) ** 2.2
