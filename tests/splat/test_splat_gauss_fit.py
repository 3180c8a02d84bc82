"""Gaussian splat fitting: recovery of a known image, monotone progress, determinism, optimisers,
densification, re-rendering at another resolution, saved parameters."""

import numpy as np
import pytest

from clrender.splat.fit import FitConfig, Fitter, densify, fit, initial_params
from clrender.splat.gauss import GaussParams, render
from clrender.splat.optim import Optimizer


def known_gaussians(n=5, size=48, seed=3, blend="sum"):
    rng = np.random.default_rng(seed)
    return GaussParams(
        xy=rng.uniform(8, size - 8, (n, 2)),
        log_scale=np.log(rng.uniform(2.5, 7, (n, 2))),
        theta=rng.uniform(-1.5, 1.5, n),
        color=rng.uniform(0.2, 0.9, (n, 3)),
        lum=np.ones(n),
        opacity=np.full(n, 0.6),
        width=size,
        height=size,
        blend=blend,
    )


@pytest.fixture(scope="module")
def target(device):
    image = render(device, known_gaussians())
    assert 0.0 <= image.min() and image.max() <= 1.0 and image.max() > 0.5
    return image


def test_fit_recovers_known_gaussians(device, target):
    result = Fitter(device, target, FitConfig(splats=16, epochs=300, blend="sum")).run(show_progress=False)
    assert result.psnr >= 40.0
    losses = [row["loss"] for row in result.log]
    assert losses[-1] < losses[0] / 100
    assert result.log[-1]["psnr"] == pytest.approx(result.psnr)


def test_same_seed_same_parameters(device, target):
    cfg = dict(splats=12, epochs=40, init="random", densify_every=10, max_splats=20)
    a = Fitter(device, target, FitConfig(seed=5, **cfg)).run(show_progress=False).params
    b = Fitter(device, target, FitConfig(seed=5, **cfg)).run(show_progress=False).params
    c = Fitter(device, target, FitConfig(seed=6, **cfg)).run(show_progress=False).params
    for name, array in a.groups().items():
        np.testing.assert_array_equal(array, getattr(b, name), err_msg=name)
    assert a.n != c.n or not np.array_equal(a.xy, c.xy)


@pytest.mark.parametrize(
    "settings",
    [
        dict(learn="scale-lum", blend="sum", optimizer="sgd", init="uniform"),
        dict(optimizer="momentum", loss="l1"),
        dict(loss="l1-ssim", batch=1024, init="random"),
        dict(blend="normalized", batch=256),
    ],
)
def test_loss_decreases(device, target, settings):
    cfg = FitConfig(splats=16, epochs=30, **settings)
    fitter = Fitter(device, target, cfg)
    start = initial_params(target, 16, cfg.init, cfg.blend, np.random.default_rng(0), fitter.renderer)
    result = fitter.run(start.copy(), show_progress=False)
    first_psnr = result.log[0]["psnr"]
    assert result.psnr > first_psnr + 1.0
    if settings.get("learn") == "scale-lum":  # only log-scales and luminance move
        np.testing.assert_array_equal(result.params.xy, start.xy)
        np.testing.assert_array_equal(result.params.color, start.color)
        assert not np.array_equal(result.params.log_scale, start.log_scale)
        assert not np.array_equal(result.params.lum, start.lum)


def test_epochs_zero_renders_the_initial_splats(device, target):
    result = Fitter(device, target, FitConfig(splats=9, epochs=0, init="uniform")).run(show_progress=False)
    assert result.steps == 0 and result.params.n == 9
    np.testing.assert_array_equal(result.params.theta, 0)


def test_fit_overrides_leave_the_callers_config_as_it_was(device, target):
    config = FitConfig(splats=9, epochs=0, init="uniform")
    result = fit(device, target, config, splats=4)
    assert result.params.n == 4 and config.splats == 9 and config == FitConfig(splats=9, epochs=0, init="uniform")
    with pytest.raises(TypeError):
        fit(device, target, config, no_such_setting=1)


def test_optimizers_minimise_a_quadratic():
    target = np.array([3.0, -2.0, 0.5], np.float32)
    for kind, lr in (("sgd", 0.1), ("momentum", 0.02), ("adam", 0.05)):
        p = {"xy": np.zeros(3, np.float32)}
        opt = Optimizer(kind, {"xy": lr})
        for _ in range(500):
            opt.step(p, {"xy": 2 * (p["xy"] - target)})
        np.testing.assert_allclose(p["xy"], target, atol=1e-2, err_msg=kind)


