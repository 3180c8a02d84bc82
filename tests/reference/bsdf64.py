"""Float64 BSDF lobes written from their published definitions, to check kernels/bsdf.h against.

Never imports clrender.  Written in the papers' own forms, not the kernel's rearranged ones: D and Lambda
with tan^2 theta (Walter et al. 2007, eqs. 33 and 72 of Heitz 2014 for the height-correlated G2), Walter's
generalised half vector h_t = -(eta_i i + eta_o o) with explicit IORs, the textbook Fresnel equations with
both IORs (taken on wi's side where the kernel takes wo's), and glTF 2.0 Appendix B's functions
(specular_brdf, diffuse_brdf, conductor_fresnel, fresnel_mix, mix) composed as the specification composes them.

Conventions (the kernel's): (n, 3) unit directions in the local frame, normal +z, both away from the
surface (wo to the viewer, wi to the light); eval = f(wo, wi) |cos theta_i|; pdf in solid angle;
eta = IOR inside (-z) / IOR outside (+z); transmission in the radiance form (eta_o^2 in the numerator).
"""

import numpy as np

GLTF_IOR = 1.5  # glTF 2.0's dielectric layer: F0 = ((1 - ior) / (1 + ior))^2 = 0.04
GLTF_LOBE_PROB_MIN = 0.1  # the kernel's sampling convention (bsdf.h), not physics: repeated for the mixture pdf


def dot(a, b):
    return np.sum(a * b, axis=-1)


def normalize(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def tan2_theta(w):
    with np.errstate(divide="ignore", invalid="ignore"):
        return (w[..., 0] ** 2 + w[..., 1] ** 2) / w[..., 2] ** 2


def ggx_d(h, alpha):
    """Trowbridge-Reitz NDF: chi+(h.n) alpha^2 / (pi cos^4 theta (alpha^2 + tan^2 theta)^2)."""
    cos2 = h[..., 2] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        d = alpha**2 / (np.pi * cos2**2 * (alpha**2 + tan2_theta(h)) ** 2)
    return np.where(h[..., 2] > 0, d, 0.0)


def smith_lambda(w, alpha):
    return (-1.0 + np.sqrt(1.0 + alpha**2 * tan2_theta(w))) / 2.0


def smith_g1(w, alpha):
    return 1.0 / (1.0 + smith_lambda(w, alpha))


def smith_g2(wo, wi, alpha):
    """Height-correlated masking-shadowing (Heitz 2014, eq. 99), without the chi+ terms."""
    return 1.0 / (1.0 + smith_lambda(wo, alpha) + smith_lambda(wi, alpha))


def fresnel_dielectric(cos_i, eta_i, eta_t):
    """Unpolarised reflectance for light in the medium of index eta_i meeting one of index eta_t at angle
    arccos(cos_i), cos_i >= 0: the mean of r_s^2 and r_p^2; 1 under total internal reflection."""
    sin_t = eta_i / eta_t * np.sqrt(np.maximum(0.0, 1.0 - cos_i**2))
    tir = sin_t >= 1.0
    cos_t = np.sqrt(np.maximum(0.0, 1.0 - sin_t**2))
    with np.errstate(divide="ignore", invalid="ignore"):
        r_s = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t)
        r_p = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t)
    return np.where(tir, 1.0, (r_s**2 + r_p**2) / 2.0)


def schlick(f0, cos_theta):
    """Schlick's approximation with an F0 of any shape broadcastable against cos_theta[..., None]."""
    return f0 + (1.0 - f0) * (1.0 - np.abs(cos_theta))[..., None] ** 5


def _upper(wo, wi):
    return (wo[..., 2] > 0) & (wi[..., 2] > 0)


# ---- Lambert
def lambert_eval(wo, wi, albedo):
    return np.where(_upper(wo, wi)[..., None], np.asarray(albedo) / np.pi * wi[..., 2:3], 0.0)


def lambert_pdf(wo, wi):
    return np.where(_upper(wo, wi), wi[..., 2] / np.pi, 0.0)


# ---- GGX conductor with Schlick's Fresnel
def conductor_eval(wo, wi, f0, alpha):
    up = _upper(wo, wi)
    h = normalize(wo + wi)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = schlick(np.asarray(f0, np.float64), dot(wo, h)) * (ggx_d(h, alpha) * smith_g2(wo, wi, alpha) / (4 * wo[..., 2] * wi[..., 2]))[..., None]
        return np.where(up[..., None], f * wi[..., 2:3], 0.0)


