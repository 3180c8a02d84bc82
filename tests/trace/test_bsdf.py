"""The BSDF lobes of kernels/bsdf.h: against a float64 reference written from the papers (tests/reference/bsdf64.py),
and the properties every lobe must have: a pdf that integrates to the share of samples kept, reciprocity (with
the eta^2 rule across a dielectric), weights equal to eval / pdf, the energy a GGX conductor keeps, no NaN.

eval is f * |cos theta_i|; directions are in the local frame (normal +z), both away from the surface.
The chi-square tests of the samplers are in test_bsdf_chi2.py.
"""

import math

import numpy as np
import pytest
from scipy import stats

from clrender.trace import bsdf

from tests.reference import bsdf64 as ref
from tests.reference.sphere_chi2 import cell_integrals

F32_EPS = 2.0**-24  # float32's unit roundoff
BASE = (0.8, 0.3, 0.1)  # a glTF base colour with three different channels
F0 = (0.95, 0.64, 0.54)  # copper-like Schlick F0


@pytest.fixture(scope="module")
def probe(device):
    return bsdf.BsdfProbe(device)


def sphere(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def hemisphere(rng, n):
    v = sphere(rng, n)
    v[:, 2] = np.abs(v[:, 2])
    return v


def f32(v):
    """What the kernel sees: float32 values, handed to the reference as float64."""
    return np.asarray(v, np.float32).astype(np.float64)


def direction(theta_degrees, phi_degrees=0.0):
    t, p = math.radians(theta_degrees), math.radians(phi_degrees)
    return np.array([math.sin(t) * math.cos(p), math.sin(t) * math.sin(p), math.cos(t)])


# (lobe, kernel record, reference eval, reference pdf, alpha, relative tolerance)
# Tolerances: float32 evaluation of formulas whose inputs are float32 unit vectors.  Lambert, conductor and glTF
# stay within 1.2e-6 of float64 over these inputs; the rough dielectric within 4e-4, at reflections from inside
# just short of the critical angle, where F has a square-root singularity (its condition number there is ~1e3).
# Plus, for all: the half vector's conditioning, 2^-23 / (alpha |cos_o|): at grazing wo the mirror pair's
# tangential components cancel (tests below keep |cos_o| >= 0.01 with alpha = 0.001).
def lobe_cases():
    cases = [("lambert", bsdf.params(colour=BASE), lambda o, i: ref.lambert_eval(o, i, BASE), ref.lambert_pdf, 1.0, 1e-5)]
    for alpha in (0.001, 0.05, 0.3, 0.8):
        rec = bsdf.params(colour=F0, alpha=alpha)
        cases.append(
            (
                "conductor",
                rec,
                lambda o, i, a=alpha: ref.conductor_eval(o, i, np.array(F0), a),
                lambda o, i, a=alpha: ref.conductor_pdf(o, i, a),
                alpha,
                1e-5,
            )
        )
        for eta in (1.5, 1 / 1.5):
            rec = bsdf.params(alpha=alpha, eta=eta)
            e = float(np.float32(eta))
            cases.append(
                (
                    "rough_dielectric",
                    rec,
                    lambda o, i, a=alpha, e=e: ref.rough_dielectric_eval(o, i, e, a),
                    lambda o, i, a=alpha, e=e: ref.rough_dielectric_pdf(o, i, e, a),
                    alpha,
                    1e-3,
                )
            )
    for metallic, roughness in ((0.0, 0.5), (1.0, 0.2), (0.5, 0.7), (0.3, 0.05)):
        rec = bsdf.gltf_params(BASE, metallic, roughness)
        r = float(np.sqrt(np.float32(roughness**2)))  # the kernel's alpha, as a roughness
        cases.append(
            (
                "gltf",
                rec,
                lambda o, i, m=metallic, r=r: ref.gltf_eval(o, i, np.array(BASE), m, r),
                lambda o, i, m=metallic, r=r: ref.gltf_pdf(o, i, np.array(BASE), m, r),
                roughness**2,
                1e-5,
            )
        )
    for kd, ks, shininess in ((BASE, (0.15, 0.3, 0.5), 5.0), ((0.5, 0.4, 0.3), (0.3, 0.3, 0.3), 50.0), ((0.1, 0.1, 0.1), (0.6, 0.5, 0.4), 500.0)):
        cases.append(
            (
                "phong",
                bsdf.phong_params(kd, ks, shininess),
                lambda o, i, kd=kd, ks=ks, s=shininess: ref.phong_eval(o, i, f32(kd), f32(ks), s),
                lambda o, i, kd=kd, ks=ks, s=shininess: ref.phong_pdf(o, i, f32(kd), f32(ks), s),
                ref.phong_alpha(shininess),
                1e-5,
            )
        )
    return [pytest.param(*c, id=f"{c[0]}-a{c[4]:g}-{k}") for k, c in enumerate(cases)]


def assert_close(got, want, rtol, cond, what):
    got = np.asarray(got, np.float64)
    floor = 1e-6 * np.median(want[want > 0]) if (want > 0).any() else 0.0  # facing-boundary flips: values ~0 there
    bound = (rtol + cond) * np.abs(want) + floor
    bad = np.abs(got - want) > bound
    assert np.isfinite(got).all(), f"{what}: NaN or inf"
    worst = np.argmax(np.abs(got - want) / np.maximum(bound, 1e-300))
    assert not bad.any(), f"{what}: {bad.sum()} of {bad.size} off, worst got {got.flat[worst]} want {want.flat[worst]}"


@pytest.mark.parametrize("lobe, rec, ref_eval, ref_pdf, alpha, rtol", lobe_cases())
def test_eval_and_pdf_match_the_float64_reference(probe, lobe, rec, ref_eval, ref_pdf, alpha, rtol):
    rng = np.random.default_rng(11)
    n = 20000
    wo = sphere(rng, 2 * n)
    wo[n:] = wo[n:] * np.where(np.abs(wo[n:, 2]) < 0.01, 0.0, 1.0)[:, None] + np.where(np.abs(wo[n:, 2]) < 0.01, 1.0, 0.0)[:, None] * [0.6, 0.8, 0.0]
    wo[n:, 2] = np.where(np.abs(wo[n:, 2]) < 0.01, 0.01, wo[n:, 2])  # the sampled half: conditioning, see above
    wo = f32(wo / np.linalg.norm(wo, axis=1, keepdims=True))
    wi_random = sphere(rng, n)
    wi_sampled = probe.sample(lobe, rec, wo[n:], rng.random((n, 3)))[0]  # where the lobe is
    wi = f32(np.concatenate([wi_random, wi_sampled]))
    cond = 2 * F32_EPS / (alpha * np.maximum(np.abs(wo[:, 2]), 1e-30))
    want_eval, want_pdf = ref_eval(wo, wi), ref_pdf(wo, wi)
    assert (want_eval > 0).any() and (want_pdf > 0).any()
    assert_close(probe.eval(lobe, rec, wo, wi), want_eval, rtol, cond[:, None], f"{lobe} eval")
    assert_close(probe.pdf(lobe, rec, wo, wi), want_pdf, rtol, cond, f"{lobe} pdf")


# lobes with a pdf (the smooth dielectric's are deltas), for the integral and weight tests
SAMPLED = [
    ("lambert", bsdf.params(colour=BASE), 30.0),
    ("conductor", bsdf.params(colour=F0, alpha=0.05), 45.0),
    ("conductor", bsdf.params(colour=F0, alpha=0.8), 80.0),
    ("rough_dielectric", bsdf.params(alpha=0.3, eta=1.5), 0.0),
    ("rough_dielectric", bsdf.params(alpha=0.05, eta=1 / 1.5), 60.0),
    ("rough_dielectric", bsdf.params(alpha=0.3, eta=1.5), 130.0),  # wo inside the glass
    ("gltf", bsdf.gltf_params(BASE, 0.5, 0.5), 60.0),
    ("phong", bsdf.phong_params(BASE, (0.1, 0.2, 0.3), 30.0), 50.0),
]


@pytest.mark.parametrize("lobe, rec, theta", SAMPLED, ids=[f"{s[0]}-{s[2]:g}" for s in SAMPLED])
def test_pdf_integrates_to_the_share_of_samples_kept(probe, lobe, rec, theta):
    """The pdf's integral over the sphere is at most 1, and equals the share of samples the sampler does not give up
    on (reflections below the horizon: single scattering's energy loss); Lambert's is exactly 1."""
    wo = direction(theta)
    n = 200_000
    integral = cell_integrals(lambda d: probe.pdf(lobe, rec, wo, d), n).sum()
    _, _, pdf, _ = probe.sample(lobe, rec, wo, np.random.default_rng(5).random((n, 3)))
    kept = np.mean(pdf > 0)
    assert integral <= 1 + 1e-5
    if lobe == "lambert":
        assert integral == pytest.approx(1.0, abs=1e-6)
        assert kept == 1.0
    sigma = math.sqrt(max(integral * (1 - integral), 1e-12) / n)
    assert abs(kept - integral) < 4.5 * sigma + 1e-5, (kept, integral)  # z < 4.5: binomial, p ~ 7e-6 two-sided


def test_white_lambert_albedo_is_one(probe):
    rec = bsdf.params(colour=(1.0, 1.0, 1.0))
    for theta in (0.0, 60.0, 89.0):
        wo = direction(theta)
        albedo = cell_integrals(lambda d, wo=wo: probe.eval("lambert", rec, wo, d)[:, 0], 10**6).sum()
        assert albedo == pytest.approx(1.0, abs=1e-6)
        _, weight, pdf, _ = probe.sample("lambert", rec, wo, np.random.default_rng(2).random((10000, 3)))
        assert (pdf > 0).all() and np.allclose(weight, 1.0, rtol=0, atol=1e-6)


REFLECTION_LOBES = [
    ("lambert", bsdf.params(colour=BASE), 1e-6),
    ("conductor", bsdf.params(colour=F0, alpha=0.05), 1e-5),
    ("conductor", bsdf.params(colour=F0, alpha=0.5), 1e-5),
    ("gltf", bsdf.gltf_params(BASE, 0.3, 0.4), 1e-5),
    ("phong", bsdf.phong_params(BASE, (0.1, 0.2, 0.3), 30.0), 1e-5),
]


@pytest.mark.parametrize("lobe, rec, rtol", REFLECTION_LOBES, ids=[f"{r[0]}-{k}" for k, r in enumerate(REFLECTION_LOBES)])
def test_reflection_is_reciprocal(probe, lobe, rec, rtol):
    """f(wo, wi) = f(wi, wo), with f = eval / |cos theta_i|."""
    rng = np.random.default_rng(3)
    wo, wi = f32(hemisphere(rng, 20000)), f32(hemisphere(rng, 20000))
    forward = probe.eval(lobe, rec, wo, wi) / wi[:, 2:3]
    backward = probe.eval(lobe, rec, wi, wo) / wo[:, 2:3]
    assert (forward > 0).all()
    np.testing.assert_allclose(forward, backward, rtol=rtol)


@pytest.mark.parametrize("eta", [1.5, 1 / 1.5])
@pytest.mark.parametrize("alpha", [0.05, 0.3, 0.8])
def test_rough_dielectric_is_reciprocal_with_the_eta_squared_rule(probe, eta, alpha):
    """Reflection on either side: f(wo, wi) = f(wi, wo).  Transmission, in the radiance form:
    f(wo, wi) eta_i^2 = f(wi, wo) eta_o^2, eta_o and eta_i the IORs on wo's and wi's sides."""
    rng = np.random.default_rng(4)
    rec = bsdf.params(alpha=alpha, eta=eta)
    e = float(np.float32(eta))
    wo, wi = f32(sphere(rng, 40000)), f32(sphere(rng, 40000))
    forward = probe.eval("rough_dielectric", rec, wo, wi)[:, 0] / np.abs(wi[:, 2])
    backward = probe.eval("rough_dielectric", rec, wi, wo)[:, 0] / np.abs(wo[:, 2])
    ior = lambda w: np.where(w[:, 2] > 0, 1.0, e)
    reflect = wo[:, 2] * wi[:, 2] > 0
    assert (forward[reflect] > 0).mean() > 0.9 and (forward[~reflect] > 0).mean() > 0.15  # a fifth of random pairs can refract
    # near the critical angle F's rounding is amplified (see lobe_cases): 1e-3
    np.testing.assert_allclose(forward[reflect], backward[reflect], rtol=1e-3, atol=1e-7)
    np.testing.assert_allclose((forward * ior(wi) ** 2)[~reflect], (backward * ior(wo) ** 2)[~reflect], rtol=1e-3, atol=1e-7)
    # and not the plain symmetry, which would hold only with eta = 1
    assert not np.allclose(forward[~reflect], backward[~reflect], rtol=1e-2)


@pytest.mark.parametrize("lobe, rec, theta", SAMPLED, ids=[f"{s[0]}-{s[2]:g}" for s in SAMPLED])
def test_sample_weight_is_eval_over_pdf(probe, lobe, rec, theta):
    rng = np.random.default_rng(6)
    n = 50000
    wo = f32(np.tile(direction(theta), (n, 1)))
    wo[n // 2 :] = f32(sphere(rng, n - n // 2))  # and from anywhere
    wi, weight, pdf, delta = probe.sample(lobe, rec, wo, rng.random((n, 3)))
    kept = pdf > 0
    assert not delta.any() and kept.mean() > 0.3
    assert (weight[~kept] == 0).all()
    np.testing.assert_allclose(np.linalg.norm(wi[kept], axis=1), 1.0, atol=1e-6)
    e = probe.eval(lobe, rec, wo[kept], wi[kept])
    p = probe.pdf(lobe, rec, wo[kept], wi[kept])
    assert (p > 0).all() and (weight[kept] >= 0).all()
    np.testing.assert_allclose(pdf[kept], p, rtol=2e-4)
    np.testing.assert_allclose(weight[kept], e / p[:, None], rtol=2e-4, atol=1e-7)


ALBEDO_ALPHAS = (0.05, 0.3, 0.8)
ALBEDO_THETAS = (0.0, 45.0, 80.0)
ALBEDO_Z = stats.norm.isf((1 - (1 - 1e-3) ** (1 / (len(ALBEDO_ALPHAS) * len(ALBEDO_THETAS)))) / 2)  # 99.9 %, Sidak


def test_the_albedo_quadrature_integrates_ggx_d_to_one():
    """The quadrature below, on the NDF's own normalisation: the integral of D(h) cos theta_h is 1."""
    for alpha in (0.001, 0.05, 0.8):
        edges = [0.0, *(alpha * 2.0**k for k in range(-3, 12) if alpha * 2.0**k < math.pi / 2), math.pi / 2]
        x, w = np.polynomial.legendre.leggauss(64)
        total = 0.0
        for a, b in zip(edges[:-1], edges[1:]):
            t = (a + b) / 2 + (b - a) / 2 * x
            h = np.stack([np.sin(t), 0 * t, np.cos(t)], axis=-1)
            total += np.sum(w * (b - a) / 2 * ref.ggx_d(h, alpha) * np.cos(t) * np.sin(t)) * 2 * math.pi
        assert total == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("alpha", ALBEDO_ALPHAS)
@pytest.mark.parametrize("theta", ALBEDO_THETAS)
def test_conductor_albedo_with_f_one_matches_the_quadrature(probe, alpha, theta):
    """F0 = 1: the directional albedo is what single scattering keeps (below 1: G2 and the samples sent below the
    horizon).  The sampler's Monte Carlo mean of the weights against the float64 quadrature of the formula,
    z-test at 99.9 % two-sided with Sidak's correction over the nine cases."""
    n = 400_000
    rec = bsdf.params(colour=(1.0, 1.0, 1.0), alpha=alpha)
    _, weight, _, _ = probe.sample("conductor", rec, direction(theta), np.random.default_rng(int(alpha * 100 + theta)).random((n, 3)))
    w = weight[:, 0].astype(np.float64)
    quadrature = ref.conductor_albedo_f1(math.radians(theta), alpha)
    z = (w.mean() - quadrature) / (w.std() / math.sqrt(n))
    assert abs(z) < ALBEDO_Z, (w.mean(), quadrature, z)
    assert quadrature < 1.0
    if alpha == 0.8:
        assert quadrature < 0.9  # the energy single scattering loses at high roughness is visible


@pytest.mark.parametrize("eta", [1.5, 1 / 1.5])
def test_smooth_dielectric_reflects_with_fresnel_and_refracts_with_snell(probe, eta):
    rng = np.random.default_rng(8)
    rec = bsdf.params(eta=eta)
    e = float(np.float32(eta))
    n = 100_000
    for theta in (0.0, 30.0, 60.0, 85.0, 120.0, 150.0, 175.0):
        wo = direction(theta, 30.0)
        wi, weight, pdf, delta = probe.sample("dielectric", rec, wo, rng.random((n, 3)))
        assert delta.all() and (pdf > 0).all()
        eta_o, eta_i = (1.0, e) if wo[2] > 0 else (e, 1.0)
        f = ref.fresnel_dielectric(np.array([abs(wo[2])]), eta_o, eta_i)[0]
        reflected = wi[:, 2] * wo[2] > 0
        # the share reflected is F: binomial z-test
        assert abs(reflected.mean() - f) < 4.5 * math.sqrt(max(f * (1 - f), 1e-12) / n) + 1e-6
        np.testing.assert_allclose(wi[reflected], np.tile([-wo[0], -wo[1], wo[2]], (reflected.sum(), 1)), atol=1e-6)
        np.testing.assert_allclose(weight[reflected], 1.0, rtol=1e-6)
        np.testing.assert_allclose(pdf[reflected], f, rtol=1e-5)
        if f < 1:
            t = wi[~reflected].astype(np.float64)
            np.testing.assert_allclose(eta_i * np.hypot(t[:, 0], t[:, 1]), eta_o * math.hypot(wo[0], wo[1]), atol=2e-6)  # Snell
            across = -wo[:2] / max(math.hypot(wo[0], wo[1]), 1e-300)  # in the plane of incidence, on the far side of n
            np.testing.assert_allclose(t[:, 0] * across[1] - t[:, 1] * across[0], 0.0, atol=1e-6)
            assert (t[:, :2] @ across >= -1e-7).all()
            np.testing.assert_allclose(weight[~reflected], (eta_o / eta_i) ** 2, rtol=1e-6)  # radiance scaling
            np.testing.assert_allclose(pdf[~reflected], 1 - f, rtol=1e-4)
        else:
            assert wo[2] < 0 if e > 1 else wo[2] > 0  # total internal reflection: only from the denser side
    wo, wi = sphere(rng, 1000), sphere(rng, 1000)
    assert (probe.eval("dielectric", rec, wo, wi) == 0).all() and (probe.pdf("dielectric", rec, wo, wi) == 0).all()


def test_an_index_matched_rough_dielectric_passes_light_straight_through(probe):
    """eta = 1: no interface, no half vector; the sampler hands back the straight continuation as a delta."""
    rng = np.random.default_rng(10)
    wo = f32(sphere(rng, 1000))
    wi, weight, pdf, delta = probe.sample("rough_dielectric", bsdf.params(alpha=0.3, eta=1.0), wo, rng.random((1000, 3)))
    assert delta.all()
    np.testing.assert_allclose(wi, -wo, atol=1e-6)
    np.testing.assert_allclose(weight, 1.0, rtol=1e-6)
    np.testing.assert_allclose(pdf, 1.0, rtol=1e-6)
    other = f32(sphere(rng, 1000))
    assert (probe.eval("rough_dielectric", bsdf.params(alpha=0.3, eta=1.0), wo, other) == 0).all()
    assert (probe.pdf("rough_dielectric", bsdf.params(alpha=0.3, eta=1.0), wo, other) == 0).all()


def test_no_nan_at_grazing_angles_below_the_surface_or_tiny_alpha(probe):
    z = [1.0, 0.5, 1e-3, 1e-7, 0.0, -0.0, -1e-7, -0.5, -1.0]
    dirs = [np.array([math.sqrt(max(0.0, 1 - c * c)), 0.0, c]) for c in z] + [np.array([0.6, -0.8, 0.0])]
    wo = np.array([a for a in dirs for _ in dirs])
    wi = np.array([b for _ in dirs for b in dirs])
    wo, wi = np.concatenate([wo, wo, wo]), np.concatenate([wi, -wo[: len(wi)], wo[: len(wi)]])  # any pair, wi = -wo, wi = wo
    u = np.array([[0.0, 0.0, 0.0], [1 - 2**-24, 1 - 2**-24, 1 - 2**-24], [0.5, 0.5, 0.25]])
    records = []
    for alpha in (0.0, 1e-4, 1e-3, 1.0):
        records += [("lambert", bsdf.params())]
        records += [("conductor", bsdf.params(colour=(1, 1, 1), alpha=alpha)), ("gltf", bsdf.params(colour=BASE, alpha=alpha, metallic=0.5))]
        records += [(lobe, bsdf.params(alpha=alpha, eta=eta)) for lobe in ("dielectric", "rough_dielectric") for eta in (1.0, 1.5, 1 / 1.5)]
    records += [("gltf", bsdf.params(colour=(0, 0, 0), alpha=0.3, metallic=1.0)), ("gltf", bsdf.params(colour=(0, 0, 0), alpha=0.3, metallic=0.0))]
    records += [("mirror", bsdf.params())] + [("phong", bsdf.phong_params(BASE, (0.2, 0.2, 0.2), s)) for s in (0.0, 1e6)]
    for lobe, rec in records:
        e, p = probe.eval(lobe, rec, wo, wi), probe.pdf(lobe, rec, wo, wi)
        assert np.isfinite(e).all() and (e >= 0).all() and np.isfinite(p).all() and (p >= 0).all(), (lobe, rec)
        for uu in u:
            s_wi, s_w, s_p, _ = probe.sample(lobe, rec, wo, np.tile(uu, (len(wo), 1)))
            assert np.isfinite(s_wi).all() and np.isfinite(s_w).all() and (s_w >= 0).all() and np.isfinite(s_p).all() and (s_p >= 0).all()
            assert ((s_p > 0) | (s_w == 0).all(axis=1)).all(), (lobe, rec, uu)


def test_the_mirror_reflects_about_the_normal_with_its_colour_and_has_no_density(probe):
    """The Phong material's mirror share, a delta lobe: from above, every sample is wo mirrored about +z, weight the
    reflectance, pdf 1 (the branch's probability), delta; from below, none; eval and pdf 0 everywhere, the mirror pair
    included (no light sampling can reach a delta)."""
    rng = np.random.default_rng(12)
    colour = (0.9, 0.6, 0.3)
    rec = bsdf.params(colour=colour)
    wo = f32(sphere(rng, 4000))
    wi, weight, pdf, delta = probe.sample("mirror", rec, wo, rng.random((len(wo), 3)))
    above = wo[:, 2] > 0
    np.testing.assert_allclose(wi[above], ref.mirror_direction(wo[above]), atol=1e-7)
    np.testing.assert_allclose(weight[above], np.tile(f32(colour), (above.sum(), 1)), rtol=0, atol=0)
    assert (pdf[above] == 1).all() and delta[above].all()
    assert (pdf[~above] == 0).all() and (weight[~above] == 0).all()
    pairs = np.concatenate([wo, wo]), np.concatenate([ref.mirror_direction(wo), f32(sphere(rng, len(wo)))])
    assert (probe.eval("mirror", rec, *pairs) == 0).all() and (probe.pdf("mirror", rec, *pairs) == 0).all()


@pytest.mark.parametrize("alpha", [0.0, 0.3])
def test_a_dielectric_tints_what_it_transmits_and_not_what_it_reflects(probe, alpha):
    """transmit_tint (glTF glass's base colour, Mitsuba's specular_transmittance) multiplies the dielectric's
    transmission, smooth or rough, in eval and in sample weights; reflection stays as the untinted lobe's."""
    rng = np.random.default_rng(13)
    tint = np.array([0.9, 0.4, 0.1])
    lobe = "rough_dielectric" if alpha > 0 else "dielectric"
    plain, tinted = bsdf.params(alpha=alpha, eta=1.5), bsdf.params(alpha=alpha, eta=1.5, transmit_tint=tint)
    wo, u = f32(sphere(rng, 20000)), rng.random((20000, 3))
    wi, weight, pdf, _ = probe.sample(lobe, tinted, wo, u)
    wi_plain, weight_plain, pdf_plain, _ = probe.sample(lobe, plain, wo, u)
    np.testing.assert_array_equal(wi, wi_plain)
    np.testing.assert_array_equal(pdf, pdf_plain)
    through = wo[:, 2] * wi[:, 2] < 0
    assert 0.3 < through.mean() < 0.95
    np.testing.assert_allclose(weight[through], weight_plain[through] * f32(tint), rtol=1e-6)
    np.testing.assert_array_equal(weight[~through], weight_plain[~through])
    if alpha > 0:
        want = ref.rough_dielectric_eval(wo, f32(wi), float(np.float32(1.5)), alpha)
        want = np.where((wo[:, 2] * wi[:, 2] < 0)[:, None], want * f32(tint), want)
        assert_close(probe.eval(lobe, tinted, wo, wi), want, 1e-3, 2 * F32_EPS / (alpha * np.abs(wo[:, 2:3])), "tinted eval")


def test_the_shading_frame_is_orthonormal_and_maps_the_normal_to_z(probe):
    rng = np.random.default_rng(9)
    normals = np.concatenate([sphere(rng, 2000), [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1e-7, -1]]])
    normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    v = sphere(rng, len(normals))
    frames, local, back = probe.frame(normals, v)
    gram = np.einsum("nij,nkj->nik", frames.astype(np.float64), frames.astype(np.float64))
    np.testing.assert_allclose(gram, np.broadcast_to(np.eye(3), gram.shape), atol=1e-6)
    np.testing.assert_allclose(frames[:, 2], normals, atol=1e-7)
    np.testing.assert_allclose(local[:, 2], np.sum(v * normals, axis=1), atol=1e-6)
    np.testing.assert_allclose(back, v, atol=1e-6)
    _, local_n, _ = probe.frame(normals, normals)
    np.testing.assert_allclose(local_n, np.tile([0, 0, 1], (len(normals), 1)), atol=1e-6)
