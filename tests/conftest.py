"""Shared fixtures: every test that runs a kernel takes `device` (PoCL CPU unless $CLRENDER_DEVICE says otherwise).

Hypothesis profiles for the fuzz tests (tests/test_fuzz_*.py):
    ci    (default) a few hundred examples across all fuzz tests, no per-example deadline
    long  pytest --hypothesis-profile=long: at least 10,000 examples per scene fuzzer, 2,000+ CLI cases
A fuzz test that wants fewer examples than the profile gives under ci asks for
`min(n, settings().max_examples)` only when `settings.get_current_profile_name() == "ci"`.
"""
import pytest

from clrender.device import get_device

try:
    from hypothesis import HealthCheck, settings

    settings.register_profile("ci", deadline=None, print_blob=True, derandomize=True,
                              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    settings.register_profile("long", deadline=None, print_blob=True, max_examples=10_000,
                              suppress_health_check=list(HealthCheck))
    settings.load_profile("ci")
except ImportError:  # hypothesis is in the `test` extra; without it the fuzz tests skip themselves
    pass


@pytest.fixture(scope="session")
def device():
    return get_device()


@pytest.fixture
def rng():
    import numpy as np

    return np.random.default_rng(12345)
