"""A Tracer's peak memory (docs/bvh.md, "Memory"): building one over a generated mesh grows the process's
resident high-water mark by well under the 580 bytes a triangle it took before the host copies went,
and under memory.py's per-triangle estimate.  Measured in a
fresh subprocess (the peak, VmHWM, is reset just before the Tracer is made) on PoCL's CPU device,
whose buffers are host memory too."""

import json
import subprocess
import sys

import pytest

from clrender import memory

SCRIPT = """
import gc, json, sys
import numpy as np
from clrender.device import get_device
from clrender.scene.meshes import dense_mesh
from clrender.trace.tracer import Tracer

def status(key):
    for line in open("/proc/self/status"):
        if line.startswith(key):
            return int(line.split()[1]) * 1024

dev = get_device("portable")
warm = Tracer(dense_mesh(2000, seed=1), device=dev)  # kernels built, driver pools warm: a cold kernel cache would
warm.intersect(np.zeros((64, 3)), np.ones((64, 3)))  # put the query kernel's compile (LLVM's memory) into the peak
del warm
mesh = dense_mesh(int(sys.argv[1]), seed=1)
v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
del mesh
gc.collect()
with open("/proc/self/clear_refs", "w") as clear:
    clear.write("5")  # VmHWM := VmRSS
base = status("VmRSS:")
tracer = Tracer((v, f), device=dev)
t, _, _ = tracer.intersect(np.zeros((64, 3)), np.random.default_rng(0).normal(size=(64, 3)))
print(json.dumps(dict(triangles=len(f), growth=status("VmHWM:") - base, peak=status("VmHWM:"), hits=int(np.isfinite(t).sum()))))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc/self/status")
def test_a_tracer_over_400k_triangles_stays_under_300_bytes_a_triangle():
    from clrender.device import get_device
    from clrender.errors import RenderFailure

    try:  # PoCL's buffers are host memory, what the peak measures; PoCL 3.0 compiles nothing on some CPUs (AMD Zen 5)
        get_device("portable").build("__kernel void probe(__global int *a) { a[0] = 1; }", "probe")
    except RenderFailure as exc:
        pytest.skip(str(exc))
    run = subprocess.run([sys.executable, "-c", SCRIPT, "400000"], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    got = json.loads(run.stdout.strip().splitlines()[-1])
    assert got["hits"] == 64  # rays from the centre of the closed blob all hit it
    per_triangle = got["growth"] / got["triangles"]
    # measured 261 B (5.2 M triangles: 170 B); before the host copies were dropped, 580 B
    assert per_triangle < 300, per_triangle
    # memory.py's estimate: BASE_BYTES for the process itself, BYTES_PER_TRIANGLE for what the Tracer adds.  The base
    # depends on the driver (a render's whole process peaks at 251 MB on Intel's runtime, 610 MB on Debian's PoCL 3.1,
    # which compiles in-process with a shared LLVM 15), so the per-triangle part is held against the Tracer's growth
    assert got["growth"] < got["triangles"] * memory.BYTES_PER_TRIANGLE
