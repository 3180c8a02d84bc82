"""A product shot from the command line (clrender/scene/staging.py): --env, --env-intensity, --env-rotation,
--ground, --up, --smooth, checked on the scene they make (no device) and their bad values on the command line."""

import numpy as np
import pytest
import trimesh

from clrender.errors import UsageError
from clrender.scene import staging
from clrender.scene.staging import GROUND_ALBEDO, GROUND_GAP, GROUND_SIZE, Stage

from tests.clitools import run_cli
from tests.scenetools import write_hdr


def box_file(tmp_path, extents=(1.0, 2.0, 4.0), name="box.ply"):
    """A box centred on (0, 0, 2), `extents` long along x, y, z: a Z-up file's tall object."""
    box = trimesh.creation.box(extents)
    box.apply_translation([0, 0, 2])
    box.export(tmp_path / name)
    return tmp_path / name


def test_env_replaces_a_bare_meshs_default_lights_with_the_map(tmp_path):
    hdr = write_hdr(tmp_path / "sky.hdr", 2.0)
    plain = staging.load(str(box_file(tmp_path)), Stage())
    assert plain.lights and plain.environment_map is None and max(plain.environment) > 0  # framing.py's key light and fill
    lit = staging.load(str(box_file(tmp_path)), Stage(env=str(hdr), env_intensity=3.0, env_rotation=90.0))
    env = lit.environment_map
    assert (env.intensity, env.rotation) == (3.0, 90.0)
    assert np.all(env.texels == 2.0)
    assert lit.lights == [] and lit.environment == (0.0, 0.0, 0.0)  # the map alone lights it


def test_the_bundled_studio_map_is_found_by_name(tmp_path):
    from tools.studio_hdr import studio

    scene = staging.load(str(box_file(tmp_path)), Stage(env="studio"))
    expected = studio()  # the shipped file is what its generator writes, to RGBE's precision (8-bit mantissas)
    np.testing.assert_allclose(scene.environment_map.texels, expected, rtol=2**-7)


def test_env_keeps_a_scenes_own_lights(tmp_path):
    """A TOML scene's lights are its own: --env adds the map and keeps them."""
    hdr = write_hdr(tmp_path / "sky.hdr")
    scene = staging.load("refract1", Stage(env=str(hdr)))
    assert scene.lights and scene.environment_map is not None


def test_env_intensity_without_env_changes_the_scenes_own_map(tmp_path):
    write_hdr(tmp_path / "sky.hdr")
    (tmp_path / "s.toml").write_text(
        '[environment]\nfile = "sky.hdr"\nintensity = 2\n[[objects]]\ntype = "sphere"\ncenter = [0, 0, -3]\nradius = 1\n'
    )
    scene = staging.load(str(tmp_path / "s.toml"), Stage(env_intensity=0.5, env_rotation=-30.0))
    assert (scene.environment_map.intensity, scene.environment_map.rotation) == (0.5, -30.0)
    with pytest.raises(UsageError, match="has none: give one with --env"):
        staging.load("refract1", Stage(env_intensity=0.5))


def test_up_z_turns_the_files_z_axis_to_y_and_its_front_to_the_camera(tmp_path):
    """A Z-up box 4 tall along z stands 4 tall along y; the file's -y side (a Z-up file's front) faces +z."""
    scene = staging.load(str(box_file(tmp_path)), Stage(up="z"))
    v = scene.objects[0].vertices
    np.testing.assert_allclose(np.ptp(v, axis=0), [1.0, 4.0, 2.0], atol=1e-12)
    np.testing.assert_allclose([v[:, 1].min(), v[:, 1].max()], [0.0, 4.0], atol=1e-12)  # z 0..4 became y 0..4
    np.testing.assert_allclose([v[:, 2].min(), v[:, 2].max()], [-1.0, 1.0], atol=1e-12)  # y -1..1 became z 1..-1
    camera = scene.cameras[0]
    np.testing.assert_allclose(camera.look_at, [0.0, 2.0, 0.0], atol=1e-9)  # the framing follows the turned box
    upright = staging.load(str(box_file(tmp_path)), Stage())
    np.testing.assert_allclose(np.ptp(upright.objects[0].vertices, axis=0), [1.0, 2.0, 4.0], atol=1e-12)


