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


def pytest_terminal_summary(terminalreporter, config):
    """pytest-randomly shows its seed in the header, which -q hides: say it last, where a failure is read."""
    seed = getattr(config.option, "randomly_seed", None)
    if config.pluginmanager.hasplugin("randomly") and isinstance(seed, int):
        terminalreporter.write_line(f"tests in random order: replay with --randomly-seed={seed} (-p no:randomly: file order)")
