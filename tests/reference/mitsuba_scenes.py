"""clrender scene dicts rendered by Mitsuba 3: the independent renderer the path tracer is tested and benchmarked against.

Imports nothing from clrender.  `to_mitsuba(scene, ...)` turns the scene dict clrender's path tracer reads (the
format of docs/scene-format.md plus issue 25's path-tracing keys) into the dict `mitsuba.load_dict` takes;
`render(scene, variant=..., spp=..., seed=...)` renders it to a linear float32 (H, W, 3) array.

What is mapped, and why each pair is the same function:
- camera `position`, `look_at`, `up`, `fov` (vertical, degrees) -> `perspective`, `fov_axis` "y", `look_at`: the
  same pinhole; row 0 at the top and right = forward x up in both (the tests check a silhouette against
  rays written out from docs/scene-format.md).
- a pixel's samples, averaged -> `independent` sampler (spp, seed), `hdrfilm` with a `box` rfilter, rgb: a box
  of radius 1/2 gives each uniformly placed sample to its own pixel only, so a pixel is the plain mean.
- `max_depth` (bounces after the primary hit) -> `path` with max_depth + 2, `hide_emitters` false: Mitsuba
  counts the camera segment and the segment to the light, so our 0 (direct light only) is its 2.
- `environment.color` -> a `constant` emitter of that radiance: every escaping direction, camera rays too.
- `environment.file` (an absolute path), `intensity`, `rotation` -> `envmap` of the same pixels with `scale` =
  intensity and `to_world` = rotate(+y, rotation): the same direction <-> (u, v) mapping and the same bilinear
  lookup between texels at u = (j + 0.5) / W and v = i / (H - 1) (docs/scene-format.md).
- material `emission` -> an `area` emitter on the shape, that radiance: one-sided in both, emitted on the side
  of the geometric normal (cross(v1 - v0, v2 - v0) for a triangle, outwards on a sphere).
- Phong `diffuse` kd alone -> `twosided(diffuse)` of reflectance kd: Lambert kd / pi; clrender's integrator
  turns the normal to the viewer's side of an opaque surface, so both faces reflect in both.
- glTF `base_color`, `metallic`, `roughness` -> `clrender_gltf`, the Python BSDF below: glTF 2.0 Appendix B
  written out, as kernels/bsdf.h does: GGX D with alpha = roughness^2, Smith's height-correlated G2,
  Schlick's F at |wo.h| with F0 = base colour (metal) and 0.04 (the dielectric layer), mixed by `metallic`.
- `transmission` 1 with `ior`, `roughness` 0 -> `dielectric` with int_ior = ior, ext_ior = 1: a smooth
  interface, exact unpolarised Fresnel in both, radiance scaled by 1/eta^2 on refraction in both; a
  `base_color` -> its `specular_transmittance` (KHR_materials_transmission tints the BTDF, not the reflection).
- sphere `center`, `radius` -> `sphere` (analytic in both); `quad` (corner, edge_a, edge_b), `triangle` and
  `mesh` (vertices, faces; normals: smooth) -> a Mitsuba `Mesh` of the same triangles, the same winding (a
  quad is [c, c+a, c+a+b], [c, c+a+b, c+b], as clrender builds it).

Why not Mitsuba's own plugins for the metal: `roughconductor` takes its Fresnel from a complex IOR (eta, k) and
`principled` with metallic 1 has the right Schlick F0 = base colour and alpha = roughness^2, but both use the
separable Smith term G1(wi) G1(wo), which is smaller than the height-correlated G2 = 1 / (1 + L(wi) + L(wo))
glTF and clrender's kernels/bsdf.h use (tests/trace/test_mitsuba_reference.py checks that our lobe is
`principled`'s times G2 / (G1 G1)).  `exact=False` uses `principled` anyway: native code, which the scalar
variant runs without calling Python per ray, and the same work as the exact lobe; the benchmark's choice, where
only speed is compared.

Seed Whitted materials (the bundled scenes, for `bench path`), by the rule documented in bench/path.py:
`diffuse` kd -> Lambert; `specular` ks with `shininess` s -> ks times a GGX conductor of reflectance 1
(`roughconductor`, material "none") with alpha = sqrt(2 / (s + 2)), added to the Lambert lobe (a `blendbsdf`
of weight w = max ks / (max kd + max ks) over Lambert(kd / (1 - w)) and conductor(ks / w) is their exact sum;
where max kd + max ks exceeds 1, which Whitted allows and Mitsuba's reflectances do not, both are scaled down
to sum to 1); `mirror` m -> (1 - m) surface + m smooth mirror;
`transparency` t with `ior` -> (1 - t) opaque part + t `dielectric`.

Lights (`[[lights]]`, docs/shading.md's units): with falloff "inverse_square" a point light's c*I is radiant
intensity (W/sr) -> `point` intensity, an area light's c*I is radiance -> a `rectangle` with an `area` emitter
facing edge_a x edge_b (clrender's area light emits from both faces; Mitsuba's rectangle from one).  Falloff
"none" has no physical counterpart (no 1/pi, no 1/r^2): it is given the physical light that makes a Lambert
surface as bright as clrender's Whitted render does at unit distance: directional irradiance pi c I, point
intensity pi c I, area radiance pi c I / area.  `ambient` is Whitted's and not drawn; `background`, in a scene
without `environment`, is the constant environment (docs/scene-format.md).
"""

