"""Are two Monte Carlo renders of one scene images of the same expected value?  A block-wise two-sample test.

Imports nothing from clrender.  Each side is K >= 2 independent renders at the same spp (different seeds), an
array (K, H, W, C).  Method:

1. Per pixel, the mean of its K values and their unbiased sample variance s^2 (ddof 1).  A pixel's K values are
   independent draws of that pixel's estimator, so s^2 / K estimates the variance of its mean without any
   assumption about the image's content (edges and gradients inside a block do not inflate it, as the spread of
   pixel values within a block would).
2. Per block of B x B pixels and channel: the block mean m (the mean of its pixel means) and its variance
   v = sum(s^2) / (B^4 K).  The pixels of a block are independent (both renderers draw each pixel's samples
   from its own random stream), so their variances add.
3. z = (m_a - m_b) / sqrt(v_a + v_b).  v is a sum of B^2 scaled chi-square terms, so z follows Student's t with
   Welch-Satterthwaite degrees of freedom, df = (v_a + v_b)^2 / sum over both sides' pixels of
   (s^2 / (B^4 K))^2 / (K - 1); with B = 8 and K = 4 that is about 380 when a block's pixels are alike, where t
   is a normal to three digits, but a block whose variance comes from a few pixels (a caustic's fireflies)
   gets fewer and its p-value is not overstated.  Two-sided p = 2 t.sf(|z|, df).
4. Every block and channel is one test: m of them.  Šidák's correction keeps the chance of any false alarm at
   alpha: each p must exceed 1 - (1 - alpha)^(1/m) (5.2e-5 for a 64 x 64 image: 64 blocks x 3 channels; |z| > 4.05).

A reconstruction filter wider than a pixel (a tent, a gaussian) splats each sample into several pixels, so
neighbouring pixels of one render are correlated and step 2's sum of variances underestimates a block mean's
variance (Mitsuba's tent-filtered Cornell box against itself fails a quarter of the time).  `lag` L > 0 adds the
sample covariances of every pair of pixels of a block at most L apart in each axis, estimated from the same K
renders: v = sum over such pairs of cov / (B^4 K), and each pixel's df term uses its row of that sum.  L is the
widest offset at which two pixels can share a sample: ceil(2 r) - 1 for a filter of radius r pixels (box 0,
Mitsuba's tent 1, its gaussian 3).

Blocks with no variance on either side (environment seen directly, a black background) are compared with a
floor on the standard deviation of REL_FLOOR times the larger mean: two float32 sums of equal values may
differ in their last bits, which is no evidence against the null hypothesis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

REL_FLOOR = 1e-5  # relative rounding of a float32 pixel mean over a few thousand samples
ABS_FLOOR = 1e-12


@dataclass
class ZTest:
    passed: bool
    worst_p: float  # the smallest p over all blocks and channels
    threshold: float  # Šidák's per-test alpha: each p must be above it
    table: list  # one dict per block and channel, smallest p first: row, col, channel, mean_a, mean_b, z, df, p

    def __iter__(self):  # passed, worst_p, threshold, table = two_sample_z(...)
        return iter((self.passed, self.worst_p, self.threshold, self.table))

    def report(self, rows: int = 6) -> str:
        """The worst blocks, for an assertion message."""
        lines = [f"worst p {self.worst_p:.3g} vs Šidák threshold {self.threshold:.3g} over {len(self.table)} tests"]
        for r in self.table[:rows]:
            lines.append(
                f"  block ({r['row']}, {r['col']}) channel {r['channel']}: {r['mean_a']:.5g} vs {r['mean_b']:.5g}, "
                f"z {r['z']:+.2f}, df {r['df']:.0f}, p {r['p']:.3g}"
            )
        return "\n".join(lines)


def block_means(img, block: int = 8) -> np.ndarray:
    """Means of block x block pixel tiles per channel: (..., H, W, C) -> (..., H / block, W / block, C)."""
    img = np.asarray(img, np.float64)
    *lead, h, w, c = img.shape
    if h % block or w % block:
        raise ValueError(f"image {h}x{w} is not a whole number of {block}x{block} blocks")
    return img.reshape(*lead, h // block, block, w // block, block, c).mean(axis=(-4, -2))


def block_stats(renders, block: int = 8, lag: int = 0):
    """Block means (Hb, Wb, C), the variance of each mean, and each block's df term sum((s^2/(B^4 K))^2/(K-1)), from
    K independent renders (K, H, W, C); `lag` > 0 counts the covariances of pixels that far apart (module docstring)."""
    x = np.asarray(renders, np.float64)
    if x.ndim != 4 or x.shape[0] < 2:
        raise ValueError(f"expected K >= 2 independent renders as (K, H, W, C), got shape {x.shape}")
    k = x.shape[0]
    pixel_var_of_mean = neighbour_covariance(x, block, lag) / k / block**4  # each pixel's share of its block mean's variance
    means = block_means(x.mean(axis=0), block)
    variances = np.maximum(block_means(pixel_var_of_mean, block) * block**2, 0.0)  # covariance sums may come out < 0
    df_terms = block_means(pixel_var_of_mean**2 / (k - 1), block) * block**2
    return means, variances, df_terms


def neighbour_covariance(x, block: int, lag: int) -> np.ndarray:
    """Per pixel (H, W, C): the sum of its sample covariances (ddof 1, over the K renders of x) with every pixel of
    its own block at most `lag` away in each axis, itself included (lag 0: its variance)."""
    if lag == 0:
        return x.var(axis=0, ddof=1)
    d = x - x.mean(axis=0)
    _, h, w, _ = x.shape
    rows, cols = np.arange(h) // block, np.arange(w) // block
    total = np.zeros(x.shape[1:])
    for dy in range(-lag, lag + 1):
        for dx in range(-lag, lag + 1):
            y0, y1, x0, x1 = max(0, -dy), min(h, h - dy), max(0, -dx), min(w, w - dx)
            same = (rows[y0:y1] == rows[y0 + dy : y1 + dy])[:, None] & (cols[x0:x1] == cols[x0 + dx : x1 + dx])[None, :]
            products = (d[:, y0:y1, x0:x1] * d[:, y0 + dy : y1 + dy, x0 + dx : x1 + dx]).sum(axis=0)
            total[y0:y1, x0:x1] += np.where(same[..., None], products, 0.0)
    return total / (x.shape[0] - 1)


def sidak(alpha: float, tests: int) -> float:
    """The per-test level that keeps the family-wise false-alarm rate of `tests` independent tests at alpha."""
    return -np.expm1(np.log1p(-alpha) / tests)


def two_sample_z(a, b, block: int = 8, alpha: float = 0.01, lag: int = 0) -> ZTest:
    """Test the null hypothesis that renders `a` and `b` ((K, H, W, C) each, K independent renders at equal spp)
    have the same expected image, block by block (the module docstring; `lag` for images whose reconstruction
    filter correlates neighbouring pixels).  Unpacks as (passed, worst p, threshold, table)."""
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if a.shape[1:] != b.shape[1:]:
        raise ValueError(f"renders of different sizes: {a.shape[1:]} vs {b.shape[1:]}")
    ma, va, da = block_stats(a, block, lag)
    mb, vb, db = block_stats(b, block, lag)
    floor = np.square(REL_FLOOR * np.maximum(np.abs(ma), np.abs(mb))) + ABS_FLOOR**2
    var = va + vb + floor
    z = (ma - mb) / np.sqrt(var)
    df = np.square(va + vb) / np.maximum(da + db, 1e-300)
    df = np.where(va + vb > 0, np.maximum(df, 1.0), np.inf)  # no variance: the floor alone, a normal
    p = 2.0 * stats.t.sf(np.abs(z), df)
    threshold = sidak(alpha, p.size)
    order = np.argsort(p, axis=None)
    rows, cols, chans = np.unravel_index(order, p.shape)
    table = [
        dict(row=int(i), col=int(j), channel=int(c), mean_a=ma[i, j, c], mean_b=mb[i, j, c], z=z[i, j, c], df=df[i, j, c], p=p[i, j, c])
        for i, j, c in zip(rows, cols, chans)
    ]
    worst = float(p.min())
    return ZTest(bool(worst > threshold), worst, float(threshold), table)
