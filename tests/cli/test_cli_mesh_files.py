"""`clrender render teapot.obj`: a mesh file as SCENE renders framed and lit, `--list` shows a file's cameras,
and a bad mesh file is refused in one line naming the file and what is allowed, exit 2, nothing written."""

import os

import numpy as np
import pytest
import trimesh

from clrender.image.files import read_image
from clrender.scene.framing import CAMERA_NAME

from tests.clitools import run_cli
from tests.gltftools import gltf_file

SIZE = ("--width", "32", "--height", "24")


@pytest.mark.parametrize("name", ["ball.obj", "ball.ply", "ball.stl", "ball.off"])
def test_a_mesh_file_renders_framed_and_lit(tmp_path, capsys, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    trimesh.creation.icosphere(subdivisions=2).export(name)
    code, out, err = run_cli(capsys, "render", name, *SIZE)
    assert code == 0, err
    assert out.strip() == "ball.png"  # the default output: SCENE's stem
    pixels = read_image("ball.png").pixels.astype(float)
    assert 0.3 < pixels.max() < 0.95  # lit and not blown out (the rig's brightest is 0.8 linear, 0.91 sRGB)
    border = np.concatenate([pixels[0], pixels[-1], pixels[:, 0], pixels[:, -1]])
    assert (border == 0).all()  # the whole ball is in the frame, on the black background


def test_a_mesh_file_renders_with_the_path_tracer(tmp_path, capsys):
    path = tmp_path / "ball.obj"
    trimesh.creation.icosphere(subdivisions=2).export(path)
    code, _, err = run_cli(capsys, "render", str(path), "--integrator", "path", "--spp", "4", *SIZE, "-o", str(tmp_path / "p.png"))
    assert code == 0, err
    assert "no lights" not in err  # the rig lights it: no warning
    pixels = read_image(tmp_path / "p.png").pixels.astype(float)
    assert pixels[0, 0] == pytest.approx(0.537, abs=0.01)  # the constant environment 0.25, in sRGB
    assert pixels.max() > 0.7


def test_list_shows_a_mesh_files_framing_camera(tmp_path, capsys):
    path = tmp_path / "ball.obj"
    trimesh.creation.icosphere(subdivisions=1).export(path)
    code, out, err = run_cli(capsys, "render", str(path), "--list")
    assert code == 0, err
    assert out.splitlines() == ["ball: ball.obj: 80 triangles, framed and lit by default", f"  * --camera 1  {CAMERA_NAME}"]
    assert list(tmp_path.iterdir()) == [path]


def test_list_shows_a_gltf_files_named_cameras(tmp_path, capsys):
    cameras = [{"type": "perspective", "perspective": {"yfov": 0.5}, "name": "hero"}, {"type": "perspective", "perspective": {"yfov": 0.8}}]
    nodes = [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 4]}, {"camera": 1, "translation": [0, 1, 5], "name": "wide shot"}]
    code, out, err = run_cli(capsys, "render", str(gltf_file(tmp_path, nodes, cameras=cameras)), "--list")
    assert code == 0, err
    assert out.splitlines() == ["scene", "  * --camera 1  hero", "    --camera 2  wide shot"]  # the camera's name, else its node's
    code, out, _ = run_cli(capsys, "render", str(gltf_file(tmp_path, [{"mesh": 0}], name="bare.gltf")), "--list")
    assert code == 0 and out.splitlines() == ["bare", f"  * --camera 1  {CAMERA_NAME}"]


def test_list_with_a_bundled_scene_shows_only_its_cameras(capsys):
    code, out, _ = run_cli(capsys, "render", "refract1", "--list")
    assert code == 0 and out.startswith("refract1: ") and len(out.splitlines()) == 6


# name -> (its contents, None for a folder and absent for a missing file; words the message must hold)
BAD_FILES = {
    "empty.obj": (b"", ["no triangles"]),
    "empty.stl": (b"", ["no triangles"]),
    "points.obj": (b"v 0 0 0\nv 1 0 0\nv 0 1 0\n", ["no triangles"]),
    "nan.obj": (b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", ["NaN"]),
    "corrupt.ply": (bytes(range(256)) * 2, ["cannot parse mesh", "PLY"]),
    # trimesh reads undecodable bytes as ASCII STL when charset_normalizer is installed: no triangles then
    "corrupt.stl": (b"\xff\xfe" + bytes(range(200)), [("cannot parse mesh", "no triangles")]),
    "index.off": (b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n", ["cannot parse mesh", "OFF"]),
    "line.obj": (b"v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\n", ["no triangle has an area"]),
    "dot.obj": (b"v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n", ["0 across"]),
    "cloud.xyz": (b"0 0 0\n1 0 0\n", ["file type clrender reads (.xyz)"]),
    "folder.obj": (None, ["does not exist"]),
    "missing.ply": ("absent", ["does not exist"]),
}


@pytest.mark.parametrize("name", list(BAD_FILES))
def test_a_bad_mesh_file_is_one_line_exit_2_and_nothing_written(tmp_path, capsys, monkeypatch, name):
    monkeypatch.chdir(tmp_path)
    contents, words = BAD_FILES[name]
    if contents is None:
        (tmp_path / name).mkdir()
    elif contents != "absent":
        (tmp_path / name).write_bytes(contents)
    before = sorted(os.listdir(tmp_path))
    for args in ((name, "-o", "out.png"), (name, "--list")):
        code, out, err = run_cli(capsys, "render", *args, *SIZE)
        assert code == 2, err
        assert err.startswith("clrender: ") and err.count("\n") == 1 and out == "", err
        assert name in err and "allowed" in err, err
        for word in words:  # a tuple: any one of its words
            assert any(w in err for w in (word if isinstance(word, tuple) else (word,))), err
        assert sorted(os.listdir(tmp_path)) == before  # nothing written


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads a file whatever its mode")
def test_an_unreadable_mesh_file_is_refused(tmp_path, capsys):
    path = tmp_path / "locked.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    path.chmod(0)
    code, _, err = run_cli(capsys, "render", str(path), "-o", str(tmp_path / "o.png"))
    assert code == 2 and "locked.obj" in err and err.count("\n") == 1, err
    assert not (tmp_path / "o.png").exists()
