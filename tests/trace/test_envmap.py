"""The image-based environment light (clrender/scene/environment.py, kernels/envmap.h) in both integrators.

References here are float64 re-derivations of docs/scene-format.md's mapping (Mitsuba 3's: v = acos(y) / pi from
+y, u = atan2(x, -z) / 2 pi, the map turned by `rotation` about +y), never clrender's own numbers:
- a white (albedo 1) convex Lambert sphere under a map of one colour c is c in every pixel (the furnace), checked
  by a pooled z-test over the pixels of K independent renders (|z| < Z_MAX: a false alarm once in ~10^5 runs;
  seeds fixed);
- the lookup: radiance bilinear between texel centres at u = (j + 1/2) / W (wrapping) and v = i / (H - 1), Mitsuba's
  envmap positions (`bilinear64`), at random directions through the device probe;
- under a map that is black but for one texel of radiance L, a Lambert sphere of albedo a shows
  a / pi x integral of the bilinear radiance x max(0, n . w) dw over the four cells around that texel, by a
  24 x 24 midpoint rule per cell in float64;
- the CDF searches' guides against a brute-force search of each sum (numpy's searchsorted) at every bucket's start,
  and the device sampler through its guides bit for bit the sampler through one-bucket guides (a search of the
  whole sum), at uniforms drawn at random and at every running sum's own values and bucket edges;
- the sampler: cell counts of 2^18 device samples against the documented weights (the mean luminance of a cell's
  four texels x sin(theta at its middle row)), normalised (Pearson's chi-square, p > 1e-3), every sample's density
  against that closed form and its radiance against `bilinear64`, and the density's integral over the sphere (a
  midpoint rule aligned with the cells: exact for a piecewise-constant density) is 1;
- MIS against the map's NEE and BSDF sampling alone (ENV_NEE=0, a test-only kernel switch) have one expectation
  (tests/reference/ztest.py's block z-test, alpha 0.01 with Šidák's correction);
- Whitted: primary rays that miss and a mirror sphere's reflected rays show `bilinear64` of the analytic direction.
"""

import dataclasses
import math

import numpy as np
import OpenImageIO as oiio
import pytest

from clrender.errors import UsageError
from clrender.scene import environment
from clrender.scene.environment import EnvironmentMap, buckets, guide
from clrender.scene.scene import Scene
from clrender.trace import envmap
from clrender.trace.envmap import EnvProbe
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests.clitools import run_cli
from tests.reference.path_scenes import camera
from tests.reference.sphere_chi2 import chi2_test
from tests.reference.ztest import two_sample_z

Z_MAX = 4.4  # two-sided normal: p = 1e-5
LUM = np.array([0.2126, 0.7152, 0.0722])


# ---------------------------------------------------------------------- float64 references
def direction_uv(d, rotation_deg=0.0):
    """(u, v) in [0, 1) x [0, 1] of unit world directions (..., 3): the documented mapping."""
    t = math.radians(rotation_deg)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    lx, lz = math.cos(t) * x - math.sin(t) * z, math.sin(t) * x + math.cos(t) * z
    u = np.arctan2(lx, -lz) / (2 * np.pi) % 1.0
    return u, np.arctan2(np.hypot(lx, lz), y) / np.pi  # not arccos(y): float32 directions near the poles


def bilinear64(texels, u, v):
    """Radiance (..., 3) of a map (H, W, 3) at (u, v), bilinear between texel centres at u = (j + 1/2) / W (the
    columns wrap) and v = i / (H - 1) (docs/scene-format.md; Mitsuba 3's envmap), float64."""
    t = np.asarray(texels, np.float64)
    h, w = t.shape[:2]
    x, y = np.asarray(u) * w - 0.5, np.asarray(v) * (h - 1)
    j0 = np.floor(x).astype(int)
    fx = (x - j0)[..., None]
    i0 = np.minimum(np.floor(y).astype(int), h - 2)
    fy = (y - i0)[..., None]
    j0, j1 = j0 % w, (j0 + 1) % w
    top = (1 - fx) * t[i0, j0] + fx * t[i0, j1]
    bottom = (1 - fx) * t[i0 + 1, j0] + fx * t[i0 + 1, j1]
    return (1 - fy) * top + fy * bottom


