"""Voronoi splats: grid == naive == numpy exactly, colours, Lloyd energy, soft-Voronoi gradients, CLI."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.image.files import read_image, write_image
from clrender.splat import voronoi as V
from clrender.splat.voronoi_soft import SoftVoronoi, TrainSettings, train
from clrender.testing import nearest_site_reference, soft_loss_reference, synthetic_photo

from tests.clitools import run_cli


def both_methods(device, sites, w, h):
    grid = V.nearest_site(device, sites, w, h, "grid")
    naive = V.nearest_site(device, sites, w, h, "naive")
    return grid, naive


def site_sets(rng):
    """(name, sites, width, height) covering the awkward cases of the ring search."""
    w, h = 61, 37  # not multiples of the 8-pixel strip or of any cell side
    cell = V.cell_side(40, w, h)
    gx, gy = np.meshgrid(np.arange(0, w + 1, cell), np.arange(0, h + 1, cell))
    borders = np.stack([gx.ravel(), gy.ravel()], axis=1)  # exactly on cell corners and borders
    centre = rng.random((30, 2)) * [w, h]
    return [
        ("random", rng.random((200, 2)) * [w, h], w, h),
        ("clustered", rng.normal([w * 0.3, h * 0.6], 1.5, (150, 2)), w, h),
        ("one corner", rng.random((40, 2)) * 2.0, w, h),
        ("duplicated", np.repeat(centre, 3, axis=0)[rng.permutation(90)], w, h),
        ("single", np.array([[w * 0.7, h * 0.2]]), w, h),
        ("cell borders", borders, w, h),
        ("integer lattice", np.stack(np.meshgrid(np.arange(0, w, 4), np.arange(0, h, 3)), -1).reshape(-1, 2), w, h),
        ("outside the image", rng.random((50, 2)) * [3 * w, 3 * h] - [w, h], w, h),
        ("1x1 image", rng.random((3, 2)) * 2 - 0.5, 1, 1),
        ("more sites than pixels", rng.random((100, 2)) * [5, 4], 5, 4),
        ("wide strip", rng.random((64, 2)) * [300, 3], 300, 3),
    ]


@pytest.mark.parametrize("case", range(11))
def test_grid_equals_naive_equals_numpy(device, rng, case):
    name, sites, w, h = site_sets(rng)[case]
    sites = sites.astype(np.float32)
    grid, naive = both_methods(device, sites, w, h)
    ref = nearest_site_reference(sites, w, h)
    assert np.array_equal(naive, ref), name
    assert np.array_equal(grid, ref), name


def test_ties_go_to_the_lower_index(device):
    # two sites at the same place, and a pixel centre equidistant from two others
    sites = np.array([[5.5, 2.5], [5.5, 2.5], [1.5, 1.5], [3.5, 1.5]], np.float32)
    for method in ("grid", "naive"):
        index = V.nearest_site(device, sites, 8, 4, method)
        assert not (index == 1).any()
        assert index[1, 2] == 2  # (2.5, 1.5) is 1 from both site 2 and site 3


def test_grid_matches_naive_at_benchmark_density(device, rng):
    sites = (rng.random((2000, 2)) * [203, 157]).astype(np.float32)
    grid, naive = both_methods(device, sites, 203, 157)
    assert np.array_equal(grid, naive)


def test_bad_sites_are_refused(device):
    with pytest.raises(UsageError):
        V.nearest_site(device, np.zeros((0, 2), np.float32), 4, 4)
    with pytest.raises(UsageError):
        V.nearest_site(device, np.array([[np.nan, 1.0]], np.float32), 4, 4)
    with pytest.raises(UsageError):
        V.nearest_site(device, np.ones((3, 2), np.float32), 4, 4, "kdtree")


def test_mean_colours_beat_sampled_colours(device):
    image = synthetic_photo(96, 80, seed=2)
    sites = V.init_sites(image, 150, "random", seed=1)
    index = V.nearest_site(device, sites, 96, 80)
    sample = V.sample_colors(image, sites)
    mean = V.mean_colors(image, index, len(sites), fallback=sample)
    mse = lambda c: float(np.mean((V.render(index, c) - image) ** 2))
    assert mse(mean) < 0.9 * mse(sample)
    # the mean is the least-squares optimum: nudging any colour makes it worse
    nudged = mean.copy()
    nudged[index[40, 50]] += 0.01
    assert mse(nudged) > mse(mean)


def test_mean_colours_match_a_per_cell_loop():
    rng = np.random.default_rng(0)
    image = rng.random((6, 7, 3)).astype(np.float32)
    index = rng.integers(0, 5, (6, 7))
    index[index == 3] = 4  # site 3 owns nothing: falls back
    fallback = np.full((5, 3), 9.0, np.float32)
    got = V.mean_colors(image, index, 5, fallback=fallback)
    for i in range(5):
        expect = image[index == i].mean(axis=0) if (index == i).any() else fallback[i]
        np.testing.assert_allclose(got[i], expect, rtol=1e-6)


def test_lloyd_never_increases_the_energy(device):
    sites = V.init_sites(np.zeros((70, 90, 3), np.float32), 60, "random", seed=4)
    sites, index, energies = V.lloyd(device, sites, 90, 70, 6)
    steps = np.diff(energies)
    assert (steps <= 1e-9 * energies[0]).all(), energies
    assert energies[-1] < 0.8 * energies[0]
    assert np.array_equal(index, nearest_site_reference(sites, 90, 70))


def test_lloyd_step_moves_to_the_centroid():
    index = np.zeros((4, 6), np.int32)
    index[:, 3:] = 1
    moved = V.lloyd_step(np.array([[0.0, 0.0], [5.0, 1.0], [9.0, 9.0]], np.float32), index)
    np.testing.assert_allclose(moved, [[1.5, 2.0], [4.5, 2.0], [9.0, 9.0]])  # site 2 owns nothing: stays


@pytest.mark.parametrize("method", V.INITS)
def test_init_sites_are_deterministic_and_inside(method):
    image = synthetic_photo(50, 30, seed=1)
    a = V.init_sites(image, 77, method, seed=3)
    b = V.init_sites(image, 77, method, seed=3)
    assert a.shape == (77, 2) and np.array_equal(a, b)
    assert (a >= 0).all() and (a[:, 0] <= 50).all() and (a[:, 1] <= 30).all()
    if method == "uniform":
        assert len(np.unique(a, axis=0)) == 77


def test_cell_edges():
    index = np.array([[0, 0, 1], [0, 0, 1], [2, 2, 2]])
    assert V.cell_edges(index).tolist() == [[False, True, False], [True, True, True], [False, False, False]]


@pytest.mark.parametrize("n, k", [(6, 8), (11, 4)])
def test_soft_voronoi_gradients_match_finite_differences(device, n, k):
    rng = np.random.default_rng(n)
    w, h = 13, 9
    sites = (rng.random((n, 2)) * [w, h]).astype(np.float32)
    colors = rng.random((n, 3)).astype(np.float32)
    target = rng.random((h, w, 3)).astype(np.float32)
    temp = 4.0
    loss, g_sites, g_colors, _ = SoftVoronoi(device, w, h, k).loss_and_grads(sites, colors, target, temp)
    assert loss == pytest.approx(soft_loss_reference(sites, colors, target, temp, k), rel=1e-5)
    eps = 1e-3

    def fd(array, i, a, is_sites):
        plus, minus = array.astype(np.float64), array.astype(np.float64)
        plus[i, a] += eps
        minus[i, a] -= eps
        if is_sites:
            return (soft_loss_reference(plus, colors, target, temp, k) - soft_loss_reference(minus, colors, target, temp, k)) / (2 * eps)
        return (soft_loss_reference(sites, plus, target, temp, k) - soft_loss_reference(sites, minus, target, temp, k)) / (2 * eps)

    fd_sites = np.array([[fd(sites, i, a, True) for a in range(2)] for i in range(n)])
    fd_colors = np.array([[fd(colors, i, a, False) for a in range(3)] for i in range(n)])
    np.testing.assert_allclose(g_sites, fd_sites, atol=1e-4 * np.abs(fd_sites).max())
    np.testing.assert_allclose(g_colors, fd_colors, atol=1e-4 * np.abs(fd_colors).max())


def test_soft_voronoi_tends_to_hard_nearest_site(device, rng):
    sites = (rng.random((20, 2)) * [24, 16]).astype(np.float32)
    colors = rng.random((20, 3)).astype(np.float32)
    _, _, _, soft = SoftVoronoi(device, 24, 16, 8).loss_and_grads(sites, colors, np.zeros((16, 24, 3), np.float32), 1e-3)
    hard = V.render(V.nearest_site(device, sites, 24, 16), colors)
    assert (np.abs(soft - hard).max(axis=2) < 1e-4).mean() > 0.97  # all but pixels on cell borders


def test_training_lowers_the_loss_and_is_deterministic(device):
    image = synthetic_photo(48, 40, seed=5)
    sites = V.init_sites(image, 40, "uniform")
    a = train(device, image, sites, steps=25)
    b = train(device, image, sites, steps=25)
    assert np.array_equal(a.sites, b.sites)
    assert a.losses[-1] < 0.8 * a.losses[0]


def test_training_steps_leave_the_callers_settings_as_they_were(device):
    image = synthetic_photo(16, 12, seed=5)
    settings = TrainSettings(steps=7, k=4)
    result = train(device, image, V.init_sites(image, 6, "uniform"), steps=2, settings=settings)
    assert len(result.losses) == 2 and settings == TrainSettings(steps=7, k=4)


# ---------------------------------------------------------------- command line


@pytest.fixture
def photo(tmp_path):
    path = tmp_path / "photo.png"
    write_image(path, synthetic_photo(64, 48, seed=3))
    return path


def test_cli_end_to_end(tmp_path, capsys, photo):
    out, npz = tmp_path / "cells.png", tmp_path / "sites.npz"
    code, stdout, err = run_cli(capsys, "splat", "voronoi", str(photo), "-o", str(out), "--splats", "120", "--lloyd", "2", "--save-sites", str(npz))
    assert code == 0, err
    assert stdout.strip() == str(out) and "PSNR" in err
    result = read_image(out).pixels
    saved = np.load(npz)
    assert saved["sites"].shape == (120, 2) and int(saved["width"]) == 64
    # the output is the saved sites' Voronoi image in the saved colours (up to 8-bit rounding)
    index = nearest_site_reference(saved["sites"], 64, 48)
    np.testing.assert_allclose(result, saved["colors"][index], atol=0.5 / 255 + 1e-6)


def test_cli_methods_agree(tmp_path, capsys, photo):
    outs = [tmp_path / f"{m}.png" for m in ("grid", "naive")]
    for m, out in zip(("grid", "naive"), outs):
        assert (
            run_cli(capsys, "splat", "voronoi", str(photo), "-o", str(out), "-n", "50", "--init", "random", "--seed", "7", "--method", m, "--edges")[
                0
            ]
            == 0
        )
    assert np.array_equal(read_image(outs[0]).pixels, read_image(outs[1]).pixels)


@pytest.mark.parametrize(
    "args, words",
    [
        (["-n", "0"], "--splats 0"),
        (["-n", "3073"], "3072"),
        (["-n", "50", "--lloyd", "-1"], "--lloyd"),
        (["-n", "50", "--train", "-3"], "--train"),
        (["--save-sites", "x.txt"], ".npz"),
    ],
)
def test_cli_bad_input_exits_2_and_writes_nothing(tmp_path, capsys, photo, args, words):
    out = tmp_path / "o.png"
    code, stdout, err = run_cli(capsys, "splat", "voronoi", str(photo), "-o", str(out), *args)
    assert code == 2 and words in err and "Traceback" not in err
    assert not out.exists()


def test_cli_refuses_non_images_and_existing_outputs(tmp_path, capsys, photo):
    text = tmp_path / "notes.txt"
    text.write_text("not an image")
    code, _, err = run_cli(capsys, "splat", "voronoi", str(text), "-o", str(tmp_path / "o.png"))
    assert code == 2 and "notes.txt" in err
    code, _, err = run_cli(capsys, "splat", "voronoi", str(photo), "-o", str(photo))
    assert code == 2 and "overwrite" in err


def test_cli_one_pixel_image(tmp_path, capsys):
    src, out = tmp_path / "one.png", tmp_path / "o.png"
    write_image(src, np.full((1, 1, 3), 0.5, np.float32))
    assert run_cli(capsys, "splat", "voronoi", str(src), "-o", str(out), "-n", "1", "--lloyd", "2")[0] == 0
    assert read_image(out).pixels.shape == (1, 1, 3)
