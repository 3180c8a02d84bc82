"""Pearson's chi-square goodness-of-fit test of a direction sampler against a pdf on the unit sphere.

As Mitsuba 3's python/mitsuba/chi2.py and pbrt-v4's bsdfs_test.cpp do it: the sampled directions are counted on
a (theta, phi) grid over the whole sphere (theta from +z); each cell's expected count is N times the pdf's
integral over the cell (Gauss-Legendre nodes in theta and phi, adaptive, in float64); samples the sampler gave up on
(pdf 0) make one more cell, expected N minus the integral over the sphere; cells expected to hold fewer than
MIN_EXPECTED samples are pooled into one; a sample in a cell whose expected count is exactly 0 fails outright.
Never imports clrender: `pdf` is any function of (n, 3) float64 unit directions.
"""

from dataclasses import dataclass

import numpy as np
from scipy import stats

THETA_RES = 40  # 4.5 degree rows: the horizon (theta = 90) is a row boundary, where reflection lobes stop
PHI_RES = 80
NODES = 6  # Gauss-Legendre nodes per cell and axis
MIN_EXPECTED = 5.0  # the usual validity rule of Pearson's test (Mitsuba's and pbrt's too)
QUADRATURE_NOISE = 0.1  # a cell's integral is refined until its error is below this many Poisson deviations of its count
MAX_DEPTH = 8  # at most 4^8 pieces per cell


def sidak(alpha: float, n_tests: int) -> float:
    """Per-test significance that keeps the chance of any false rejection among n_tests at alpha."""
    return 1.0 - (1.0 - alpha) ** (1.0 / n_tests)


