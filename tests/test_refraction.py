"""Snell's law and total internal reflection, as the tracing kernel applies them."""

import math

import numpy as np
import pyopencl as cl
import pytest

from clrender.trace.tracer import trace_defines


def refract(device, incidence_degrees, n1, n2):
    """Refract unit rays hitting the plane z=0 (normal +z) from above at the given angles."""
    theta = np.radians(np.asarray(incidence_degrees, np.float64))
    k = len(theta)
    d = np.zeros((k, 4), np.float32)
    d[:, 0], d[:, 2] = np.sin(theta), -np.cos(theta)
    normals = np.tile(np.float32([0, 0, 1, 0]), (k, 1))
    eta = np.full(k, n1 / n2, np.float32)
    out = device.empty(16 * k)
    knl = device.kernel("trace.cl", "refract_rays", trace_defines())
    knl(device.queue, (k,), None, n=k, d=device.to_device(d), normals=device.to_device(normals), eta=device.to_device(eta), out=out)
    result = np.empty((k, 4), np.float32)
    cl.enqueue_copy(device.queue, result, out)
    return result


@pytest.mark.parametrize("n1, n2", [(1.0, 1.5), (1.5, 1.0), (1.0, 1.333), (1.333, 1.5)])
def test_refracted_angle_obeys_snells_law(device, n1, n2):
    critical = math.degrees(math.asin(min(1.0, n2 / n1))) if n1 > n2 else 90.0
    angles = [a for a in (0.0, 10.0, 25.0, 40.0, 60.0, 80.0, 89.0) if a < critical - 0.5]
    out = refract(device, angles, n1, n2)
    assert (out[:, 3] == 1).all()
    t = out[:, :3].astype(np.float64)
    np.testing.assert_allclose(np.linalg.norm(t, axis=1), 1.0, atol=1e-6)
    # n1 sin(theta1) = n2 sin(theta2), the ray continues downwards, in the plane of incidence
    sin_t = np.hypot(t[:, 0], t[:, 1])
    np.testing.assert_allclose(n2 * sin_t, n1 * np.sin(np.radians(angles)), atol=2e-6)
    assert (t[:, 2] < 0).all()
    np.testing.assert_allclose(t[:, 1], 0.0, atol=1e-7)
    assert (t[:, 0] >= 0).all()


def test_total_internal_reflection_starts_at_the_critical_angle(device):
    n1, n2 = 1.5, 1.0
    critical = math.degrees(math.asin(n2 / n1))  # 41.81 degrees for glass to air
    out = refract(device, [critical - 0.05, critical - 0.01, critical + 0.01, critical + 0.05, 70.0], n1, n2)
    assert out[:, 3].tolist() == [1, 1, 0, 0, 0]
    # just below the critical angle the refracted ray grazes the surface
    assert abs(out[1, 2]) < 0.02


def test_no_total_internal_reflection_entering_a_denser_medium(device):
    out = refract(device, [89.9], 1.0, 1.5)
    assert out[0, 3] == 1
    critical_inside = math.degrees(math.asin(1 / 1.5))
    refracted = math.degrees(math.asin(math.hypot(out[0, 0], out[0, 1])))
    assert refracted == pytest.approx(critical_inside, abs=0.05)


def test_the_specular_power_matches_float64_within_float32_rounding_of_its_exponent(device):
    """(n.h)^s is computed inline as 2^(s log2 x); float32 rounds the exponent s log2 x, so the
    relative error grows with it: at most 2^-22 (1 + |s log2 x|) (two ulps of the exponent), as for any
    exp2/log2 pow."""
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.random(20000), np.logspace(-30, 0, 5000), 1 - np.logspace(-8, -1, 500), [1.0]])
    x = np.maximum(x, 1e-30).astype(np.float32)
    s = np.concatenate([rng.uniform(0.01, 2000, len(x) - 3), [1, 150, 0.5]]).astype(np.float32)
    n = len(x)
    out = device.empty(4 * n)
    knl = device.kernel("trace.cl", "specular_power", trace_defines())
    knl(device.queue, (n,), None, n=n, x=device.to_device(x), s=device.to_device(s), out=out)
    got = np.empty(n, np.float32)
    cl.enqueue_copy(device.queue, got, out)
    exponent = s.astype(np.float64) * np.log2(x.astype(np.float64))
    want = np.exp2(exponent)
    normal = want > 2.0**-125  # below that the kernel flushes to 0
    rel = np.abs(got[normal] - want[normal]) / want[normal]
    assert (rel <= 2.0**-22 * (1 + np.abs(exponent[normal]))).all()
    assert np.abs(got[~normal]).max() <= 2.0**-125
    assert got[-1] == 1.0  # 1^s is exactly 1
