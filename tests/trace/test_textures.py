"""Image textures rendered (kernels/texture.h): a textured quad under a head-on directional light, every pixel
against the texel a numpy lookup of the same UV finds times the BRDF, for the Whitted integrator (kd I cos) and
the path tracer (the float64 glTF BRDF of tests/reference/bsdf64.py); wrap modes, glTF's UV orientation, the
sRGB decode, KHR_texture_transform, vertex colours, a metallic-roughness map that switches lobes per texel, and
an emissive texture seen directly and lighting a plane (NEE and BSDF rays, against the analytic irradiance)."""

import math

import numpy as np
import pytest

import clrender

from tests.gltftools import png_bytes, quad_hits, textured_quad
from tests.reference import bsdf64

N = 32  # image side
TEXELS = np.array(  # 4 x 4 texels, row 0 the image's top; 128 decodes to 0.2158605
    [
        [[255, 255, 255], [0, 0, 0], [255, 0, 0], [128, 128, 128]],
        [[0, 255, 0], [128, 128, 128], [0, 0, 255], [255, 255, 0]],
        [[64, 32, 200], [255, 255, 255], [10, 20, 30], [0, 0, 0]],
        [[128, 128, 128], [200, 100, 50], [0, 0, 0], [255, 255, 255]],
    ],
    np.uint8,
)
WRAPS = {"repeat": 10497, "clamp": 33071, "mirror": 33648}


def srgb(c):
    c = np.asarray(c, np.float64) / 255
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def wrapped(i, n, mode):
    if mode == "clamp":
        return np.clip(i, 0, n - 1)
    if mode == "mirror":
        m = np.mod(i, 2 * n)
        return np.where(m < n, m, 2 * n - 1 - m)
    return np.mod(i, n)


def nearest(texels, uv, wrap_s="repeat", wrap_t="repeat", margin=0.02):
    """(expected linear colours, mask of pixels whose centre is `margin` texels or more from a texel edge) of
    nearest lookups.  The path tracer jitters its rays over the pixel: its tests ask for half a pixel's width."""
    h, w = texels.shape[:2]
    x, y = uv[..., 0] * w, uv[..., 1] * h
    far = (np.abs(x - np.round(x)) > margin) & (np.abs(y - np.round(y)) > margin)
    i, j = wrapped(np.floor(x).astype(int), w, wrap_s), wrapped(np.floor(y).astype(int), h, wrap_t)
    return srgb(texels)[j, i], far


def quad_uv(scale=1.0):
    """Each pixel's UV on textured_quad (UV (0, 0) at the quad's top-left corner (-1, 1))."""
    xy = quad_hits(N)
    return np.stack([(xy[..., 0] + 1) / 2, (1 - xy[..., 1]) / 2], -1) * scale


def render(path, integrator="whitted", **kw):
    if integrator == "path":
        kw = dict(integrator="path", spp=1, max_depth=0, **kw)  # one ray a pixel, at a random point of it
    return clrender.render(str(path), width=N, height=N, aa="none", **kw).astype(np.float64)


def lambert_path(base, metallic=0.0, roughness=1.0, offset=(0.5, 0.5)):
    """The path tracer's pixel under the light: E f cos with the float64 glTF BRDF, seen through each pixel's point
    `offset`."""
    xy = quad_hits(N, offset)
    eye = np.array([0.0, 0.0, 2.0])
    p = np.concatenate([xy, np.zeros((N, N, 1))], -1)
    wo = eye - p
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    wi = np.broadcast_to([0.0, 0.0, 1.0], wo.shape)
    return math.pi * bsdf64.gltf_eval(wo, wi, base, np.asarray(metallic), np.asarray(roughness))


def within_pixel(image, base, metallic=0.0, roughness=1.0, rtol=1e-4):
    """Whether each path-traced pixel (one ray at a random point of it) lies within the range the float64 BRDF
    takes over the pixel's corners and centre, widened by rtol (smooth and monotone over so small a patch).
    `base`: the base colour, or a function of the pixel point's offset giving it per pixel."""
    colour = base if callable(base) else lambda offset: base
    offsets = ((0, 0), (1, 0), (0, 1), (1, 1), (0.5, 0.5))
    corners = np.stack([lambert_path(colour(o), metallic, roughness, o) for o in offsets])
    lo, hi = corners.min(0), corners.max(0)
    return (image >= lo * (1 - rtol) - 1e-6) & (image <= hi * (1 + rtol) + 1e-6)


def material(**pbr):
    return {"pbrMetallicRoughness": {"metallicFactor": 0.0, **pbr}}


