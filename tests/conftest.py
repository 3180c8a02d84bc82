"""Shared fixtures: every test that runs a kernel takes `device` (PoCL CPU unless $CLRENDER_DEVICE says otherwise)."""
import pytest

from clrender.device import get_device


@pytest.fixture(scope="session")
def device():
    return get_device()


@pytest.fixture
def rng():
    import numpy as np

    return np.random.default_rng(12345)