from __future__ import annotations

import glob
import math
import os

import numpy as np

MITSUBA_DEPTH_OFFSET = 2  # Mitsuba's max_depth counts the camera segment and the segment to the light
GGX_ALPHA_MIN = 1e-4  # as clrender's kernels/bsdf.h: an exact mirror is a delta lobe, not a GGX one
GLTF_DIELECTRIC_F0 = 0.04  # glTF 2.0 Appendix B: ((1 - 1.5) / (1 + 1.5))^2
LLVM_GLOBS = ("/usr/lib/x86_64-linux-gnu/libLLVM.so.*", "/usr/lib/*/libLLVM*.so*", "/usr/lib/llvm-*/lib/libLLVM*.so*")
VARIANTS = ("llvm_ad_rgb", "scalar_rgb")


class MitsubaUnavailable(RuntimeError):
    """Mitsuba, or the variant asked for, cannot run here; the message says why (a test skips with it)."""


_registered: set = set()


def load_mitsuba(variant: str = "llvm_ad_rgb"):
    """The `mitsuba` module with `variant` set.  The LLVM variants need libLLVM: $DRJIT_LIBLLVM_PATH, else the
    first libLLVM.so.* found in the system's library folders (Debian's libllvm19 puts it in
    /usr/lib/x86_64-linux-gnu).  Raises MitsubaUnavailable naming what is missing."""
    if variant.startswith("llvm") and not os.environ.get("DRJIT_LIBLLVM_PATH"):
        found = sorted(p for pattern in LLVM_GLOBS for p in glob.glob(pattern) if ".so" in p)
        if found:
            os.environ["DRJIT_LIBLLVM_PATH"] = found[-1]
    try:
        import mitsuba as mi
    except ImportError as exc:
        raise MitsubaUnavailable(f"mitsuba is not installed ({exc}); pip install -e '.[reference]'") from None
    if variant not in mi.variants():
        raise MitsubaUnavailable(f"mitsuba {mi.__version__} has no variant {variant} (it has {', '.join(mi.variants())})")
    try:
        mi.set_variant(variant)
    except Exception as exc:  # drjit raises a plain Exception when libLLVM cannot be loaded
        raise MitsubaUnavailable(f"mitsuba variant {variant} does not start ({exc}); set DRJIT_LIBLLVM_PATH to a libLLVM.so") from None
    if variant not in _registered:
        mi.register_bsdf("clrender_gltf", lambda props: _gltf_class(mi)(props))
        _registered.add(variant)
    return mi