def test_up_x_turns_the_files_x_axis_to_y(tmp_path):
    scene = staging.load(str(box_file(tmp_path)), Stage(up="x"))
    np.testing.assert_allclose(np.ptp(scene.objects[0].vertices, axis=0), [2.0, 1.0, 4.0], atol=1e-12)


def test_smooth_gives_a_bare_mesh_vertex_normals(tmp_path):
    trimesh.creation.icosphere(subdivisions=2).export(tmp_path / "ball.stl")
    flat = staging.load(str(tmp_path / "ball.stl"), Stage())
    smooth = staging.load(str(tmp_path / "ball.stl"), Stage(smooth=True))
    assert not flat.objects[0].smooth and flat.objects[0].vertex_normals is None
    mesh = smooth.objects[0]
    assert mesh.smooth
    # a sphere's vertex normals point away from its centre (the welded STL's, within the faces' tilt)
    radial = mesh.vertices / np.linalg.norm(mesh.vertices, axis=1, keepdims=True)
    assert np.min(np.sum(mesh.vertex_normals * radial, axis=1)) > 0.98


def test_ground_is_a_grey_plane_just_under_the_bounding_box(tmp_path):
    scene = staging.load(str(box_file(tmp_path)), Stage(ground=True))
    box, ground = scene.objects
    lo, hi = box.vertices.min(axis=0), box.vertices.max(axis=0)
    diagonal = np.linalg.norm(hi - lo)
    gv = ground.vertices
    np.testing.assert_allclose(gv[:, 1], lo[1] - GROUND_GAP * diagonal, rtol=0, atol=1e-12)  # flat, just below
    np.testing.assert_allclose(np.ptp(gv[:, [0, 2]], axis=0), GROUND_SIZE * diagonal, rtol=1e-9)
    np.testing.assert_allclose(gv[:, [0, 2]].mean(axis=0), ((lo + hi) / 2)[[0, 2]], atol=1e-6)
    material = scene.materials[ground.material]
    assert material.diffuse == (GROUND_ALBEDO,) * 3 and material.specular == (0.0, 0.0, 0.0)
    normal = np.cross(gv[1] - gv[0], gv[2] - gv[0])
    assert normal[1] > 0  # its front faces up


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--env", "missing.hdr"], "--env 'missing.hdr' does not exist; allowed: an equirectangular .hdr or .exr image"),
        (["--env", "studio", "--env-intensity", "-1"], "--env-intensity -1 is not allowed; allowed: a number >= 0"),
        (["--env", "studio", "--env-rotation", "400"], "--env-rotation 400 is not allowed"),
        (["--up", "w"], "--up 'w' is not an axis; allowed: y, z, x"),
    ],
)
def test_bad_stage_values_are_one_line_and_exit_2(tmp_path, monkeypatch, capsys, argv, message):
    monkeypatch.chdir(tmp_path)
    box_file(tmp_path)
    code, out, err = run_cli(capsys, "render", "box.ply", *argv, "-o", "out.png")
    assert code == 2 and out == ""
    assert err.startswith(f"clrender: {message}") and err.count("\n") == 1
    assert not (tmp_path / "out.png").exists()


def test_up_and_smooth_are_refused_for_scenes_that_are_not_bare_meshes(capsys):
    code, _, err = run_cli(capsys, "render", "refract1", "--up", "z")
    assert code == 2 and "--up z is for a bare mesh file" in err
    code, _, err = run_cli(capsys, "render", "refract1", "--smooth")
    assert code == 2 and "--smooth is for a bare mesh file" in err
