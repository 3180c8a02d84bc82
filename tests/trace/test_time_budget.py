"""--time-budget says what it did and never overflows: the pass counter, the progress bar's seconds left, the
summary's spp and passes (issue 37; issue 38, item 10: pass 2049 at --spp 1048576 raised OverflowError)."""

import itertools
import types

import numpy as np
import pytest

import clrender.trace.integrators as integrators_module
import clrender.trace.renderer as renderer_module
from clrender.errors import RenderWarning, UsageError
from clrender.layout import ID_RECORD_DTYPE
from clrender.scene.scene import Scene
from clrender.trace.path import path_params
from clrender.trace.renderer import MAX_SPP, Renderer
from clrender.trace.tracer import Tracer

from tests.clitools import run_cli

LIT = {
    "width": 4,
    "height": 3,
    "objects": [{"type": "sphere", "center": [0, 0, -5], "radius": 1}],
    "lights": [{"type": "point", "position": [0, 5, 0]}],
}


def path_renderer(device, **settings):
    scene = Scene.from_dict(LIT)
    return Renderer(scene, tracer=Tracer(scene, device=device), integrator="path", max_depth=0, **settings)


@pytest.fixture
def ticking_clock(monkeypatch):
    """The renderer's clock reads 0.1 s later at every reading: a budget allows a known number of passes."""
    ticks = itertools.count()
    clock = types.SimpleNamespace(perf_counter=lambda: 0.1 * next(ticks))
    monkeypatch.setattr(renderer_module, "time", clock)
    monkeypatch.setattr(integrators_module, "time", clock)  # the path integrator's passes


def fake_launch(seen):
    """A Renderer.launch that packs the real PathParams record (where the overflow was) and traces nothing."""

    def launch(self, pixels, sampler, n, record, first_sample=0):
        k = len(pixels)
        seen.append(int(path_params(self.integrator, self.frame(k, sampler, n, record), first_sample)["first_sample"]))
        shadow = np.ones((k, self.n_lights), np.float32)
        return np.ones((k, 4), np.float32), np.full(k, -1, ID_RECORD_DTYPE), shadow, np.zeros((k, 2), np.uint32), None

    return launch


def test_passes_past_two_to_the_31_paths_a_pixel_keep_counting_and_stop_at_two_to_the_32(device, ticking_clock, monkeypatch):
    """At --spp 2**20 under a budget that never runs out, pass 2049 starts at path 2**31 (an int32 overflowed there):
    every pass's first sample reaches the kernel exactly, and the passes stop, with a warning, at 2**32 paths a pixel,
    the most the kernels' 32-bit sample counter numbers (4096 passes)."""
    renderer = path_renderer(device, spp=MAX_SPP, width=1, height=1, time_budget=1e12)
    seen = []
    monkeypatch.setattr(Renderer, "launch", fake_launch(seen))
    with pytest.warns(RenderWarning, match=r"stopped at 4294967296 paths a pixel"):
        result = renderer.run()
    assert seen == [i * MAX_SPP for i in range(4096)]
    assert result.passes == 4096 and result.samples_per_pixel == 2**32


def test_a_first_sample_the_kernel_cannot_number_is_refused(device):
    renderer = path_renderer(device, spp=4, width=1, height=1)
    frame = renderer.frame(1, "random", 1, True)
    assert path_params(renderer.integrator, frame, 2**32 - 4)["first_sample"] == 2**32 - 4
    with pytest.raises(UsageError, match=r"first sample 4294967293 is not allowed; allowed: 0 to 2\*\*32 - spp \(4\)"):
        path_params(renderer.integrator, frame, 2**32 - 3)


def test_the_progress_bar_of_a_budgeted_render_shows_the_seconds_left(device, ticking_clock, monkeypatch):
    labels = []
    real = renderer_module.progress
    monkeypatch.setattr(renderer_module, "progress", lambda items, desc=None, **kw: labels.append(desc) or real(items, desc=desc, **kw))
    result = path_renderer(device, spp=1, time_budget=1.0).run()
    assert len(labels) == result.passes >= 2
    # the clock ticks 0.1 s a reading: pass 1 starts at 0.1 s of 1.0 (0.9 s left, shown as 1s)
    assert labels[0] == "pass 1, 1s left" and all(label.startswith(f"pass {i + 1}, ") and label.endswith("s left") for i, label in enumerate(labels))


def test_the_summary_says_the_spp_reached_and_the_passes_run(ticking_clock, capsys, tmp_path):
    scene = tmp_path / "lit.toml"
    scene.write_text(
        'width = 4\nheight = 3\n[[objects]]\ntype = "sphere"\ncenter = [0, 0, -5]\nradius = 1\n[[lights]]\ntype = "point"\nposition = [0, 5, 0]\n'
    )
    code, _, err = run_cli(capsys, "render", str(scene), "--integrator", "path", "--spp", "3", "--time-budget", "1", "-o", str(tmp_path / "a.png"))
    assert code == 0, err
    passes = int(err.split(" spp in ")[1].split()[0])
    assert passes >= 2 and f"{3 * passes} spp in {passes} passes of 3" in err
