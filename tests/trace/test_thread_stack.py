"""Driver threads get a stack that holds a work-group's private state (clrender/thread_stack.py; issue 38,
defect 0): a process started under `ulimit -s unlimited`, where glibc gives new threads 2 MiB, still renders
the instanced BLEND path kernel on PoCL at its default 64-item groups (it crashed there with a segmentation
fault, reproduced with PoCL 3.1 before the fix)."""

import os
import resource
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from clrender.thread_stack import DRIVER_THREAD_STACK

ROOT = Path(__file__).resolve().parents[2]


def unlimited_stack():
    resource.setrlimit(resource.RLIMIT_STACK, (resource.RLIM_INFINITY, resource.RLIM_INFINITY))


def run_unlimited(code: str, **env) -> subprocess.CompletedProcess:
    """`code` in a fresh Python whose stack limit is unlimited (the container case)."""
    _, hard = resource.getrlimit(resource.RLIMIT_STACK)
    if hard != resource.RLIM_INFINITY:
        pytest.skip("the hard stack limit is finite here: a child cannot start with an unlimited one")
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        cwd=ROOT,
        env={**os.environ, **env},
        preexec_fn=unlimited_stack,
        capture_output=True,
        text=True,
        timeout=900,
    )


def test_glibc_gives_threads_two_mib_under_an_unlimited_stack_limit():
    """The condition the fix answers: without clrender, new threads get 2 MiB (glibc's x86-64 default)."""
    child = run_unlimited("from clrender.thread_stack import default_thread_stack; print(default_thread_stack())")
    if child.stdout.strip() == "None":
        pytest.skip("not glibc: the default thread stack cannot be read")
    assert int(child.stdout) < DRIVER_THREAD_STACK, child.stdout


def test_importing_the_device_module_raises_the_driver_thread_stack():
    child = run_unlimited("import clrender.device\nfrom clrender.thread_stack import default_thread_stack\nprint(default_thread_stack())")
    assert child.returncode == 0, child.stderr
    if child.stdout.strip() == "None":
        pytest.skip("not glibc: the default thread stack cannot be read")
    assert int(child.stdout) >= DRIVER_THREAD_STACK


RENDER = """
    import sys, tempfile
    from pathlib import Path
    import numpy as np
    import pyopencl as cl
    from clrender.device import _cannot_compile, _describe, cpu_devices, get_device
    from clrender.trace.renderer import Renderer
    from tests.scenetools import copies_scene

    pocl = [d for d in cpu_devices() if "portable computing language" in d.platform.name.lower() and _cannot_compile(d) is None]
    if not pocl:
        print("no PoCL CPU device compiles here"); sys.exit(3)
    get_device(_describe(pocl[0]))
    import os; os.environ["CLRENDER_DEVICE"] = _describe(pocl[0])
    material = {"diffuse": [0.8, 0.7, 0.6], "alpha": {"mode": "blend", "factor": 0.5}}
    scene = copies_scene(Path(tempfile.mkdtemp()), 12, material=material)
    image = Renderer(scene, integrator="path", spp=2, width=48, height=36, instancing=True).run().image
    print(np.isfinite(image).all() and image.max() > 0)
"""


@pytest.mark.slow
def test_instanced_blend_path_render_on_pocl_under_an_unlimited_stack_limit():
    child = run_unlimited(RENDER)
    if child.returncode == 3:
        pytest.skip(child.stdout.strip())
    assert child.returncode == 0, (child.returncode, child.stderr[-2000:])
    assert child.stdout.strip().splitlines()[-1] == "True"
