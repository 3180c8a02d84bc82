"""The command line's wiring: seed-style positionals reach their settings, exit codes 0/1/2,
`devices`, `render --list` and `--filter`."""

import shutil

import numpy as np
import OpenImageIO as oiio
import pytest

import clrender.device
import clrender.trace.renderer
from clrender.cli import build_parser
from clrender.commands.render import settings_from_args
from clrender.errors import UsageError
from clrender.trace.renderer import RenderSettings, render

from tests.clitools import run_cli


def settings_for(*argv) -> RenderSettings:
    return settings_from_args(build_parser().parse_args(["render", *argv]))


# ------------------------------------------------------------------ seed-style positionals

DEFAULT = RenderSettings()


@pytest.mark.parametrize(
    "argv, expected",
    [
        (
            ["refract1", "3", "edge_detect", "sobol", "8", "2.5", "false"],
            dict(camera=3, aa="edge_detect", sampler="sobol", samples=8, thickness=2.5, shadow_edges=False),
        ),
        (
            ["refract1", "2", "full", "random", "5"],
            dict(camera=2, aa="full", sampler="random", samples=5, thickness=DEFAULT.thickness, shadow_edges=True),
        ),
        (
            ["refract1", "4", "full", "uniform"],  # AA_SAMPLES left out: 4 when anti-aliasing
            dict(camera=4, aa="full", sampler="uniform", samples=4),
        ),
        (
            ["refract1", "1", "none", "random"],  # ... and 1 without
            dict(camera=1, aa="none", sampler="random", samples=1),
        ),
        (
            ["refract1", "5", "edge_detect", "uniform", "3", "0", "TRUE"],
            dict(camera=5, aa="edge_detect", sampler="uniform", samples=3, thickness=0.0, shadow_edges=True),
        ),
    ],
)
def test_each_seed_positional_reaches_its_setting(argv, expected):
    s = settings_for(*argv)
    for key, value in expected.items():
        assert getattr(s, key) == value, key
        assert type(getattr(s, key)) is type(value), key


@pytest.mark.parametrize(
    "option, positionals",
    [
        (["--camera", "4"], ["2", "full", "uniform"]),
        (["--aa", "none"], ["2", "full", "uniform"]),
        (["--samples", "2"], ["2", "full", "uniform", "6"]),
        (["--thickness", "9"], ["2", "edge_detect", "uniform", "6", "3.5"]),
    ],
)
def test_a_setting_given_both_ways_is_refused(tmp_path, capsys, option, positionals):
    code, _, err = run_cli(capsys, "render", "refract1", *positionals, *option, "-o", str(tmp_path / "x.png"))
    assert code == 2 and err.startswith("clrender: ") and err.count("\n") == 1, err
    assert option[0] in err
    assert list(tmp_path.iterdir()) == []


def test_named_options_reach_their_settings():
    s = settings_for(
        "refract1",
        "--camera",
        "2",
        "--aa",
        "full",
        "--sampler",
        "random",
        "--samples",
        "3",
        "--thickness",
        "0.5",
        "--no-shadow-edges",
        "--width",
        "31",
        "--height",
        "17",
        "--light-samples",
        "7",
        "--max-depth",
        "3",
        "--fresnel",
        "--no-bvh",
        "--bvh-builder",
        "median",
        "--seed",
        "99",
        "--pixel-filter",
        "tent",
        "--contrast",
        "0.2",
    )
    assert (s.camera, s.aa, s.sampler, s.samples, s.thickness, s.shadow_edges) == (2, "full", "random", 3, 0.5, False)
    assert (s.width, s.height, s.light_samples, s.max_depth, s.fresnel) == (31, 17, 7, 3, True)
    assert (s.bvh, s.bvh_builder, s.seed, s.pixel_filter, s.contrast) == (False, "median", 99, "tent", 0.2)