@pytest.mark.parametrize("wrap_s, wrap_t", [("repeat", "repeat"), ("mirror", "clamp"), ("clamp", "mirror")])
def test_checkerboard_whitted_is_texel_times_light(tmp_path, wrap_s, wrap_t):
    """kd I cos = texel exactly (I cos = 1); UVs run to 1.5 across the quad, so each wrap mode shows past 1."""
    sampler = [{"magFilter": 9728, "wrapS": WRAPS[wrap_s], "wrapT": WRAPS[wrap_t]}]
    path = textured_quad(tmp_path, material(baseColorTexture={"index": 0}), [png_bytes(TEXELS)], uv_scale=1.5, samplers=sampler)
    expected, far = nearest(TEXELS, quad_uv(1.5), wrap_s, wrap_t)
    image = render(path)
    assert far.mean() > 0.8
    np.testing.assert_allclose(image[far], expected[far], rtol=2e-6, atol=1e-7)


def test_srgb_decode_of_128(tmp_path):
    """A uniform texel 128 decodes to 0.2158605 (sRGB), times a base colour factor."""
    path = textured_quad(tmp_path, material(baseColorTexture={"index": 0}, baseColorFactor=[1, 0.5, 0.25, 1]), [png_bytes(np.full((2, 2, 3), 128))])
    image = render(path)
    np.testing.assert_allclose(image, np.broadcast_to(0.2158605 * np.array([1, 0.5, 0.25]), image.shape), rtol=1e-6)


def test_checkerboard_path_is_texel_times_gltf_brdf(tmp_path):
    path = textured_quad(tmp_path, material(baseColorTexture={"index": 0}), [png_bytes(TEXELS)], uv_scale=2.0)
    expected, far = nearest(TEXELS, quad_uv(2.0), margin=0.12)  # a pixel is 0.225 texels wide
    image = render(path, "path")
    assert far.mean() > 0.25
    assert within_pixel(image, expected)[far].all()


def test_bilinear_between_texel_centres(tmp_path):
    """A 2 x 1 texture black | white, linear filter, clamped: the colour ramps from texel centre to centre."""
    texels = np.array([[[0, 0, 0], [255, 255, 255]]], np.uint8)
    sampler = [{"magFilter": 9729, "wrapS": 33071, "wrapT": 33071}]
    path = textured_quad(tmp_path, material(baseColorTexture={"index": 0}), [png_bytes(texels)], samplers=sampler)
    u = quad_uv()[..., 0]
    expected = np.clip(u * 2 - 0.5, 0, 1)
    np.testing.assert_allclose(render(path)[..., 1], expected, atol=2e-6)


def test_texture_transform_moves_the_checkerboard(tmp_path):
    """KHR_texture_transform offset, rotation and scale: uv' = T R S uv (the extension's matrices, written out)."""
    offset, rotation, scale = [0.3, -0.2], 0.7, [1.5, 0.8]
    info = {"index": 0, "extensions": {"KHR_texture_transform": {"offset": offset, "rotation": rotation, "scale": scale}}}
    sampler = [{"magFilter": 9728}]
    path = textured_quad(tmp_path, material(baseColorTexture=info), [png_bytes(TEXELS)], samplers=sampler)
    t = np.array([[1, 0, offset[0]], [0, 1, offset[1]], [0, 0, 1]])
    r = np.array([[math.cos(rotation), math.sin(rotation), 0], [-math.sin(rotation), math.cos(rotation), 0], [0, 0, 1]])
    s = np.diag([scale[0], scale[1], 1])
    uv = quad_uv()
    moved = np.einsum("ij,hwj->hwi", t @ r @ s, np.concatenate([uv, np.ones((N, N, 1))], -1))[..., :2]
    expected, far = nearest(TEXELS, moved)
    image = render(path)
    np.testing.assert_allclose(image[far], expected[far], rtol=2e-6, atol=1e-7)
    unmoved, _ = nearest(TEXELS, uv)
    assert np.abs(unmoved - expected)[far].max() > 0.5  # the transform did move it


