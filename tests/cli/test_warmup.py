"""Kernel compiles: `clrender warmup` builds the very programs renders use, and a slow build says so on stderr once."""

import re
import time
import types

import pytest

import clrender.device as device_module
from clrender import progress
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer, RenderSettings

from tests.clitools import run_cli

SPHERE = {
    "width": 4,
    "height": 3,
    "objects": [{"type": "sphere", "center": [0, 0, -5], "radius": 1}],
    "lights": [{"type": "point", "position": [0, 5, 0]}],
}


def test_warmup_lists_every_variant_a_render_can_reach(capsys):
    """1 BVH builder; 5 Tracer states (BVH or not x flat, instanced, instanced with a wide top tree, which needs a
    BVH), each with the ray queries' build and 2 integrators x 2^3 flag sets (AOVs, alpha test, culling): 86."""
    code, out, err = run_cli(capsys, "warmup", "--list")
    assert code == 0, err
    labels = out.splitlines()
    assert len(labels) == 1 + 5 * (1 + 2 * 8) == len(set(labels))
    assert sum(label.startswith("path, ") for label in labels) == 40 and sum(label.startswith("whitted, ") for label in labels) == 40
    assert "path, bvh, instanced, wide top, aovs, alpha test, back-face culling" in labels
    assert not any("no bvh, instanced, wide top" in label for label in labels)


def test_warmup_refuses_an_only_that_matches_nothing(capsys):
    code, out, err = run_cli(capsys, "warmup", "--only", "nonesuch")
    assert code == 2 and err == "clrender: --only 'nonesuch' matches no variant; `clrender warmup --list` names them\n" and out == ""


def test_warmup_builds_the_program_a_render_then_uses(device, capsys, monkeypatch):
    """On a fresh Device (its own program cache), warming one variant leaves the render nothing of trace.cl to build."""
    monkeypatch.setattr(device_module, "_DEVICES", {})
    code, out, err = run_cli(capsys, "-q", "warmup", "--only", "whitted, bvh, flat, plain")
    assert code == 0, err
    assert out.endswith("s  whitted, bvh, flat, plain\n") and len(out.splitlines()) == 1
    fresh = device_module.get_device()
    warmed = {key for key in fresh._programs if key[0] == "trace.cl"}
    assert len(warmed) == 1
    Renderer(Scene.from_dict(SPHERE), device=None).run()
    rendered = {key for key in fresh._programs if key[0] == "trace.cl" and ("WRITE_AOV", 0) in key[1]}
    assert rendered == warmed


def test_warmup_builds_the_path_program_a_default_render_then_uses(device, capsys, monkeypatch):
    """The path tracer's variants are built as a render under the default settings builds them: its sampler and film
    defines, and on a CPU the lane kernel's LANES (render_path_lanes)."""
    monkeypatch.setattr(device_module, "_DEVICES", {})
    code, out, err = run_cli(capsys, "-q", "warmup", "--only", "path, bvh, flat, plain")
    assert code == 0, err
    fresh = device_module.get_device()
    warmed = {key for key in fresh._programs if key[0] == "path.cl"}
    assert len(warmed) == 1
    Renderer(Scene.from_dict(SPHERE), device=None, settings=RenderSettings(integrator="path", spp=1)).run()
    assert {key for key in fresh._programs if key[0] == "path.cl"} == warmed


@pytest.fixture
def slow_build(monkeypatch):
    """cl.Program whose build takes 0.3 s; the notice due after 0.05 s; no notice said yet in this process."""

    class Program:
        def __init__(self, context, source):
            pass

        def build(self, options, cache_dir=None):
            time.sleep(0.3)
            return self

    monkeypatch.setattr(device_module, "cl", types.SimpleNamespace(Program=Program, RuntimeError=RuntimeError))
    monkeypatch.setattr(device_module, "COMPILE_NOTICE_SECONDS", 0.05)
    monkeypatch.setattr(device_module, "_compile_notice", {"said": False, "open": 0})
    monkeypatch.setattr(progress, "SHOW", None)


def test_a_slow_build_says_once_that_kernels_are_compiling(device, slow_build, capsys):
    for _ in range(2):
        device.build("__kernel void k(void) {}", "k.cl")
    time.sleep(0.1)  # a late timer would have fired by now
    err = capsys.readouterr().err
    assert err == f"clrender: compiling kernels for {device.name} (first run; cached afterwards)...\n"


def test_a_fast_build_or_quiet_says_nothing(device, slow_build, capsys, monkeypatch):
    monkeypatch.setattr(device_module, "COMPILE_NOTICE_SECONDS", 5.0)  # a cached build ends before the notice is due
    device.build("__kernel void k(void) {}", "k.cl")
    monkeypatch.setattr(device_module, "COMPILE_NOTICE_SECONDS", 0.05)
    monkeypatch.setattr(progress, "SHOW", False)  # -q
    device.build("__kernel void k(void) {}", "k.cl")
    time.sleep(0.1)
    assert capsys.readouterr().err == ""


def test_python_m_clrender_warmup_is_the_subcommand(capsys):
    import subprocess
    import sys

    proc = subprocess.run([sys.executable, "-m", "clrender.warmup", "--list"], capture_output=True, text=True, timeout=120)
    code, out, err = run_cli(capsys, "warmup", "--list")
    assert proc.returncode == code == 0, proc.stderr
    assert proc.stdout == out


def test_every_build_the_suite_makes_ahead_is_a_variant_whose_extra_defines_the_kernels_read():
    """A renamed switch or define would leave conftest.SUITE_BUILDS compiling variants no test uses."""
    from clrender.device import kernel_dir
    from clrender.trace.variant import Variant

    from tests.conftest import SUITE_BUILDS

    variants = [Variant(**switches) for switches in SUITE_BUILDS]  # an unknown switch is a TypeError
    source = "".join(path.read_text() for path in kernel_dir().glob("*.[ch]*"))
    code = re.sub(r"/\*.*?\*/|//[^\n]*", " ", source, flags=re.S)  # a name left only in a comment is read by nothing
    named = {name for variant in variants for name, _ in variant.extra}
    assert named and not {name for name in named if not re.search(rf"\b{name}\b", code)}
    assert not re.search(r"\bRR_DEPTH\b", code)  # a field of PathParams now: no build per Russian-roulette depth


def test_warmup_refuses_jobs_below_one(capsys):
    code, out, err = run_cli(capsys, "warmup", "--jobs", "0")
    assert code == 2 and err.startswith("clrender: ") and "--jobs" in err and "1 or more" in err and out == ""


@pytest.mark.slow
def test_warmup_on_two_processes_builds_what_a_render_then_loads(device, capsys, monkeypatch):
    """The processes fill pyopencl's cache; the parent then loads each program and prints the processes' build seconds."""
    monkeypatch.setattr(device_module, "_DEVICES", {})
    code, out, err = run_cli(capsys, "-q", "warmup", "--only", "ray queries, bvh", "--jobs", "2")
    assert code == 0, err
    assert [line.split("s  ", 1)[1] for line in out.splitlines()] == [
        "ray queries, bvh, flat",
        "ray queries, bvh, instanced",
        "ray queries, bvh, instanced, wide top",
    ]
    fresh = device_module.get_device()
    assert sum(key[0] == "trace.cl" for key in fresh._programs) == 3
