"""Chi-square goodness-of-fit of each BSDF sampler (kernels/bsdf.h) against its own pdf, as Mitsuba 3's chi2.py
and pbrt-v4's bsdfs_test.cpp test theirs (tests/reference/sphere_chi2.py): N directions sampled on the device,
counted on a 40 x 80 (theta, phi) grid over the sphere, each cell's expected count N times the kernel pdf's
integral over it (adaptive Gauss-Legendre in float64), the samples the sampler gave up on as one more cell, cells
expecting fewer than 5 pooled.  Each test rejects at p < SIGNIFICANCE, the 1 % level Sidak-corrected over every
case in this file (fast and slow), so that all of them together wrongly fail at most 1 % of the time; the seeds
are fixed, so a run is repeatable.

The planted-bug tests prove the test has power: each builds a copy of the probe with one bug pasted into bsdf.h
and shows that the same test rejects it.
"""

import math
import re

import numpy as np
import pytest

from clrender.device import kernel_dir
from clrender.trace import bsdf

from tests.reference.sphere_chi2 import cell_integrals, chi2_test, histogram, sidak

N_SAMPLES = 1_000_000
BASE = (0.8, 0.3, 0.1)


def direction(theta_degrees):
    t = math.radians(theta_degrees)
    return np.array([math.sin(t), 0.0, math.cos(t)])


def case(lobe, rec, theta):
    name = f"{lobe}-a{rec[0, 3]:.3g}-eta{rec[0, 4]:.3g}-m{rec[0, 5]:.2g}-{theta:g}deg"
    if lobe == "phong":
        name = f"{lobe}-a{rec[0, 3]:.3g}-p{rec[0, -1]:.2g}-{theta:g}deg"
    return pytest.param(lobe, rec, theta, id=name)


FAST = [case("lambert", bsdf.params(colour=BASE), 45.0)]
FAST += [case("conductor", bsdf.params(colour=(0.95, 0.64, 0.54), alpha=a), t) for a in (0.05, 0.3, 0.8) for t in (0.0, 45.0, 80.0)]
FAST += [
    case("rough_dielectric", bsdf.params(alpha=a, eta=e), t) for e in (1.5, 1 / 1.5) for a, t in ((0.05, 30.0), (0.3, 0.0), (0.3, 60.0), (0.8, 80.0))
]
# wo inside the glass
FAST += [case("rough_dielectric", bsdf.params(alpha=0.3, eta=1.5), 130.0), case("rough_dielectric", bsdf.params(alpha=0.05, eta=1.5), 100.0)]
FAST += [case("gltf", bsdf.gltf_params(BASE, m, r), t) for m, r in ((0.0, 0.5), (1.0, 0.3), (0.5, 0.7)) for t in (30.0, 75.0)]
# the Phong material's Lambert-plus-glossy mix: a broad and a sharp glossy lobe, a dim and a bright one
PHONG = [((0.5, 0.4, 0.3), (0.3, 0.3, 0.3), 20.0), (BASE, (0.1, 0.1, 0.1), 300.0)]
FAST += [case("phong", bsdf.phong_params(kd, ks, s), t) for kd, ks, s in PHONG for t in (30.0, 75.0)]
# wider sweeps: rougher and smoother, nearer the horizon, white and black bases
SLOW = [case("conductor", bsdf.params(colour=(1, 1, 1), alpha=a), t) for a in (0.02, 0.1, 1.0) for t in (10.0, 60.0, 88.0)]
SLOW += [case("rough_dielectric", bsdf.params(alpha=a, eta=e), t) for e in (1.33, 2.4, 1 / 2.4) for a, t in ((0.02, 20.0), (0.5, 85.0), (0.2, 135.0))]
SLOW += [
    case("gltf", bsdf.gltf_params(b, m, r), t)
    for b, m, r in (((1, 1, 1), 0.0, 0.1), ((0, 0, 0), 0.0, 0.6), ((0, 0, 0), 1.0, 0.4))
    for t in (5.0, 85.0)
]
SIGNIFICANCE = sidak(0.01, len(FAST) + len(SLOW))


@pytest.fixture(scope="module")
def probe(device):
    return bsdf.BsdfProbe(device)


def run_chi2(probe, lobe, rec, theta, n=N_SAMPLES, seed=1):
    wo = direction(theta)
    u = np.random.default_rng(seed).random((n, 3), dtype=np.float32)
    wi, _, pdf, _ = probe.sample(lobe, rec, wo, u)
    kept = pdf > 0
    expected = cell_integrals(lambda d: probe.pdf(lobe, rec, wo, d), n)
    return chi2_test(histogram(wi[kept]), expected, n, int(np.sum(~kept)))


@pytest.mark.parametrize("lobe, rec, theta", FAST)
def test_sampler_matches_its_pdf(probe, lobe, rec, theta):
    result = run_chi2(probe, lobe, rec, theta)
    assert result.p_value > SIGNIFICANCE, f"{result}; rejects at p < {SIGNIFICANCE:.3g}"


@pytest.mark.slow
@pytest.mark.parametrize("lobe, rec, theta", SLOW)
def test_sampler_matches_its_pdf_wider_sweep(probe, lobe, rec, theta):
    result = run_chi2(probe, lobe, rec, theta, n=4 * N_SAMPLES, seed=2)
    assert result.p_value > SIGNIFICANCE, f"{result}; rejects at p < {SIGNIFICANCE:.3g}"


