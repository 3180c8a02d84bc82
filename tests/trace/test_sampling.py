"""Where anti-aliasing samples fall inside a pixel."""

import numpy as np
import pytest

from clrender.trace.sampling import sample_offsets

PIXELS = np.arange(0, 5000, 37)


@pytest.mark.parametrize("sampler", ["uniform", "random", "stratified", "sobol"])
@pytest.mark.parametrize("n", [1, 2, 5])
def test_every_sample_lies_inside_its_pixel(device, sampler, n):
    s = sample_offsets(PIXELS, sampler, n, seed=7, device=device)
    assert s.shape == (len(PIXELS), n * n, 2)
    assert (s >= 0).all() and (s < 1).all()


def test_uniform_is_the_centred_grid(device):
    n = 4
    s = sample_offsets(PIXELS, "uniform", n, device=device)
    p, q = np.divmod(np.arange(n * n), n)  # p: vertical, q: horizontal sub-pixel index
    # the seed: (i + (p + 0.5)/n - 0.5, j + (q + 0.5)/n - 0.5) about the pixel centre
    expected = np.stack([(q + 0.5) / n, (p + 0.5) / n], axis=1)
    np.testing.assert_array_equal(s, np.broadcast_to(expected.astype(np.float32), s.shape))


# Sobol points form a (0, m, 2)-net only when N*N is a power of two
@pytest.mark.parametrize("sampler, n", [("stratified", 6), ("sobol", 4), ("sobol", 8)])
def test_stratified_samplers_put_one_sample_in_each_sub_square(device, sampler, n):
    s = sample_offsets(PIXELS, sampler, n, seed=3, device=device)
    cell = np.floor(s * n).astype(int)
    index = cell[..., 1] * n + cell[..., 0]
    for row in index:
        assert sorted(row) == list(range(n * n))


def test_stratified_sample_s_is_in_sub_square_s(device):
    n = 5
    s = sample_offsets(PIXELS, "stratified", n, seed=1, device=device)
    p, q = np.divmod(np.arange(n * n), n)
    assert (np.floor(s[..., 0] * n) == q).all() and (np.floor(s[..., 1] * n) == p).all()


@pytest.mark.parametrize("sampler", ["random", "stratified", "sobol"])
def test_same_seed_same_positions_different_seed_different(device, sampler):
    a = sample_offsets(PIXELS, sampler, 3, seed=11, device=device)
    b = sample_offsets(PIXELS, sampler, 3, seed=11, device=device)
    c = sample_offsets(PIXELS, sampler, 3, seed=12, device=device)
    np.testing.assert_array_equal(a, b)
    assert (a != c).mean() > 0.9


def test_random_positions_are_uniform_and_independent_between_pixels(device):
    s = sample_offsets(np.arange(20000), "random", 1, seed=5, device=device)[:, 0]
    counts, _, _ = np.histogram2d(s[:, 0], s[:, 1], bins=10, range=[[0, 1], [0, 1]])
    expected = len(s) / 100
    chi2 = ((counts - expected) ** 2 / expected).sum()
    assert chi2 < 150  # 99 degrees of freedom; p ~ 0.001 at 148
    assert abs(np.corrcoef(s[:-1, 0], s[1:, 0])[0, 1]) < 0.03