def test_vertex_colours_multiply_the_base_colour(tmp_path):
    """COLOR_0 affine in x, y is interpolated exactly on both triangles; it multiplies factor x texture."""
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], float)

    def colour(xy):
        return np.stack([0.5 + 0.25 * xy[..., 0], 0.5 + 0.2 * xy[..., 1], 0.6 + 0.1 * xy[..., 0] - 0.1 * xy[..., 1]], -1)

    path = textured_quad(
        tmp_path,
        material(baseColorTexture={"index": 0}, baseColorFactor=[0.8, 1, 0.5, 1]),
        [png_bytes(np.full((2, 2, 3), 128))],
        colours=colour(corners),
    )
    expected = colour(quad_hits(N)) * 0.2158605 * np.array([0.8, 1, 0.5])
    np.testing.assert_allclose(render(path), expected, rtol=1e-5)
    # the path tracer's ray lands anywhere in the pixel: the BRDF with the colour of each corner
    image = render(path, "path")
    assert within_pixel(image, lambda o: colour(quad_hits(N, o)) * 0.2158605 * np.array([0.8, 1, 0.5])).all()


def test_metallic_roughness_map_switches_lobes(tmp_path):
    """Left half metallic 0 (B = 0), right half metallic 1 (B = 255), G = 200 -> roughness 0.9 x 200/255; the path
    tracer's pixels are the glTF BRDF of each half's parameters (a dielectric layer, then a conductor).  The
    jittered ray moves the broad highlight by up to 0.3 % from the pixel centre's value."""
    mr = np.zeros((1, 2, 3), np.uint8)
    mr[0, :, 1] = 200
    mr[0, 1, 2] = 255
    base = np.array([0.9, 0.6, 0.3])
    mat = material(baseColorFactor=[*base, 1], metallicFactor=1.0, roughnessFactor=0.9, metallicRoughnessTexture={"index": 0})
    path = textured_quad(tmp_path, mat, [png_bytes(mr)])
    image = render(path, "path")
    left = quad_uv()[..., 0] < 0.5
    roughness = 0.9 * 200 / 255
    far = np.abs(quad_uv()[..., 0] - 0.5) > 0.02
    inside = np.where(left[..., None], within_pixel(image, base, 0.0, roughness), within_pixel(image, base, 1.0, roughness))
    assert inside[far].all()
    lambert, conductor = lambert_path(base, 0.0, roughness), lambert_path(base, 1.0, roughness)
    assert (np.abs(lambert - conductor) > 0.05 * lambert).mean() > 0.8  # the two lobes differ far beyond the tolerance


def test_emissive_texture_seen_directly(tmp_path):
    """The camera sees emissiveFactor x strength x texel (no light, max_depth 0)."""
    mat = {
        "emissiveFactor": [1.0, 0.5, 2.0],
        "emissiveTexture": {"index": 0},
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 3.0}},
        "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]},
    }
    path = textured_quad(tmp_path, mat, [png_bytes(TEXELS)])
    expected, far = nearest(TEXELS, quad_uv(), margin=0.06)  # a pixel is 0.1125 texels wide
    image = render(path, "path")
    np.testing.assert_allclose(image[far], (expected * np.array([3.0, 1.5, 6.0]))[far], rtol=2e-6, atol=1e-7)


def rectangle_factor(a, b, c):
    """Form factor from a point to an a x b rectangle parallel to it at height c, over one of its corners."""
    x, y = a / c, b / c
    return (x / math.hypot(1, x) * math.atan(y / math.hypot(1, x)) + y / math.hypot(1, y) * math.atan(x / math.hypot(1, y))) / (2 * math.pi)


def test_emissive_texture_lights_a_plane(tmp_path):
    """A 2 x 2 emitter 1 above a white Lambert floor, its texture white on the half x < 0 and black on x > 0: the
    floor below the centre gets E = L pi (F(1, 1) + F(1, 1)) (the lit half as two unit squares over the foot
    point); NEE picks the emitter by its mean (0.5 L) but evaluates the texel at its point."""
    from PIL import Image

    Image.fromarray(np.array([[[255, 255, 255], [0, 0, 0]]], np.uint8)).save(tmp_path / "half.png")
    radiance = 2.0
    scene = {
        "width": 16,
        "height": 16,
        "cameras": [{"position": [0, -3, 0.4], "look_at": [0, 0, 0], "fov": 0.6}],
        "textures": {"half": {"file": "half.png", "filter": "nearest", "wrap_s": "clamp_to_edge"}},
        "materials": {
            "light": {"base_color": [0, 0, 0], "emission": [radiance] * 3, "emissive_texture": "half"},
            "floor": {"diffuse": [1, 1, 1]},
        },
        "objects": [
            # facing down: edge_a x edge_b = -z; its image upright along edge_a = +x
            {"type": "quad", "corner": [-1, 1, 1], "edge_a": [2, 0, 0], "edge_b": [0, -2, 0], "material": "light"},
            {"type": "quad", "corner": [-5, -5, 0], "edge_a": [10, 0, 0], "edge_b": [0, 10, 0], "material": "floor"},
        ],
    }
    from clrender.scene.scene import Scene

    s = Scene.from_dict(scene, base_dir=tmp_path)
    image = clrender.Renderer(s, integrator="path", spp=256, max_depth=0, seed=3).run().image.astype(np.float64)
    expected = radiance * 2 * rectangle_factor(1, 1, 1)  # albedo/pi x E = L x sum of the form factors
    values = image[..., 0].ravel()
    stderr = values.std(ddof=1) / math.sqrt(values.size)
    assert abs(values.mean() - expected) < 4 * stderr + 0.01 * expected, (values.mean(), expected, stderr)


