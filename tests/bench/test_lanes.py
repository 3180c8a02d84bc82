"""bench lanes' probe (kernels/lanes_probe.cl): the same shading at 1, 8 and 16 pixels a work-item, lanes refilled or
not, gives the same bits, and what it computes is the estimator it states, against a float64 numpy reference."""

import numpy as np
import pytest

from bench import lanes

PIXELS, SPP, DEPTH = 1024, 2, 6


@pytest.fixture(scope="module")
def radiance_by_variant(device):
    variants = [(w, refill) for w in lanes.WIDTHS for refill in (False, True)]
    return {v: lanes.run(device, v[0], v[1], PIXELS, SPP, DEPTH, runs=1)[0] for v in variants}


def test_every_lane_width_refilled_or_not_gives_the_same_bits(radiance_by_variant):
    one = radiance_by_variant[1, False].view(np.uint32)
    for variant, image in radiance_by_variant.items():
        assert np.array_equal(image.view(np.uint32), one), variant


# ---- the reference: integers as numpy uint32 (wrapping as OpenCL's uint), floats in float64
M = np.uint32(0xFFFFFFFF)


def mix32(x):
    x = x ^ (x >> np.uint32(16))
    x = x * np.uint32(0x7FEB352D)
    x = x ^ (x >> np.uint32(15))
    x = x * np.uint32(0x846CA68B)
    return x ^ (x >> np.uint32(16))


def reverse(x):
    bits = (x[..., None] >> np.arange(32, dtype=np.uint32)) & np.uint32(1)
    return (bits << np.arange(31, -1, -1, dtype=np.uint32)).sum(-1, dtype=np.uint64).astype(np.uint32)


def laine_karras(x, seed):
    x = x + seed
    for c in (0x6C50B47C, 0xB82F1E52, 0xC7AFE638, 0x8D22F6E6):
        x = x ^ (x * np.uint32(c))
    return x


def superset_xor(x):  # bit j of the result: the xor of the bits k of x with k a superset of j
    out = np.zeros_like(x)
    for j in range(32):
        supersets = np.uint32(sum(1 << k for k in range(32) if k & j == j))
        parity = np.array([bin(int(v)).count("1") & 1 for v in (x & supersets)], np.uint32)
        out |= parity << np.uint32(j)
    return out


def u01(h):
    return (h >> np.uint32(8)).astype(np.float64) / 2.0**24


def sobol2(key, index_reversed, pair):
    k = mix32(key ^ np.uint32(pair + 0x27D4EB2F))
    i = reverse(laine_karras(index_reversed, k))
    x = u01(reverse(laine_karras(i, mix32(k ^ np.uint32(0x3C6EF372)))))
    y = u01(reverse(laine_karras(superset_xor(i), mix32(k ^ np.uint32(0x68BC21EB)))))
    return x, y


