"""The path tracer's MIS between NEE and BSDF sampling for a physical parallelogram area light (kernels/path.cl
light_sample and area_lights_on_ray): a BSDF-sampled ray that meets the light weights itself against the light's
area pdf converted to solid angle, dist^2 / (A cos).  Both weights must use the same pdfs to sum to 1; with dist in
place of dist^2 they do not, and the floor's radiance is biased.  Reference: Lambert's exact irradiance of a
polygon (tests/trace/test_area_light.py's lambert_irradiance, numpy), averaged over each pixel's area (the box
filter) on a 4 x 4 grid; the floor (kd = 1) shows E / pi.  One bounce (max_depth 1) lets BSDF rays from the
floor reach the light; the floor sees nothing else (the light is not geometry, the sky is black)."""

import numpy as np
import pytest

from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests.arealighttools import FLOOR, LIGHT, SCENE, SIZE, SUB, floor_points, light_seen
from tests.reference import pathtracer
from tests.reference.polygon_light import lambert_irradiance


def test_bsdf_rays_meeting_an_area_light_are_weighted_by_the_solid_angle_pdf():
    scene = Scene.from_dict(SCENE)
    image = Renderer(scene, integrator="path", spp=64, max_depth=1, seed=5).run().image[..., 0].astype(np.float64)
    fine = floor_points(SUB)
    reference = (lambert_irradiance(fine, LIGHT) / np.pi).reshape(SIZE, SUB, SIZE, SUB).mean(axis=(1, 3))
    clear = ~light_seen(fine).reshape(SIZE, SUB, SIZE, SUB).any(axis=(1, 3))  # pixels that never see the light itself
    assert clear.all() and reference.min() > 0.1
    ratio = image[clear].sum() / reference[clear].sum()
    assert abs(ratio - 1) < 0.02, ratio  # 1.0009 measured; dist for dist^2: 1.487


# Against the float64 path tracer (tests/reference/pathtracer.py), which has no parallelogram lights: the light is an
# emissive quad there, facing down (edge_a x edge_b = -y) with the light's radiance, black, above the camera (no
# camera ray meets it; clrender's light is two-sided, but only its underside is seen from the floor).  Three of
# clrender's estimators of one image: MIS (the default kernel), NEE alone (-DAREA_BSDF=0: BSDF rays that meet the
# light count nothing after a non-delta vertex) and BSDF rays alone (-DAREA_NEE=0), each against the reference's MIS.
# The image totals' difference over its standard error (K seeds of clrender, the reference's per-pixel errors) is a
# t with K - 1 = 7 degrees of freedom: |t| > Z_MAX has probability 2e-3 when both are right.  dist for dist^2
# shifts only the MIS total, by 49 %.
K, SPP, Z_MAX = 8, 16, 4.8
STRATEGIES = {"mis": {}, "nee": {"AREA_BSDF": 0}, "bsdf": {"AREA_NEE": 0}}


def reference_total():
    quad = {"type": "quad", "corner": LIGHT["corner"], "edge_a": LIGHT["edge_a"], "edge_b": LIGHT["edge_b"], "material": "lamp"}
    lamp = {"diffuse": [0, 0, 0], "emission": [LIGHT["intensity"]] * 3}
    materials = {"white": {"diffuse": [1, 1, 1]}, "lamp": lamp}  # Lambert: specular 0 is clrender's spelling of none
    scene = {**SCENE, "lights": [], "materials": materials, "objects": [FLOOR, quad]}
    ref = pathtracer.render(scene, spp=256, max_depth=1, seed=3)
    return ref.image[..., 0].sum(), np.sqrt((ref.stderr[..., 0] ** 2).sum())


@pytest.mark.parametrize("strategy", list(STRATEGIES))
def test_an_area_light_by_mis_nee_alone_and_bsdf_rays_alone_is_the_float64_reference(device, strategy):
    scene = Scene.from_dict(SCENE)
    totals = []
    for seed in range(K):
        r = Renderer(scene, tracer=Tracer(scene, device=device), integrator="path", spp=SPP, max_depth=1, seed=seed)
        if STRATEGIES[strategy]:
            r.kernel = r.tracer.device.kernel("path.cl", "render_path", {**r.tracer.defines, "WRITE_AOV": 0, **STRATEGIES[strategy]})
        totals.append(r.run().image[..., 0].astype(np.float64).sum())
    ref, ref_se = reference_total()
    se = np.sqrt(np.var(totals, ddof=1) / K + ref_se**2)
    assert abs(np.mean(totals) - ref) < Z_MAX * se, (strategy, np.mean(totals), ref, se)
    assert se < 0.01 * ref  # the test can see a 5 % bias