def cell_weights(texels):
    """The sampler's documented cell weights (H - 1, W): mean luminance of a cell's four texels x sin(theta) at its middle."""
    lum = np.asarray(texels, np.float64) @ LUM
    h = lum.shape[0]
    corners = lum[:-1] + lum[1:]
    return 0.25 * (corners + np.roll(corners, -1, axis=1)) * np.sin(np.pi * (np.arange(h - 1) + 0.5) / (h - 1))[:, None]


def uv_cell(u, v, h, w):
    """(row, column) of the cell between texel centres holding (u, v)."""
    return np.minimum(np.floor(v * (h - 1)).astype(int), h - 2), np.floor(u * w - 0.5).astype(int) % w


def to_world(local, rotation_deg):
    t = math.radians(rotation_deg)
    x, z = local[..., 0], local[..., 2]
    return np.stack([math.cos(t) * x + math.sin(t) * z, local[..., 1], -math.sin(t) * x + math.cos(t) * z], -1)


def uv_direction(u, v):
    theta, phi = np.pi * v, 2 * np.pi * u
    return np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], axis=-1)


def write_map(path, pixels) -> str:
    """An OpenEXR (or any OpenImageIO format by extension) float file of `pixels` (H, W, C)."""
    pixels = np.ascontiguousarray(pixels, np.float32)
    h, w, c = pixels.shape
    out = oiio.ImageOutput.create(str(path))
    assert out.open(str(path), oiio.ImageSpec(w, h, c, "float"))
    assert out.write_image(pixels)
    out.close()
    return str(path)


def sphere_scene(material: dict, size: int, environment: dict, position=(0, 0, 5), fov=28) -> dict:
    return {
        "width": size,
        "height": size,
        "cameras": [camera(list(position), [0, 0, 0], fov)],
        "environment": environment,
        "materials": {"m": material},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}],
    }


def renderer(scene: dict, folder, device, **settings) -> Renderer:
    loaded = Scene.from_dict(scene, base_dir=folder)
    return Renderer(loaded, tracer=Tracer(loaded, device=device), **settings)


def renders(scene: dict, folder, device, seeds, env_nee: bool = True, env_bsdf: bool = True, **settings) -> np.ndarray:
    """(K, H, W, 3) float64 path renders, one per seed; env_nee False builds the kernel without the map's NEE, env_bsdf
    False without its BSDF rays (after a non-delta vertex only NEE finds the map, unweighted)."""
    out = []
    for seed in seeds:
        r = renderer(scene, folder, device, integrator="path", seed=seed, **settings)
        if not (env_nee and env_bsdf):
            switches = {"ENV_NEE": int(env_nee), "ENV_BSDF": int(env_bsdf)}
            r.kernel = r.tracer.device.kernel("path.cl", "render_path", {**r.tracer.defines, "WRITE_AOV": 0, **switches})
        out.append(r.run().image.astype(np.float64))
    return np.array(out)


def sphere_hits(scene: Scene, size: int, offsets):
    """Per pixel and sub-pixel offset: the unit sphere's normal where the ray meets it (NaN on a miss), and the ray."""
    normals, directions = [], []
    for off in offsets:
        o, d = scene.camera(1).rays(size, size, off)
        b = np.einsum("...i,...i", o, d)
        disc = b * b - (np.einsum("...i,...i", o, o) - 1.0)
        t = -b - np.sqrt(np.where(disc > 0, disc, np.nan))
        normals.append(o + t[..., None] * d)
        directions.append(d)
    return np.array(normals), np.array(directions)