# ---- planted bugs: (name, the text in bsdf.h, its replacement, the case that should now fail)
PLANTED = [
    (
        # the pdf of sampling D(h) cos(theta_h) instead of the visible normals: the visible-normal Jacobian is lost
        "pdf_without_visible_normals",
        "return ggx_d(h, alpha) / (2.0f * (abs_l(wo.z) + ggx_r(wo, alpha)));",
        "return ggx_d(h, alpha) * h.z / (4.0f * vdot(wo, h));",
        ("conductor", bsdf.params(alpha=0.3), 45.0),
    ),
    (
        # the sampler draws from the whole projected disk, not the visible half (Heitz 2018's warp of t2 dropped)
        "vndf_without_the_visible_warp",
        "p2 = (1.0f - s) * sqrt_l(max_l(0.0f, 1.0f - p1 * p1)) + s * p2;",
        "p2 = p2;",
        ("conductor", bsdf.params(alpha=0.8), 60.0),
    ),
    (
        # Lambert's pdf off by the cosine (uniform hemisphere) while the sampler stays cosine-weighted
        "lambert_pdf_without_cosine",
        "return ((wo.z > 0.0f) & (wi.z > 0.0f)) ? wi.z * M_1_PI_F : (LF)(0.0f);",
        "return ((wo.z > 0.0f) & (wi.z > 0.0f)) ? (LF)(0.5f * M_1_PI_F) : (LF)(0.0f);",
        ("lambert", bsdf.params(), 30.0),
    ),
    (
        # the transmission Jacobian dh/dwi without its eta_i^2
        "transmission_jacobian_without_eta_squared",
        "LF dh_dwi = eta_i * eta_i * abs_l(vdot(wi, h)) / len2;",
        "LF dh_dwi = abs_l(vdot(wi, h)) / len2;",
        ("rough_dielectric", bsdf.params(alpha=0.3, eta=1.5), 30.0),
    ),
    (
        # subtle: the rough dielectric chooses reflection with Schlick's F (R0 = 0.04, eta 1.5), its pdf with the exact F
        # (they differ by at most ~0.03 of probability, at grazing microfacets)
        "reflection_chosen_with_schlick",
        "LI reflect = u1 < f;",
        "LI reflect = u1 < 0.04f + 0.96f * pow5(1.0f - abs_l(cos_oh));",
        ("rough_dielectric", bsdf.params(alpha=0.3, eta=1.5), 60.0),
    ),
    (
        # the glTF sampler picks its lobes half and half while the pdf still weights them by p_spec
        "gltf_lobe_choice_not_the_pdfs",
        "V3 wi = glossy_or_diffuse(wo, u1 < p_spec,",
        "V3 wi = glossy_or_diffuse(wo, u1 < 0.5f,",
        ("gltf", bsdf.gltf_params(BASE, 0.0, 0.4), 45.0),
    ),
    (
        # the Phong lobe samples its glossy part half the time while its pdf weights it by specular_prob
        "phong_lobe_choice_not_the_pdfs",
        "LI glossy = u1 < p.specular_prob;",
        "LI glossy = u1 < 0.5f;",
        ("phong", bsdf.phong_params(BASE, (0.1, 0.1, 0.1), 20.0), 45.0),
    ),
    (
        # the Phong lobe's mixture pdf without the Lambert share: samples of the diffuse part outnumber it
        "phong_pdf_without_the_lambert_weight",
        "pdf = (1.0f - p.specular_prob) * pdf + p.specular_prob * conductor_pdf(wo, wi, p.alpha);",
        "pdf = pdf + p.specular_prob * conductor_pdf(wo, wi, p.alpha);",
        ("phong", bsdf.phong_params((0.5, 0.4, 0.3), (0.3, 0.3, 0.3), 20.0), 30.0),
    ),
]


def planted_program(device, old, new):
    """bsdf_probe.cl with bsdf.h pasted in, one bug planted.  Pasted rather than included from a patched folder so
    that the source itself differs: kernel caches (PyOpenCL's, PoCL's) key on it, and the device's cache of
    programs never sees this build."""
    header = (kernel_dir() / "bsdf.h").read_text()
    assert header.count(old) == 1, f"the planted bug's anchor is not in bsdf.h once: {old!r}"
    source = (kernel_dir() / bsdf.PROBE).read_text()
    source = re.sub(r'#include "bsdf.h"', lambda _: header.replace(old, new), source, count=1)
    return device.build(source, "bsdf_probe.cl (a bug planted)", bsdf.bsdf_defines())


@pytest.mark.slow
@pytest.mark.parametrize("name, old, new, target", PLANTED, ids=[p[0] for p in PLANTED])
def test_a_planted_bug_fails_the_chi_square_test(device, probe, name, old, new, target):
    lobe, rec, theta = target
    assert run_chi2(probe, lobe, rec, theta).p_value > SIGNIFICANCE  # the healthy lobe passes the same test
    result = run_chi2(bsdf.BsdfProbe(device, planted_program(device, old, new)), lobe, rec, theta)
    assert result.p_value < SIGNIFICANCE, f"{name} was not caught: {result}"
