"""Next-event estimation's one light a vertex, picked by power (clrender/trace/light_choice.py, kernels/light_choice.h,
kernels/path.cl direct_lighting; docs/materials.md, "How NEE picks a light").

Statistics.  Every Monte Carlo check is a test whose false-alarm probability, for a seed drawn at random, is at most
ALPHA = 0.001 per test function; the seeds are fixed, so each test is deterministic.
- The kernel's picks against the host's probabilities: Pearson's chi-square over the lights (expected counts all
  above 40), p above ALPHA.  Its power: the same counts reject a uniform choice and the choice by the probabilities
  one place off (p far below 1e-100).
- The image against the float64 reference (tests/reference/pathtracer.py, which sends a shadow ray to every point
  light and picks its emitters by power, so it shares neither the choice nor its code): K renders of clrender and
  REFERENCE_K of the reference, 4 x 4-pixel
  block means, tests/reference/ztest.py's two_sample_z at ALPHA (Šidák over blocks and channels).  Its point and
  directional lights also take the near choice (path.cl pick_near), whose probability is checked the same way.  With the choice's
  probability left out of the BSDF rays' MIS weights (an emitter's, the environment's), the weights of the two
  strategies no longer sum to 1 and the lamp-lit floor darkens by several standard errors (tools/mutants.toml's
  path-choice-* mutants).
"""

import math

import numpy as np
import pytest
from scipy import stats

from clrender.scene.lights import Light
from clrender.scene.scene import Scene
from clrender.trace.light_choice import MIN_SHARE, NEAR_SHARE, choices, light_power, near_share, picks
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests import arealighttools as area_mis
from tests.reference import pathtracer as pt
from tests.reference.path_scenes import camera, quad
from tests.reference.polygon_light import lambert_irradiance
from tests.reference.ztest import two_sample_z

ALPHA = 1e-3
K = 8  # clrender's renders for the image test (seeds 1..K)
REFERENCE_K = 4  # the reference's (seeds 100..)


# ------------------------------------------------------------------ the host's distribution
def test_choices_are_a_distribution_by_power():
    """prob sums to 1, is each record's step of the running sum, is the power's share for lights of fair power,
    at least MIN_SHARE for a faint one and 0 for a black one; cdf reaches exactly 1 at the last light that can be
    chosen, so a black environment after it is never picked."""
    power = np.array([5.0, 0.0, 1.0, 1e-12, 4.0, 0.0])
    r = choices(power)
    prob, cdf = r["prob"].astype(np.float64), r["cdf"].astype(np.float64)
    assert abs(prob.sum() - 1) < 1e-6
    np.testing.assert_array_equal(prob, np.diff(cdf, prepend=0.0).astype(np.float32))
    assert np.all(np.diff(cdf) >= 0) and cdf[4] == 1.0 and cdf[5] == 1.0
    assert prob[1] == 0 and prob[5] == 0
    assert MIN_SHARE * 0.9 < prob[3] < MIN_SHARE * 1.1
    np.testing.assert_allclose(prob[[0, 2, 4]], power[[0, 2, 4]] / 10.0, rtol=1e-5)


def test_the_defensive_share_is_spread_evenly_over_the_groups():
    """Half by power, half evenly over the groups with power, by power inside a group: powers 6, 0, 2, 1, 1, 0 in groups
    0, 1, 2, 3, 3, 4 (groups 1 and 4 black) give 0.3 + 1/6, 0, 0.1 + 1/6, then 0.05 + 1/12 twice, and 0."""
    r = choices(np.array([6.0, 0, 2, 1, 1, 0]), np.array([0, 1, 2, 3, 3, 4]), 0.5)
    np.testing.assert_allclose(r["prob"], [0.3 + 1 / 6, 0, 0.1 + 1 / 6, 0.05 + 1 / 12, 0.05 + 1 / 12, 0], atol=1e-6)
    assert r["cdf"][-1] == 1.0 and r["cdf"][-2] == 1.0


def test_the_near_choice_is_one_more_record_and_only_where_it_can_tell_lights_apart():
    """With `near`, every light's share times 1 - near and a last record of share near.  near_share is NEAR_SHARE where
    two or more lights can take the near choice; 0 with only a physical area light (whose probability must not depend
    on the vertex: MIS) and with one light that can take it (a fixed pick whatever the vertex)."""
    r = choices(np.array([3.0, 1.0]), near=0.5)
    np.testing.assert_allclose(r["prob"], [0.375, 0.125, 0.5], atol=1e-6)
    assert r["cdf"][-1] == 1.0
    area = {"type": "area", "corner": [0, 1, 0], "edge_a": [1, 0, 0], "edge_b": [0, 0, 1], "falloff": "inverse_square"}
    point = {"type": "point", "position": [0, 1, 0], "falloff": "inverse_square"}
    sun = {"type": "directional", "direction": [0, -1, 0], "falloff": "inverse_square"}
    scene = lambda *lights: Scene.from_dict({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}], "lights": list(lights)})
    assert near_share(scene(area)) == near_share(scene(area, point)) == near_share(scene(area, sun)) == 0.0
    assert near_share(scene(point, sun)) == near_share(scene(area, point, {**point, "position": [2, 1, 0]})) == NEAR_SHARE > 0


