"""Generated tangents for normal maps (clrender/trace/geometry.py vertex_tangents, MikkTSpace's scheme): per vertex,
not per face, so a smooth UV-mapped sphere's tangents are continuous across its faces and follow the analytic
dP/du; a flat quad's are exactly its dP/du; split (unshared) vertices weld again by value."""

import numpy as np
import pytest

from clrender.trace.geometry import face_tangents, vertex_tangents


def uv_sphere(n_lat=24, n_lon=48):
    """A unit sphere P = (sin t cos p, sin t sin p, cos t), u = p / 2 pi, v = t / pi, with its seam column doubled
    (u = 0 and u = 1); the poles' rows are left out (dP/du vanishes there), so the top and bottom rings are open."""
    t = np.linspace(0.15, np.pi - 0.15, n_lat + 1)
    p = np.linspace(0, 2 * np.pi, n_lon + 1)
    tt, pp = np.meshgrid(t, p, indexing="ij")
    vertices = np.stack([np.sin(tt) * np.cos(pp), np.sin(tt) * np.sin(pp), np.cos(tt)], -1).reshape(-1, 3)
    uvs = np.stack([pp / (2 * np.pi), tt / np.pi], -1).reshape(-1, 2)
    index = np.arange((n_lat + 1) * (n_lon + 1)).reshape(n_lat + 1, n_lon + 1)
    a, b, c, d = index[:-1, :-1], index[:-1, 1:], index[1:, 1:], index[1:, :-1]
    faces = np.concatenate([np.stack([a, d, c], -1).reshape(-1, 3), np.stack([a, c, b], -1).reshape(-1, 3)])  # outward
    return vertices, faces, uvs, pp.reshape(-1)


def angle_deg(a, b):
    cos = np.einsum("...i,...i->...", a, b) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(cos, -1, 1)))


def test_sphere_tangents_follow_dp_du_and_agree_at_shared_vertices():
    vertices, faces, uvs, phi = uv_sphere()
    t = vertex_tangents(vertices, faces, uvs, vertices)  # unit sphere: the normal is the position
    analytic = np.stack([-np.sin(phi), np.cos(phi), np.zeros_like(phi)], -1)[faces]
    error = angle_deg(t[..., :3], analytic)
    seam = (uvs[faces][..., 0] == 0) | (uvs[faces][..., 0] == 1)  # faces on one side only: UVs split the seam
    assert error[~seam].max() < 0.01, error[~seam].max()  # the per-face tangents: 3.75 degrees
    assert error[seam].max() < 7.5 / 2 + 0.1  # half a face's width (7.5 degrees): a one-sided mean of dP/du
    # w: the bitangent w n x t points towards decreasing v (up the image), i.e. towards decreasing theta: +z-ish
    assert (t[..., 3] == 1).all()
    # continuous: every corner of a vertex carries the same tangent
    corner_t = t[..., :3].reshape(-1, 3)
    first = np.zeros((len(vertices), 3))
    first[faces.reshape(-1)] = corner_t
    np.testing.assert_array_equal(corner_t, first[faces.reshape(-1)])


def test_per_face_tangents_were_discontinuous_where_vertex_tangents_are_not():
    """The per-face tangents (the old scheme) differ between faces at a vertex by about the face's angular width."""
    vertices, faces, uvs, _ = uv_sphere()
    corner_t = np.repeat(face_tangents(vertices[faces], uvs[faces])[:, None, :3], 3, axis=1).reshape(-1, 3)
    some = np.zeros((len(vertices), 3))
    some[faces.reshape(-1)] = corner_t  # one of each vertex's faces' tangents
    assert angle_deg(corner_t, some[faces.reshape(-1)]).max() > 5.0


def test_split_vertices_weld_again_by_value():
    vertices, faces, uvs, _ = uv_sphere(8, 16)
    shared = vertex_tangents(vertices, faces, uvs, vertices)
    split_v, split_uv = vertices[faces].reshape(-1, 3), uvs[faces].reshape(-1, 2)
    split = vertex_tangents(split_v, np.arange(len(split_v)).reshape(-1, 3), split_uv, split_v)
    np.testing.assert_allclose(split, shared, atol=1e-12)


@pytest.mark.parametrize("flip_v", [False, True])
def test_flat_quad_tangent_is_the_analytic_dp_du(flip_v):
    """A parallelogram quad in a tilted plane with a skewed UV map: dP/du from the 2 x 2 inverse of the map,
    normalised, at all six corners; w +1, or -1 when v runs the other way (a mirrored map)."""
    rotation = np.linalg.qr(np.array([[1.0, 0.3, 0.2], [0.1, 1.0, 0.4], [0.3, 0.2, 1.0]]))[0]
    vertices = np.array([[0, 0, 0], [2, 0.5, 0], [2.5, 1.5, 0], [0.5, 1.0, 0]]) @ rotation.T
    uvs = np.array([[0.1, 0.9], [0.7, 0.8], [0.8, 0.2], [0.2, 0.3]])
    uvs[3] = uvs[0] + uvs[2] - uvs[1]  # an affine map over the whole parallelogram: one dP/du for both triangles
    if flip_v:
        uvs[:, 1] = 1 - uvs[:, 1]
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    e = np.stack([vertices[1] - vertices[0], vertices[3] - vertices[0]], 1)  # (3, 2): dP along the two edges
    duv = np.stack([uvs[1] - uvs[0], uvs[3] - uvs[0]], 1)  # (2, 2): d(u, v) along them
    dp_duv = e @ np.linalg.inv(duv)  # columns dP/du, dP/dv
    dp_du = dp_duv[:, 0] / np.linalg.norm(dp_duv[:, 0])
    t = vertex_tangents(vertices, faces, uvs, None)
    np.testing.assert_allclose(t[..., :3], np.broadcast_to(dp_du, (2, 3, 3)), atol=1e-12)
    n = np.cross(vertices[1] - vertices[0], vertices[2] - vertices[0])
    towards_decreasing_v = -dp_duv[:, 1]
    w = np.sign(np.cross(n, dp_du) @ towards_decreasing_v)
    assert (t[..., 3] == w).all() and w == (-1 if flip_v else 1)
