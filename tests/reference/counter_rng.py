"""The counter-based random numbers docs/shading.md documents: a value is a hash of
(seed, pixel, sample, dimension).  Reproduced here only so that the reference
renderer can put its area-light samples where the renderer puts them; the
hash is Wellons' lowbias32 finaliser chained over the four counters, and a
value in [0, 1) keeps its top 24 bits.
"""

import numpy as np

MASK = np.uint64(0xFFFFFFFF)


def _mix32(x):
    x = x.astype(np.uint64)
    x ^= x >> np.uint64(16)
    x = (x * np.uint64(0x7FEB352D)) & MASK
    x ^= x >> np.uint64(15)
    x = (x * np.uint64(0x846CA68B)) & MASK
    x ^= x >> np.uint64(16)
    return x


def _add(a, k):
    return (np.asarray(a, np.uint64) + np.uint64(k)) & MASK


def uniform(seed, pixel, sample, dim):
    """Uniform numbers in [0, 1) for arrays of (pixel, dim) at one seed and sample."""
    pixel, dim = np.broadcast_arrays(np.asarray(pixel, np.uint64), np.asarray(dim, np.uint64))
    h = _mix32(_add(np.full(pixel.shape, seed, np.uint64), 0x9E3779B9))
    h = _mix32(h ^ _add(pixel, 0x85EBCA6B))
    h = _mix32(h ^ _add(np.full(pixel.shape, sample, np.uint64), 0xC2B2AE35))
    h = _mix32(h ^ _add(dim, 0x27D4EB2F))
    return (h >> np.uint64(8)).astype(np.float64) / 16777216.0