def visible_normal_density(wo, h, alpha):
    """D_wo(h) = G1(wo) max(0, wo.h) D(h) / cos_o (Heitz 2018, eq. 1), wo taken on h's (+z) side."""
    w = wo * np.sign(wo[..., 2])[..., None]
    return smith_g1(w, alpha) * np.maximum(0.0, dot(w, h)) * ggx_d(h, alpha) / w[..., 2]


def conductor_pdf(wo, wi, alpha):
    up = _upper(wo, wi)
    h = normalize(wo + wi)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(up, visible_normal_density(wo, h, alpha) / (4 * dot(wo, h)), 0.0)


# ---- rough dielectric (Walter et al. 2007)
def _dielectric_terms(wo, wi, eta, alpha):
    """Walter's quantities for each pair: (valid, reflect, h, eta_o, eta_i, F) with F computed on wi's side."""
    wo, wi = normalize(wo), normalize(wi)  # near the critical angle F depends on |w| - 1 a thousandfold
    eta_o = np.where(wo[..., 2] > 0, 1.0, eta)
    eta_i = np.where(wi[..., 2] > 0, 1.0, eta)
    reflect = wo[..., 2] * wi[..., 2] > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        h_r = np.sign(wi[..., 2])[..., None] * normalize(wi + wo)
        h_t = normalize(-(eta_i[..., None] * wi + eta_o[..., None] * wo))
        h = np.where(reflect[..., None], h_r, h_t)
        h = h * np.where(h[..., 2] < 0, -1.0, 1.0)[..., None]
        # chi+((v.h) / (v.n)) for both directions: the microfacet faces each one from its own side
        faces = (dot(wo, h) / wo[..., 2] > 0) & (dot(wi, h) / wi[..., 2] > 0)
        eta_beyond = np.where(wi[..., 2] > 0, eta, 1.0)  # the medium across the interface from wi
        f = fresnel_dielectric(np.abs(dot(wi, h)), eta_i, eta_beyond)
    valid = faces & (wo[..., 2] != 0) & (wi[..., 2] != 0) & np.isfinite(h).all(axis=-1)
    return valid, reflect, h, eta_o, eta_i, f


def rough_dielectric_eval(wo, wi, eta, alpha):
    wo, wi = normalize(wo), normalize(wi)
    valid, reflect, h, eta_o, eta_i, f = _dielectric_terms(wo, wi, eta, alpha)
    co, ci = np.abs(wo[..., 2]), np.abs(wi[..., 2])
    ih, oh = dot(wi, h), dot(wo, h)
    with np.errstate(divide="ignore", invalid="ignore"):
        dg = ggx_d(h, alpha) * smith_g2(wo, wi, alpha)
        f_r = f * dg / (4 * ci * co)
        f_t = np.abs(ih) * np.abs(oh) / (ci * co) * eta_o**2 * (1 - f) * dg / (eta_i * ih + eta_o * oh) ** 2
        value = np.where(reflect, f_r, f_t) * ci
    return np.repeat(np.where(valid, value, 0.0)[..., None], 3, axis=-1)


def rough_dielectric_pdf(wo, wi, eta, alpha):
    """Visible normals of wo, then reflection with probability F, else transmission (Walter's eq. 17 Jacobian)."""
    wo, wi = normalize(wo), normalize(wi)
    valid, reflect, h, eta_o, eta_i, f = _dielectric_terms(wo, wi, eta, alpha)
    ih, oh = dot(wi, h), dot(wo, h)
    with np.errstate(divide="ignore", invalid="ignore"):
        dwo = visible_normal_density(wo, h, alpha)
        p_r = f * dwo / (4 * np.abs(oh))
        p_t = (1 - f) * dwo * eta_i**2 * np.abs(ih) / (eta_i * ih + eta_o * oh) ** 2
        return np.where(valid, np.where(reflect, p_r, p_t), 0.0)


