"""Tracing rays on the device: scene flattening (geometry), the BVH (bvh, bvh_wide), ray queries
(tracer), images (renderer, sampling), object-ID edges (edges), AOVs (aov) and turntables."""


def __getattr__(name):  # submodules load on first use: clrender.trace.X after a plain `import clrender`
    from .. import _submodule

    return _submodule(__name__, name)
