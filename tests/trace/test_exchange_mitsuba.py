"""The lobes of kernels/bsdf_exchange.h and the spot light against Mitsuba 3's own plugins, point by point: the same
(wo, wi) pairs given to our probe kernels and to Mitsuba's `roughconductor`, `roughplastic`, `plastic`, `conductor`,
`thindielectric` and `spot` (scalar_rgb), in the mapping docs/materials.md states (Mitsuba's alpha = roughness^2,
smith "separable", int_ior / ext_ior = ior, eta and k per channel as `rgb`).  Mitsuba is the `reference` extra
(setup.cfg); without it these skip.  Mitsuba's si.wi is our wo (towards the viewer), its wo our wi; both return
f cos(theta_i)."""

import math

import numpy as np
import pytest

from clrender.trace import bsdf

from tests.reference import mitsuba_scenes
from tests.reference.ztest import two_sample_z

pytestmark = pytest.mark.slow
COPPER_ETA, COPPER_K = [0.200438, 0.924033, 1.10221], [3.91295, 2.45285, 2.14219]
N = 300


@pytest.fixture(scope="module")
def mi():
    reason = mitsuba_scenes.unavailable("scalar_rgb")
    if reason:
        pytest.skip(reason)
    return mitsuba_scenes.load_mitsuba("scalar_rgb")


@pytest.fixture(scope="module")
def probe(device):
    return bsdf.BsdfProbe(device)


def pairs(seed=4):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(2, N, 3))
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    v[..., 2] = np.abs(v[..., 2]) + 0.02
    v /= np.linalg.norm(v, axis=-1, keepdims=True)
    return v.astype(np.float32).astype(np.float64)


def mitsuba_eval(mi, plugin: dict, wo, wi):
    """(eval (N, 3), pdf (N,)) of a Mitsuba BSDF at our (wo, wi) pairs."""
    b = mi.load_dict(plugin)
    ctx = mi.BSDFContext()
    values, pdfs = [], []
    for o, i in zip(wo, wi):
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        si.wi = mi.Vector3f(*o)
        values.append(list(b.eval(ctx, si, mi.Vector3f(*i))))
        pdfs.append(float(b.pdf(ctx, si, mi.Vector3f(*i))))
    return np.array(values), np.array(pdfs)


def rgb(v):
    return {"type": "rgb", "value": list(v)}


@pytest.mark.parametrize("alpha", [0.05, 0.3, 0.7])
def test_metal_is_mitsubas_roughconductor(mi, probe, alpha):
    wo, wi = pairs()
    rec = bsdf.params(alpha=float(np.float32(math.sqrt(alpha)) ** 2), eta3=COPPER_ETA, k3=COPPER_K, tint=(0.9, 0.8, 1.0), smith=1)
    plugin = {"type": "roughconductor", "distribution": "ggx", "alpha": alpha, "eta": rgb(COPPER_ETA), "k": rgb(COPPER_K)}
    plugin["specular_reflectance"] = rgb((0.9, 0.8, 1.0))
    want, want_pdf = mitsuba_eval(mi, plugin, wo, wi)
    np.testing.assert_allclose(probe.eval("metal", rec, wo, wi), want, rtol=2e-3, atol=1e-5 * want.max())
    np.testing.assert_allclose(probe.pdf("metal", rec, wo, wi), want_pdf, rtol=2e-3, atol=1e-5 * want_pdf.max())


@pytest.mark.parametrize("alpha, nonlinear", [(0.09, False), (0.36, True)])
def test_coated_diffuse_is_mitsubas_roughplastic(mi, probe, alpha, nonlinear):
    wo, wi = pairs(5)
    diffuse = (0.6, 0.3, 0.1)
    rec = bsdf.coated_params(diffuse, 1.5, math.sqrt(alpha), (1, 1, 1), nonlinear, "separable")
    plugin = {"type": "roughplastic", "distribution": "ggx", "alpha": alpha, "int_ior": 1.5, "ext_ior": 1.0}
    plugin.update(diffuse_reflectance=rgb(diffuse), nonlinear=nonlinear)
    want, want_pdf = mitsuba_eval(mi, plugin, wo, wi)
    # the coat's tables: ours and Mitsuba's are two quadratures of one integral (tests/trace/test_bsdf_exchange.py)
    np.testing.assert_allclose(probe.eval("coated_diffuse", rec, wo, wi), want, rtol=5e-3, atol=1e-5 * want.max())
    np.testing.assert_allclose(probe.pdf("coated_diffuse", rec, wo, wi), want_pdf, rtol=5e-3, atol=1e-5 * want_pdf.max())


