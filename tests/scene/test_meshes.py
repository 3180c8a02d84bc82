"""Procedural meshes: closed, outward-wound, sized as asked, finite, deterministic, cached."""

import numpy as np
import pytest
import trimesh

from clrender.errors import UsageError
from clrender.scene import meshes


def check_closed_outward(mesh, watertight=True):
    assert np.isfinite(mesh.vertices).all() and len(mesh.faces) > 0
    assert mesh.faces.min() >= 0 and mesh.faces.max() < len(mesh.vertices)
    assert mesh.is_winding_consistent
    if watertight:
        assert mesh.is_watertight
    assert mesh.volume > 0  # outward winding
    assert np.isfinite(mesh.vertex_normals).all()


def test_surface_nets_ellipsoid_volume():
    """An independent check of the mesher: an ellipsoid's volume within 1%."""
    radii = (1.0, 0.6, 0.8)
    v, f = meshes.surface_nets(lambda p: meshes.sd_ellipsoid(p, (0, 0, 0), radii), (-1.2,) * 3, (1.2,) * 3, 40)
    m = trimesh.Trimesh(v, f, process=False)
    check_closed_outward(m)
    assert m.volume == pytest.approx(4 / 3 * np.pi * np.prod(radii), rel=0.01)
    # vertices lie on the surface
    q = v / radii
    assert np.abs(np.linalg.norm(q, axis=1) - 1).max() < 0.01


@pytest.mark.parametrize("n", [8, 1000, 100_000])
def test_dense_mesh_size(n):
    m = meshes.dense_mesh(n, seed=3)
    check_closed_outward(m)
    assert abs(len(m.faces) - n) <= 0.05 * n + 8
    r = np.linalg.norm(m.vertices, axis=1)
    assert 0.5 < r.min() and r.max() < 1.5


def test_dense_mesh_deterministic_and_seeded():
    a, b, c = meshes.dense_mesh(5000, seed=1), meshes.dense_mesh(5000, seed=1), meshes.dense_mesh(5000, seed=2)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert not np.allclose(a.vertices, c.vertices)


@pytest.mark.parametrize("n", [0, 7, 10**9])
def test_dense_mesh_bad_size(n):
    with pytest.raises(UsageError):
        meshes.dense_mesh(n)


@pytest.mark.slow  # builds the bunny from its implicit surface (~1-4 s); test_bunny_deterministic_without_cache stays fast
def test_bunny_built_cached_and_loaded(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    m = meshes.bunny()
    check_closed_outward(m)
    assert len(m.faces) >= 20_000
    lo, hi = m.bounds
    assert lo[1] == pytest.approx(0, abs=1e-9) and (hi - lo).max() == pytest.approx(1)
    assert abs(lo[0] + hi[0]) < 1e-9 and abs(lo[2] + hi[2]) < 1e-9
    # ears: the top tenth of the height holds two separate thin parts
    top = m.vertices[m.vertices[:, 1] > 0.9]
    assert (top[:, 0] > 0.02).any() and (top[:, 0] < -0.02).any() and not (np.abs(top[:, 0]) < 0.02).any()
    # the head (front, high) is in +z
    assert m.vertices[m.vertices[:, 1] > 0.5, 2].mean() > 0
    cached = list((tmp_path / "clrender").glob("bunny-*.npz"))
    assert len(cached) == 1
    again = meshes.bunny()  # from the cache file, normals included
    assert np.array_equal(again.faces, m.faces) and np.allclose(again.vertices, m.vertices, atol=1e-6)
    assert np.allclose(again.vertex_normals, m.vertex_normals, atol=1e-9)


def test_bunny_deterministic_without_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    a, b = meshes.bunny(48, cache=False), meshes.bunny(48, cache=False)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert a.volume > 0 and a.is_winding_consistent
    assert not (tmp_path / "clrender").exists()


@pytest.mark.parametrize(
    "call",
    [
        lambda: meshes.bunny(4),
        lambda: meshes.bunny(10_000),
        lambda: meshes.bunny(64.5),
        lambda: meshes.wizard_hat(2),
        lambda: meshes.tower(True),
        lambda: meshes.cat(0),
    ],
)
def test_bad_parameters(call):
    with pytest.raises(UsageError):
        call()


@pytest.mark.parametrize("name, watertight, faces", [("wizard_hat", True, (200, 5000)), ("tower", True, (50, 5000)), ("cat", False, (500, 10000))])
def test_low_poly_props(name, watertight, faces):
    m = getattr(meshes, name)()
    check_closed_outward(m, watertight=watertight)
    assert faces[0] <= len(m.faces) <= faces[1]
    assert m.bounds[0, 1] == pytest.approx(0, abs=1e-9)  # stands on y = 0


def test_scene_generators_exist():
    """Every generator name the scene loader accepts is a zero-argument function here."""
    from clrender.scene.scene import MESH_GENERATORS

    for name in MESH_GENERATORS:
        assert callable(getattr(meshes, name))