# ---------------------------------------------------------------------- path tracer
def test_furnace_under_a_one_colour_map_equals_the_colour(tmp_path, device):
    """Albedo 1, convex: every pixel's expectation is the map's colour times its intensity, as with `color`."""
    colour = np.array([0.25, 0.5, 0.75])
    write_map(tmp_path / "flat.exr", np.broadcast_to(colour, (8, 16, 3)))
    scene = sphere_scene({"diffuse": [1, 1, 1]}, 16, {"file": "flat.exr", "intensity": 2.0, "rotation": 33.0})
    images = renders(scene, tmp_path, device, (1, 2, 3, 4), spp=16, max_depth=64)
    expected = 2.0 * colour
    k = len(images)
    diff = (images.mean(axis=0) - expected).reshape(-1, 3)
    var = (images.var(axis=0, ddof=1) / k).reshape(-1, 3)
    z = diff.sum(axis=0) / np.sqrt(var.sum(axis=0))
    assert np.all(np.abs(z) < Z_MAX), (z, images.mean(axis=(0, 1, 2)))
    np.testing.assert_allclose(images.mean(axis=(0, 1, 2)), expected, rtol=0.01)
    constant = sphere_scene({"diffuse": [1, 1, 1]}, 16, {"color": list(expected)})
    np.testing.assert_allclose(renders(constant, tmp_path, device, (1,), spp=4, max_depth=64)[0], np.broadcast_to(expected, (16, 16, 3)), atol=1e-5)


def test_one_bright_texel_lights_a_lambert_sphere_by_the_cosine_law(tmp_path, device):
    """radiance = albedo / pi x integral of the bilinear radiance x max(0, n . w) over the solid angle of the four
    cells around the texel, pixel by pixel (the 8 x 8 uniform sub-pixel rays the render uses, averaged), where the
    texel lies well above the horizon."""
    h, w, row, col, L, albedo, size, n = 16, 32, 5, 20, 40.0, 0.8, 24, 8
    pixels = np.zeros((h, w, 3), np.float32)
    pixels[row, col] = L
    write_map(tmp_path / "spot.exr", pixels)
    scene = sphere_scene({"diffuse": [albedo] * 3}, size, {"file": "spot.exr"}, position=(3, 0.5, 3.5), fov=30)
    images = renders(scene, tmp_path, device, (5, 6, 7), spp=n * n, samples=n, sampler="uniform", max_depth=0)
    # the four cells around the texel as 48 x 48 midpoints with their solid angles, float64
    k = 48
    uu, vv = np.meshgrid((col - 0.5 + 2 * (np.arange(k) + 0.5) / k) / w, (row - 1 + 2 * (np.arange(k) + 0.5) / k) / (h - 1))
    dirs = uv_direction(uu, vv).reshape(-1, 3)
    d_omega = (2 * np.pi**2 * np.sin(np.pi * vv) * 4 / (w * (h - 1) * k * k)).ravel()
    seen = bilinear64(pixels, uu, vv)[..., 0].ravel()
    centre = uv_direction((col + 0.5) / w, row / (h - 1))
    offsets = [((q + 0.5) / n, (p + 0.5) / n) for p in range(n) for q in range(n)]
    normals, _ = sphere_hits(Scene.from_dict(scene, base_dir=tmp_path), size, offsets)
    irradiance = np.maximum(normals @ dirs.T, 0.0) @ (seen * d_omega)  # (n*n, H, W)
    expected = (albedo / np.pi * irradiance).mean(axis=0)
    lit = np.all(normals @ centre > 0.3, axis=0)  # every sub-pixel ray meets the sphere, the texel well above its horizon
    assert lit.sum() > 60, lit.sum()
    got = images.mean(axis=0)[..., 0]
    se = np.sqrt(images.var(axis=0, ddof=1)[..., 0] / len(images))
    z = (got[lit] - expected[lit]).sum() / np.sqrt(np.square(se[lit]).sum())
    assert abs(z) < Z_MAX, z
    assert abs(got[lit].mean() / expected[lit].mean() - 1) < 0.01  # (a cell's radiance varies over it: each pixel is noisy)
    dark = np.all(normals @ centre < -0.3, axis=0)  # facing away from the only light: black
    assert dark.sum() > 20 and np.all(got[dark] == 0.0), dark.sum()