@pytest.mark.parametrize("tilt", [(1, 0), (0, 1), (-1, 0)])
def test_normal_map_tilts_the_shading_normal(tmp_path, tilt):
    """A uniform normal map tilting the normal 30 degrees towards +u (image right, +x), -u, or up the image (+y),
    under a light leaning towards +x and +y: Whitted shows kd cos(angle between them), from the 8-bit texel's
    own vector; a wrong tangent or bitangent sign would show another value."""
    from PIL import Image

    from clrender.scene.scene import Scene

    theta, phi = math.radians(30), math.radians(20)
    n = np.array([tilt[0] * math.sin(theta), tilt[1] * math.sin(theta), math.cos(theta)])
    code = np.round((n + 1) / 2 * 255).astype(np.uint8)
    Image.fromarray(np.broadcast_to(code, (2, 2, 3)).copy()).save(tmp_path / "n.png")
    mapped = 2 * code.astype(float) / 255 - 1
    mapped /= np.linalg.norm(mapped)
    light = np.array([math.sin(phi), 0.5 * math.sin(phi), math.cos(phi)])  # towards the light
    light /= np.linalg.norm(light)
    scene = {
        "width": 8,
        "height": 8,
        "cameras": [{"position": [0, 0, 3], "look_at": [0, 0, 0], "fov": 20}],
        "textures": {"n": {"file": "n.png"}},
        "materials": {"m": {"base_color": [0.5, 0.5, 0.5], "normal_texture": "n"}},
        "lights": [{"type": "directional", "direction": (-light).tolist()}],
        "objects": [{"type": "quad", "corner": [-1, -1, 0], "edge_a": [2, 0, 0], "edge_b": [0, 2, 0], "material": "m"}],
    }
    image = clrender.Renderer(Scene.from_dict(scene, base_dir=tmp_path), aa="none").run().image
    np.testing.assert_allclose(image, 0.5 * max(float(mapped @ light), 0.0), rtol=1e-5)
    # the path tracer's glTF BRDF with the mapped normal = the same BRDF on a plain quad turned so that its geometric
    # normal is the mapped one (same camera rays, so the same wo, wi and normal at every sample)
    path = dict(integrator="path", spp=1, max_depth=0, seed=4)
    traced = clrender.Renderer(Scene.from_dict(scene, base_dir=tmp_path), **path).run().image
    a = np.cross([0.0, 1.0, 0.0], mapped)
    a *= 4 / np.linalg.norm(a)
    b = np.cross(mapped, a)  # a x b is along the mapped normal
    turned = {**scene, "materials": {"m": {"base_color": [0.5, 0.5, 0.5]}}}
    turned["objects"] = [{"type": "quad", "corner": (-(a + b) / 2).tolist(), "edge_a": a.tolist(), "edge_b": b.tolist(), "material": "m"}]
    expected = clrender.Renderer(Scene.from_dict(turned), **path).run().image
    assert expected.min() > 0.05
    np.testing.assert_allclose(traced, expected, rtol=1e-4)
    wrong = [-1, 1, 1] if tilt[0] else [1, -1, 1]  # the tangent (or bitangent) of the other sign
    assert abs((mapped * wrong) @ light - mapped @ light) > 0.05


