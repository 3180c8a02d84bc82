"""Same bits on two independent OpenCL implementations: kernels/mathf.h's functions, and path-traced images,
on the test device (Intel's CPU runtime or PoCL) and on Oclgrind, the simulator (its own compiler and its own
float semantics: it interprets LLVM IR on the host's IEEE float32 operations).

Before mathf.h the path tracer's images differed in the last bits on 30% of the pixels of the scene below
between Intel's runtime and Oclgrind (their sin, cos, exp, atan2 differ, and contraction of a * b + c into fma
was each compiler's choice).

Oclgrind runs in a child process (it reports on stderr, and its build options come from its environment):
Oclgrind 21.10's interpreter lacks the intrinsics llvm.sqrt.f32 (clang's __builtin_sqrtf, common.h's sqrt_f)
and llvm.experimental.noalias.scope.decl (forced inlining), so it builds with -D__builtin_sqrtf=sqrt (its sqrt
builtin is the correctly rounded one: the same bits) and -fno-inline (which changes no result).  Skipped where
Oclgrind is not installed."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from clrender.drivers import oclgrind_installed

ROOT = Path(__file__).resolve().parents[2]
OCLGRIND_OPTIONS = "-D__builtin_sqrtf=sqrt -fno-inline"

pytestmark = pytest.mark.skipif(not oclgrind_installed(), reason="the Oclgrind OpenCL platform is not installed")

PROBE_ARGS = """
import numpy as np
from tests.kernels.test_mathf import arguments, atan2_arguments
def probe_args(n):
    return {name: (arguments(name, n), None) for name in ("sin", "cos", "exp", "log", "acos", "asin")} | {"atan2": atan2_arguments(n)}
"""

PATH_SCENE = """
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer
from tests.reference import path_scenes
def path_image(device):
    scene = Scene.from_dict(path_scenes.cornell_box(8))
    return Renderer(scene, tracer=Tracer(scene, device=device), integrator="path", spp=2, width=8, height=8, seed=3).run().image
"""


def under_oclgrind(code: str, out: Path) -> np.ndarray:
    env = dict(os.environ, CLRENDER_DEVICE="oclgrind", PYOPENCL_NO_CACHE="1", OCLGRIND_BUILD_OPTIONS=OCLGRIND_OPTIONS)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    script = "from clrender.device import get_device\ndev = get_device('oclgrind')\n" + textwrap.dedent(code)
    result = subprocess.run([sys.executable, "-c", script], env=env, cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "Oclgrind - " not in result.stderr and "FATAL" not in result.stderr, result.stderr[-2000:]
    return np.load(out)


def not_oclgrind(device):
    if "oclgrind" in device.name.lower():
        pytest.skip("the test device is Oclgrind itself")


def test_mathf_same_bits_on_oclgrind(device, tmp_path):
    from clrender.mathf_probe import evaluate

    not_oclgrind(device)
    exec(PROBE_ARGS, namespace := {})
    args = namespace["probe_args"](1 << 9)
    here = np.concatenate([evaluate(name, a, b, device=device) for name, (a, b) in args.items()])
    out = tmp_path / "probe.npy"
    code = (
        PROBE_ARGS
        + f"""
from clrender.mathf_probe import evaluate
args = probe_args({1 << 9})
np.save({str(out)!r}, np.concatenate([evaluate(name, a, b, device=dev) for name, (a, b) in args.items()]))
"""
    )
    there = under_oclgrind(code, out)
    assert np.array_equal(here.view(np.uint32), there.view(np.uint32)), f"{np.sum(here.view(np.uint32) != there.view(np.uint32))} differ"


@pytest.mark.slow
def test_path_image_same_bits_on_oclgrind(device, tmp_path):
    not_oclgrind(device)
    exec(PATH_SCENE, namespace := {})
    here = namespace["path_image"](device)
    out = tmp_path / "path.npy"
    there = under_oclgrind(PATH_SCENE + f"\nimport numpy as np\nnp.save({str(out)!r}, path_image(dev))\n", out)
    assert here.mean() > 0.05  # a lit image, not two blank ones
    assert np.array_equal(here.view(np.uint32), there.view(np.uint32)), f"{np.mean(np.any(here != there, axis=-1)):.1%} of pixels differ"
