"""Vertex normals computed with numpy (clrender.scene.meshes.vertex_normals), so a fresh install never
asks trimesh for them (trimesh needs scipy for that and otherwise loops over vertices in Python)."""

import numpy as np
import trimesh

from clrender.scene import meshes


def test_sphere_normals_point_along_the_radius():
    # an icosphere's exact normal at a vertex on the unit sphere is the vertex itself
    sphere = trimesh.creation.icosphere(subdivisions=3)
    n = meshes.vertex_normals(sphere.vertices, sphere.faces)
    assert np.allclose(n, sphere.vertices / np.linalg.norm(sphere.vertices, axis=1, keepdims=True), atol=0.02)
    assert np.allclose(np.linalg.norm(n, axis=1), 1)


def test_cube_corner_normal_is_the_diagonal_whatever_the_triangulation():
    # angle weighting makes a cube corner's normal the body diagonal even though the corner
    # touches one, two or three triangles of different faces (area weighting would not)
    cube = trimesh.creation.box()
    n = meshes.vertex_normals(cube.vertices, cube.faces)
    assert np.allclose(n, np.sign(cube.vertices) / np.sqrt(3), atol=1e-12)


def test_unused_vertex_and_degenerate_face_give_no_nan():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]], float)
    f = np.array([[0, 1, 2], [0, 0, 1]])  # the second face has zero area
    n = meshes.vertex_normals(v, f)
    assert np.isfinite(n).all()
    assert np.allclose(n[:3], [0, 0, 1]) and np.array_equal(n[3], [0, 0, 0])


def test_generated_meshes_carry_normals_that_match_trimesh():
    # trimesh's angle-weighted normals (computed here with scipy) are the independent reference
    for mesh in (meshes.cat(24), meshes.wizard_hat(12), meshes.tower(8), meshes.dense_mesh(2000)):
        reference = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False).vertex_normals
        assert np.allclose(mesh.vertex_normals, reference, atol=1e-9)