def alpha_scene(tmp_path, alpha: dict, light):
    """A red quad at z = 1 over x, y in [-1, 1], its texture's alpha 0 on the half x < 0 and 1 on x > 0, over a
    white quad at z = 0 three times as wide; a nearly orthographic camera above sees x, y in [-1.5, 1.5]."""
    from PIL import Image

    from clrender.scene.scene import Scene

    texels = np.full((1, 2, 4), 255, np.uint8)
    texels[0, 0, 3] = 0
    Image.fromarray(texels, "RGBA").save(tmp_path / "a.png")
    scene = {
        "width": 30,
        "height": 30,
        "cameras": [{"position": [0, 0, 100], "look_at": [0, 0, 0], "fov": math.degrees(2 * math.atan(1.5 / 100))}],
        "textures": {"a": {"file": "a.png", "filter": "nearest", "wrap_s": "clamp_to_edge"}},
        "materials": {"front": {"diffuse": [1, 0, 0], "diffuse_texture": "a", "alpha": alpha}, "back": {"diffuse": [1, 1, 1]}},
        "lights": [{"type": "directional", "direction": light}],
        "objects": [
            {"type": "quad", "corner": [-1, -1, 1], "edge_a": [2, 0, 0], "edge_b": [0, 2, 0], "material": "front"},
            {"type": "quad", "corner": [-3, -3, 0], "edge_a": [6, 0, 0], "edge_b": [0, 6, 0], "material": "back"},
        ],
    }
    return Scene.from_dict(scene, base_dir=tmp_path)


def test_alpha_mask_is_seen_through_by_camera_and_shadow_rays(tmp_path):
    """Light at 45 degrees from +x: the opaque half (x in (0, 1)) is red and lit (cos 45); through the cut-out half
    the camera sees the white floor, shadowed there by the opaque half; past the red quad (x < -1) the floor's
    shadow rays pass through the cut-out half, so it is lit."""
    scene = alpha_scene(tmp_path, {"mode": "mask", "cutoff": 0.5}, [-1, 0, -1])
    image = clrender.Renderer(scene, integrator="path", spp=1, max_depth=0).run().image.astype(np.float64)
    x = ((np.arange(30) + 0.5) / 30 * 2 - 1) * 1.5
    c = math.sqrt(0.5)
    rows = slice(6, 24)  # y in (-0.9, 0.9): inside the red quad's rows
    for lo, hi, colour in ((0.05, 0.95, [c, 0, 0]), (-0.95, -0.05, [0, 0, 0]), (-1.45, -1.05, [c, c, c]), (1.05, 1.45, [c, c, c])):
        cols = (x > lo) & (x < hi)
        assert cols.any()
        np.testing.assert_allclose(image[rows][:, cols], np.broadcast_to(colour, image[rows][:, cols].shape), atol=2e-3)


def test_alpha_blend_is_stochastic_coverage(tmp_path):
    """alpha factor 0.5 times the texture's 1 on x > 0: half the paths see the red quad (lit: red), half the white
    floor, whose shadow ray passes it with probability 0.5: the mean is 0.5 (1, 0, 0) + 0.25 (1, 1, 1)."""
    scene = alpha_scene(tmp_path, {"mode": "blend", "factor": 0.5}, [0, 0, -1])
    image = clrender.Renderer(scene, integrator="path", spp=64, max_depth=0, seed=5).run().image.astype(np.float64)
    x = ((np.arange(30) + 0.5) / 30 * 2 - 1) * 1.5
    values = image[6:24][:, (x > 0.05) & (x < 0.95)].reshape(-1, 3)
    stderr = values.std(axis=0, ddof=1) / math.sqrt(len(values))
    assert (np.abs(values.mean(axis=0) - [0.75, 0.25, 0.25]) < 4 * stderr + 1e-3).all(), (values.mean(axis=0), stderr)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_occlusion_darkens_the_albedo_aov_and_the_ambient_term_only(tmp_path, integrator):
    """occlusionTexture R = 128 (linear 0.50196), strength 0.5: occlusion 1 + 0.5 (0.50196 - 1); the albedo AOV is
    base x occlusion; Whitted's ambient term is ambient x kd x occlusion, its light term untouched."""
    from clrender.scene.scene import Scene

    occlusion = 1 + 0.5 * (128 / 255 - 1)
    mat = material(baseColorFactor=[0.8, 0.6, 0.4, 1])
    mat["occlusionTexture"] = {"index": 0, "strength": 0.5}
    path = textured_quad(tmp_path, mat, [png_bytes(np.full((2, 2, 3), 128))])
    scene = Scene.load(str(path))
    scene.ambient = (0.1, 0.1, 0.1)
    kw = dict(integrator="path", spp=1, max_depth=0) if integrator == "path" else {}
    result = clrender.Renderer(scene, width=N, height=N, aovs=("albedo",), **kw).run()
    base = np.array([0.8, 0.6, 0.4])
    np.testing.assert_allclose(result.aovs["albedo"], np.broadcast_to(base * occlusion, (N, N, 3)), rtol=1e-6)
    if integrator == "whitted":  # the light shows kd (I cos = 1), the ambient 0.1 kd occlusion
        np.testing.assert_allclose(result.image, np.broadcast_to(base * (1 + 0.1 * occlusion), (N, N, 3)), rtol=1e-5)
