"""Charts (matplotlib): bars and lines land where their values say, both training curves stay
visible when they carry the same numbers, bad series are refused, files are whole PNGs."""

import matplotlib.colors
import numpy as np
import pytest

from clrender.image import plot
from clrender.image.files import probe_image


def ink(pixels, colour, tolerance=0):
    """Mask of the pixels drawn in exactly this palette colour (anti-aliased edges excluded)."""
    rgb = np.array(matplotlib.colors.to_rgb(colour)) * 255
    return np.all(np.abs(pixels.astype(int) - rgb.round()) <= tolerance, axis=2)


def test_bars_stand_as_high_as_their_values(tmp_path):
    fig = plot.bar_figure(["a", "b", "c"], {"first": [1.0, 2.0, 4.0], "second": [3.0, None, 0.5]})
    ax = fig.axes[0]
    first, second = ([bar.get_height() for bar in c] for c in ax.containers)
    assert first == [1.0, 2.0, 4.0]
    assert second[0] == 3.0 and np.isnan(second[1]) and second[2] == 0.5  # None: no bar
    # and in the pixels: each bar's column of ink is proportional to its value above the zero line
    pixels = plot.figure_pixels(fig)
    heights = []
    for bar in ax.containers[0]:
        (x0, y0), (x1, y1) = ax.transData.transform([(bar.get_x(), 0), (bar.get_x() + bar.get_width(), bar.get_height())])
        column = int((x0 + x1) / 2)
        heights.append(ink(pixels, plot.PALETTE[0])[:, column].sum())
    assert heights[0] > 20
    assert heights[1] / heights[0] == pytest.approx(2.0, abs=0.06)
    assert heights[2] / heights[0] == pytest.approx(4.0, abs=0.12)


def test_log_scale_is_asked_for(tmp_path):
    assert plot.bar_figure(["a", "b"], {"s": [0.01, 10.0]}, log=True).axes[0].get_yscale() == "log"
    assert plot.line_figure([1, 2], {"s": [0.01, 10.0]}, log=True).axes[0].get_yscale() == "log"
    assert plot.line_figure([1, 2], {"s": [0.01, 10.0]}).axes[0].get_yscale() == "linear"


def test_line_follows_its_values_with_a_gap_at_none():
    x = list(range(11))
    y = [float(v) ** 2 for v in x]
    y[5] = None
    y[7] = float("nan")
    (line,) = plot.line_figure(x, {"y": y}).axes[0].get_lines()
    got = np.asarray(line.get_ydata(), float)
    assert np.isnan(got[[5, 7]]).all()
    keep = [i for i in x if i not in (5, 7)]
    np.testing.assert_array_equal(got[keep], np.array(keep, float) ** 2)


def test_training_curve_shows_psnr_and_loss_even_when_they_carry_the_same_numbers(tmp_path):
    # for the L2 loss PSNR = -10 log10(loss): on one axis the two lines coincide and one hides
    steps = np.arange(50)
    loss = 0.1 * np.exp(-steps / 15) + 1e-3
    psnr = -10 * np.log10(loss)
    path = plot.training_curve(tmp_path / "curve.png", steps, loss, psnr, title="fit")
    info = probe_image(path)
    assert (info.width, info.height) == (960, 560)
    fig = plot.training_figure(steps, loss, psnr)
    loss_axes, psnr_axes = fig.axes
    assert loss_axes.get_yscale() == "log" and "PSNR" in psnr_axes.get_ylabel()
    pixels = plot.figure_pixels(fig)
    assert ink(pixels, plot.PALETTE[0]).sum() > 300  # the loss line
    assert ink(pixels, plot.PALETTE[1]).sum() > 300  # the PSNR line, not hidden
    # PSNR rises as the loss falls: its ink climbs from left to right
    rows, cols = np.nonzero(ink(pixels, plot.PALETTE[1]))
    assert np.corrcoef(cols, rows)[0, 1] < -0.5


def test_bad_series_are_refused_and_nothing_is_written(tmp_path):
    with pytest.raises(ValueError, match="has 2 values"):
        plot.bar_chart(tmp_path / "x.png", ["a", "b", "c"], {"s": [1, 2]})
    with pytest.raises(ValueError, match="at least one series"):
        plot.line_chart(tmp_path / "x.png", [1, 2], {})
    with pytest.raises(ValueError, match="finite x"):
        plot.line_chart(tmp_path / "x.png", [1, float("inf")], {"s": [1, 2]})
    assert not (tmp_path / "x.png").exists()


def test_charts_create_their_folder_and_write_a_png(tmp_path):
    path = plot.bar_chart(tmp_path / "sub" / "bars.png", ["a"], {"s": [1.0]}, title="t", ylabel="seconds")
    assert path == tmp_path / "sub" / "bars.png"
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_no_pyplot_state_is_touched():
    import sys

    plot.line_figure([0, 1], {"s": [0, 1]})
    if "matplotlib.pyplot" in sys.modules:  # another test may have imported it: then no figure of ours is open
        import matplotlib.pyplot as plt

        assert plt.get_fignums() == []
