"""The path tracer against Mitsuba 3: the same scene dicts, block means compared by a two-sample z-test.

The oracle is tests/reference/mitsuba_scenes.py (scene dicts to Mitsuba, imports nothing from clrender), the
test tests/reference/ztest.py (8 x 8-pixel block means, variance from K independent renders per side, Šidák
over all blocks and channels at alpha 0.01), the scenes tests/reference/path_scenes.py.  First the test is
tested on Mitsuba alone: renders of one scene by two variants (scalar and LLVM) or two seed sets pass (its
false-alarm side), a planted difference fails (its power side).  Then clrender's path tracer is held to it;
those tests skip until clrender has `integrator="path"` (issue 25).

Mitsuba is the `reference` extra (setup.cfg); without it every test here that needs it skips.  The LLVM
variant needs libLLVM: DRJIT_LIBLLVM_PATH, else mitsuba_scenes finds Debian's libLLVM.so.* (docs/testing.md).
"""

import numpy as np
import pytest

from tests.mitsubatools import LLVM, MAX_DEPTH, SCALAR, SPP, K, clrender_path_renders, mitsuba_or_skip, mitsuba_renders
from tests.reference import mitsuba_scenes, path_scenes
from tests.reference.ztest import block_means, sidak, two_sample_z


# ---------------------------------------------------------------------- the z-test on numbers we know
def test_block_means_average_each_tile_per_channel():
    img = np.arange(16 * 8 * 2, dtype=float).reshape(16, 8, 2)
    means = block_means(img, 8)
    assert means.shape == (2, 1, 2)
    np.testing.assert_allclose(means[1, 0, 1], img[8:, :, 1].mean())
    with pytest.raises(ValueError, match="whole number"):
        block_means(np.zeros((12, 8, 3)), 8)


def test_sidak_keeps_the_family_wise_rate():
    assert sidak(0.01, 1) == pytest.approx(0.01)
    assert (1 - sidak(0.01, 192)) ** 192 == pytest.approx(0.99)


def test_ztest_passes_noise_of_one_mean_and_fails_a_shifted_block(rng):
    """Gaussian pixels whose noise level varies across the image (sigma 0.02 to 1): 200 pairs of one mean
    pass but for the rare false alarm Šidák allows (1%); one block shifted by 6 sigma of its mean fails."""
    truth = rng.uniform(0, 1, (64, 64, 3))
    sigma = rng.uniform(0.02, 1.0, (64, 64, 3))
    draw = lambda: truth + sigma * rng.standard_normal((K, 64, 64, 3))
    false_alarms = sum(not two_sample_z(draw(), draw()).passed for _ in range(200))
    assert false_alarms <= 8  # Binomial(200, 0.01): P(> 8) < 1e-3
    shifted = draw()
    block_sd = np.sqrt((sigma[8:16, 16:24, 1] ** 2).sum() / K) / 64
    shifted[:, 8:16, 16:24, 1] += 6 * np.sqrt(2) * block_sd
    result = two_sample_z(draw(), shifted)
    assert not result.passed
    assert (result.table[0]["row"], result.table[0]["col"], result.table[0]["channel"]) == (1, 2, 1)


def test_ztest_compares_blocks_without_variance_up_to_float_rounding():
    flat = np.full((K, 16, 16, 3), 0.8)
    assert two_sample_z(flat, flat.astype(np.float32).astype(np.float64) * (1 + 1e-7)).passed
    assert not two_sample_z(flat, flat * 1.001).passed