def test_a_scene_without_power_chooses_uniformly():
    r = choices(np.zeros(4))
    np.testing.assert_allclose(r["prob"], 0.25, rtol=1e-6)
    assert r["cdf"][-1] == 1.0


def test_light_powers_are_their_emitted_flux():
    """Against quadrature, not the formulas: a physical point light radiates I over 4 pi sr; a pbrt spot's
    smoothstep profile integrated over the sphere numerically; a two-sided area light of radiance L and area A
    emits 2 A pi L (the cosine-weighted hemisphere, twice)."""
    point = Light(type="point", intensity=2.0, color=(1.0, 0.5, 0.0), falloff="inverse_square")
    assert math.isclose(light_power(point, 3.0), 4 * math.pi * 2.0 * 0.5, rel_tol=1e-12)
    spot = Light(type="spot", intensity=3.0, cutoff_angle=40.0, beam_width=25.0, profile="pbrt", falloff="inverse_square")
    cos_t = np.linspace(-1, 1, 2_000_001)
    lo, hi = math.cos(math.radians(40.0)), math.cos(math.radians(25.0))
    x = np.clip((cos_t - lo) / (hi - lo), 0, 1)
    flux = 2 * math.pi * 3.0 * np.trapezoid(x * x * (3 - 2 * x), cos_t)
    assert math.isclose(light_power(spot, 3.0), flux, rel_tol=1e-5)
    area = Light(type="area", intensity=1.5, edge_a=(2.0, 0, 0), edge_b=(0, 0, 0.5), falloff="inverse_square")
    mu = np.linspace(0, 1, 100_001)
    hemisphere = 2 * math.pi * np.trapezoid(mu, mu)  # the integral of cos over a hemisphere: pi
    assert math.isclose(light_power(area, 3.0), 2 * 1.0 * 1.5 * hemisphere, rel_tol=1e-8)


# ------------------------------------------------------------------ the kernel's picks
def test_the_kernels_picks_follow_the_hosts_probabilities(device):
    """2^18 picks by kernels/light_choice.h with the kernels' random numbers: chi-square against the records'
    probabilities at ALPHA (the two lights too faint for an expected count of 40 are pooled); black lights are never
    picked.  Power: the same counts reject a uniform choice and the probabilities shifted one light along."""
    power = np.array([50.0, 1.0, 1.0, 1.0, 0.0, 20.0, 1e-4, 8.0, 0.0, 3e-4, 15.0])
    r = choices(power)
    n = 1 << 18
    counts = np.bincount(picks(device, r, n, seed=3), minlength=len(r))
    assert counts[power == 0].sum() == 0
    prob = r["prob"].astype(np.float64)
    fair = prob * n >= 40

    def p_value(p):
        expected = np.append(p[fair], p[~fair].sum()) * n
        observed = np.append(counts[fair], counts[~fair].sum())
        keep = expected > 0
        return stats.chisquare(observed[keep], expected[keep] * observed[keep].sum() / expected[keep].sum()).pvalue

    assert p_value(prob) > ALPHA, (counts, prob * n)
    live = power > 0
    assert p_value(np.where(live, 1.0 / live.sum(), 0.0)) < 1e-100
    assert p_value(np.where(live, np.roll(prob, 1), 0.0)) < 1e-100


@pytest.mark.parametrize("lanes", [8, 16])
def test_picks_in_lanes_are_the_scalar_picks(device, lanes):
    """The binary search built for 8 and 16 picks a work-item, each lane searching until every lane's search has
    ended, picks what one pick a work-item does: over lights of every probability, zero ones included, and over
    record counts from one to past a power of two."""
    rng = np.random.default_rng(5)
    for count in (1, 2, 7, 16, 33):
        power = np.where(rng.uniform(size=count) < 0.2, 0.0, rng.exponential(size=count))
        power[rng.integers(count)] = 1.0  # one light at least
        r = choices(power)
        assert np.array_equal(picks(device, r, 5001, seed=count, lanes=lanes), picks(device, r, 5001, seed=count)), count


