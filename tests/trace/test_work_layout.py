"""The work layout (clrender/trace/work_layout.py): rays per work-item and work-group size, chosen from
what the device reports, change the speed and nothing else.  Every layout gives the same t bits,
primitives, objects and occluded flags for the same rays (coherent packets, incoherent pairs, a
count that leaves a partial work-group and a partial packet), and the same rendered image bits."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene.meshes import dense_mesh
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer
from clrender.trace.work_layout import ENV, GPU, POCL, SCALAR_CPU, WorkLayout, choose, parse, work_layout


def assert_same_hits(a, b, what):
    """Bit for bit: t's float32 bits, primitive ids and object ids."""
    for name, x, y in zip(("t", "primitive", "object"), a, b):
        np.testing.assert_array_equal(np.asarray(x).view(np.uint32), np.asarray(y).view(np.uint32), err_msg=f"{what}: {name}")


LAYOUTS = [WorkLayout(8, 64), WorkLayout(8, 8), WorkLayout(8, 1), WorkLayout(1, 64), WorkLayout(1, 1)]
CPU, GPU_TYPE = 2, 4  # cl.device_type bits


def test_layout_follows_what_the_device_reports():
    assert choose(CPU, 16, 4096) == POCL  # PoCL: explicit vectors wanted
    assert choose(CPU, 1, 8192) == SCALAR_CPU  # Intel's CPU runtime: it vectorises across work-items itself
    assert choose(GPU_TYPE, 1, 1024) == GPU
    assert (POCL.rays_per_item, POCL.local_size) == (8, 64)  # the measured PoCL layout, as before
    small = choose(CPU, 16, 32)  # a device that takes fewer work-items a group
    assert (small.rays_per_item, small.local_size) == (8, 32)


def test_environment_overrides_and_refuses_bad_values(monkeypatch, device):
    monkeypatch.setenv(ENV, "1:16")
    assert (work_layout(device.device).rays_per_item, work_layout(device.device).local_size) == (1, 16)
    for bad in ("2:64", "8", "8:0", "a:b", "8:4096"):
        with pytest.raises(UsageError, match=ENV):
            parse(bad)


def query_rays(n, seed=0):
    """Camera-like coherent rays (most groups of 8 form packets) and random incoherent ones."""
    rng = np.random.default_rng(seed)
    side = int(np.sqrt(n // 2))
    u, v = np.meshgrid(np.linspace(-0.3, 0.3, side), np.linspace(-0.3, 0.3, side))
    coherent = np.stack([u.ravel(), v.ravel(), -np.ones(u.size)], 1)
    incoherent = rng.normal(size=(n - u.size + 37, 3))  # a count that is no multiple of 8 or of a group
    d = np.concatenate([coherent, incoherent]).astype(np.float32)
    o = np.where(np.arange(len(d))[:, None] < u.size, [0.0, 0.0, 3.0], [0.05, -0.02, 0.1]).astype(np.float32)
    return o, d


@pytest.mark.parametrize("width", [8, 2])
def test_every_layout_answers_queries_alike(device, width):
    mesh = dense_mesh(3000, seed=3)
    o, d = query_rays(1600)
    t_max = np.random.default_rng(1).uniform(0.2, 3.0, len(d)).astype(np.float32)
    answers = []
    for layout in LAYOUTS:
        tracer = Tracer(mesh, device=device, bvh_width=width)
        tracer.layout = layout
        hits = tracer.intersect(o, d, t_min=1e-4)
        answers.append((layout, hits, tracer.occluded(o, d, t_max)))
    assert 0.5 < np.isfinite(answers[0][1][0]).mean() < 1 and 0.1 < answers[0][2].mean() < 0.9  # both answers exercised
    for layout, hits, occluded in answers[1:]:
        assert_same_hits(answers[0][1], hits, f"{layout}")
        np.testing.assert_array_equal(answers[0][2], occluded, err_msg=f"{layout}: occluded")


def test_rendered_bits_do_not_depend_on_the_layout(device):
    scene = Scene.load("wizard_cat")
    images = []
    for layout in (WorkLayout(8, 64), WorkLayout(8, 8), WorkLayout(1, 1)):
        tracer = Tracer(scene, device=device)
        tracer.layout = layout
        images.append(Renderer(scene, tracer=tracer, width=40, height=30, camera=3, aa="full", samples=2, seed=1).run().image)
    for image in images[1:]:
        np.testing.assert_array_equal(images[0].view(np.uint32), image.view(np.uint32))
