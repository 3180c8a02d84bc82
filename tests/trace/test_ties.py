"""Ties: a ray that meets two surfaces at exactly the same distance reports the lower primitive id,
whatever the traversal order (kernels/intersect.h), so BVH on, BVH off and both builders agree."""

import numpy as np
import pytest

from clrender.trace.tracer import Tracer


@pytest.mark.parametrize("use_bvh, builder", [(False, "sah"), (True, "sah"), (True, "median")])
def test_coincident_triangles_report_the_lower_id(device, use_bvh, builder):
    rng = np.random.default_rng(3)
    vertices = np.array([[-1.0, -1, -2], [1, -1, -2], [0, 1, -2]])
    # the same triangle three times (ids 0, 1, 2: the same arithmetic, so exactly the same distance),
    # plus a few scattered others so the BVH has more than one leaf
    faces = [[0, 1, 2], [0, 1, 2], [0, 1, 2]]
    others = rng.uniform(-5, 5, (30, 3, 3)) + [0, 0, -10]
    all_vertices = np.concatenate([vertices, others.reshape(-1, 3)])
    faces = np.array(faces + (3 + np.arange(90).reshape(30, 3)).tolist())
    tracer = Tracer((all_vertices, faces), use_bvh=use_bvh, builder=builder)
    d = np.tile([0.0, 0, -1], (25, 1)) + np.c_[rng.uniform(-0.1, 0.1, (25, 2)), np.zeros(25)]
    t, prim, _ = tracer.intersect(np.zeros_like(d), d)
    assert np.isfinite(t).all()
    assert (prim == 0).all(), prim