# ------------------------------------------------------------------ the path tracer
def lights_of_unequal_power(size: int = 16) -> dict:
    """A floor and a ball under a small emissive lamp, one bright and three dim coloured point lights, a dim
    directional one and a constant sky: the bright light takes most of the choice, the sky much of the rest, the lamp
    a few percent, each dim light a fraction of a percent.  In the float64 reference's subset (Lambert, quads,
    spheres, point and directional lights, a constant environment)."""
    return {
        "width": size,
        "height": size,
        "cameras": [camera([0, 1.5, 4], [0, 0.3, 0], 45)],
        "environment": {"color": [0.2, 0.2, 0.25]},
        "materials": {
            "floor": {"diffuse": [0.7, 0.7, 0.7]},
            "ball": {"diffuse": [0.6, 0.3, 0.2]},
            "lamp": {"diffuse": [0, 0, 0], "emission": [4, 3.5, 3]},
        },
        "objects": [
            quad([-3, 0, -3], [0, 0, 6], [6, 0, 0], "floor"),
            {"type": "sphere", "center": [0.5, 0.5, 0], "radius": 0.5, "material": "ball"},
            quad([-0.9, 1.5, -0.5], [1, 0, 0], [0, 0, 1], "lamp"),  # facing down
        ],
        "lights": [
            {"type": "point", "position": [-1.0, 2.0, 1.0], "intensity": 20.0, "falloff": "inverse_square"},
            {"type": "point", "position": [1.5, 1.0, 1.0], "intensity": 0.3, "color": [1, 0.2, 0.2], "falloff": "inverse_square"},
            {"type": "point", "position": [-1.5, 0.8, -1.0], "intensity": 0.3, "color": [0.2, 1, 0.2], "falloff": "inverse_square"},
            {"type": "point", "position": [0.0, 0.5, 1.5], "intensity": 0.3, "color": [0.2, 0.2, 1], "falloff": "inverse_square"},
            {"type": "directional", "direction": [0.3, -1, -0.2], "intensity": 0.2, "falloff": "inverse_square"},
        ],
    }


def test_one_shadow_ray_a_vertex_whatever_the_number_of_lights(device):
    """Direct light only (max_depth 0) where every camera ray meets the floor: each path traces its camera ray, its
    BSDF ray (for the emission it meets) and at most one shadow ray, not one per light (seven here: five lights, the
    lamp, the sky; 9 rays a path before)."""
    scene = lights_of_unequal_power(8)
    scene["cameras"] = [camera([2, 3, 2], [2, 0, 1.8], 30)]  # looking down at the floor alone, beside the lamp
    loaded = Scene.from_dict(scene)
    result = Renderer(loaded, tracer=Tracer(loaded, device=device), integrator="path", spp=16, max_depth=0, seed=1).run()
    paths = 8 * 8 * 16
    assert 2 * paths < result.rays <= 3 * paths


def test_lights_of_unequal_power_match_the_float64_reference(device):
    """max_depth 1, 12 x 12: clrender's K = 8 renders of 64 paths against the reference's 4 of 64, 4 x 4-pixel block
    means by two_sample_z at ALPHA (Šidák over 9 blocks x 3 channels)."""
    scene = lights_of_unequal_power(12)
    loaded = Scene.from_dict(scene)
    tracer = Tracer(loaded, device=device)
    ours = np.stack([Renderer(loaded, tracer=tracer, integrator="path", spp=64, max_depth=1, seed=s).run().image for s in range(1, K + 1)]).astype(
        np.float64
    )
    reference = np.stack([pt.render(scene, spp=64, max_depth=1, seed=100 + s).image for s in range(REFERENCE_K)])
    result = two_sample_z(ours, reference, block=4, alpha=ALPHA)
    assert result.passed, result.report()
    assert ours.mean() > 0.1  # the view is lit


def test_an_area_light_under_a_sky_weights_bsdf_rays_by_its_choice(device):
    """tests/trace/test_area_light_mis.py's large area light over a white floor (kd 1, max_depth 1), now under a
    constant sky of radiance 0.5 that takes about half the choice.  The floor is see-through lit: E / pi from the
    light (Lambert's exact polygon irradiance) plus 0.5 from the sky (a white plane under a uniform sky that nothing
    blocks: area lights are see-through).  Without the light's choice probability in the BSDF ray's MIS weight the
    two weights of the light no longer sum to 1 and the floor is 10 % off or more; measured within 0.3 %."""
    sky = 0.5
    loaded = Scene.from_dict({**area_mis.SCENE, "environment": {"color": [sky] * 3}})
    image = Renderer(loaded, tracer=Tracer(loaded, device=device), integrator="path", spp=64, max_depth=1, seed=5).run().image
    fine = area_mis.floor_points(area_mis.SUB)
    n, sub = area_mis.SIZE, area_mis.SUB
    reference = (lambert_irradiance(fine, area_mis.LIGHT) / np.pi).reshape(n, sub, n, sub).mean(axis=(1, 3)) + sky
    clear = ~area_mis.light_seen(fine).reshape(n, sub, n, sub).any(axis=(1, 3))
    ratio = image[..., 0].astype(np.float64)[clear].sum() / reference[clear].sum()
    assert abs(ratio - 1) < 0.02, ratio