def test_ztest_with_lag_holds_its_rate_on_pixels_a_filter_correlates(rng):
    """Pixels that share samples, as a tent filter's do: each pixel the mean of the 2 x 2 noise cells at its
    corners, so neighbours at most 1 apart are correlated (0.5 side by side).  Counting variances alone (lag 0)
    the block variance is a quarter of the truth and nearly every pair of one mean fails; lag 1 keeps Šidák's 1%
    over 200 pairs, and still finds a block shifted by 6 sigma of its mean."""
    truth = rng.uniform(0, 1, (64, 64, 3))
    sigma = rng.uniform(0.02, 1.0, (65, 65, 3))

    def draw():
        cells = sigma * rng.standard_normal((K, 65, 65, 3))
        return truth + (cells[:, :-1, :-1] + cells[:, 1:, :-1] + cells[:, :-1, 1:] + cells[:, 1:, 1:]) / 4

    assert sum(not two_sample_z(draw(), draw()).passed for _ in range(20)) >= 15
    false_alarms = sum(not two_sample_z(draw(), draw(), lag=1).passed for _ in range(200))
    assert false_alarms <= 8  # Binomial(200, 0.01): P(> 8) < 1e-3
    shifted = draw()
    w = np.outer(*2 * [np.r_[1, [2] * 7, 1] / 16])  # each of the block's 9 x 9 cells' weight in its mean
    block_sd = np.sqrt((w**2 * sigma[8:17, 16:25, 1] ** 2).sum() / K)
    shifted[:, 8:16, 16:24, 1] += 6 * np.sqrt(2) * block_sd
    result = two_sample_z(draw(), shifted, lag=1)
    assert not result.passed
    assert (result.table[0]["row"], result.table[0]["col"], result.table[0]["channel"]) == (1, 2, 1)


# ---------------------------------------------------------------------- the mapping to Mitsuba
def pinhole_directions(cam: dict, width: int, height: int) -> np.ndarray:
    """Unit directions through pixel centres, written out from docs/scene-format.md's camera (row 0 at the top,
    right = forward x up, vertical fov)."""
    eye, target, up = (np.asarray(cam[k], float) for k in ("position", "look_at", "up"))
    forward = (target - eye) / np.linalg.norm(target - eye)
    right = np.cross(forward, up)
    right /= np.linalg.norm(right)
    true_up = np.cross(right, forward)
    half_h = np.tan(np.radians(cam["fov"]) / 2)
    ys, xs = np.mgrid[0:height, 0:width] + 0.5
    sx = (2 * xs / width - 1) * half_h * width / height
    sy = (1 - 2 * ys / height) * half_h
    d = forward + sx[..., None] * right + sy[..., None] * true_up
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def test_mitsuba_sees_the_scene_through_clrenders_camera():
    """A black sphere off-centre against a white sky, 40 x 24 (not square): Mitsuba's silhouette is the pinhole
    camera's, pixel for pixel away from the rim (orientation, aspect ratio, vertical fov)."""
    mitsuba_or_skip(SCALAR)
    cam = {"position": [0.5, 0.3, 4.0], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 35}
    center, radius = np.array([0.9, 0.5, -0.3]), 0.6
    scene = {
        "cameras": [cam],
        "environment": {"color": [1, 1, 1]},
        "materials": {"black": {"diffuse": [0, 0, 0]}},
        "objects": [{"type": "sphere", "center": center.tolist(), "radius": radius, "material": "black"}],
    }
    img = mitsuba_scenes.render(scene, variant=SCALAR, spp=16, width=40, height=24, max_depth=0)
    d = pinhole_directions(cam, 40, 24)
    v = center - np.asarray(cam["position"], float)
    miss = np.linalg.norm(v - (d @ v)[..., None] * d, axis=-1)  # distance of the centre from each pixel's ray
    half_pixel = 4.5 * np.tan(np.radians(35 / 24)) * 0.75  # a pixel's half diagonal at the sphere's distance
    inside, outside = miss < radius - half_pixel, miss > radius + half_pixel
    assert inside.sum() > 40 and outside.sum() > 500
    assert np.all(img[inside] == 0)
    np.testing.assert_allclose(img[outside], 1.0, rtol=1e-6)


