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


# ---- the Phong material's lobe (docs/materials.md): Lambert kd plus ks times a GGX reflection with F = 1, the GGX width
# matched to the Blinn-Phong exponent s by Walter et al. 2007 (alpha = sqrt(2 / (s + 2))); the kernel's sampling
# convention: the glossy lobe with probability lum(ks) / (lum(ks) + lum(kd)), Rec. 709 luminance
REC709 = np.array([0.2126, 0.7152, 0.0722])


def phong_alpha(shininess):
    return max(np.sqrt(2.0 / (shininess + 2.0)), 1e-4)


def phong_eval(wo, wi, kd, ks, shininess):
    alpha = phong_alpha(shininess)
    up = _upper(wo, wi)
    h = normalize(wo + wi)
    with np.errstate(divide="ignore", invalid="ignore"):
        glossy = (ggx_d(h, alpha) * smith_g2(wo, wi, alpha) / (4 * wo[..., 2] * wi[..., 2]))[..., None] * np.asarray(ks, np.float64)
    f = np.asarray(kd, np.float64) / np.pi + glossy
    return np.where(up[..., None], f * wi[..., 2:3], 0.0)


def phong_pdf(wo, wi, kd, ks, shininess):
    lk, ld = REC709 @ np.asarray(ks, np.float64), REC709 @ np.asarray(kd, np.float64)
    q = lk / (lk + ld)
    return q * conductor_pdf(wo, wi, phong_alpha(shininess)) + (1 - q) * lambert_pdf(wo, wi)


# ---- a perfect mirror: the delta reflection about +z, reflectance `colour`, from above only
def mirror_direction(wo):
    return wo * np.array([-1.0, -1.0, 1.0])


def graded_panels(alpha, theta_nodes):
    """Gauss-Legendre nodes and weights in theta over panels spaced geometrically from alpha / 8 (a microfacet
    distribution's scale is alpha) to pi / 2."""
    edges = [0.0]
    t = alpha / 8
    while t < np.pi / 2:
        edges.append(t)
        t *= 2
    edges.append(np.pi / 2)
    x, w = np.polynomial.legendre.leggauss(theta_nodes)
    nodes = np.concatenate([(a + b) / 2 + (b - a) / 2 * x for a, b in zip(edges[:-1], edges[1:])])
    weights = np.concatenate([(b - a) / 2 * w for a, b in zip(edges[:-1], edges[1:])])
    return nodes, weights


# ---- directional albedo of the GGX conductor with F = 1, by quadrature of the formula
def conductor_albedo_f1(theta_o, alpha, theta_nodes=48, phi_nodes=512):
    """integral over the hemisphere of f(wo, wi) cos theta_i dwi with F = 1 (what single scattering keeps),
    as an integral over half vectors (dwi = 4 |wo.h| dwh): D(h) G2 |wo.h| / cos_o over h with wi.z > 0.
    theta_h in Gauss-Legendre panels spaced geometrically from alpha / 8 (D's scale is alpha) to pi / 2,
    phi_h by the trapezoid rule (periodic)."""
    thetas, theta_w = graded_panels(alpha, theta_nodes)
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


# ---- the lobes of issue 36 (kernels/bsdf_exchange.h)
def smith_g_separable(wo, wi, alpha):
    """Mitsuba's rough plugins' masking-shadowing: G1(wo) G1(wi)."""
    return smith_g1(wo, alpha) * smith_g1(wi, alpha)


def fresnel_conductor(cos_i, eta, k):
    """Unpolarised reflectance of a conductor of complex IOR n = eta + i k, from the Fresnel equations with a complex
    refraction angle: cos_t = sqrt(1 - sin_i^2 / n^2), r_s = (cos_i - n cos_t) / (cos_i + n cos_t),
    r_p = (n cos_i - cos_t) / (n cos_i + cos_t), F = (|r_s|^2 + |r_p|^2) / 2.  cos_i (...), eta and k broadcast."""
    n = np.asarray(eta, np.float64) + 1j * np.asarray(k, np.float64)
    c = np.asarray(cos_i, np.complex128)
    cos_t = np.sqrt(1 - (1 - c**2) / n**2)
    r_s = (c - n * cos_t) / (c + n * cos_t)
    r_p = (n * c - cos_t) / (n * c + cos_t)
    return (np.abs(r_s) ** 2 + np.abs(r_p) ** 2) / 2


def _g(wo, wi, alpha, smith):
    return smith_g_separable(wo, wi, alpha) if smith == "separable" else smith_g2(wo, wi, alpha)


def metal_eval(wo, wi, eta, k, tint, alpha, smith="correlated"):
    """tint F(wo.h) D G / (4 cos_o cos_i) times cos_i, F the complex Fresnel per channel."""
    up = _upper(wo, wi)
    h = normalize(wo + wi)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = fresnel_conductor(dot(wo, h)[..., None], eta, k) * np.asarray(tint, np.float64)
        value = f * (ggx_d(h, alpha) * _g(wo, wi, alpha, smith) / (4 * wo[..., 2]))[..., None]
    return np.where(up[..., None], value, 0.0)


def coat_fdr(eta):
    """Mitsuba's fresnel_diffuse_reflectance fit (Egan and Hilgeman 1973 below 1, d'Eon and Irving 2011 above)."""
    if eta < 1:
        return -1.4399 * eta**2 + 0.7099 * eta + 0.6681 + 0.0636 / eta
    x = 1 / eta
    return 0.919317 - 3.4793 * x + 6.75335 * x**2 - 7.80989 * x**3 + 4.98554 * x**4 - 1.36881 * x**5