def _gauss(t0, t1, p0, p1, nodes):
    """Gauss-Legendre directions (R, nodes^2, 3) and solid-angle weights (R, nodes^2) of R (theta, phi) rectangles."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    u = (x + 1) / 2
    theta = t0[:, None] + (t1 - t0)[:, None] * u[None, :]  # (R, nodes)
    phi = p0[:, None] + (p1 - p0)[:, None] * u[None, :]
    th, ph = theta[:, :, None], phi[:, None, :]
    dirs = np.stack(np.broadcast_arrays(np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)), axis=-1)
    weights = (w[:, None] * w[None, :])[None] * ((t1 - t0) * (p1 - p0) / 4)[:, None, None] * np.sin(th)
    return dirs.reshape(len(t0), nodes * nodes, 3), weights.reshape(len(t0), nodes * nodes)


def _integrate(pdf, t0, t1, p0, p1, nodes):
    dirs, weights = _gauss(t0, t1, p0, p1, nodes)
    values = np.asarray(pdf(dirs.reshape(-1, 3)), np.float64).reshape(weights.shape)
    return np.sum(values * weights, axis=1)


def cell_integrals(pdf, n_samples: int, theta_res=THETA_RES, phi_res=PHI_RES, nodes=NODES, noise=QUADRATURE_NOISE, max_depth=MAX_DEPTH):
    """(theta_res, phi_res) integrals of pdf over each cell, adaptively: a rectangle is split into four while the
    four's sum differs from its own estimate by more than `noise` times the Poisson deviation of the cell's count
    (n_samples samples), halved at each split.  A fixed rule stalls at the pdf's steps inside cells (the
    transmitted lobe of a rough dielectric ends where its microfacets reach the horizon)."""
    i, j = np.meshgrid(np.arange(theta_res), np.arange(phi_res), indexing="ij")
    owner = (i * phi_res + j).ravel()
    t0, p0 = i.ravel() * np.pi / theta_res, j.ravel() * 2 * np.pi / phi_res
    t1, p1 = t0 + np.pi / theta_res, p0 + 2 * np.pi / phi_res
    estimate = _integrate(pdf, t0, t1, p0, p1, nodes)
    tol = noise * np.sqrt(np.maximum(n_samples * estimate, 1.0)) / n_samples
    total = np.zeros(theta_res * phi_res)
    for depth in range(max_depth + 1):
        tm, pm = (t0 + t1) / 2, (p0 + p1) / 2
        ct0, ct1 = np.concatenate([t0, t0, tm, tm]), np.concatenate([tm, tm, t1, t1])
        cp0, cp1 = np.concatenate([p0, pm, p0, pm]), np.concatenate([pm, p1, pm, p1])
        children = _integrate(pdf, ct0, ct1, cp0, cp1, nodes)
        refined = children.reshape(4, -1).sum(axis=0)
        done = (np.abs(refined - estimate) <= tol) | (depth == max_depth)
        np.add.at(total, owner[done], refined[done])
        keep = np.tile(~done, 4)
        if not keep.any():
            break
        owner, tol = np.tile(owner, 4)[keep], np.tile(tol / 2, 4)[keep]
        t0, t1, p0, p1, estimate = ct0[keep], ct1[keep], cp0[keep], cp1[keep], children[keep]
    return total.reshape(theta_res, phi_res)


def histogram(wi, theta_res=THETA_RES, phi_res=PHI_RES) -> np.ndarray:
    """(theta_res, phi_res) counts of directions wi (n, 3)."""
    wi = np.asarray(wi, np.float64)
    wi = wi / np.linalg.norm(wi, axis=1, keepdims=True)
    theta = np.arccos(np.clip(wi[:, 2], -1.0, 1.0))
    phi = np.mod(np.arctan2(wi[:, 1], wi[:, 0]), 2 * np.pi)
    i = np.minimum((theta / np.pi * theta_res).astype(np.int64), theta_res - 1)
    j = np.minimum((phi / (2 * np.pi) * phi_res).astype(np.int64), phi_res - 1)
    return np.bincount(i * phi_res + j, minlength=theta_res * phi_res).reshape(theta_res, phi_res)


@dataclass
class Chi2Result:
    statistic: float
    dof: int
    p_value: float
    cells: int  # cells after pooling
    pooled: int  # cells pooled for expecting fewer than MIN_EXPECTED
    failed_samples: int  # samples the sampler gave up on
    expected_failed: float  # N minus N * (integral of the pdf over the sphere)

    def __str__(self):
        return (
            f"chi2 = {self.statistic:.1f}, dof = {self.dof}, p = {self.p_value:.3g} ({self.cells} cells, {self.pooled} pooled; "
            f"failed samples {self.failed_samples}, expected {self.expected_failed:.1f})"
        )


def chi2_test(counts, integrals, n_samples: int, failed: int) -> Chi2Result:
    """Pearson's test of `counts` (the histogram of the n_samples - failed valid samples) against
    n_samples * integrals, with one more cell for the failed samples."""
    expected = np.append(n_samples * np.asarray(integrals, np.float64).ravel(), 0.0)
    expected_failed = n_samples - expected[:-1].sum()
    expected[-1] = max(0.0, expected_failed)
    observed = np.append(np.asarray(counts).ravel(), failed).astype(np.float64)
    # cells the quadrature gives no mass (a lobe narrower than its points can miss a sliver of a cell)
    # are pooled with the other small ones; samples where the whole pool expects nothing are impossible
    order = np.argsort(expected, kind="stable")
    expected, observed = expected[order], observed[order]
    small = int(np.searchsorted(expected, MIN_EXPECTED))  # cells expecting < MIN_EXPECTED, pooled into one
    pool_e, pool_o = expected[:small].sum(), observed[:small].sum()
    rest_e, rest_o = expected[small:], observed[small:]
    if 0 < pool_e < MIN_EXPECTED and len(rest_e):  # still too small: join the smallest of the others
        pool_e, pool_o = pool_e + rest_e[0], pool_o + rest_o[0]
        rest_e, rest_o = rest_e[1:], rest_o[1:]
    if pool_e == 0 and pool_o > 0:
        return Chi2Result(np.inf, 0, 0.0, len(expected), small, int(failed), float(expected_failed))
    if pool_e > 0:
        rest_e, rest_o = np.append(rest_e, pool_e), np.append(rest_o, pool_o)
    statistic = float(np.sum((rest_o - rest_e) ** 2 / rest_e))
    dof = len(rest_e) - 1
    return Chi2Result(statistic, dof, float(stats.chi2.sf(statistic, dof)), len(rest_e), small, int(failed), float(expected_failed))