def test_the_settings_reach_the_renderer(tmp_path, capsys, monkeypatch):
    """main() hands the parsed settings to Renderer unchanged (Renderer replaced by a recorder)."""
    seen = {}

    def recorder(self, scene, settings=None, *args, **overrides):
        seen["settings"], seen["overrides"] = settings, overrides
        raise UsageError("stopped by the test")  # a clean exit 2, nothing rendered

    # the class itself, wherever the command imports it from
    monkeypatch.setattr(clrender.trace.renderer.Renderer, "__init__", recorder)
    code, _, err = run_cli(
        capsys, "-q", "render", "refract1", "2", "full", "stratified", "3", "1.5", "off", "--seed", "7", "-o", str(tmp_path / "x.png")
    )
    assert code == 2 and "stopped by the test" in err
    s = seen["settings"]
    assert (s.camera, s.aa, s.sampler, s.samples, s.thickness, s.shadow_edges, s.seed) == (2, "full", "stratified", 3, 1.5, False, 7)
    assert seen["overrides"] == {}
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize(
    "argv, words",
    [
        (["x", "full", "uniform"], ["CAMERA 'x'"]),
        (["2", "full", "uniform", "many"], ["SAMPLES 'many'"]),
        (["2", "full", "uniform", "4", "thick"], ["THICKNESS 'thick'"]),
        (["2", "full", "uniform", "4", "1.0", "maybe"], ["'maybe'", "true|false"]),
        (["2", "full"], ["at least CAMERA AA_TYPE SAMPLE_TYPE"]),
        (["2", "full", "uniform", "4", "1.0", "true", "extra"], ["too many arguments"]),
        (["2", "blurry", "uniform"], ["blurry"]),
        (["2", "full", "halton"], ["halton"]),
    ],
)
def test_bad_seed_positionals_exit_2_with_one_line(tmp_path, capsys, argv, words):
    code, out, err = run_cli(capsys, "render", "refract1", *argv, "-o", str(tmp_path / "x.png"))
    assert code == 2
    assert err.startswith("clrender: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    for w in words:
        assert w in err
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ argparse errors: every one exits 2


@pytest.mark.parametrize(
    "argv",
    [
        [],  # no command
        ["paint"],  # unknown command
        ["render", "refract1", "--aa", "lots"],  # invalid choice
        ["render", "refract1", "--width", "wide"],  # not an integer
        ["render", "refract1", "--thickness", "thick"],  # not a number
        ["render", "refract1", "--no-such-option"],  # unknown option
        ["render", "refract1", "--pixel-filter", "lanczos"],  # invalid choice
        ["convolve", "in.png"],  # missing arguments
        ["splat"],  # missing sub-subcommand
        ["splat", "gauss"],  # missing input
        ["splat", "gauss", "in.png", "--loss", "l3"],  # invalid choice
        ["splat", "voronoi", "in.png", "--sites", "many"],  # not an integer
        ["devices", "--bogus"],  # unknown option
    ],
)
def test_every_argparse_error_exits_2_with_one_line(tmp_path, capsys, monkeypatch, argv):
    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, *argv)
    assert code == 2, (code, err)
    assert err.startswith("clrender: ") and err.count("\n") == 1, err
    assert out == "" and list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ exit status 1: failures at run time


def test_kernel_build_failure_exits_1(tmp_path, capfd, monkeypatch):
    """A kernel that does not compile is a run-time failure (exit 1), reported in one line without a
    traceback; capfd, since the OpenCL compiler may write to the process's stderr itself."""
    broken = tmp_path / "kernels"
    shutil.copytree(clrender.device.kernel_dir(), broken)  # every kernel file as it is (the BVH build needs its own)
    (broken / "trace.cl").write_text("__kernel void render(__global float *x) { this is not C; }\n")
    monkeypatch.setattr(clrender.device, "kernel_dir", lambda: broken)
    monkeypatch.setattr(clrender.device, "_DEVICES", {})  # a fresh device: nothing built yet
    out = tmp_path / "x.png"
    code, stdout, err = run_cli(capfd, "-q", "render", "refract1", "--width", "8", "--height", "6", "-o", str(out))
    assert code == 1, err
    assert err.startswith("clrender: building kernels/trace.cl failed") and err.count("\n") == 1, err
    assert "Traceback" not in err and stdout == ""
    assert list(tmp_path.iterdir()) == [broken]  # no output, not even a partial one


