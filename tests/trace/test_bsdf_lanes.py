"""The lobes in lanes: kernels/bsdf.h built for 8 and 16 items a work-item (one in each lane of a vector, masks for the
branches, a masked pass per lobe present) gives the same bits as built for one, the width the path tracer runs, for
every lobe's eval, pdf and sample and for the shading frame, on batches that mix every lobe, both masking terms,
both sides of the surface and the degenerate inputs the scalar code returns early on."""

import numpy as np
import pytest

from clrender.layout import BSDF_LOBES
from clrender.trace import bsdf

N = 3001  # not a multiple of 16: the last work-item's spare lanes are not stored
WIDTHS = (8, 16)


def unit_rows(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.fixture(scope="module")
def inputs():
    """Records of every lobe, mixed item by item, and directions and samples with the edge cases in them."""
    rng = np.random.default_rng(35)
    table_at = bsdf.BSDF_PROBE_DTYPE.fields["coat_transmittance"][1] // 4
    table = bsdf.coated_params(roughness=0.4).reshape(-1)[table_at : table_at + 64]  # a rough coat's, as scenes pack it
    records = bsdf.params(
        colour=rng.uniform(0, 1, (N, 3)),
        alpha=rng.choice([1e-4, 0.01, 0.2, 0.7, 1.0], N),
        eta=rng.choice([1.0, 1.33, 1.5, 0.6], N),  # 1: the rough dielectric's delta pass-through
        metallic=rng.uniform(0, 1, N),
        smith=rng.integers(0, 2, N),
        eta3=rng.uniform(0.1, 3, (N, 3)),
        k3=rng.uniform(0, 5, (N, 3)),
        tint=rng.uniform(0, 1, (N, 3)),
        transmit_tint=rng.uniform(0, 1, (N, 3)),
        nonlinear=rng.integers(0, 2, N),
        coat_weight=rng.uniform(0, 1, N),
        coat_internal=rng.uniform(0, 0.9, N),
        coat_transmittance=table,
        specular_prob=rng.uniform(0, 1, N),
        lobe=rng.choice(sorted(BSDF_LOBES.values()), N),
    )
    wo, wi = unit_rows(rng, N), unit_rows(rng, N)
    wo[:40, 2] = 0.0  # grazing: the lobes' early returns
    wi[40:80] = wo[40:80] * [-1, -1, 1]  # mirror pairs
    wi[80:120] = -wo[80:120]  # straight through
    u = rng.uniform(0, 1, (N, 3))
    u[120:160, 0] = 0.0
    return records, wo.astype(np.float32), wi.astype(np.float32), u.astype(np.float32)


def bits(a):
    return np.ascontiguousarray(a).view(np.uint8)


def outputs(probe, inputs):
    records, wo, wi, u = inputs
    return {
        "eval": probe.eval(None, records, wo, wi),
        "pdf": probe.pdf(None, records, wo, wi),
        **dict(zip(("wi", "weight", "sample pdf", "delta"), probe.sample(None, records, wo, u))),
        **dict(zip(("frame", "local", "world"), probe.frame(wo, wi))),
    }


@pytest.fixture(scope="module")
def width_one(device, inputs):
    return outputs(bsdf.BsdfProbe(device), inputs)


@pytest.mark.parametrize("lanes", WIDTHS)
def test_every_lobe_in_lanes_gives_the_scalar_bits(device, inputs, width_one, lanes):
    got = outputs(bsdf.BsdfProbe(device, lanes=lanes), inputs)
    for name, want in width_one.items():
        assert np.array_equal(bits(got[name]), bits(want)), name


def test_the_batch_exercises_every_lobe_and_both_outcomes(inputs, width_one):
    """Every lobe is in the batch, and the samples include failures (pdf 0), delta branches and kept ones."""
    records = inputs[0]
    lobes = set(records[:, bsdf.LOBE_FIELD].astype(int))
    assert lobes == set(BSDF_LOBES.values())
    pdf, delta = width_one["sample pdf"], width_one["delta"]
    assert (pdf == 0).any() and delta.any() and ((pdf > 0) & ~delta).any()