def coated_smooth_eval(wo, wi, diffuse, eta, nonlinear=False):
    """Mitsuba's plastic, its diffuse part: base / (1 - fdr_int) (1 - F(cos_o)) (1 - F(cos_i)) / (pi eta^2) times cos_i."""
    fdr = coat_fdr(1 / eta)
    d = np.asarray(diffuse, np.float64)
    base = d / (1 - (d * fdr if nonlinear else fdr))
    t = lambda w: 1 - fresnel_dielectric(np.clip(w[..., 2], 0, 1), 1.0, eta)
    value = base * (t(wo) * t(wi) * wi[..., 2] / (np.pi * eta**2))[..., None]
    return np.where(_upper(wo, wi)[..., None], value, 0.0)


def coated_smooth_specular_probability(cos_o, diffuse, tint, eta):
    w = np.mean(tint) / (np.mean(diffuse) + np.mean(tint))
    f = fresnel_dielectric(cos_o, 1.0, eta)
    return f * w / (f * w + (1 - f) * (1 - w))


def rough_interface(mu, eta, alpha, smith, transmit, theta_nodes=64, phi_nodes=128):
    """What light arriving at cos mu (from the side of index 1, the other side's index eta) leaves by the rough interface's
    reflection (transmit False) or transmission (True), single scattering: the integral over microfacet normals h of
    (F or 1 - F)(wi.h) G(wi, wo) D(h) max(0, wi.h) / mu with wo the mirror or refracted direction, by Gauss-Legendre in
    theta_h (panels graded towards alpha) and phi_h, rather than Mitsuba's quadrature of the visible-normal sampler's
    square.  Mitsuba's roughplastic tabulates 1 - this (transmit) and uses 2 mean(R(mu; 1 / eta) mu) (reflection)."""
    th, tw = graded_panels(alpha, theta_nodes)
    ph = (np.arange(phi_nodes) + 0.5) * 2 * np.pi / phi_nodes
    T, P = np.meshgrid(th, ph, indexing="ij")
    h = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1)
    wi = np.array([np.sqrt(1 - mu * mu), 0.0, mu])
    c = h @ wi
    f = fresnel_dielectric(np.clip(c, 0, 1), 1.0, eta)
    if transmit:
        cos_t = np.sqrt(np.maximum(0.0, 1 - (1 - c**2) / eta**2))
        wo = -wi / eta + (c / eta - cos_t)[..., None] * h
        ok, value = (wo[..., 2] < 0) & (c > 0), 1 - f
    else:
        wo = 2 * c[..., None] * h - wi
        ok, value = (wo[..., 2] > 0) & (c > 0), f
    wi_b = np.broadcast_to(wi, wo.shape)
    with np.errstate(divide="ignore", invalid="ignore"):
        g = _g(wi_b, wo, alpha, smith)
        integrand = np.where(ok, value * g * ggx_d(h, alpha) * c / mu, 0.0)
    return float(np.sum(integrand * np.sin(T) * tw[:, None]) * 2 * np.pi / phi_nodes)


def coated_rough_eval(wo, wi, diffuse, tint, eta, alpha, table, internal, smith="correlated", nonlinear=False):
    """Mitsuba's roughplastic: tint F(wo.h) D G / (4 cos_o cos_i) + base / (1 - internal) T(cos_o) T(cos_i) / (pi eta^2),
    times cos_i; T the lerp of `table` (transmittance at cos = i / (len - 1)) as Mitsuba's lerp_gather does."""
    up = _upper(wo, wi)
    h = normalize(wo + wi)
    d = np.asarray(diffuse, np.float64)
    base = d / (1 - (d * internal if nonlinear else internal))
    n = len(table)

    def lerp(c):
        x = np.clip(c, 0, 1) * (n - 1)
        i = np.minimum(x.astype(np.int64), n - 2)
        return (1 - (x - i)) * table[i] + (x - i) * table[i + 1]

    with np.errstate(divide="ignore", invalid="ignore"):
        f = fresnel_dielectric(np.clip(dot(wo, h), 0, 1), 1.0, eta)
        spec = np.asarray(tint, np.float64) * (f * ggx_d(h, alpha) * _g(wo, wi, alpha, smith) / (4 * wo[..., 2]))[..., None]
        diff = base * (lerp(wo[..., 2]) * lerp(wi[..., 2]) * wi[..., 2] / (np.pi * eta**2))[..., None]
    return np.where(up[..., None], spec + diff, 0.0)


def thin_dielectric_reflectance(cos_i, eta):
    """A thin sheet's reflectance with its inter-reflections: R' = R + T^2 R / (1 - R^2), T = 1 - R."""
    r = fresnel_dielectric(np.abs(cos_i), 1.0, eta)
    return r + (1 - r) ** 2 * r / (1 - r**2)


def spot_profile(cos_theta, cutoff_deg, beam_deg, profile):
    """Mitsuba 3's spot falloff (linear in the angle between beam_width and cutoff_angle) or pbrt-v4's
    (smoothstep of the cosine between cos cutoff and cos beam)."""
    c = np.asarray(cos_theta, np.float64)
    cutoff, beam = np.radians(cutoff_deg), np.radians(beam_deg)
    if profile == "pbrt":
        t = np.clip((c - np.cos(cutoff)) / (np.cos(beam) - np.cos(cutoff)), 0, 1)
        return t * t * (3 - 2 * t)
    theta = np.arccos(np.clip(c, -1, 1))
    return np.where(theta < cutoff, np.where(theta <= beam, 1.0, (cutoff - theta) / (cutoff - beam)), 0.0)
