"""Shared fixtures: every test that runs a kernel takes `device`.

Devices: `device` is the default CPU driver (docs/command-line.md, "Devices") unless $CLRENDER_DEVICE names another
(a substring of "<platform>: <device>").
$CLRENDER_TEST_DEVICES, a comma-separated list of such substrings, runs every test that takes `device` once per
device listed (ids `[dev-nvidia]`, ...), e.g. CLRENDER_TEST_DEVICES=nvidia,portable on a GPU machine.  Tests that
reach a device implicitly (Renderer() without a device, `python -m clrender` in a subprocess) follow
$CLRENDER_DEVICE; when exactly one test device is listed and $CLRENDER_DEVICE is unset, it is set to that one,
so the whole suite runs there.

Hypothesis profiles for the fuzz tests (tests/*/test_fuzz_*.py):
    ci    (default) a few hundred examples across all fuzz tests, no per-example deadline
    long  pytest --hypothesis-profile=long: at least 10,000 examples per scene fuzzer, 2,000+ CLI cases
A fuzz test that wants fewer examples than the profile gives under ci asks for
`min(n, settings().max_examples)` only when `settings.get_current_profile_name() == "ci"`.
"""

import os

import pytest

from clrender.device import get_device
from clrender.trace.knobs import TraceKnobs
from clrender.trace.variant import Variant

TEST_DEVICES = [spec.strip() for spec in os.environ.get("CLRENDER_TEST_DEVICES", "").split(",") if spec.strip()]
if len(TEST_DEVICES) == 1:
    os.environ.setdefault("CLRENDER_DEVICE", TEST_DEVICES[0])

try:
    from hypothesis import HealthCheck, settings

    settings.register_profile(
        "ci", deadline=None, print_blob=True, derandomize=True, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
    )
    settings.register_profile("long", deadline=None, print_blob=True, max_examples=10_000, suppress_health_check=list(HealthCheck))
    settings.load_profile("ci")
except ImportError:  # hypothesis is in the `test` extra; without it the fuzz tests skip themselves
    pass


def pytest_generate_tests(metafunc):
    # only when devices are listed: by default the test ids stay as they are, without a [device] suffix
    if TEST_DEVICES and "device" in metafunc.fixturenames:
        metafunc.parametrize("device", TEST_DEVICES, ids=[f"dev-{spec}" for spec in TEST_DEVICES], indirect=True, scope="session")


@pytest.fixture(scope="session")
def device(request):
    """The Device for this test: one of $CLRENDER_TEST_DEVICES, else $CLRENDER_DEVICE, else the default CPU driver."""
    return get_device(getattr(request, "param", None))


@pytest.fixture
def rng():
    import numpy as np

    return np.random.default_rng(12345)


# The slowest kernel builds a whole run of the suite makes, as clrender.trace.variant.Variant switches (the Tracer's
# defaults otherwise; `extra`: test-only and film defines), the slowest first.  A driver's compiler uses one core, so a
# run of many tests builds these first on every core at once (clrender/warmup.py, --jobs): on an empty pyopencl
# cache, as in CI, that halves their compile time on two cores, and on a warm cache each loads in a fraction of a
# second.  A build missing here is still made when a test needs it; tests/cli/test_warmup.py checks that every
# `extra` define is one the kernels read.
TINY_STACKS = TraceKnobs(stack_size=2)  # the stack-overflow fallback's tests
SUITE_BUILDS = (
    dict(filename="path.cl", render=True, instanced=True, top_wide=True),
    dict(filename="path.cl", render=True, alpha_test=True),
    dict(render=True, alpha_test=True),
    dict(knobs=TINY_STACKS),
    dict(bvh_width=4),
    dict(render=True, cull_backfaces=True),
    dict(filename="path.cl", render=True, extra=(("SPLAT_FILTER", 1), ("SPLAT_RADIUS", 1))),
    dict(filename="path.cl", render=True, extra=(("SPLAT_FILTER", 2), ("SPLAT_RADIUS", 2))),
    dict(render=True),
    dict(bvh_width=4, knobs=TINY_STACKS),
    dict(bvh_width=4, count_prim_tests=True),
    dict(ray_packets=False),
    dict(filename="path.cl", render=True, extra=(("ENV_BSDF", 1), ("ENV_NEE", 0))),
    dict(filename="path.cl", render=True, extra=(("AREA_BSDF", 0),)),
    dict(filename="path.cl", render=True, extra=(("AREA_NEE", 0),)),
    dict(filename="path.cl", render=True, extra=(("HIDE_EMITTERS", 1),)),
    dict(bvh_width=2),
    dict(filename="path.cl", render=True, cull_backfaces=True),
    dict(render=True, instanced=True, top_wide=True),
    dict(bvh_width=4, use_bvh=False),
    dict(render=True, use_bvh=False),
    dict(bvh_width=2, count_prim_tests=True),
    dict(render=True, write_aov=True),
    dict(use_bvh=False),
    dict(bvh_width=2, knobs=TINY_STACKS),
    dict(filename="path.cl", render=True, write_aov=True),
    dict(),
    dict(filename="path.cl", render=True),
    dict(bvh_width=4, use_bvh=False, knobs=TINY_STACKS),
)
WARM_AHEAD = {"seconds": 0.0, "count": 0}


def suite_builds(dev) -> list:
    """SUITE_BUILDS as Variants for `dev` (its work layout's rays per work-item)."""
    from clrender.trace.work_layout import work_layout

    per_item = work_layout(dev.device).rays_per_item
    return [Variant(**{"rays_per_item": per_item, **switches, **path_sampler(switches)}) for switches in SUITE_BUILDS]


def path_sampler(switches: dict) -> dict:
    """A path.cl build's `extra` with the define of the default path sampler (integrators.PathIntegrator.variant)."""
    from clrender.layout import PATH_SAMPLERS
    from clrender.trace.renderer import RenderSettings

    name = RenderSettings().path_sampler
    if switches.get("filename") != "path.cl" or name == "independent":
        return {}
    return {"extra": tuple(sorted(switches.get("extra", ()) + (("PATH_SAMPLER", PATH_SAMPLERS[name]),)))}


def pytest_collection_finish(session):
    files = {item.path for item in session.items}  # a run of the suite or much of it, not of a file or a few
    if len(files) < 40 or session.config.option.collectonly or os.environ.get("CLRENDER_TEST_WARMUP") == "0":
        return
    if len(TEST_DEVICES) > 1 or (os.cpu_count() or 1) < 2:
        return
    import io
    import time

    from clrender.warmup import warm

    start = time.perf_counter()
    dev = get_device()
    warm(dev, suite_builds(dev), out=io.StringIO(), jobs=os.cpu_count())
    WARM_AHEAD.update(seconds=time.perf_counter() - start, count=len(SUITE_BUILDS))


def pytest_terminal_summary(terminalreporter, config):
    """pytest-randomly shows its seed in the header, which -q hides: say it last, where a failure is read."""
    if WARM_AHEAD["seconds"] > 10:
        count, seconds = WARM_AHEAD["count"], WARM_AHEAD["seconds"]
        terminalreporter.write_line(f"{count} kernel variants built ahead on {os.cpu_count()} processes in {seconds:.0f} s")
    seed = getattr(config.option, "randomly_seed", None)
    if config.pluginmanager.hasplugin("randomly") and isinstance(seed, int):
        terminalreporter.write_line(f"tests in random order: replay with --randomly-seed={seed} (-p no:randomly: file order)")