def test_optimizer_reindex_keeps_state_rows():
    p = {"xy": np.zeros((3, 2), np.float32)}
    opt = Optimizer("adam", {"xy": 0.1})
    opt.step(p, {"xy": np.array([[1, 1], [2, 2], [3, 3]], np.float32)})
    m = opt.state["xy"][0].copy()
    opt.reindex(np.array([2, 0, 0, 1]))
    np.testing.assert_array_equal(opt.state["xy"][0], m[[2, 0, 0, 1]])


def test_densify_prunes_splits_clones_within_budget():
    n = 6
    params = GaussParams(
        xy=np.full((n, 2), 20.0),
        log_scale=np.log([[1, 1], [1, 1], [6, 2], [1, 1], [1, 1], [1, 1]]),
        theta=np.zeros(n),
        color=np.full((n, 3), 0.5),
        lum=np.ones(n),
        opacity=np.array([1, 0.001, 1, 1, 1, 1]),
        width=40,
        height=40,
    )
    grad = np.array([0.0, 5.0, 3.0, 2.0, 0.0, 0.0])
    weight = np.full(n, 10.0)
    weight[5] = 0.0  # contributes nothing
    new, src = densify(params, grad, weight, max_splats=6, rng=np.random.default_rng(0))
    # splats 1 (transparent) and 5 (no weight) go; the freed budget goes to 2 (big: split) and 3 (small: clone)
    np.testing.assert_array_equal(src, [0, 2, 3, 4, 2, 3])
    assert new.n == 6
    split = [1, 4]
    np.testing.assert_allclose(new.log_scale[split], np.log([[6, 2], [6, 2]]) - np.log(1.6), rtol=1e-6)
    np.testing.assert_allclose(new.xy[split].mean(0), [20, 20], atol=1e-5)  # halves either side
    np.testing.assert_allclose(np.abs(new.xy[split, 0] - 20), 3.0, atol=1e-5)  # half a major sigma
    assert not np.array_equal(new.xy[5], new.xy[2])  # the clone moved away from its original
    np.testing.assert_array_equal(new.log_scale[[2, 5]], params.log_scale[[3, 3]])


def test_render_at_twice_the_size_matches_the_original(device):
    params = known_gaussians(size=48)
    small = render(device, params)
    big = render(device, params.scaled(2.0, 96, 96))
    # the 2x render averaged over 2x2 blocks agrees with the 1x render up to sampling error
    pooled = big.reshape(48, 2, 48, 2, 3).mean(axis=(1, 3))
    assert np.abs(pooled - small).max() < 0.03
    assert np.abs(pooled - small).mean() < 0.003


def test_params_save_load_roundtrip(tmp_path):
    params = known_gaussians(blend="normalized")
    params.background[:] = [0.1, 0.2, 0.3]
    params.save(tmp_path / "p.npz")
    loaded = GaussParams.load(tmp_path / "p.npz")
    assert (loaded.width, loaded.height, loaded.blend) == (48, 48, "normalized")
    for name, array in params.groups().items():
        np.testing.assert_array_equal(getattr(loaded, name), array)
    np.testing.assert_array_equal(loaded.background, params.background)


def test_log_has_one_row_per_step_and_ends_with_the_final_model(device, target):
    # 20 steps end on a logged step (every 10th): the final row must not repeat it with another loss
    result = Fitter(device, target, FitConfig(splats=16, epochs=20, blend="sum", loss="l2")).run(show_progress=False)
    steps = [row["step"] for row in result.log]
    assert steps == [1, 10, 20] and result.steps == 20
    last = result.log[-1]
    error = result.image.astype(np.float64) - target
    assert last["loss"] == pytest.approx(float(np.mean(error**2)), rel=1e-5)  # the final image's l2 loss
    clipped = np.clip(result.image, 0, 1).astype(np.float64) - target  # PSNR, as saved: clipped to [0, 1]
    assert last["psnr"] == result.psnr == pytest.approx(-10 * np.log10(np.mean(clipped**2)), abs=1e-6)
