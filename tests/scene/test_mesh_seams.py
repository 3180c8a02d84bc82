"""Smooth normals across patch borders and in spite of a file's zero or NaN normals (issue 23).

A mesh file whose patches repeat the border vertices (the Utah teapot has 403 such copies) must
get one normal at each border position, the analytic one for a sphere; a fold the file splits on
purpose (a cube's corners) stays sharp; and a glTF's zero, NaN or infinite NORMAL falls back to
the geometric normal instead of putting NaN into every hit pixel.
"""

import math

import numpy as np
import pytest

from clrender.scene import meshes
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer

from tests.gltftools import gltf_file


def write_obj(path, vertices, faces):
    lines = [f"v {x:.17g} {y:.17g} {z:.17g}" for x, y, z in vertices] + [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def patched_sphere(rings=16, segments=24, patches=4):
    """A unit UV sphere cut along meridians into `patches` patches, each with its own copy of the
    border vertices (as exporters write surface patches); poles copied per patch too."""
    vertices, faces = [], []
    per = segments // patches
    theta = np.pi * np.arange(rings + 1) / rings
    for p in range(patches):
        phi = 2 * np.pi * np.arange(p * per, (p + 1) * per + 1) / segments  # per + 1 columns: shares both borders
        base = len(vertices)
        for t in theta:
            for ph in phi:
                vertices.append((math.sin(t) * math.sin(ph), math.cos(t), math.sin(t) * math.cos(ph)))
        cols = per + 1
        for r in range(rings):
            for s in range(per):
                a, b = base + r * cols + s, base + r * cols + s + 1
                c, d = a + cols, b + cols
                if r > 0:
                    faces.append((a, c, b))  # counter-clockwise seen from outside
                if r < rings - 1:
                    faces.append((b, c, d))
    v = np.array(vertices)
    v[np.abs(v) < 1e-15] = 0.0  # sin(pi) etc.: make the copies of one point bit-for-bit equal
    return v, np.array(faces)


def angle_degrees(a, b):
    return np.degrees(np.arccos(np.clip((a * b).sum(-1), -1, 1)))


def test_patched_sphere_file_gets_the_analytic_normal_on_both_sides_of_each_seam(tmp_path):
    v, f = patched_sphere()
    used = np.unique(f)
    _, copies = np.unique(v[used], axis=0, return_counts=True)
    assert (copies > 1).sum() > 50  # the file really repeats its border vertices
    write_obj(tmp_path / "sphere.obj", v, f)
    scene = Scene.from_dict({"objects": [{"type": "mesh", "file": "sphere.obj", "smooth": True}]}, base_dir=tmp_path)
    (mesh,) = scene.objects
    used = np.unique(mesh.faces)
    p, n = mesh.vertices[used], mesh.vertex_normals[used]
    exact = p / np.linalg.norm(p, axis=1, keepdims=True)
    err = angle_degrees(n, exact)
    # one-sided normals at a seam are off by half a face's turn (7.5 degrees at 24 segments)
    assert err.max() < 1.0, f"{err.max():.2f} degrees off the analytic normal"
    seams = np.abs(np.arctan2(p[:, 0], p[:, 2]) % (np.pi / 2)) < 1e-9  # on the meridians the patches share
    assert seams.sum() > 30
    np.testing.assert_allclose(n[seams], exact[seams], atol=0.01)


def test_a_cube_split_by_faces_keeps_its_sharp_edges():
    # each face has its own four corners: the file means the edges to be sharp
    corners = np.array([[x, y, z] for x in (-1.0, 1.0) for y in (-1.0, 1.0) for z in (-1.0, 1.0)])
    vertices, faces = [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            quad = corners[corners[:, axis] == sign]
            normal = np.eye(3)[axis] * sign
            centre = quad.mean(0)
            u = quad[0] - centre
            order = np.argsort(np.arctan2(((quad - centre) @ np.cross(normal, u)), (quad - centre) @ u))
            base = len(vertices)
            vertices.extend(quad[order])
            faces += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    v, f = np.array(vertices), np.array(faces)
    n = meshes.welded_vertex_normals(v, f)
    face_normal = np.repeat(np.eye(3)[[0, 0, 1, 1, 2, 2]] * np.tile([-1.0, 1.0], 3)[:, None], 4, axis=0)
    assert np.array_equal(n, face_normal)


@pytest.mark.parametrize("bad", [[0, 0, 0], [math.nan, 0, 1], [math.inf, 0, 0]], ids=["zero", "nan", "inf"])
def test_unusable_gltf_normals_fall_back_to_the_face_normal(tmp_path, bad):
    path = gltf_file(tmp_path, [{"mesh": 0}], normals=bad, cameras=[{"type": "perspective", "perspective": {"yfov": 0.8}}])
    scene = Scene.load(path)
    (mesh,) = scene.objects
    assert mesh.smooth
    np.testing.assert_array_equal(mesh.vertex_normals, np.broadcast_to([0.0, 0.0, 1.0], (4, 3)))


def test_the_normal_aov_of_a_zero_normal_gltf_is_the_face_normal(tmp_path):
    path = gltf_file(
        tmp_path,
        [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 3]}],
        normals=[0, 0, 0],
        cameras=[{"type": "perspective", "perspective": {"yfov": 0.5}}],
    )
    result = Renderer(Scene.load(path), width=8, height=6, aovs=("normal",)).run()
    normal = result.aovs["normal"]
    assert np.isfinite(normal).all()
    np.testing.assert_allclose(normal[3, 4], [0, 0, 1], atol=1e-6)  # the centre pixel sees the quad


def test_usable_normals_are_kept_bit_for_bit():
    v, f = patched_sphere(8, 8, 2)
    given = np.random.default_rng(0).normal(size=v.shape)
    given /= np.linalg.norm(given, axis=1, keepdims=True)
    assert np.array_equal(meshes.shading_normals(v, f, given), given)
