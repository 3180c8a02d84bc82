"""What a scene reads, checked before it is read (issue 38, defects 4 and 6): only regular files (a FIFO named by
an OBJ's `mtllib` or `map_Kd`, a texture, a glTF image or an environment map would block the read forever, and
SIGINT did not end it), and a huge file's size from os.stat or its header, before its bytes: a 3 GB glTF image
uri or OBJ map_Kd is refused without being read.  The huge files are sparse (truncate): no disk is used."""

import json
import os
import subprocess
import sys
import tracemalloc

import numpy as np
import pytest
from PIL import Image

from clrender.errors import UsageError
from clrender.scene.scene import Scene

from tests.clitools import run_cli
from tests.gltftools import textured_quad

MATERIAL = {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.0}}
OBJ = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\nf 1/1 2/2 3/3\n"
HUGE = 3 * 10**9  # the red team's 3 GB


def obj_with(tmp_path, *, mtl="newmtl a\nKd 1 1 1\nmap_Kd t.png\n"):
    (tmp_path / "q.obj").write_text(OBJ)
    if mtl is not None:
        (tmp_path / "m.mtl").write_text(mtl)
    return tmp_path / "q.obj"


def cli_child(args, timeout=30):
    """`clrender ARGS` as a child process, killed after `timeout` s (a read that blocks forever fails the test)."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    try:
        return subprocess.run([sys.executable, "-m", "clrender", *args], capture_output=True, text=True, timeout=timeout, env=env)
    except subprocess.TimeoutExpired:
        pytest.fail(f"clrender {' '.join(args)} still ran after {timeout} s (a blocking read)")


def assert_refused(result, *words):
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    for word in words:
        assert word in lines[0], lines[0]


@pytest.mark.parametrize("fifo", ["m.mtl", "t.png"])
def test_an_obj_whose_mtllib_or_map_kd_is_a_fifo_is_refused(tmp_path, fifo):
    """The red team's hang: mtllib or map_Kd naming a FIFO.  Now one line at once, naming the FIFO."""
    obj_with(tmp_path, mtl=None if fifo == "m.mtl" else "newmtl a\nKd 1 1 1\nmap_Kd t.png\n")
    os.mkfifo(tmp_path / fifo)
    out = tmp_path / "out.png"
    result = cli_child(["render", str(tmp_path / "q.obj"), "--width", "8", "--height", "8", "-o", str(out)])
    assert_refused(result, "not a regular file (a FIFO)", fifo)
    assert not out.exists()


@pytest.mark.parametrize("kind", ["texture", "gltf image", "environment map"])
def test_a_fifo_texture_gltf_image_or_environment_map_is_refused(tmp_path, kind):
    """The other files a scene names: a TOML texture, a glTF image uri and an environment map, each a FIFO
    (in a child process with a timeout: the read blocked forever)."""
    os.mkfifo(tmp_path / "f.png")
    os.mkfifo(tmp_path / "f.exr")
    if kind == "texture":
        scene = tmp_path / "s.toml"
        scene.write_text(
            '[textures.t]\nfile = "f.png"\n[materials.m]\ndiffuse_texture = "t"\n'
            '[[objects]]\ntype = "quad"\ncorner = [-1, -1, -3]\nedge_a = [2, 0, 0]\nedge_b = [0, 2, 0]\nmaterial = "m"\n'
        )
    elif kind == "gltf image":
        scene = textured_quad(tmp_path, MATERIAL, [{"uri": "f.png"}])
    else:
        scene = tmp_path / "e.toml"
        scene.write_text('[environment]\nfile = "f.exr"\n[[objects]]\ntype = "sphere"\ncenter = [0, 0, -3]\nradius = 1\n')
    out = tmp_path / "out.exr"
    result = cli_child(["render", str(scene), "--integrator", "path", "--spp", "1", "--width", "8", "--height", "8", "-o", str(out)])
    assert_refused(result, "is not a regular file (a FIFO); allowed: regular files")
    assert not out.exists()


def test_a_sparse_3gb_gltf_image_is_refused_before_it_is_read(tmp_path):
    """A 3 GB image uri (sparse: nothing on disk): refused from its header, with a Python peak far below its size
    (it was read whole first: 3.2 GB)."""
    with open(tmp_path / "huge.png", "wb") as f:
        f.truncate(HUGE)
    gltf = textured_quad(tmp_path, MATERIAL, [{"uri": "huge.png"}])
    tracemalloc.start()
    try:
        with pytest.raises(UsageError, match="huge.png"):
            Scene.from_file(gltf)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50 * 2**20, peak


def test_a_sparse_3gb_map_kd_is_refused_before_it_is_read(tmp_path, monkeypatch):
    """A 3 GB OBJ map_Kd (sparse): refused from its header (it was read whole, 3.3 GB, then dropped: exit 0)."""
    obj_with(tmp_path)
    with open(tmp_path / "t.png", "wb") as f:
        f.truncate(HUGE)
    reads = []
    real_open = open

    def watched_open(file, mode="r", *args, **kwargs):  # the resolver's whole-file read goes through open(..., "rb")
        if str(file).endswith("t.png") and "b" in mode:
            reads.append(file)
        return real_open(file, mode, *args, **kwargs)

    import clrender.scene.confine as confine

    monkeypatch.setattr(confine, "open", watched_open, raising=False)
    with pytest.raises(UsageError, match=r"t\.png.*not an image"):
        Scene.from_file(tmp_path / "q.obj")
    assert reads == []


def test_a_gltf_buffer_is_checked_against_memory_before_it_is_read(capsys, tmp_path):
    """A buffer file's size (os.stat) is checked against --max-memory before a byte is read."""
    path = textured_quad(tmp_path, MATERIAL, [{"uri": "t.png"}])
    Image.fromarray(np.full((2, 2, 3), 9, np.uint8)).save(tmp_path / "t.png")
    doc = json.loads(path.read_text())
    with open(tmp_path / "big.bin", "wb") as f:
        f.truncate(HUGE)
    doc["buffers"].append({"byteLength": HUGE, "uri": "big.bin"})
    path.write_text(json.dumps(doc))
    out = tmp_path / "out.png"
    code, _, err = run_cli(capsys, "--max-memory", "1G", "render", str(path), "--width", "8", "--height", "8", "-o", str(out))
    budget = "--max-memory is 1.0 GiB" in err or "is available" in err  # the smaller of the two is named
    assert code == 2 and len(err.strip().splitlines()) == 1 and "buffers[1]" in err and budget, err
    assert not out.exists()
