"""One consistent command line: contradictory options refused, pointless ones warned about, the
image's aspect ratio kept, written paths on stdout, timings and warnings on stderr, and
'clrender:' only in front of errors."""

import os
import re
import tomllib

import numpy as np
import pytest

from clrender.cli import main
from clrender.image.files import probe_image, write_image
from clrender.scene.scene import Scene, bundled_scenes
from clrender.trace.renderer import RenderSettings


def run(capsys, *argv):
    code = main([str(a) for a in argv])
    out = capsys.readouterr()
    return code, out.out, out.err


def tiny(tmp_path, name="r.png"):
    return ["--width", "16", "--height", "12", "-o", tmp_path / name]


# ------------------------------------------------------------------ refused
@pytest.mark.parametrize(
    "option, words",
    [
        (["--aa", "none"], ["--aa none", "AA_TYPE 'full'"]),
        (["--camera", "2"], ["--camera 2", "CAMERA '1'"]),
        (["--sampler", "sobol"], ["--sampler sobol", "SAMPLE_TYPE 'uniform'"]),
    ],
)
def test_seed_positionals_and_the_same_named_option_are_refused(tmp_path, capsys, option, words):
    code, out, err = run(capsys, "render", "refract1", "1", "full", "uniform", *option, *tiny(tmp_path))
    assert code == 2 and out == ""
    assert err.startswith("clrender: ") and err.count("\n") == 1
    for w in words:
        assert w in err
    assert os.listdir(tmp_path) == []


def test_seed_sample_count_and_samples_option_are_refused(tmp_path, capsys):
    code, out, err = run(capsys, "render", "refract1", "1", "full", "uniform", "4", "--samples", "2", *tiny(tmp_path))
    assert code == 2 and "--samples 2" in err and "AA_SAMPLES '4'" in err


def test_seed_positionals_with_an_option_they_do_not_set_are_fine(tmp_path, capsys):
    # CAMERA AA_TYPE SAMPLE_TYPE leave the sample count to --samples
    code, out, err = run(capsys, "-q", "render", "refract1", "1", "full", "uniform", "--samples", "2", *tiny(tmp_path))
    assert code == 0 and err == ""


@pytest.mark.parametrize("option", ["--width", "--height"])
def test_zero_size_is_refused(tmp_path, capsys, option):
    code, out, err = run(capsys, "render", "refract1", option, "0", "-o", tmp_path / "r.png")
    assert code == 2
    assert err.startswith(f"clrender: argument {option}: 0 is not allowed; allowed: 1 or more")
    assert os.listdir(tmp_path) == []


def test_zero_width_from_python_is_refused_not_taken_as_the_scenes():
    scene = Scene.from_dict({"width": 40, "height": 30, "objects": [{"type": "sphere", "center": [0, 0, -3], "radius": 1}]})
    with pytest.raises(Exception, match="at least 1x1"):
        RenderSettings(width=0).validate(scene)


# ------------------------------------------------------------------ warned
@pytest.mark.parametrize(
    "extra, says",
    [
        (["--aa", "none", "--samples", "3"], "3 x 3 samples have no effect with --aa none"),
        (["--aa", "none", "--thickness", "2"], "--thickness has no effect with --aa none"),
        (["--aa", "full", "--thickness", "2"], "--thickness has no effect with --aa full"),
    ],
)
def test_options_without_effect_warn_and_still_render(tmp_path, capsys, extra, says):
    code, out, err = run(capsys, "-q", "render", "refract1", *extra, *tiny(tmp_path))
    assert code == 0 and out == f"{tmp_path / 'r.png'}\n"
    assert err.startswith("warning: ") and says in err and "clrender:" not in err


def test_options_with_effect_do_not_warn(tmp_path, capsys):
    code, _, err = run(capsys, "-q", "render", "refract1", "--aa", "edge_detect", "--samples", "2", "--thickness", "2", *tiny(tmp_path))
    assert code == 0 and err == ""


def test_bad_value_is_an_error_without_a_warning_first(tmp_path, capsys):
    code, _, err = run(capsys, "render", "refract1", "--thickness", "-1", *tiny(tmp_path))
    assert code == 2 and err.startswith("clrender: ") and "warning" not in err


def test_scene_without_lights_warns(tmp_path, capsys):
    scene = tmp_path / "dark.toml"
    scene.write_text('ambient = [0.2, 0.2, 0.2]\n[[objects]]\ntype = "sphere"\ncenter = [0, 0, -3]\nradius = 1\n')
    code, out, err = run(capsys, "-q", "render", scene, *tiny(tmp_path))
    assert code == 0
    assert err == "warning: scene 'dark' has no lights: only the ambient term and the background will show\n"


# ------------------------------------------------------------------ aspect ratio
@pytest.mark.parametrize(
    "given, expected",
    [
        (["--width", "48"], (48, 36)),  # refract1 is 480 x 360
        (["--height", "45"], (60, 45)),
        (["--width", "50", "--height", "10"], (50, 10)),  # both given: exactly those
    ],
)
def test_one_side_keeps_the_scenes_aspect_ratio(tmp_path, capsys, given, expected):
    out = tmp_path / "r.png"
    assert run(capsys, "-q", "render", "refract1", *given, "-o", out)[0] == 0
    info = probe_image(out)
    assert (info.width, info.height) == expected