def test_the_gltf_metal_differs_from_mitsubas_principled_only_by_the_height_correlated_g2():
    """Our Python BSDF against Mitsuba's own `principled` (metallic 1: GGX D with alpha = roughness^2, Schlick F
    with F0 = base colour, separable Smith G1 G1), at random direction pairs: the ratio is G2 / (G1 G1)."""
    mi = mitsuba_or_skip(SCALAR)
    rng = np.random.default_rng(3)
    base, roughness = [0.9, 0.6, 0.3], 0.45
    ours = mi.load_dict(mitsuba_scenes.bsdf({"base_color": base, "metallic": 1.0, "roughness": roughness}))
    theirs = mi.load_dict({"type": "principled", "base_color": {"type": "rgb", "value": base}, "metallic": 1.0, "roughness": roughness})
    alpha = roughness**2
    lam = lambda w: (np.sqrt(1 + alpha**2 * (w[0] ** 2 + w[1] ** 2) / w[2] ** 2) - 1) / 2
    checked = 0
    for _ in range(40):
        wi, wo = (v / np.linalg.norm(v) for v in rng.normal(size=(2, 3)) * [1, 1, 0.5] + [0, 0, 0.6])
        if wi[2] < 0.05 or wo[2] < 0.05:
            continue
        si = mi.SurfaceInteraction3f()
        si.wi = mi.Vector3f(*wi)
        a = np.array(ours.eval(mi.BSDFContext(), si, mi.Vector3f(*wo)))
        b = np.array(theirs.eval(mi.BSDFContext(), si, mi.Vector3f(*wo)))
        g_ratio = (1 + lam(wi)) * (1 + lam(wo)) / (1 + lam(wi) + lam(wo))
        np.testing.assert_allclose(a, b * g_ratio, rtol=2e-4)
        checked += 1
    assert checked >= 10


def test_the_gltf_lobes_sampling_matches_its_pdf_chi_square(tmp_path, monkeypatch):
    """Mitsuba's own chi-square test (mitsuba.chi2) on our Python BSDF: the sampled directions follow pdf();
    a wrong pdf would bias the Mitsuba reference through its MIS weights (a pdf of cos^2 instead of cos for
    the diffuse branch fails it)."""
    mitsuba_or_skip(LLVM)
    monkeypatch.chdir(tmp_path)  # a rejected test writes chi2_data.py into the working folder
    from mitsuba import chi2

    for material, wi in (
        ({"base_color": [0.9, 0.6, 0.3], "metallic": 1.0, "roughness": 0.3}, [0.5, 0.0, 0.866]),
        ({"base_color": [0.2, 0.5, 0.3], "metallic": 0.0, "roughness": 0.6}, [0.0, 0.8, 0.6]),
    ):
        extra = mitsuba_scenes.bsdf(material)
        sample_func, pdf_func = chi2.BSDFAdapter("clrender_gltf", extra, wi=wi)
        test = chi2.ChiSquareTest(domain=chi2.SphericalDomain(), sample_func=sample_func, pdf_func=pdf_func, sample_dim=3, sample_count=200_000)
        assert test.run(), test.messages


# ---------------------------------------------------------------------- the z-test on Mitsuba: false alarms and power
@pytest.mark.slow
def test_two_seed_sets_of_mitsuba_pass_on_every_reference_scene():
    for name, make in path_scenes.SCENES.items():
        scene = make()
        result = two_sample_z(mitsuba_renders(scene, seeds=range(K)), mitsuba_renders(scene, seeds=range(100, 100 + K)))
        assert result.passed, f"{name}: {result.report()}"


@pytest.mark.slow
def test_mitsubas_scalar_and_llvm_variants_pass_on_the_cornell_box():
    """Two different executions of the same estimator (scalar C++ with the Python BSDF called per ray, and
    LLVM megakernels), 16 spp a render to keep the scalar side near 15 s."""
    scene = path_scenes.cornell_box()
    scalar = mitsuba_renders(scene, SCALAR, seeds=range(K), spp=16)
    llvm = mitsuba_renders(scene, LLVM, seeds=range(100, 100 + K), spp=16)
    result = two_sample_z(scalar, llvm)
    assert result.passed, result.report()


