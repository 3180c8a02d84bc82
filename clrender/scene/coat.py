"""What the coated diffuse lobe (kernels/bsdf_exchange.h) needs precomputed per material, as Mitsuba 3's plastic and
roughplastic compute it: the coat's specular sampling weight, its internal diffuse reflectance, and for a rough coat
the table of its external transmittance over cos theta.

Smooth coat: internal reflectance fdr_int = Mitsuba's fresnel_diffuse_reflectance(1 / eta) (the fits of Egan and
Hilgeman 1973 for eta < 1 and d'Eon and Irving 2011 for eta > 1).  Rough coat (roughplastic): at the 64 cosines
mu_i = max(1e-6, i / 63), the transmittance T(mu) = the integral of (1 - F(wi . m)) G(wi, wo) / G1(wi) over the
visible normals m of wi (wo refracted through m), and the internal reflectance 2 mean(R(mu_i; 1 / eta) mu_i) with R
the same integral of F G / G1 over reflections, both by Gauss-Legendre quadrature of the sampler's unit square
(32 x 32 nodes for eta > 1, 128 x 128 below), as Mitsuba's eval_transmittance and eval_reflectance do.  G is the
material's Smith term (separable: G1(wo)); Mitsuba's is separable.
"""

from __future__ import annotations

import functools

import numpy as np

from ..layout import COAT_TABLE_RES


def fresnel_diffuse_reflectance(eta: float) -> float:
    """Mitsuba's fit of the hemispherical average of the dielectric Fresnel reflectance for relative IOR eta."""
    if eta < 1.0:
        return 0.0636 / eta + eta * (eta * -1.4399 + 0.7099) + 0.6681
    inv = 1.0 / eta
    return 0.919317 - 3.4793 * inv + 6.75335 * inv**2 - 7.80989 * inv**3 + 4.98554 * inv**4 - 1.36881 * inv**5


def sampling_weight(diffuse, tint) -> float:
    """Mitsuba's specular_sampling_weight: mean(tint) / (mean(diffuse) + mean(tint))."""
    s, d = float(np.mean(tint)), float(np.mean(diffuse))
    return s / (d + s) if d + s > 0 else 1.0


def _fresnel(cos_i, eta):
    """Dielectric reflectance and the transmitted cosine (> 0) for cos_i > 0, eta = IOR beyond / IOR of cos_i's side."""
    cos2_t = 1.0 - (1.0 - cos_i**2) / eta**2
    tir = cos2_t <= 0.0
    cos_t = np.sqrt(np.maximum(cos2_t, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        r_s = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
        r_p = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    return np.where(tir, 1.0, 0.5 * (r_s**2 + r_p**2)), cos_t


def _g1(w, alpha):
    c2 = w[..., 2] ** 2
    return 2.0 * np.abs(w[..., 2]) / (np.abs(w[..., 2]) + np.sqrt(c2 + alpha**2 * (1.0 - c2)))


def _vndf(wi, alpha, u1, u2):
    """Heitz 2018's visible-normal samples (..., 3) for directions wi (k, 3), wi.z > 0, and samples u1, u2 (n,): (k, n, 3),
    as kernels/bsdf.h's ggx_sample_vndf."""
    wh = wi * np.array([alpha, alpha, 1.0])
    wh /= np.linalg.norm(wh, axis=-1, keepdims=True)
    lensq = wh[:, 0] ** 2 + wh[:, 1] ** 2
    safe = np.where(lensq > 0, np.sqrt(lensq), 1.0)
    t1 = np.where((lensq > 0)[:, None], np.stack([-wh[:, 1], wh[:, 0], 0 * wh[:, 0]], axis=-1) / safe[:, None], [1.0, 0.0, 0.0])
    t2 = np.cross(wh, t1)
    r, phi = np.sqrt(u1), 2 * np.pi * u2
    p1, p2 = r * np.cos(phi), r * np.sin(phi)
    s = 0.5 * (1.0 + wh[:, 2:3])
    p2 = (1.0 - s) * np.sqrt(np.maximum(0.0, 1.0 - p1**2)) + s * p2  # (k, n)
    p3 = np.sqrt(np.maximum(0.0, 1.0 - p1**2 - p2**2))
    nh = p1[..., None] * t1[:, None] + p2[..., None] * t2[:, None] + p3[..., None] * wh[:, None]
    m = np.stack([alpha * nh[..., 0], alpha * nh[..., 1], np.maximum(0.0, nh[..., 2])], axis=-1)
    return m / np.linalg.norm(m, axis=-1, keepdims=True)


def interface_integral(mu, eta, alpha, separable, transmit) -> np.ndarray:
    """Mitsuba's eval_reflectance (transmit False) or eval_transmittance (True) at the cosines mu (k,)."""
    res = 32 if eta > 1 else 128
    x, w = np.polynomial.legendre.leggauss(res)
    u1, u2 = (a.ravel() for a in np.meshgrid((x + 1) / 2, (x + 1) / 2, indexing="ij"))
    weights = np.outer(w, w).ravel()
    mu = np.asarray(mu, np.float64)
    wi = np.stack([np.sqrt(1 - mu * mu), 0 * mu, mu], axis=-1)
    m = _vndf(wi, alpha, u1, u2)
    c = np.einsum("knj,kj->kn", m, wi)
    f, cos_t = _fresnel(c, eta)
    if transmit:
        wo = -wi[:, None] / eta + (c / eta - cos_t)[..., None] * m
        value, ok = 1.0 - f, wo[..., 2] < 0
    else:
        wo = 2 * c[..., None] * m - wi[:, None]
        value, ok = f, wo[..., 2] > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        if separable:
            g = _g1(wo, alpha)
        else:  # G2 / G1(wi), the height-correlated term's weight for a visible-normal sample
            lam = lambda v: 1.0 / _g1(v, alpha) - 1.0
            g = (1.0 + lam(wi)[:, None]) / (1.0 + lam(wi)[:, None] + lam(wo))
    return np.sum(np.where(ok, value * g, 0.0) * weights, axis=1) * 0.25


def table_cosines() -> np.ndarray:
    return np.maximum(1e-6, np.linspace(0.0, 1.0, COAT_TABLE_RES))


@functools.lru_cache(maxsize=64)
def rough_coat(eta: float, alpha: float, separable: bool) -> tuple:
    """(external transmittance table (COAT_TABLE_RES,), internal reflectance) of a rough coat."""
    mu = table_cosines()
    table = interface_integral(mu, eta, alpha, separable, True)
    internal = 2.0 * float(np.mean(interface_integral(mu, 1.0 / eta, alpha, separable, False) * mu))
    return table, internal


def conductor_normal_reflectance(eta, k) -> tuple:
    """F at normal incidence per channel, ((eta - 1)^2 + k^2) / ((eta + 1)^2 + k^2): the Whitted stand-in's colour."""
    eta, k = np.asarray(eta, np.float64), np.asarray(k, np.float64)
    return tuple(float(v) for v in ((eta - 1) ** 2 + k**2) / ((eta + 1) ** 2 + k**2))