def unavailable(variant: str = "llvm_ad_rgb") -> str | None:
    """Why `variant` cannot run here, or None when it can (for pytest.skip)."""
    try:
        load_mitsuba(variant)
    except MitsubaUnavailable as exc:
        return str(exc)
    return None


# ---------------------------------------------------------------------- the glTF lobe as a Mitsuba BSDF
_gltf_classes: dict = {}


def _gltf_class(mi):
    """clrender's glTF metallic-roughness lobe (glTF 2.0 Appendix B) as a Python BSDF of the current variant.

    With V the viewer's direction, L the light's, h = unit(V + L) (all in the local frame, turned to the normal's
    side together: opaque surfaces reflect on both faces, as clrender's integrator makes them):
        specular   = D(h) G2(V, L) / (4 V.z L.z)            GGX, alpha = max(roughness^2, 1e-4)
        G2         = 1 / (1 + Lambda(V) + Lambda(L))         Smith, height-correlated (Heitz 2014)
        F_metal    = base + (1 - base) (1 - |V.h|)^5         Schlick, F0 = base colour
        F_dielec   = 0.04 + 0.96 (1 - |V.h|)^5
        f          = (1 - m) ((1 - F_dielec) base / pi + F_dielec specular) + m F_metal specular
    Sampling (its own choice, any unbiased one does): visible GGX normals with probability 1/2 + m/2, else the
    cosine-weighted hemisphere; pdf the mixture."""
    key = mi.variant()
    if key in _gltf_classes:
        return _gltf_classes[key]
    import drjit as dr

    def lam_r(w, alpha):  # sqrt(cos^2 + alpha^2 sin^2): Lambda(w) = (r / |cos| - 1) / 2
        return dr.sqrt(dr.square(w.z) + dr.square(alpha) * (dr.square(w.x) + dr.square(w.y)))

    class ClrenderGltf(mi.BSDF):
        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            base = props.get("base_color")  # an `rgb` dict arrives as a colour
            self.base = mi.Color3f(float(base[0]), float(base[1]), float(base[2]))
            self.metallic = float(props.get("metallic", 1.0))
            self.alpha = max(float(props.get("roughness", 0.5)) ** 2, GGX_ALPHA_MIN)
            self.p_specular = 0.5 + 0.5 * self.metallic
            sides = mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
            self.m_components = [mi.BSDFFlags.GlossyReflection | sides, mi.BSDFFlags.DiffuseReflection | sides]
            self.m_flags = self.m_components[0] | self.m_components[1]

        def _frame(self, si, wo):
            """V, L turned to the normal's side (both mirrored in the tangent plane when V is below it)."""
            flip = mi.Frame3f.cos_theta(si.wi) < 0
            s = dr.select(flip, -1.0, 1.0)
            return mi.Vector3f(si.wi.x, si.wi.y, si.wi.z * s), mi.Vector3f(wo.x, wo.y, wo.z * s)

        def _eval(self, si, v, l, active):
            active = active & (v.z > 0) & (l.z > 0)
            alpha = self.alpha
            h = dr.normalize(v + l)
            d = dr.square(alpha) / (dr.pi * dr.square(dr.square(alpha * h.z) + dr.square(h.x) + dr.square(h.y)))
            rv, rl = lam_r(v, alpha), lam_r(l, alpha)
            g2 = 2.0 * v.z * l.z / (rv * l.z + rl * v.z)  # 1 / (1 + Lambda(v) + Lambda(l)), no division by a cosine
            specular = d * g2 / (4.0 * v.z * l.z)
            s = dr.power(dr.clip(1.0 - dr.abs(dr.dot(v, h)), 0.0, 1.0), 5)
            base = self.base
            f_metal = base + (1.0 - base) * s
            f_dielectric = GLTF_DIELECTRIC_F0 + (1.0 - GLTF_DIELECTRIC_F0) * s
            m = self.metallic
            f = (1.0 - m) * ((1.0 - f_dielectric) * base * dr.inv_pi + f_dielectric * specular) + m * f_metal * specular
            return dr.select(active, f * l.z, 0.0)

        def _pdf(self, v, l, active):
            active = active & (v.z > 0) & (l.z > 0)
            h = dr.normalize(v + l)
            distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, self.alpha, True)
            spec = distr.pdf(v, h) / (4.0 * dr.abs(dr.dot(l, h)))
            p = self.p_specular
            return dr.select(active, p * spec + (1.0 - p) * l.z * dr.inv_pi, 0.0)

        def eval(self, ctx, si, wo, active=True):
            v, l = self._frame(si, wo)
            return self._eval(si, v, l, active)

        def pdf(self, ctx, si, wo, active=True):
            v, l = self._frame(si, wo)
            return self._pdf(v, l, active)

        def eval_pdf(self, ctx, si, wo, active=True):
            v, l = self._frame(si, wo)
            return self._eval(si, v, l, active), self._pdf(v, l, active)

        def sample(self, ctx, si, sample1, sample2, active=True):
            flip = mi.Frame3f.cos_theta(si.wi) < 0
            s = dr.select(flip, -1.0, 1.0)
            v = mi.Vector3f(si.wi.x, si.wi.y, si.wi.z * s)
            specular = sample1 < self.p_specular
            distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, self.alpha, True)
            m, _ = distr.sample(v, sample2)
            l_spec = mi.reflect(v, m)
            l_diff = mi.warp.square_to_cosine_hemisphere(sample2)
            l = dr.select(specular, l_spec, l_diff)
            value, pdf = self._eval(si, v, l, active), self._pdf(v, l, active)
            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = mi.Vector3f(l.x, l.y, l.z * s)
            bs.pdf = pdf
            bs.eta = 1.0
            bs.sampled_type = dr.select(specular, mi.UInt32(+mi.BSDFFlags.GlossyReflection), mi.UInt32(+mi.BSDFFlags.DiffuseReflection))
            bs.sampled_component = dr.select(specular, mi.UInt32(0), mi.UInt32(1))
            ok = active & (pdf > 0)
            return bs, dr.select(ok, value / dr.select(ok, pdf, 1.0), 0.0)

        def traverse(self, callback):
            pass

        def parameters_changed(self, keys):
            pass

        def to_string(self):
            return f"ClrenderGltf[metallic={self.metallic}, alpha={self.alpha}]"

    _gltf_classes[key] = ClrenderGltf
    return ClrenderGltf