@pytest.mark.slow
@pytest.mark.parametrize("planted", ["albedo 0.75 -> 0.70", "lamp 5% brighter"])
def test_a_planted_difference_fails(planted):
    """Measured at this K and spp: both detected in 10 of 10 seed sets (median worst p 1e-24 and 1e-13); the
    lamp 2% brighter in 8 of 10, 1% in none."""
    other = path_scenes.cornell_box(albedo=0.70) if planted.startswith("albedo") else path_scenes.cornell_box(radiance=8.0 * 1.05)
    result = two_sample_z(mitsuba_renders(path_scenes.cornell_box(), seeds=range(K)), mitsuba_renders(other, seeds=range(100, 100 + K)))
    assert not result.passed, result.report()


# ---------------------------------------------------------------------- clrender's path tracer against Mitsuba


@pytest.mark.slow
@pytest.mark.parametrize("name", list(path_scenes.SCENES))
def test_clrenders_path_tracer_matches_mitsuba(name, device):
    """(a) the Cornell box: Lambert walls, a rough glTF metal (roughness 0.3), smooth glass, an emissive quad;
    (b) an emissive icosphere over a diffuse floor; (c) a constant environment over diffuse, rough metal and
    glTF dielectric spheres.  64 x 64, K = 4 renders of 64 spp a side, max_depth 6."""
    mitsuba_or_skip(LLVM)
    scene = path_scenes.SCENES[name]()
    ours = clrender_path_renders(scene, device)
    theirs = mitsuba_renders(scene, seeds=range(100, 100 + K))
    result = two_sample_z(ours, theirs)
    assert result.passed, f"{name}: clrender (a) vs Mitsuba (b)\n{result.report()}"


@pytest.mark.slow
def test_a_diffuse_sphere_under_an_environment_map_matches_mitsuba(device, tmp_path):
    """A generated 16 x 8 HDR map (smooth sky, a bright patch 20x the rest), turned 30 degrees and scaled 1.5,
    lighting a Lambert sphere (albedo 0.6) that fills the view (the map is never seen directly here;
    test_envmap.py compares it seen directly).  32 x 32, K = 4 renders of 64 spp a side, max_depth 6."""
    import OpenImageIO as oiio

    mitsuba_or_skip(LLVM)
    v, u = np.meshgrid((np.arange(8) + 0.5) / 8, (np.arange(16) + 0.5) / 16, indexing="ij")
    sky = np.stack([0.3 + 0.2 * np.cos(np.pi * v), 0.4 + 0.1 * np.sin(2 * np.pi * u), 0.5 + 0.0 * u], -1).astype(np.float32)
    sky[2, 5:7] = 8.0
    path = tmp_path / "sky.exr"
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(16, 8, 3, "float"))
    out.write_image(sky)
    out.close()
    scene = {
        "width": 32,
        "height": 32,
        "cameras": [path_scenes.camera([0.5, 0.4, 3.0], [0, 0, 0], 24)],
        "environment": {"file": str(path), "intensity": 1.5, "rotation": 30.0},
        "materials": {"m": {"diffuse": [0.6, 0.6, 0.6]}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}],
    }
    ours = clrender_path_renders(scene, device)
    theirs = mitsuba_renders(scene, seeds=range(100, 100 + K))
    result = two_sample_z(ours, theirs)
    assert result.passed, f"clrender (a) vs Mitsuba (b)\n{result.report()}"


# ---------------------------------------------------------------------- textures against Mitsuba
def write_image(path, pixels):
    """An image file by OpenImageIO: uint8 pixels as an 8-bit PNG (sRGB codes), float32 as EXR."""
    import OpenImageIO as oiio

    pixels = np.ascontiguousarray(pixels)
    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(str(path))
    out.open(str(path), oiio.ImageSpec(w, h, c, "uint8" if pixels.dtype == np.uint8 else "float"))
    out.write_image(pixels)
    out.close()
    return str(path)


