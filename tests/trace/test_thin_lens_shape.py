"""The thin lens samples its whole disc (kernels/camera.h): the 2-D shape of an out-of-focus point's blur, not
only its radius (issue 38, "behaviours no fast test pins": a sampler that put every lens sample on a diagonal
line across the disc passed the radius test).  A uniform disc of radius R has the covariance R^2 / 4 I: equal
variances along x and y, no covariance; a line along a diagonal has Cxx = Cyy = Cxy, a horizontal one Cyy = 0.
Convolution adds covariances: the tiny square's h^2 / 3 per axis and the pixel box's 1 / 12 are taken off."""

import math

import numpy as np
import pytest

from clrender.trace.renderer import render

from tests.scenetools import flat_scene, pixels_per_unit, square

FOV, SIZE, APERTURE, DEPTH, FOCUS = 30.0, 64, 1.0, 10.0, 5.0


def covariance(image):
    v = image[..., 0].astype(np.float64)
    ys, xs = np.mgrid[0 : v.shape[0], 0 : v.shape[1]] + 0.5
    total = v.sum()
    cx, cy = (v * xs).sum() / total, (v * ys).sum() / total
    dx, dy = xs - cx, ys - cy
    return np.array([[(v * dx * dx).sum(), (v * dx * dy).sum()], [(v * dx * dy).sum(), (v * dy * dy).sum()]]) / total


def test_out_of_focus_point_is_an_isotropic_disc():
    scale = pixels_per_unit(FOV, SIZE)
    h = 2.0  # the square's half side in pixels, in focus: 16 px^2, about 4,000 of the 256 samples a pixel hit it
    camera = {"position": [0, 0, 0], "look_at": [0, 0, -1], "fov": FOV, "aperture": APERTURE, "focus_distance": FOCUS}
    image = render(flat_scene([square((0, 0, -DEPTH), h / scale * DEPTH)], camera, (SIZE, SIZE)), aa="full", samples=16, seed=7)
    c = covariance(image) - (h * h / 3 + 1 / 12) * np.eye(2)
    radius = APERTURE * abs(DEPTH - FOCUS) / (FOCUS * DEPTH) * scale  # 11.9 pixels
    # 4,096 samples: each variance's relative standard error is 1/64 (x^2 on a disc: sd = mean), the covariance's
    # standard error about R^2 / 4 / 64; the bounds are 7 and 6 standard errors
    assert c[0, 0] == pytest.approx(radius**2 / 4, rel=0.12)
    assert c[1, 1] == pytest.approx(radius**2 / 4, rel=0.12)
    assert abs(c[0, 1]) < 0.1 * radius**2 / 4  # a diagonal line: c01 = c00
    lit = image[..., 0] > 0
    minkowski = (2 * h) ** 2 + 4 * (2 * h) * radius + math.pi * radius**2  # the square swept over the disc: 655 px
    assert lit.sum() == pytest.approx(minkowski, rel=0.2)  # a disc's area, not a line's