# ---------------------------------------------------------------------- materials
def rgb(value) -> dict:
    return {"type": "rgb", "value": [float(x) for x in value]}


GLTF_KEYS = ("base_color", "metallic", "roughness")
GLASS_KEYS = ("transmission",)
PHONG_KEYS = ("diffuse", "specular", "shininess", "mirror", "transparency", "ior")


MITSUBA_WRAP = {"repeat": "repeat", "mirrored_repeat": "mirror", "clamp_to_edge": "clamp"}


def bitmap(spec: dict, *, srgb: bool, flip_v: bool = False) -> dict:
    """A scene `[textures]` entry as Mitsuba's `bitmap` texture: bilinear between texel centres (or nearest),
    the glTF wrap mode (Mitsuba has one mode for both axes), an 8-bit colour image sRGB-decoded (`raw` False)
    before filtering as clrender decodes it on loading.  UVs need no flip: Mitsuba's bitmap, like glTF, puts
    v = 0 at the image's first (top) row.  `flip_v` is the planted bug of the negative control."""
    wrap_s, wrap_t = spec.get("wrap_s", "repeat"), spec.get("wrap_t", "repeat")
    if wrap_s != wrap_t:
        raise NotImplementedError(f"wrap_s {wrap_s!r} != wrap_t {wrap_t!r}: Mitsuba's bitmap has one wrap mode")
    out = {
        "type": "bitmap",
        "filename": str(spec["file"]),
        "filter_type": "nearest" if spec.get("filter") == "nearest" else "bilinear",
        "wrap_mode": MITSUBA_WRAP[wrap_s],
        "raw": not srgb,
    }
    if flip_v:
        import mitsuba as mi

        out["to_uv"] = mi.ScalarTransform4f().translate([0, 1, 0]) @ mi.ScalarTransform4f().scale([1, -1, 1])
    return out