def test_mis_with_the_maps_nee_equals_bsdf_sampling_alone(tmp_path, device):
    """Two estimators of one image: NEE to the map + BSDF rays, power heuristic; BSDF rays alone (ENV_NEE=0)."""
    rng = np.random.default_rng(7)
    pixels = rng.uniform(0.1, 0.6, (8, 16, 3))
    pixels[2:4, 5:9] = 6.0  # a bright patch, so the strategies differ
    write_map(tmp_path / "sky.exr", pixels)
    scene = sphere_scene({"diffuse": [0.7, 0.5, 0.3], "specular": [0.2, 0.2, 0.2], "shininess": 40}, 16, {"file": "sky.exr", "rotation": 60})
    scene["objects"].append({"type": "sphere", "center": [1.2, -0.6, 1.0], "radius": 0.5, "material": "m"})
    settings = dict(spp=64, max_depth=3)
    mis = renders(scene, tmp_path, device, (11, 12, 13, 14), **settings)
    bsdf = renders(scene, tmp_path, device, (21, 22, 23, 24), env_nee=False, **settings)
    result = two_sample_z(mis, bsdf, block=4)
    assert result.passed, result.report()
    # and the map's NEE helps: the MIS image is less noisy
    assert mis.var(axis=0).mean() < 0.5 * bsdf.var(axis=0).mean()


@pytest.mark.slow  # a kernel variant of its own to build
def test_the_maps_nee_alone_equals_bsdf_sampling_alone(tmp_path, device):
    """The sampler's density is the one it samples by, and positive wherever the bilinear radiance is: NEE alone
    (ENV_BSDF=0: piecewise-constant density over the cells, bilinear radiance) and BSDF rays alone (ENV_NEE=0)
    estimate one image of a diffuse sphere under a map with black patches, sharp texels and a black pole
    (tests/reference/ztest.py's block z-test, alpha 0.01 with Šidák's correction)."""
    rng = np.random.default_rng(17)
    pixels = rng.uniform(0.0, 1.0, (8, 16, 3)) ** 3
    pixels[0] = 0.0  # a black top row: the cells next to it are lit by one row only
    pixels[4, 2:6] = 0.0
    pixels[3, 10] = 12.0  # one sharp bright texel: its light is a bilinear tent, sampled by four flat cells
    write_map(tmp_path / "patchy.exr", pixels)
    scene = sphere_scene({"diffuse": [0.8, 0.8, 0.8]}, 16, {"file": "patchy.exr", "rotation": 15}, position=(0, 1.5, 4.5))
    settings = dict(spp=64, max_depth=2)
    nee = renders(scene, tmp_path, device, (31, 32, 33, 34), env_bsdf=False, **settings)
    bsdf = renders(scene, tmp_path, device, (41, 42, 43, 44), env_nee=False, **settings)
    result = two_sample_z(nee, bsdf, block=4)
    assert result.passed, result.report()


# ---------------------------------------------------------------------- the sampler
@pytest.fixture
def patchy_map():
    rng = np.random.default_rng(3)
    texels = rng.uniform(0.0, 1.0, (8, 12, 3)).astype(np.float32) ** 3
    texels[0:2] = 0.0  # two black rows: the cells between them are never sampled
    texels[4:6, 3:6] = 0.0  # black cells (4, 3) and (4, 4)
    texels[6, 9] = 20.0
    return EnvironmentMap(texels, intensity=1.5, rotation=-40.0)