def test_output_folder_vanishing_during_the_render_exits_1(tmp_path, capsys, monkeypatch):
    """The output is checked before rendering; a folder removed meanwhile is a run-time failure."""
    import shutil

    folder = tmp_path / "out"
    folder.mkdir()
    render_run = clrender.trace.renderer.Renderer.run

    def run_then_remove_the_folder(self):
        result = render_run(self)
        shutil.rmtree(folder)
        return result

    monkeypatch.setattr(clrender.trace.renderer.Renderer, "run", run_then_remove_the_folder)
    code, stdout, err = run_cli(capsys, "-q", "render", "refract1", "--width", "8", "--height", "6", "-o", str(folder / "x.png"))
    assert code == 1, err
    assert err.startswith("clrender: ") and err.count("\n") == 1 and "Traceback" not in err, err
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ devices, --list, --filter


def test_devices_lists_every_device_and_stars_the_default(capsys):
    from clrender.device import get_device, list_devices

    code, out, err = run_cli(capsys, "devices")
    assert code == 0 and err == ""
    lines = [line.split("  [")[0] for line in out.splitlines()]  # a CPU device's cached speed follows in brackets
    assert [line[2:] for line in lines] == list_devices()
    starred = [line[2:] for line in lines if line.startswith("* ")]
    assert starred == [get_device().name]
    assert all(line.startswith(("* ", "  ")) for line in lines)


def test_devices_with_an_unknown_device_exits_2(capsys):
    code, out, err = run_cli(capsys, "devices", "--device", "no-such-device-anywhere")
    assert code == 2 and "no OpenCL device matches 'no-such-device-anywhere'" in err


def test_render_list_prints_the_bundled_scenes(tmp_path, capsys, monkeypatch):
    from pathlib import Path

    monkeypatch.chdir(tmp_path)
    code, out, err = run_cli(capsys, "render", "--list")
    assert code == 0
    shipped = {p.stem for p in (Path(__file__).resolve().parents[2] / "scenes").glob("*.toml")}
    assert {"refract1", "refract2", "bunny", "wizard_cat"} <= shipped
    # one line per scene, "name: description", then its cameras indented
    listed = [line.split(":")[0] for line in out.splitlines() if line[:1].isalnum()]
    assert sorted(listed) == sorted(shipped)
    assert list(tmp_path.iterdir()) == []  # nothing rendered


def read_float(path):
    inp = oiio.ImageInput.open(str(path))
    spec = inp.spec()
    pixels = np.asarray(inp.read_image(0, 0, 0, spec.nchannels, "float")).reshape(spec.height, spec.width, -1)
    inp.close()
    return pixels


def test_filters_apply_in_order_to_the_render(tmp_path, capsys):
    out = tmp_path / "f.exr"
    filters = ("--filter", "brighten_2", "--filter", "box_blur_3")
    # --aa none: the Python default (the command line's is the scene's `aa`)
    code, _, err = run_cli(capsys, "-q", "render", "refract1", "--aa", "none", "--width", "20", "--height", "15", *filters, "-o", str(out))
    assert code == 0, err
    image = 2.0 * render("refract1", width=20, height=15).astype(np.float64)
    padded = np.pad(image, ((1, 1), (1, 1), (0, 0)), mode="reflect")  # numpy's reflect is reflect-101
    blurred = sum(padded[dy : dy + 15, dx : dx + 20] for dy in range(3) for dx in range(3)) / 9
    np.testing.assert_allclose(read_float(out), blurred, rtol=1e-5, atol=1e-6)


def test_unknown_filter_is_refused_before_rendering(tmp_path, capsys, monkeypatch):
    def no_render(*args, **kwargs):
        raise AssertionError("rendered before checking the filter")

    monkeypatch.setattr(clrender.trace.renderer.Renderer, "__init__", no_render)
    code, _, err = run_cli(capsys, "render", "refract1", "--filter", "sharpen_3", "-o", str(tmp_path / "x.png"))
    assert code == 2 and err.startswith("clrender: ") and "sharpen_3" in err
    assert list(tmp_path.iterdir()) == []
