"""Shared fixtures: every test that runs a kernel takes `device`.

Devices: `device` is PoCL's CPU unless $CLRENDER_DEVICE names another (a substring of "<platform>: <device>").
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
    """The Device for this test: one of $CLRENDER_TEST_DEVICES, else $CLRENDER_DEVICE, else PoCL's CPU."""
    return get_device(getattr(request, "param", None))


@pytest.fixture
def rng():
    import numpy as np

    return np.random.default_rng(12345)


# The kernel variants a whole run of the suite builds (`clrender warmup --list` names them), the slowest first.
# A driver's compiler uses one core, so a run of many tests builds these first on every core at once
# (clrender/warmup.py, --jobs): on an empty pyopencl cache, as in CI, that halves the compile time on two
# cores; on a warm cache each is loaded in a fraction of a second.  A variant missing here is still built
# when a test needs it; tests/cli/test_warmup.py checks that every label names a variant.
SUITE_VARIANTS = ()
WARM_AHEAD = {"seconds": 0.0, "count": 0}


def pytest_collection_finish(session):
    if len(session.items) < 100 or session.config.option.collectonly or os.environ.get("CLRENDER_TEST_WARMUP") == "0":
        return
    if len(TEST_DEVICES) > 1 or (os.cpu_count() or 1) < 2:
        return
    import io
    import time

    from clrender.warmup import variants, warm

    start = time.perf_counter()
    dev = get_device()
    chosen = [v for v in variants(dev) if v.label in SUITE_VARIANTS]
    warm(dev, chosen, out=io.StringIO(), jobs=min(len(chosen), os.cpu_count()))
    WARM_AHEAD.update(seconds=time.perf_counter() - start, count=len(chosen))


def pytest_terminal_summary(terminalreporter, config):
    """pytest-randomly shows its seed in the header, which -q hides: say it last, where a failure is read."""
    if WARM_AHEAD["seconds"] > 10:
        count, seconds = WARM_AHEAD["count"], WARM_AHEAD["seconds"]
        terminalreporter.write_line(f"{count} kernel variants built ahead on {os.cpu_count()} processes in {seconds:.0f} s")
    seed = getattr(config.option, "randomly_seed", None)
    if config.pluginmanager.hasplugin("randomly") and isinstance(seed, int):
        terminalreporter.write_line(f"tests in random order: replay with --randomly-seed={seed} (-p no:randomly: file order)")