def test_env_lookup_is_bilinear_between_texel_centres_as_mitsuba_reads_a_map(patchy_map, device):
    """The device lookup at 4096 random directions (and on texel centres, seams and poles) against `bilinear64`."""
    env = patchy_map
    h, w = env.height, env.width
    rng = np.random.default_rng(11)
    u, v = rng.random(4096), np.arccos(rng.uniform(-1, 1, 4096)) / np.pi
    i, j = np.mgrid[0:h, 0:w]
    u = np.concatenate([u, ((j + 0.5) / w).ravel(), [0.0, 0.5 / w, 1 - 0.5 / w, 0.999999]])
    v = np.concatenate([v, (i / (h - 1)).ravel(), [0.3, 0.5, 0.7, 0.4]])
    radiance, _ = EnvProbe(device, env).eval(to_world(uv_direction(u, v), env.rotation))
    expected = 1.5 * bilinear64(env.texels, u, v)
    np.testing.assert_allclose(radiance, expected, rtol=2e-4, atol=2e-4 * expected.max())
    centres = slice(4096, 4096 + h * w)  # a texel's own value at its centre
    np.testing.assert_allclose(radiance[centres], 1.5 * env.texels.reshape(-1, 3), rtol=1e-3, atol=1e-5)


def test_a_one_row_map_is_read_as_two_equal_rows(device):
    """v = i / (H - 1) needs two rows: a one-row map varies along u only, bilinearly, and its density integrates to 1."""
    texels = np.array([[[1.0, 2.0, 3.0], [4.0, 0.0, 1.0], [0.5, 0.5, 0.5]]], np.float32)
    rng = np.random.default_rng(2)
    u, v = rng.random(512), rng.random(512)
    probe = EnvProbe(device, EnvironmentMap(texels))
    radiance, _ = probe.eval(uv_direction(u, v))
    np.testing.assert_allclose(radiance, bilinear64(np.repeat(texels, 2, axis=0), u, v), rtol=2e-4, atol=1e-4)
    np.testing.assert_allclose(radiance, bilinear64(np.repeat(texels, 2, axis=0), u, 0 * v), rtol=2e-4, atol=1e-4)
    dirs, _, pdf = probe.sample(rng.random((4096, 2)))
    assert np.all(np.isfinite(dirs)) and np.all(pdf > 0)


def test_each_guide_entry_is_the_interval_a_full_search_finds():
    rng = np.random.default_rng(5)
    for n in (1, 2, 3, 12, 255, 256, 257):
        weight = rng.random((4, n)) ** 6 * (rng.random((4, n)) > 0.3)  # empty intervals, and a row of them
        weight[0] = 0.0
        sums = np.zeros((4, n + 1))
        sums[:, 1:] = np.cumsum(weight, axis=1) / np.maximum(weight.sum(axis=1, keepdims=True), 1e-300)
        sums[:, -1] = 1.0
        sums = sums.astype(np.float32)
        b = buckets(n)
        assert b >= n and b & (b - 1) == 0
        table = guide(sums, b)
        for row, g in zip(sums, table):
            brute = np.searchsorted(row[:n].astype(np.float64), np.arange(b + 1) / b, side="right") - 1
            np.testing.assert_array_equal(g, brute)


def test_guided_env_samples_are_bit_for_bit_a_search_of_the_whole_sum(patchy_map, device, monkeypatch):
    env = patchy_map
    d = environment.distribution(env)
    whole_sums = np.concatenate([guide(d.marginal, 1).ravel(), guide(d.conditional, 1).ravel()])
    one_bucket = dataclasses.replace(d, row_buckets=1, column_buckets=1, guides=whole_sums)
    u_edges = np.concatenate([d.marginal, np.arange(d.row_buckets) / d.row_buckets])
    v_edges = np.concatenate([d.conditional.ravel(), np.arange(d.column_buckets) / d.column_buckets])
    rng = np.random.default_rng(9)
    u = np.concatenate([rng.random((1 << 14, 2)), np.stack([rng.choice(u_edges, 4096), rng.choice(v_edges, 4096)], axis=1)])
    u = np.minimum(u.astype(np.float32), np.float32(1 - 2**-24))
    guided = EnvProbe(device, env).sample(u)
    monkeypatch.setattr(envmap, "distribution", lambda _: one_bucket)
    whole = EnvProbe(device, env).sample(u)
    for a, b in zip(guided, whole):
        np.testing.assert_array_equal(a, b)