def textured_scene(folder) -> dict:
    """A checker floor (64 x 64 8-bit sRGB PNG, 16 squares a side, bilinear, repeat) and an upright card whose
    texture ramps red along u and green down v (so a flipped v or a skipped sRGB decoding changes block means),
    under a generated 32 x 16 HDR sky with a sun patch; the camera looks down so the map is never seen directly."""
    i, j = np.mgrid[0:64, 0:64]
    checker = np.where(((i // 4 + j // 4) % 2)[..., None] == 0, [230, 210, 170], [40, 80, 150]).astype(np.uint8)
    v, u = np.mgrid[0:32, 0:32] / 31.0
    ramp = np.stack([40 + 200 * u, 30 + 210 * v, 60 + 0 * u], -1).astype(np.uint8)
    sv, su = np.meshgrid((np.arange(16) + 0.5) / 16, (np.arange(32) + 0.5) / 32, indexing="ij")
    sky = np.stack([0.5 + 0.3 * np.cos(np.pi * sv), 0.6 + 0.2 * np.sin(2 * np.pi * su), 0.9 + 0.0 * su], -1).astype(np.float32)
    sky[3:5, 9:11] = [30.0, 28.0, 24.0]
    return {
        "width": 64,
        "height": 64,
        "cameras": [path_scenes.camera([0.3, 2.2, 2.4], [0, 0.3, -0.2], 36)],
        "environment": {"file": write_image(folder / "sky.exr", sky), "intensity": 1.0, "rotation": 20.0},
        "textures": {
            "checker": {"file": write_image(folder / "checker.png", checker), "filter": "linear"},
            "ramp": {"file": write_image(folder / "ramp.png", ramp), "filter": "linear", "wrap_s": "clamp_to_edge", "wrap_t": "clamp_to_edge"},
        },
        "materials": {"floor": {"diffuse": [1, 1, 1], "diffuse_texture": "checker"}, "card": {"diffuse": [1, 1, 1], "diffuse_texture": "ramp"}},
        "objects": [
            {"type": "quad", "corner": [-5, 0, 5], "edge_a": [10, 0, 0], "edge_b": [0, 0, -10], "material": "floor"},
            {"type": "quad", "corner": [-0.8, 0, -0.5], "edge_a": [1.6, 0, 0.3], "edge_b": [0, 1.2, 0], "material": "card"},
        ],
    }


@pytest.mark.slow
def test_a_textured_scene_under_an_environment_map_matches_mitsuba_and_planted_texture_bugs_fail(device, tmp_path):
    """Textures on both sides (clrender's float texels and bilinear lookups, Mitsuba's `bitmap`): the same
    z-test passes; the same Mitsuba scene with its textures left sRGB-encoded (`raw`) or v flipped fails
    (docs/testing.md has the measured p-values).  64 x 64, K = 4 renders of 64 spp a side, max_depth 6."""
    mitsuba_or_skip(LLVM)
    scene = textured_scene(tmp_path)
    ours = clrender_path_renders(scene, device)
    results = {}
    for planted in ("", "raw", "flip_v"):
        mi, loaded = mitsuba_scenes.load(scene, variant=LLVM, spp=SPP, max_depth=MAX_DEPTH, planted=planted)
        theirs = np.stack([mitsuba_scenes.render_loaded(mi, loaded, spp=SPP, seed=s) for s in range(100, 100 + K)])
        results[planted] = two_sample_z(ours, theirs)
        print(f"planted {planted or 'none'}: worst p {results[planted].worst_p:.3g} (threshold {results[planted].threshold:.3g})")
    assert results[""].passed, f"clrender (a) vs Mitsuba (b)\n{results[''].report()}"
    for planted in ("raw", "flip_v"):
        assert not results[planted].passed, f"planted {planted} was not detected\n{results[planted].report()}"
