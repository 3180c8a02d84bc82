"""Tracing rays on the device: scene flattening (geometry), the BVH (bvh, bvh_wide), ray queries
(tracer), images (renderer, sampling), object-ID edges (edges), AOVs (aov) and turntables."""
