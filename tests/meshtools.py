"""Triangle soups and rays for the ray-query tests (tests/trace/), in numpy only, and the answer for rays
straight down onto a flat grid of triangles: which triangles contain each point."""

import numpy as np


def degenerate_meshes(rng):
    """Meshes that give builders nothing to split on."""
    base = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    coincident = np.tile(base, (300, 1))  # 300 copies of one triangle, plus a few ordinary ones
    extra = rng.uniform(-2, 2, (30, 3, 3))
    yield "coincident", np.concatenate([coincident, extra.reshape(-1, 3)])
    # triangles strung along one line, their centroids collinear
    x = np.repeat(np.linspace(0, 10, 400), 3)
    spread = rng.uniform(-0.5, 0.5, (1200, 2)) * np.tile([[1, 1], [1, 1], [1, 1]], (400, 1))
    yield "collinear", np.c_[x + rng.uniform(-0.3, 0.3, 1200), spread]
    # randomly rotated and sized triangles that all have their centroid at one point
    tri = rng.normal(size=(600, 3, 3)) * rng.uniform(0.1, 2, (600, 1, 1))
    tri -= tri.mean(1, keepdims=True)
    yield "same centroid", tri.reshape(-1, 3)


def rays_at_triangles(rng, vertices, n):
    """Rays from random directions aimed at random points of random triangles."""
    tri = vertices.reshape(-1, 3, 3)
    k = rng.integers(0, len(tri), n)
    w = rng.dirichlet([1, 1, 1], n)
    target = np.einsum("ni,nij->nj", w, tri[k])
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return target - 20 * d, d


def grid_mesh(n, z=0.0):
    """An n x n grid of unit squares in the plane z, two triangles each, ids in row order."""
    x, y = np.meshgrid(np.arange(n + 1, dtype=float), np.arange(n + 1, dtype=float))
    vertices = np.c_[x.ravel(), y.ravel(), np.full(x.size, z)]
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    faces = np.concatenate([np.c_[i, i + 1, i + n + 2], np.c_[i, i + n + 2, i + n + 1]])
    return vertices, faces


def triangles_containing(vertices, faces, pts):
    """(triangles, points) booleans: whether each triangle's closed area, seen from above, contains
    each 2D point (the reference for rays straight down; its argmax over axis 0 is the lowest id)."""
    contains = []
    for a, b, c in vertices[faces][:, :, :2]:
        cross = lambda p, q, r: (q[0] - p[0]) * (r[:, 1] - p[1]) - (q[1] - p[1]) * (r[:, 0] - p[0])
        s = np.stack([cross(a, b, pts), cross(b, c, pts), cross(c, a, pts)])
        contains.append((s >= 0).all(0) | (s <= 0).all(0))
    return np.array(contains)