# ---- glTF 2.0 metallic-roughness, Appendix B
def gltf_eval(wo, wi, base_colour, metallic, roughness):
    """material = mix(dielectric_brdf, metal_brdf, metallic); alpha = roughness^2."""
    alpha = np.asarray(roughness, np.float64) ** 2
    base = np.asarray(base_colour, np.float64)
    h = normalize(wo + wi)
    v_dot_h = dot(wo, h)
    with np.errstate(divide="ignore", invalid="ignore"):
        # specular_brdf = V D, V = G2 / (4 |N.L| |N.V|)
        specular = (smith_g2(wo, wi, alpha) / (4 * np.abs(wo[..., 2]) * np.abs(wi[..., 2])) * ggx_d(h, alpha))[..., None]
    diffuse = np.broadcast_to(base / np.pi, specular.shape[:-1] + (3,))
    metal_brdf = specular * schlick(base, v_dot_h)  # conductor_fresnel(f0 = base colour, bsdf = specular)
    f0 = ((1 - GLTF_IOR) / (1 + GLTF_IOR)) ** 2
    fr = schlick(np.float64(f0), v_dot_h)  # fresnel_mix(ior, base = diffuse, layer = specular)
    dielectric_brdf = diffuse * (1 - fr) + specular * fr
    m = np.asarray(metallic, np.float64)[..., None]
    f = dielectric_brdf * (1 - m) + metal_brdf * m
    return np.where(_upper(wo, wi)[..., None], f * wi[..., 2:3], 0.0)


def gltf_specular_probability(wo, base_colour, metallic):
    """The kernel's lobe choice (bsdf.h, gltf_specular_probability): E_s / (E_s + E_d) at cos_o, clamped."""
    base = np.asarray(base_colour, np.float64)
    m = np.asarray(metallic, np.float64)
    cos_o = wo[..., 2]
    f0 = ((1 - GLTF_IOR) / (1 + GLTF_IOR)) ** 2
    f_d = schlick(np.float64(f0), cos_o)[..., 0]
    e_s = (1 - m) * f_d + m * schlick(base, cos_o).mean(axis=-1)
    e_d = (1 - m) * (1 - f_d) * base.mean(axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.clip(e_s / (e_s + e_d), GLTF_LOBE_PROB_MIN, 1 - GLTF_LOBE_PROB_MIN)
    return np.where(e_d > 0, p, 1.0)


def gltf_pdf(wo, wi, base_colour, metallic, roughness):
    p = gltf_specular_probability(wo, base_colour, metallic)
    alpha = np.asarray(roughness, np.float64) ** 2
    return p * conductor_pdf(wo, wi, alpha) + (1 - p) * lambert_pdf(wo, wi)


# ---- directional albedo of the GGX conductor with F = 1, by quadrature of the formula
def conductor_albedo_f1(theta_o, alpha, theta_nodes=48, phi_nodes=512):
    """integral over the hemisphere of f(wo, wi) cos theta_i dwi with F = 1 (what single scattering keeps),
    as an integral over half vectors (dwi = 4 |wo.h| dwh): D(h) G2 |wo.h| / cos_o over h with wi.z > 0.
    theta_h in Gauss-Legendre panels spaced geometrically from alpha / 8 (D's scale is alpha) to pi / 2,
    phi_h by the trapezoid rule (periodic)."""
    edges = [0.0]
    t = alpha / 8
    while t < np.pi / 2:
        edges.append(t)
        t *= 2
    edges.append(np.pi / 2)
    x, w = np.polynomial.legendre.leggauss(theta_nodes)
    thetas = np.concatenate([(a + b) / 2 + (b - a) / 2 * x for a, b in zip(edges[:-1], edges[1:])])
    theta_w = np.concatenate([(b - a) / 2 * w for a, b in zip(edges[:-1], edges[1:])])
    phis = (np.arange(phi_nodes) + 0.5) * (2 * np.pi / phi_nodes)
    th, ph = np.meshgrid(thetas, phis, indexing="ij")
    h = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], axis=-1)
    wo = np.array([np.sin(theta_o), 0.0, np.cos(theta_o)])
    wo_h = dot(wo, h)
    wi = 2 * wo_h[..., None] * h - wo
    ok = (wi[..., 2] > 0) & (wo_h > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.where(ok, ggx_d(h, alpha) * smith_g2(np.broadcast_to(wo, wi.shape), wi, alpha) * wo_h / wo[2], 0.0)
    return float(np.sum(g * np.sin(th) * theta_w[:, None]) * (2 * np.pi / phi_nodes))