def test_env_samples_follow_the_cell_weights_times_solid_angle(patchy_map, device):
    env, n = patchy_map, 1 << 18
    h, w = env.height, env.width
    probe = EnvProbe(device, env)
    dirs, radiance, pdf = probe.sample(np.random.default_rng(1).random((n, 2)))
    u, v = direction_uv(dirs.astype(np.float64), env.rotation)
    rows, cols = uv_cell(u, v, h, w)
    weight = cell_weights(env.texels)
    prob = weight / weight.sum()
    counts = np.bincount(rows * w + cols, minlength=(h - 1) * w)
    result = chi2_test(counts, prob, n, 0)
    assert result.p_value > 1e-3, str(result)
    assert counts.reshape(h - 1, w)[0].sum() == 0 and counts.reshape(h - 1, w)[4, 3:5].sum() == 0
    # every sample's density is p_uv / (2 pi^2 sin theta), p_uv = the cell's probability x W (H - 1)
    expected_pdf = prob[rows, cols] * w * (h - 1) / (2 * np.pi**2 * np.sin(np.pi * v))
    # not on a cell's edge, where float32 may pick the neighbour
    inside = (np.abs(v * (h - 1) - np.round(v * (h - 1))) > 1e-3) & (np.abs(u * w - 0.5 - np.round(u * w - 0.5)) > 1e-3)
    np.testing.assert_allclose(pdf[inside], expected_pdf[inside], rtol=2e-3)
    expected = 1.5 * bilinear64(env.texels, u, v)
    np.testing.assert_allclose(radiance, expected, rtol=2e-4, atol=2e-4 * expected.max())


def test_env_pdf_integrates_to_one(patchy_map, device):
    env, k = patchy_map, 6  # k x k midpoints per cell: the density is constant over each
    h, w = env.height, env.width
    uu, vv = np.meshgrid((0.5 + (np.arange(w * k) + 0.5) / k) / w % 1.0, (np.arange((h - 1) * k) + 0.5) / ((h - 1) * k))
    _, pdf = EnvProbe(device, env).eval(to_world(uv_direction(uu, vv).reshape(-1, 3), env.rotation))
    d_omega = 2 * np.pi**2 * np.sin(np.pi * vv).ravel() / (w * k * (h - 1) * k)
    assert abs(np.sum(pdf.astype(np.float64) * d_omega) - 1.0) < 1e-4


# ---------------------------------------------------------------------- Whitted
def test_whitted_primary_and_mirror_rays_see_the_bilinear_map(tmp_path, device):
    rng = np.random.default_rng(5)
    h, w, size, rotation = 6, 10, 48, 25.0
    pixels = rng.uniform(0.05, 1.0, (h, w, 3)).astype(np.float32)
    write_map(tmp_path / "tiles.hdr", pixels)
    scene = sphere_scene({"diffuse": [0, 0, 0], "mirror": 1.0}, size, {"file": "tiles.hdr", "rotation": rotation, "intensity": 3.0}, fov=40)
    loaded = Scene.from_dict(scene, base_dir=tmp_path)
    stored = loaded.environment_map.texels  # the Radiance HDR file rounds the floats: its own values are the map
    assert np.allclose(stored, pixels, atol=0.01)
    image = renderer(scene, tmp_path, device).run().image
    normal, d = sphere_hits(loaded, size, [(0.5, 0.5)])
    normal, d = normal[0], d[0]
    hit = ~np.isnan(normal[..., 0])
    seen = np.where(hit[..., None], d - 2 * np.einsum("...i,...i", d, normal)[..., None] * normal, d)
    u, v = direction_uv(seen, rotation)
    grazing = hit & (np.abs(np.einsum("...i,...i", d, np.nan_to_num(normal))) < 0.2)  # near the silhouette: skip
    check = ~grazing
    assert check[hit].sum() > 300 and check[~hit].sum() > 300
    expected = 3.0 * bilinear64(stored, u, v)
    np.testing.assert_allclose(image[check], expected[check], rtol=2e-4, atol=2e-4 * expected.max())