def test_aspect_ratio_rule_in_python_rounds_to_the_nearest_pixel():
    scene = Scene.from_dict({"width": 640, "height": 480})
    assert RenderSettings(width=101).validate(scene).height == round(101 * 480 / 640)  # 75.75 -> 76
    assert RenderSettings(height=1).validate(scene).width == 1
    assert RenderSettings(width=1).validate(scene).height == 1  # never 0


# ------------------------------------------------------------------ stdout / stderr
def test_render_prints_the_path_on_stdout_and_timings_on_stderr(tmp_path, capsys):
    code, out, err = run(capsys, "render", "refract1", *tiny(tmp_path))
    assert code == 0
    assert out == f"{tmp_path / 'r.png'}\n"
    assert err.startswith("refract1: 16x12") and "clrender:" not in err


def test_render_prints_every_written_path(tmp_path, capsys):
    edges = tmp_path / "edges.png"
    code, out, err = run(capsys, "-q", "render", "refract1", "--aa", "edge_detect", "--edges-out", edges, *tiny(tmp_path))
    assert code == 0 and out.split() == [str(tmp_path / "r.png"), str(edges)]


def test_list_shows_descriptions_and_cameras_with_the_default_one_marked(capsys):
    code, out, err = run(capsys, "render", "--list")
    assert code == 0 and err == ""
    blocks = re.split(r"\n(?=\S)", out.strip())
    scenes = bundled_scenes()
    listed = {b.split(":")[0]: b for b in blocks if not b.startswith("(")}
    assert set(listed) == set(scenes)
    for name, block in listed.items():
        data = tomllib.loads(scenes[name].read_text())
        head, *cameras = block.splitlines()
        assert head == f"{name}: {data['description']}" and len(data["description"]) > 20
        assert len(cameras) == len(data["cameras"])
        marked = [c for c in cameras if c.lstrip().startswith("*")]
        assert len(marked) == 1 and f"--camera {data['default_camera']} " in marked[0]
        for number, (line, camera) in enumerate(zip(cameras, data["cameras"]), start=1):
            assert f"--camera {number}  {camera['name']}" in line
    # the original report's edge-AA run of wizard_cat used camera 3 (docs/benchmarks.md, bench aa)
    assert "* --camera 3" in listed["wizard_cat"]
    assert out.rstrip().endswith("(* the scene's default view, rendered when --camera is not given: the one it was made for; --camera picks any)")


# ------------------------------------------------------------------ splat commands
@pytest.fixture
def photo(tmp_path):
    rng = np.random.default_rng(5)
    path = tmp_path / "in.png"
    write_image(path, rng.random((24, 32, 3)).astype(np.float32), format="uint8")
    return path


def test_splat_commands_honour_device(tmp_path, photo, capsys):
    code, out, err = run(capsys, "splat", "voronoi", photo, "-o", tmp_path / "v.png", "--splats", "8", "--device", "no-such-device-anywhere")
    assert code == 2 and "no-such-device-anywhere" in err and err.startswith("clrender: ")
    code, out, err = run(
        capsys, "splat", "gauss", photo, "-o", tmp_path / "g.png", "--splats", "8", "--epochs", "1", "--device", "no-such-device-anywhere"
    )
    assert code == 2 and "no-such-device-anywhere" in err
    assert sorted(os.listdir(tmp_path)) == ["in.png"]


def test_splat_gauss_prints_every_written_path(tmp_path, photo, capsys):
    out = tmp_path / "g.png"
    code, stdout, err = run(capsys, "-q", "splat", "gauss", photo, "-o", out, "--splats", "16", "--epochs", "2", "--save-params", tmp_path / "p.npz")
    assert code == 0 and err == ""
    assert stdout.split() == [str(out), str(tmp_path / "p.npz"), str(tmp_path / "g.curve.png")]
    code, stdout, err = run(capsys, "-q", "splat", "render", tmp_path / "p.npz", "-o", tmp_path / "big.png", "--width", "64")
    assert code == 0 and stdout == f"{tmp_path / 'big.png'}\n"
    assert probe_image(tmp_path / "big.png").height == 48


def test_voronoi_default_sites_are_not_a_grid():
    # the default must give cells that look like Voronoi cells, not pixelation: sites off any grid
    from clrender.splat.voronoi import VoronoiSettings, init_sites

    settings = VoronoiSettings()
    rng = np.random.default_rng(0)
    image = rng.random((60, 80, 3)).astype(np.float32)
    sites = init_sites(image, 400, settings.init, settings.seed)
    grid = init_sites(image, 400, "uniform", 0)
    assert len(np.unique(grid[:, 1])) <= 25  # the grid: about sqrt(400) rows
    assert len(np.unique(np.round(sites[:, 1], 3))) > 300  # the default: (almost) every site its own row