@pytest.mark.parametrize("nonlinear", [False, True])
def test_smooth_coated_diffuse_is_mitsubas_plastic(mi, probe, nonlinear):
    wo, wi = pairs(6)
    diffuse = (0.6, 0.3, 0.1)
    rec = bsdf.coated_params(diffuse, 1.5, 0.0, (1, 1, 1), nonlinear)
    plugin = {"type": "plastic", "int_ior": 1.5, "ext_ior": 1.0, "diffuse_reflectance": rgb(diffuse), "nonlinear": nonlinear}
    want, want_pdf = mitsuba_eval(mi, plugin, wo, wi)
    np.testing.assert_allclose(probe.eval("coated_diffuse_smooth", rec, wo, wi), want, rtol=1e-4)
    np.testing.assert_allclose(probe.pdf("coated_diffuse_smooth", rec, wo, wi), want_pdf, rtol=1e-4)


def mitsuba_sample_weights(mi, plugin: dict, wo, u):
    b = mi.load_dict(plugin)
    ctx = mi.BSDFContext()
    out = []
    for o, uu in zip(wo, u):
        si = mi.SurfaceInteraction3f()
        si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
        si.wi = mi.Vector3f(*o)
        bs, weight = b.sample(ctx, si, float(uu[0]), mi.Point2f(float(uu[1]), float(uu[2])))
        out.append([*list(bs.wo), *list(weight)])
    return np.array(out)