def bsdf(material: dict, exact: bool = True, textures: dict | None = None, planted: str = "") -> dict:
    """A Mitsuba BSDF dict for one clrender material (the table in the module docstring); `textures` is the
    scene's `[textures]` table, for `diffuse_texture` (kd must then be white: Mitsuba's bitmap has no scale)."""
    if material.get("type") in ("conductor", "coated_diffuse", "thin_dielectric"):
        return exchange_bsdf(material)
    if "diffuse_texture" in material:
        kd = material.get("diffuse", (1.0, 1.0, 1.0))
        rest = set(material) - {"diffuse", "diffuse_texture"}
        if any(float(c) != 1.0 for c in kd) or rest or not isinstance(material["diffuse_texture"], str):
            raise NotImplementedError("a diffuse_texture is mapped on a plain Lambert material of kd 1 only")
        spec = (textures or {})[material["diffuse_texture"]]
        tex = bitmap(spec, srgb=planted != "raw", flip_v=planted == "flip_v")
        return {"type": "twosided", "material": {"type": "diffuse", "reflectance": tex}}
    if material.get("transmission", 0.0) > 0:
        if material.get("transmission") != 1.0 or material.get("roughness", 0.0) != 0.0:
            raise NotImplementedError(
                "only smooth glass (transmission 1, roughness 0) is mapped: Mitsuba's roughdielectric uses the separable Smith G"
            )
        glass = {"type": "dielectric", "int_ior": float(material.get("ior", 1.5)), "ext_ior": 1.0}
        if "base_color" in material:  # KHR_materials_transmission: the BTDF times base colour, reflection white
            glass["specular_transmittance"] = rgb(material["base_color"])
        return glass
    if any(k in material for k in GLTF_KEYS):
        base = material.get("base_color", (1.0, 1.0, 1.0))
        metallic, roughness = float(material.get("metallic", 1.0)), float(material.get("roughness", 1.0))
        if exact:
            return {"type": "clrender_gltf", "base_color": rgb(base), "metallic": metallic, "roughness": roughness}
        principled = {"type": "principled", "base_color": rgb(base), "metallic": metallic, "roughness": roughness}
        return {"type": "twosided", "material": principled}
    return phong_bsdf(material)


def exchange_bsdf(material: dict) -> dict:
    """A `type = ...` material (docs/materials.md) as the Mitsuba plugin it follows: roughness^2 is Mitsuba's alpha;
    `smith` must be "separable" for a rough one (Mitsuba's only term)."""
    kind, r = material["type"], float(material.get("roughness", 0.0))
    if r > 0 and material.get("smith", "correlated") != "separable":
        raise NotImplementedError("Mitsuba's rough plugins use the separable Smith G: give smith = 'separable'")
    tint = rgb(material.get("tint", (1.0, 1.0, 1.0)))
    if kind == "conductor":
        out = {"eta": rgb(material.get("eta", (0.0, 0.0, 0.0))), "k": rgb(material.get("k", (1.0, 1.0, 1.0))), "specular_reflectance": tint}
        out.update({"type": "roughconductor", "distribution": "ggx", "alpha": r * r} if r > 0 else {"type": "conductor"})
        return out
    ior = float(material.get("ior", 1.5))
    if kind == "thin_dielectric":
        return {
            "type": "thindielectric",
            "int_ior": ior,
            "ext_ior": 1.0,
            "specular_reflectance": tint,
            "specular_transmittance": rgb(material.get("transmittance", (1.0, 1.0, 1.0))),
        }
    out = {"int_ior": ior, "ext_ior": 1.0, "diffuse_reflectance": rgb(material.get("diffuse", (0.5, 0.5, 0.5))), "specular_reflectance": tint}
    out["nonlinear"] = bool(material.get("nonlinear", False))
    out.update({"type": "roughplastic", "distribution": "ggx", "alpha": r * r} if r > 0 else {"type": "plastic"})
    return out


