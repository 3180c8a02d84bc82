"""Charts: bars and lines land where their values say, bad series are refused."""
import cv2
import numpy as np
import pytest

from clrender import plot


def _mask(img, colour):
    """Pixels of exactly this colour inside the plot frame (the legend sits below it)."""
    mask = np.all(img == np.array(colour, np.uint8), axis=2)
    mask[plot.HEIGHT - plot.MARGIN["bottom"] + 1 :] = False
    return mask


def test_bar_heights_are_proportional_to_values(tmp_path):
    path = plot.bar_chart(tmp_path / "sub" / "bars.png", ["a", "b", "c"],
                          {"first": [1.0, 2.0, 4.0], "second": [3.0, None, 0.5]}, title="t", ylabel="seconds")
    img = cv2.imread(str(path))
    assert img.shape == (plot.HEIGHT, plot.WIDTH, 3)
    first = _mask(img, plot.PALETTE[0])
    second = _mask(img, plot.PALETTE[1])
    # bar height per group: the tallest column of that colour within the group's third of the plot
    x0, x1 = plot.MARGIN["left"], plot.WIDTH - plot.MARGIN["right"]
    groups = np.array_split(np.arange(x0, x1), 3)
    h1 = [first[:, g].sum(axis=0).max() for g in groups]
    h2 = [second[:, g].sum(axis=0).max() for g in groups]
    assert h1[0] > 20
    assert h1[1] / h1[0] == pytest.approx(2.0, abs=0.05)
    assert h1[2] / h1[0] == pytest.approx(4.0, abs=0.1)
    assert h2[0] / h1[0] == pytest.approx(3.0, abs=0.1)
    assert h2[1] == 0  # None draws no bar
    assert h2[2] / h1[0] == pytest.approx(0.5, abs=0.05)


def test_log_bars_are_proportional_to_log_values(tmp_path):
    img = cv2.imread(str(plot.bar_chart(tmp_path / "log.png", ["a", "b"], {"s": [0.01, 10.0]}, log=True)))
    col = _mask(img, plot.PALETTE[0]).sum(axis=0)
    x0, x1 = plot.MARGIN["left"], plot.WIDTH - plot.MARGIN["right"]
    a, b = (col[g].max() for g in np.array_split(np.arange(x0, x1), 2))
    # axis runs 0.01 .. 10 (three decades): 0.01 sits on the base, 10 fills the plot
    assert a <= 2
    assert b == pytest.approx(plot.HEIGHT - plot.MARGIN["top"] - plot.MARGIN["bottom"], abs=2)


def test_line_rises_with_its_values_and_gaps_at_none(tmp_path):
    x = list(range(11))
    y = [float(v) for v in x]
    y[5] = None
    img = cv2.imread(str(plot.line_chart(tmp_path / "line.png", x, {"y": y}, xlabel="x", ylabel="y")))
    rows, cols = np.nonzero(_mask(img, plot.PALETTE[0]))
    inside = cols > plot.MARGIN["left"] + 2
    rows, cols = rows[inside], cols[inside]
    assert len(cols) > 100
    # y increases with x, so the pixel row falls as the column grows
    assert np.corrcoef(cols, rows)[0, 1] < -0.99
    # no ink around x = 5 (the gap), ink around x = 2
    x0, x1 = plot.MARGIN["left"], plot.WIDTH - plot.MARGIN["right"]
    at = lambda v: x0 + v / 10 * (x1 - x0)  # noqa: E731
    assert not np.any(np.abs(cols - at(5)) < 3)
    assert np.any(np.abs(cols - at(2)) < 3)


def test_bad_series_are_refused(tmp_path):
    with pytest.raises(ValueError, match="has 2 values"):
        plot.bar_chart(tmp_path / "x.png", ["a", "b", "c"], {"s": [1, 2]})
    with pytest.raises(ValueError, match="at least one series"):
        plot.line_chart(tmp_path / "x.png", [1, 2], {})
    assert not (tmp_path / "x.png").exists()