def test_smooth_metal_and_thin_sheet_sample_as_mitsubas_conductor_and_thindielectric(mi, probe):
    wo, _ = pairs(7)
    wo[: N // 2, 2] *= -1  # the thin sheet is seen from both sides
    u = np.random.default_rng(8).random((N, 3)) * 0.998 + 0.001
    up = wo[:, 2] > 0
    plugin = {"type": "conductor", "eta": rgb(COPPER_ETA), "k": rgb(COPPER_K)}
    want = mitsuba_sample_weights(mi, plugin, wo[up], u[up])
    wi, weight, _, _ = probe.sample("metal_smooth", bsdf.params(eta3=COPPER_ETA, k3=COPPER_K), wo[up], u[up])
    np.testing.assert_allclose(wi, want[:, :3], atol=1e-6)
    np.testing.assert_allclose(weight, want[:, 3:], rtol=1e-4)
    plugin = {"type": "thindielectric", "int_ior": 1.5, "ext_ior": 1.0}
    want = mitsuba_sample_weights(mi, plugin, wo, u)
    wi, weight, _, _ = probe.sample("thin_dielectric", bsdf.params(eta=1.5), wo, u)
    np.testing.assert_allclose(wi, want[:, :3], atol=1e-6)
    np.testing.assert_allclose(weight, want[:, 3:], rtol=1e-5)


@pytest.mark.parametrize("cutoff, beam", [(20.0, 15.0), (40.0, 10.0)])
def test_the_mitsuba_spot_profile_is_mitsubas_spot(mi, cutoff, beam):
    """Mitsuba's spot emitter at the origin looking along +z: sample_direction's value, intensity x falloff / r^2, at
    points around its cone, against our spot light's irradiance on a plane rendered by the path tracer is tested in
    test_spot_light.py; here the profile itself: kernels/spot.h's formula (as tests/reference/bsdf64.py writes it)
    equals Mitsuba's at every angle."""
    from tests.reference import bsdf64 as ref

    e = mi.load_dict({"type": "spot", "cutoff_angle": cutoff, "beam_width": beam, "intensity": rgb((2.0, 2.0, 2.0))})
    thetas = np.linspace(0.0, cutoff + 5, 200)
    got = []
    for t in np.radians(thetas):
        it = mi.Interaction3f()
        it.p = mi.Point3f(3 * math.sin(t), 0.0, 3 * math.cos(t))
        _, value = e.sample_direction(it, mi.Point2f(0.5, 0.5))
        got.append(float(value[0]) * 9 / 2)
    np.testing.assert_allclose(got, ref.spot_profile(np.cos(np.radians(thetas)), cutoff, beam, "mitsuba"), atol=2e-5)


# ---------------------------------------------------------------- whole renders, block z-test (test_mitsuba_reference.py)
def exchange_scene(material: dict, lights=(), environment=(0.6, 0.7, 0.9)) -> dict:
    """A sphere of `material` on a grey floor, 32 x 32 pixels, under a constant sky and/or `lights`."""
    from tests.reference import path_scenes

    view = path_scenes.camera([0, 1.2, 3.2], [0, 0.45, 0], 40)
    objects = [
        path_scenes.quad([-3, 0, -3], [6, 0, 0], [0, 0, 6], "floor"),
        {"type": "sphere", "center": [0, 0.6, 0], "radius": 0.6, "material": "m"},
    ]
    scene = path_scenes.scene(32, view, {"floor": {"diffuse": [0.5, 0.5, 0.5]}, "m": material}, objects, environment)
    scene["lights"] = list(lights)
    return scene


K, SPP, MAX_DEPTH = 4, 64, 6  # renders per side, paths per pixel each, clrender's bounces (Mitsuba's max_depth 8)


def mitsuba_renders(scene: dict) -> np.ndarray:
    """(K, H, W, 3): Mitsuba's path tracer (LLVM variant), one render per seed."""
    reason = mitsuba_scenes.unavailable("llvm_ad_rgb")
    if reason:
        pytest.skip(reason)
    mi, loaded = mitsuba_scenes.load(scene, variant="llvm_ad_rgb", spp=SPP, max_depth=MAX_DEPTH)
    return np.stack([mitsuba_scenes.render_loaded(mi, loaded, spp=SPP, seed=s) for s in range(K)])


def clrender_renders(scene: dict, device) -> np.ndarray:
    from clrender import Renderer
    from clrender.scene.scene import Scene
    from clrender.trace.tracer import Tracer

    loaded = Scene.from_dict(scene)
    tracer = Tracer(loaded, device=device)
    return np.stack([Renderer(loaded, tracer=tracer, integrator="path", spp=SPP, max_depth=MAX_DEPTH, seed=s).run().image for s in range(K)])


RENDER_CASES = {
    "roughconductor": {"type": "conductor", "eta": COPPER_ETA, "k": COPPER_K, "roughness": 0.4, "smith": "separable"},
    "conductor": {"type": "conductor", "eta": COPPER_ETA, "k": COPPER_K},
    "roughplastic": {"type": "coated_diffuse", "diffuse": [0.7, 0.2, 0.1], "ior": 1.5, "roughness": 0.3, "smith": "separable"},
    "plastic": {"type": "coated_diffuse", "diffuse": [0.1, 0.3, 0.7], "ior": 1.5},
    "thindielectric": {"type": "thin_dielectric", "ior": 1.5},
}


@pytest.mark.parametrize("name", list(RENDER_CASES))
def test_each_lobe_renders_as_mitsuba_renders_it(device, name):
    scene = exchange_scene(RENDER_CASES[name])
    result = two_sample_z(clrender_renders(scene, device), mitsuba_renders(scene))
    assert result.passed, result.report()


def test_the_spot_light_renders_as_mitsubas_spot(device):
    spot = {"type": "spot", "position": [1.0, 2.5, 1.0], "direction": [-1.0, -2.2, -1.0], "cutoff_angle": 30.0, "beam_width": 15.0}
    spot.update(intensity=6.0, color=[1.0, 0.9, 0.8])
    scene = exchange_scene(RENDER_CASES["roughplastic"], lights=[spot], environment=None)
    result = two_sample_z(clrender_renders(scene, device), mitsuba_renders(scene))
    assert result.passed, result.report()