def phong_bsdf(material: dict) -> dict:
    """A Phong material by the documented rule: Lambert kd + ks GGX conductor (alpha from shininess),
    mirror, transparency."""
    kd = np.asarray(material.get("diffuse", (0.8, 0.8, 0.8)), float)
    ks = np.asarray(material.get("specular", (0.0, 0.0, 0.0)), float)
    shininess = float(material.get("shininess", 32.0))
    mirror, transparency = float(material.get("mirror", 0.0)), float(material.get("transparency", 0.0))
    surface = {"type": "diffuse", "reflectance": rgb(kd)}
    if ks.max() > 0:
        alpha = math.sqrt(2.0 / (shininess + 2.0))  # Walter et al. 2007: Blinn-Phong exponent s ~ Beckmann/GGX width
        total = kd.max() + ks.max()
        if total > 1:  # Whitted's kd + ks need not conserve energy; Mitsuba's reflectances must lie in [0, 1]
            kd, ks = kd / total, ks / total
            total = 1.0
        w = ks.max() / total  # the blend (1 - w) Lambert(kd / (1 - w)) + w conductor(ks / w) is their sum, each in [0, 1]
        glossy = {"type": "roughconductor", "material": "none", "distribution": "ggx", "alpha": alpha, "specular_reflectance": rgb(ks / w)}
        lambert = {"type": "diffuse", "reflectance": rgb(kd / (1 - w))} if w < 1 else glossy
        surface = {"type": "blendbsdf", "weight": w, "bsdf_0": lambert, "bsdf_1": glossy}
    if mirror > 0:
        surface = {"type": "blendbsdf", "weight": mirror, "bsdf_0": surface, "bsdf_1": {"type": "conductor", "material": "none"}}
    opaque = {"type": "twosided", "material": surface}
    if transparency > 0:
        glass = {"type": "dielectric", "int_ior": float(material.get("ior", 1.0)), "ext_ior": 1.0}
        return {"type": "blendbsdf", "weight": transparency, "bsdf_0": opaque, "bsdf_1": glass}
    return opaque


# ---------------------------------------------------------------------- lights
def light_emitter(light: dict) -> dict:
    """A `[[lights]]` entry as a Mitsuba emitter (units in the module docstring)."""
    kind = light.get("type", "point")
    c = np.asarray(light.get("color", (1.0, 1.0, 1.0)), float) * float(light.get("intensity", 1.0))
    physical = light.get("falloff", "none") == "inverse_square"
    if kind == "directional":
        return {"type": "directional", "direction": list(map(float, light["direction"])), "irradiance": rgb(c * (1.0 if physical else math.pi))}
    if kind == "point":
        return {"type": "point", "position": list(map(float, light["position"])), "intensity": rgb(c * (1.0 if physical else math.pi))}
    if kind == "spot":  # Mitsuba's profile only (pbrt's smoothstep is not Mitsuba's)
        if light.get("profile", "mitsuba") != "mitsuba":
            raise NotImplementedError("Mitsuba's spot has its own falloff only: profile = 'mitsuba'")
        import mitsuba as mi

        p, d = np.asarray(light["position"], float), np.asarray(light["direction"], float)
        up = [0.0, 1.0, 0.0] if abs(d[1]) < 0.9 * np.linalg.norm(d) else [1.0, 0.0, 0.0]
        cutoff = float(light.get("cutoff_angle", 20.0))
        return {
            "type": "spot",
            "to_world": mi.ScalarTransform4f().look_at(origin=p.tolist(), target=(p + d).tolist(), up=up),
            "intensity": rgb(c),
            "cutoff_angle": cutoff,
            "beam_width": float(light.get("beam_width", 0.75 * cutoff)),
        }
    corner, a, b = (np.asarray(light[k], float) for k in ("corner", "edge_a", "edge_b"))
    normal = np.cross(a, b)
    area = float(np.linalg.norm(normal))
    radiance = c if physical else c * math.pi / area
    return {"type": "rectangle", "to_world": _parallelogram_matrix(corner, a, b), "emitter": {"type": "area", "radiance": rgb(radiance)}}