def test_without_a_map_whitted_keeps_its_background(tmp_path, device):
    scene = sphere_scene({"diffuse": [0, 0, 0], "mirror": 1.0}, 8, {"color": [1, 1, 1]})
    scene["background"] = [0.2, 0.3, 0.4]
    image = renderer(scene, tmp_path, device).run().image
    assert np.all(image == np.float32([0.2, 0.3, 0.4]))


# ---------------------------------------------------------------------- the scene key
def scene_with(environment: dict) -> dict:
    return {"environment": environment, "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]}


def test_map_keys_and_defaults(tmp_path):
    write_map(tmp_path / "m.exr", np.ones((2, 4, 4)))  # RGBA: alpha dropped
    s = Scene.from_dict(scene_with({"file": "m.exr"}), base_dir=tmp_path)
    env = s.environment_map
    assert (env.intensity, env.rotation, env.texels.shape, s.environment) == (1.0, 0.0, (2, 4, 3), (0.0, 0.0, 0.0))
    grey = write_map(tmp_path / "g.exr", np.full((2, 4, 1), 0.5))
    assert np.all(Scene.from_dict(scene_with({"file": grey})).environment_map.texels == 0.5)
    assert Scene.from_dict(scene_with({"color": [1, 1, 1]})).environment_map is None


def bad(tmp_path, environment, match, **kwargs):
    with pytest.raises(UsageError, match=match) as info:
        Scene.from_dict(scene_with(environment), base_dir=tmp_path, **kwargs)
    assert "\n" not in str(info.value)


def test_bad_maps_are_one_line_errors(tmp_path, monkeypatch):
    write_map(tmp_path / "ok.exr", np.ones((2, 4, 3)))
    write_map(tmp_path / "two.exr", np.ones((2, 4, 2)))
    write_map(tmp_path / "neg.exr", -np.ones((2, 4, 3)))
    write_map(tmp_path / "nan.exr", np.full((2, 4, 3), np.nan))
    (tmp_path / "text.hdr").write_text("not an image\n")
    data = (tmp_path / "ok.exr").read_bytes()
    (tmp_path / "cut.exr").write_bytes(data[: len(data) // 2])
    bad(tmp_path, {"file": "missing.exr"}, "environment.file: .*does not exist")
    bad(tmp_path, {"file": "text.hdr"}, "environment.file: cannot read")
    bad(tmp_path, {"file": "cut.exr"}, "environment.file: .*(damaged|truncated|cannot read)")
    bad(tmp_path, {"file": "two.exr"}, "2 channels; allowed: 1 .*3 .*4")
    bad(tmp_path, {"file": "neg.exr"}, "value -1; allowed: radiance from 0")
    bad(tmp_path, {"file": "nan.exr"}, "value nan")
    bad(tmp_path, {"file": "ok.exr", "intensity": -1}, "environment.intensity: -1 is out of range")
    bad(tmp_path, {"file": "ok.exr", "color": [1, 1, 1]}, "either 'color' .* or 'file'")
    bad(tmp_path, {"intensity": 2}, "environment.intensity: needs 'file'")
    bad(tmp_path, {"file": 3}, "expected a path")
    bad(tmp_path, {"file": "ok.exr", "scale": 2}, "environment.scale: unknown key")
    outside = tmp_path / "inner"
    outside.mkdir()
    bad(outside, {"file": "../ok.exr"}, "outside the scene folder", allow_outside=False)
    assert Scene.from_dict(scene_with({"file": "../ok.exr"}), base_dir=outside).environment_map is not None
    monkeypatch.setattr("clrender.memory.MAX_MEMORY", 1 << 20)
    bad(tmp_path, {"file": "ok.exr"}, "environment map 4x2 needs about .* of memory")


def test_cli_refuses_a_bad_map_with_exit_2(tmp_path, capsys):
    (tmp_path / "s.toml").write_text('[environment]\nfile = "nowhere.hdr"\n[[objects]]\ntype = "sphere"\ncenter = [0, 0, 0]\nradius = 1\n')
    out = tmp_path / "o.png"
    code, _, stderr = run_cli(capsys, "render", str(tmp_path / "s.toml"), "--integrator", "path", "-o", str(out))
    assert code == 2 and "nowhere.hdr" in stderr and len(stderr.strip().splitlines()) == 1 and not out.exists()


# ---------------------------------------------------------------------- against Mitsuba 3
@pytest.mark.slow
def test_a_map_seen_directly_matches_mitsubas_envmap(tmp_path, device):
    """A 32 x 16 random HDR map (texels uniform^3 x 4), turned 30 degrees and scaled 1.5, seen by a 96 x 64 camera
    (fov 70) with nothing in front of it: clrender's path tracer and Mitsuba's `envmap` of the same EXR
    (tests/reference/mitsuba_scenes.py), 256 spp each, differ by under 1% relative L1 (the nearest lookup: 40%)."""
    from tests.reference import mitsuba_scenes

    reason = mitsuba_scenes.unavailable("scalar_rgb")
    if reason:
        pytest.skip(reason)
    rng = np.random.default_rng(21)
    path = write_map(tmp_path / "random.exr", 4.0 * rng.uniform(0, 1, (16, 32, 3)) ** 3)
    scene = {
        "width": 96,
        "height": 64,
        "cameras": [camera([0, 0, 0], [1, 0.4, -1], 70)],
        "environment": {"file": path, "intensity": 1.5, "rotation": 30.0},
        "materials": {},
        "objects": [],
    }
    ours = renders(scene, tmp_path, device, (1,), spp=256, max_depth=0)[0]
    theirs = mitsuba_scenes.render(scene, variant="scalar_rgb", spp=256, seed=3, max_depth=0).astype(np.float64)
    l1 = np.abs(ours - theirs).sum() / np.abs(theirs).sum()
    assert l1 < 0.01, l1


@pytest.mark.slow
def test_a_map_seen_directly_and_through_smooth_glass_matches_mitsuba_by_blocks(tmp_path, device):
    """A 32 x 16 random HDR map behind a smooth glass sphere (IOR 1.5) that fills half the view, 64 x 64: clrender's
    path tracer and Mitsuba's (llvm_ad_rgb, `envmap` of the same EXR), K = 4 renders of 64 spp a side, max_depth 6,
    the block z-test of tests/reference/ztest.py (alpha 0.01, Šidák); the nearest lookup failed 43 of 900 blocks."""
    from tests.mitsubatools import K, clrender_path_renders, mitsuba_or_skip, mitsuba_renders

    mitsuba_or_skip("llvm_ad_rgb")
    rng = np.random.default_rng(23)
    path = write_map(tmp_path / "random.exr", 2.0 * rng.uniform(0, 1, (16, 32, 3)) ** 2)
    scene = sphere_scene({"transmission": 1.0, "ior": 1.5, "roughness": 0.0}, 64, {"file": path, "rotation": -20.0}, position=(0, 0.5, 3.2), fov=50)
    ours = clrender_path_renders(scene, device)
    theirs = mitsuba_renders(scene, seeds=range(100, 100 + K))
    result = two_sample_z(ours, theirs)
    assert result.passed, f"clrender (a) vs Mitsuba (b)\n{result.report()}"
