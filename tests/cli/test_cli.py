"""The command line, end to end: images written, bad input refused with one line and exit 2."""

import os
import subprocess
import sys

import pytest

from clrender.image.files import read_image

from tests.clitools import run_cli


def test_render_writes_a_readable_png(tmp_path, capsys):
    out = tmp_path / "r.png"
    code, stdout, err = run_cli(capsys, "render", "refract1", "--width", "40", "--height", "30", "-o", str(out))
    assert code == 0
    assert stdout.strip() == str(out)
    img = read_image(out)
    assert img.pixels.shape == (30, 40, 3) and img.format == "uint8"
    assert img.pixels.std() > 0.05  # not a blank image
    assert "trace" in err and "compile" in err


def test_exr_output_stays_linear_float(tmp_path, capsys):
    out = tmp_path / "r.exr"
    assert run_cli(capsys, "render", "refract1", "--width", "16", "--height", "12", "-o", str(out))[0] == 0
    assert read_image(out).format in ("float", "half")


def test_seed_style_arguments_map_onto_the_options(tmp_path, capsys):
    out = tmp_path / "e.png"
    edges = tmp_path / "edges.png"
    code, _, err = run_cli(
        capsys,
        "render",
        "refract1",
        "1",
        "edge_detect",
        "stratified",
        "2",
        "1.0",
        "true",
        "--width",
        "32",
        "--height",
        "24",
        "-o",
        str(out),
        "--edges-out",
        str(edges),
    )
    assert code == 0, err
    assert "resample" in err
    assert read_image(edges).pixels.shape == (24, 32, 3)


@pytest.mark.parametrize(
    "args, words",
    [
        (["render", "no_such_scene"], ["unknown scene 'no_such_scene'", "refract1"]),
        (["render", "refract1", "--thickness", "-1"], ["thickness -1.0", ">= 0"]),
        (["render", "refract1", "--camera", "9"], ["camera 9", "1 to 5"]),
        (["render", "refract1", "--samples", "0"], ["samples 0"]),
        (["render", "refract1", "--max-depth", "99"], ["max depth 99"]),
        (["render", "refract1", "--width", "100000", "--height", "100000"], ["too large"]),
        (["render", "refract1", "--aa", "lots"], ["invalid choice: 'lots'"]),
        (["render", "refract1", "1", "full"], ["at least CAMERA AA_TYPE SAMPLE_TYPE"]),
        (["render", "refract1", "x", "full", "uniform"], ["CAMERA 'x'"]),
        (["render", "refract1", "-o", "/no/such/folder/out.png"], ["does not exist"]),
        (["render", "refract1", "-o", "out.unknownext"], ["no image writer", ".unknownext"]),
    ],
)
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch, args, words):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, *args)
    assert code == 2
    assert err.startswith("clrender: ") and err.count("\n") == 1, err
    for w in words:
        assert w in err
    assert os.listdir(tmp_path) == []  # nothing written


def test_existing_output_needs_overwrite(tmp_path, capsys):
    out = tmp_path / "r.png"
    out.write_bytes(b"keep me")
    code, _, err = run_cli(capsys, "render", "refract1", "-o", str(out))
    assert code == 2 and "--overwrite" in err
    assert out.read_bytes() == b"keep me"


def test_malformed_scene_file(tmp_path, capsys):
    scene = tmp_path / "bad.toml"
    scene.write_text("[[objects]]\ntype = 'sphere'\ncenter = [0, 0]\nradius = 1\n")
    code, _, err = run_cli(capsys, "render", str(scene), "-o", str(tmp_path / "o.png"))
    assert code == 2 and "objects[0].center" in err and "bad.toml" in err
    assert not (tmp_path / "o.png").exists()


def test_missing_opencl_device_explains_how_to_install_pocl(tmp_path):
    env = dict(os.environ, CLRENDER_DEVICE="no-such-device-anywhere")
    proc = subprocess.run(
        [sys.executable, "-m", "clrender", "render", "refract1", "-o", str(tmp_path / "x.png")], capture_output=True, text=True, env=env, cwd=tmp_path
    )
    assert proc.returncode == 2
    assert proc.stderr.startswith("clrender: no OpenCL device matches 'no-such-device-anywhere'")
    assert "Traceback" not in proc.stderr and proc.stderr.count("\n") == 1