def _parallelogram_matrix(corner, a, b):
    """The affine map of Mitsuba's rectangle [-1, 1]^2 x {0} (normal +z) onto corner + s a + t b (normal a x b)."""
    import mitsuba as mi

    n = np.cross(a, b)
    n /= np.linalg.norm(n)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = a / 2, b / 2, n, corner + (a + b) / 2
    return mi.ScalarTransform4f(m.tolist())


# ---------------------------------------------------------------------- shapes
def _mesh(mi, name: str, vertices, faces, normals, bsdf_dict: dict, emission, uvs=None):
    """A Mitsuba Mesh of these triangles (and texture coordinates), its BSDF and (when `emission`) an area emitter."""
    vertices = np.ascontiguousarray(vertices, np.float32).reshape(-1, 3)
    faces = np.ascontiguousarray(faces, np.uint32).reshape(-1, 3)
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf_dict)
    if emission is not None:
        props["emitter"] = mi.load_dict({"type": "area", "radiance": rgb(emission)})
    mesh = mi.Mesh(name, len(vertices), len(faces), props=props, has_vertex_normals=normals is not None, has_vertex_texcoords=uvs is not None)
    params = mi.traverse(mesh)
    params["vertex_positions"] = type(params["vertex_positions"])(vertices.ravel())
    params["faces"] = type(params["faces"])(faces.ravel())
    if normals is not None:
        normals = np.ascontiguousarray(normals, np.float32).reshape(-1, 3)
        params["vertex_normals"] = type(params["vertex_normals"])(normals.ravel())
    if uvs is not None:
        params["vertex_texcoords"] = type(params["vertex_texcoords"])(np.ascontiguousarray(uvs, np.float32).ravel())
    params.update()
    return mesh


QUAD_UVS = np.array([[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]])  # the image upright: u along edge_a, v down edge_b


def _triangles(obj: dict):
    """(vertices, faces, normals or None, uvs or None) of a quad, triangle or mesh object, as clrender builds them
    (docs/materials.md: a quad lays its image upright, glTF UVs with (0, 0) at the image's top-left)."""
    kind = obj["type"]
    if kind == "quad":
        c, a, b = (np.asarray(obj[k], float) for k in ("corner", "edge_a", "edge_b"))
        return np.array([c, c + a, c + a + b, c + b]), np.array([[0, 1, 2], [0, 2, 3]]), None, QUAD_UVS
    if kind == "triangle":
        return np.asarray(obj["vertices"], float), np.array([[0, 1, 2]]), None, None
    if kind == "mesh" and "vertices" in obj:
        return np.asarray(obj["vertices"], float), np.asarray(obj["faces"]), obj.get("normals"), obj.get("uvs")
    raise NotImplementedError(f"object type {kind!r} (keys {sorted(obj)}) is not mapped to Mitsuba; give meshes as vertices + faces")