def unit(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


def dot(a, b):
    return (a * b).sum(-1)


def ggx_g1(w, alpha):
    return 2 * w[:, 2] / (w[:, 2] + np.sqrt(alpha**2 * (w[:, 0] ** 2 + w[:, 1] ** 2) + w[:, 2] ** 2))


def schlick(f0, wo, h):
    return f0 + ((1 - np.maximum(0, dot(wo, h))) ** 5)[:, None] * (1 - f0)


def ggx_visible_normal(wo, alpha, u0, u1):  # Heitz 2018
    vh = unit(np.stack([alpha * wo[:, 0], alpha * wo[:, 1], wo[:, 2]], -1))
    len2 = vh[:, 0] ** 2 + vh[:, 1] ** 2
    inv = np.where(len2 > 0, 1 / np.sqrt(np.where(len2 > 0, len2, 1)), 0)
    t1 = np.stack([np.where(len2 > 0, -vh[:, 1] * inv, 1), np.where(len2 > 0, vh[:, 0] * inv, 0), np.zeros_like(len2)], -1)
    t2 = np.cross(vh, t1)
    r, phi = np.sqrt(u0), 2 * np.pi * u1
    p1, p2, h = r * np.cos(phi), r * np.sin(phi), 0.5 * (1 + vh[:, 2])
    p2 = (1 - h) * np.sqrt(np.maximum(0, 1 - p1**2)) + h * p2
    nh = p1[:, None] * t1 + p2[:, None] * t2 + np.sqrt(np.maximum(0, 1 - p1**2 - p2**2))[:, None] * vh
    return unit(np.stack([alpha * nh[:, 0], alpha * nh[:, 1], np.maximum(0, nh[:, 2])], -1))


def reference(seed=1):
    """Each pixel's radiance summed over its samples: the estimator bench/lanes.py's docstring states, in float64."""
    tris, mats, (e0, e1), area = lanes.room()
    prim, uv = lanes.hits(PIXELS, DEPTH, len(tris) - 2, seed)
    v, mats = tris.reshape(-1, 3, 3).astype(np.float64), mats.astype(np.float64)
    pixel = np.arange(PIXELS, dtype=np.uint32)
    key = mix32(mix32(mix32(np.full(PIXELS, seed + 0x9E3779B9, np.uint32)) ^ (pixel + np.uint32(0x85EBCA6B))) ^ np.uint32(0x5EB01 + 0xC2B2AE35))
    total = np.zeros((PIXELS, 3))
    for sample in range(SPP):
        index = reverse(np.full(PIXELS, sample, np.uint32))
        c0, c1 = sobol2(key, index, 0)
        z = 1 - 2 * c0
        r = np.sqrt(np.maximum(0, 1 - z * z))
        d = np.stack([r * np.cos(2 * np.pi * c1), r * np.sin(2 * np.pi * c1), z], -1)
        beta, radiance, live = np.ones((PIXELS, 3)), np.zeros((PIXELS, 3)), np.ones(PIXELS, bool)
        for vertex in range(DEPTH):
            t, m = v[prim[vertex]], mats[prim[vertex]]
            p = t[:, 0] + uv[0, vertex, :, None] * (t[:, 1] - t[:, 0]) + uv[1, vertex, :, None] * (t[:, 2] - t[:, 0])
            ng = unit(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]))
            ng = np.where((dot(ng, d) > 0)[:, None], -ng, ng)
            a, metal, alpha = m[:, :3], m[:, 6] != 0, m[:, 7]
            radiance += live[:, None] * beta * m[:, 3:6]
            (ul0, ul1), (ub0, ub1), (urr, _) = (sobol2(key, index, 4 * vertex + k) for k in (1, 2, 3))
            # NEE: a uniform point of one of the two emitting triangles
            first = ul0 < 0.5
            e = np.where(first, e0, e1)
            su, w = np.sqrt(np.where(first, 2 * ul0, 2 * ul0 - 1)), v[e]
            y = (1 - su)[:, None] * w[:, 0] + (su * (1 - ul1))[:, None] * w[:, 1] + (su * ul1)[:, None] * w[:, 2]
            dist = np.linalg.norm(y - p, axis=-1)
            wi = (y - p) / dist[:, None]
            light_pdf = 0.5 * dist**2 / (area * -dot(unit(np.cross(w[:, 1] - w[:, 0], w[:, 2] - w[:, 0])), wi))
            # the shading frame (Duff et al.), local directions
            sign = np.where(ng[:, 2] >= 0, 1.0, -1.0)
            h = -1 / (sign + ng[:, 2])
            tx = np.stack([1 + sign * ng[:, 0] ** 2 * h, sign * ng[:, 0] * ng[:, 1] * h, -sign * ng[:, 0]], -1)
            bx = np.stack([ng[:, 0] * ng[:, 1] * h, sign + ng[:, 1] ** 2 * h, -ng[:, 1]], -1)
            frame = np.stack([tx, bx, ng], 1)
            wo, wl = np.einsum("nij,nj->ni", frame, -d), np.einsum("nij,nj->ni", frame, wi)
            # the lobes: f cos and density towards the light; the sample and its weight
            cos_i = np.maximum(wl[:, 2], 0)
            hl = unit(wo + wl)
            d_h = alpha**2 / (np.pi * (hl[:, 2] ** 2 * (alpha**2 - 1) + 1) ** 2)
            above = wl[:, 2] > 0
            f_metal = (d_h * ggx_g1(wo, alpha) * ggx_g1(wl, alpha) / (4 * wo[:, 2]))[:, None] * schlick(a, wo, hl)
            f = np.where(metal[:, None], np.where(above[:, None], f_metal, 0), a * cos_i[:, None] / np.pi)
            lobe_pdf = np.where(metal, np.where(above, ggx_g1(wo, alpha) * d_h / (4 * wo[:, 2]), 0), cos_i / np.pi)
            lit = live & (light_pdf > 0) & np.isfinite(light_pdf) & (wo[:, 2] > 0)
            weight_l = light_pdf / (light_pdf**2 + lobe_pdf**2)
            radiance += np.where(lit[:, None], beta * weight_l[:, None] * f * mats[e, 3:6], 0)
            rr, phi = np.sqrt(ub0), 2 * np.pi * ub1
            cosine = np.stack([rr * np.cos(phi), rr * np.sin(phi), np.sqrt(np.maximum(0, 1 - ub0))], -1)
            hm = ggx_visible_normal(wo, alpha, ub0, ub1)
            ws = 2 * dot(wo, hm)[:, None] * hm - wo
            weight_m = np.where((ws[:, 2] > 0)[:, None], ggx_g1(ws, alpha)[:, None] * schlick(a, wo, hm), 0)
            wn = np.where(metal[:, None], ws, cosine)
            beta = np.where(live[:, None], beta * np.where(metal[:, None], weight_m, a), beta)
            d = np.where(live[:, None], wn[:, :1] * tx + wn[:, 1:2] * bx + wn[:, 2:] * ng, d)
            q = np.minimum(beta.max(-1), 0.95)
            late = vertex >= 2
            ended = live & ((late & (urr >= q)) | (vertex == DEPTH - 1) | (wo[:, 2] <= 0) | (beta.max(-1) <= 0))
            if late:
                beta = beta / np.where(q > 0, q, 1)[:, None]  # q is 0 only where the path ended
            total += np.where(ended[:, None], radiance, 0)
            live &= ~ended
    return total.T


def test_the_probe_computes_the_estimator_it_states(radiance_by_variant):
    got, want = radiance_by_variant[16, True].astype(np.float64), reference()
    close = np.isclose(got, want, rtol=1e-3, atol=1e-5).all(0)
    # a roulette draw within float32 rounding of its threshold may end a path in one and not the other
    assert close.mean() > 0.98, close.mean()
    assert want.sum(0).astype(bool).mean() > 0.5  # most pixels gather light: the comparison is not of zeros