def to_mitsuba(
    scene: dict,
    *,
    spp: int,
    seed: int = 0,
    max_depth: int = 8,
    camera: int = 1,
    width=None,
    height=None,
    exact=True,
    planted: str = "",
    rr_depth: int | None = None,
) -> dict:
    """The mitsuba.load_dict dict of a clrender scene dict, for the variant already set (load_mitsuba).  `planted`
    ("raw": textures not sRGB-decoded, "flip_v": v flipped) is a known mistake, for the tests' negative controls.
    `rr_depth`: clrender's RenderSettings.rr_depth, given to Mitsuba as its rr_depth (+ 1); None: Mitsuba's own (5)."""
    import mitsuba as mi

    width = int(width or scene.get("width", 640))
    height = int(height or scene.get("height", 480))
    cam = scene.get("cameras", [{}])[camera - 1]
    to_world = mi.ScalarTransform4f().look_at(
        origin=list(map(float, cam.get("position", (0, 0, 0)))),
        target=list(map(float, cam.get("look_at", (0, 0, -1)))),
        up=list(map(float, cam.get("up", (0, 1, 0)))),
    )
    out = {
        "type": "scene",
        "integrator": {
            "type": "path",
            "max_depth": int(max_depth) + MITSUBA_DEPTH_OFFSET,
            "hide_emitters": False,
            **({} if rr_depth is None else {"rr_depth": int(rr_depth) + 1}),  # Mitsuba's depth is 1 at the primary hit
        },
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": float(cam.get("fov", 60.0)),
            "to_world": to_world,
            "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent", "sample_count": int(spp), "seed": int(seed)},
        },
    }
    env = scene.get("environment")
    if env is None and any(scene.get("background", (0, 0, 0))):  # docs/scene-format.md: then background is the environment
        env = {"color": scene["background"]}
    if env is not None and "file" in env:
        out["environment"] = {
            "type": "envmap",
            "bitmap": mi.Bitmap(read_image(env["file"])),
            "scale": float(env.get("intensity", 1.0)),
            "to_world": mi.ScalarTransform4f().rotate([0, 1, 0], float(env.get("rotation", 0.0))),
        }
    elif env is not None:
        out["environment"] = {"type": "constant", "radiance": rgb(env.get("color", (1.0, 1.0, 1.0)))}
    for i, light in enumerate(scene.get("lights", [])):
        out[f"light_{i}"] = light_emitter(light)
    materials = scene.get("materials", {})
    for i, obj in enumerate(scene.get("objects", [])):
        material = materials.get(obj.get("material", "default"), {})
        bsdf_dict = bsdf(material, exact, scene.get("textures", {}), planted)
        emission = material.get("emission")
        if emission is not None and max(emission) <= 0:
            emission = None
        if obj["type"] == "sphere":
            shape = {"type": "sphere", "center": list(map(float, obj["center"])), "radius": float(obj["radius"]), "bsdf": bsdf_dict}
            if emission is not None:
                shape["emitter"] = {"type": "area", "radiance": rgb(emission)}
            out[f"object_{i}"] = shape
        else:
            vertices, faces, normals, uvs = _triangles(obj)
            out[f"object_{i}"] = _mesh(mi, f"object_{i}", vertices, faces, normals, bsdf_dict, emission, uvs)
    return out


def read_image(path) -> np.ndarray:
    """(H, W, 3) float32 linear RGB of an image file, by OpenImageIO (grey copied to RGB, alpha dropped)."""
    import OpenImageIO as oiio

    pixels = np.asarray(oiio.ImageBuf(str(path)).get_pixels(oiio.FLOAT), np.float32)
    return np.repeat(pixels, 3, axis=2) if pixels.shape[2] == 1 else pixels[..., :3]


def load(scene: dict, *, variant: str = "llvm_ad_rgb", **settings):
    """(mitsuba module, loaded mitsuba Scene) of a clrender scene dict; `settings`: to_mitsuba's keywords."""
    mi = load_mitsuba(variant)
    return mi, mi.load_dict(to_mitsuba(scene, **settings))


def render_loaded(mi, mi_scene, *, spp: int, seed: int = 0) -> np.ndarray:
    """One render of a loaded scene: linear float32 (H, W, 3)."""
    return np.array(mi.render(mi_scene, spp=int(spp), seed=int(seed)), dtype=np.float32)[..., :3]


def render(
    scene: dict, *, variant: str = "llvm_ad_rgb", spp: int, seed: int = 0, max_depth: int = 8, camera: int = 1, width=None, height=None, exact=True
):
    """A clrender scene dict rendered by Mitsuba: linear float32 (H, W, 3)."""
    mi, mi_scene = load(scene, variant=variant, spp=spp, seed=seed, max_depth=max_depth, camera=camera, width=width, height=height, exact=exact)
    return render_loaded(mi, mi_scene, spp=spp, seed=seed)
