"""Gaussian splats: forward kernel vs a float64 numpy reference, backward kernel vs central
finite differences of that reference's loss, binning invariants, losses, optimisers, fitting."""

import numpy as np
import pyopencl as cl
import pytest

from clrender.layout import SPLAT_BOX_DTYPE
from clrender.splat.gauss import GROUPS, GaussParams, GaussRenderer
from clrender.splat.losses import loss_and_grad, psnr, ssim

W, H = 40, 37  # not a multiple of the 16-pixel tile: partial tiles on two sides


def reference_render(p: dict, width: int, height: int, blend: str, background=(0.1, 0.2, 0.3)):
    """Every splat at every pixel, in float64, written from the definition (no tiles, no (A, B2, C))."""
    ys, xs = np.mgrid[0:height, 0:width] + 0.5
    d = np.stack([xs[None] - p["xy"][:, 0, None, None], ys[None] - p["xy"][:, 1, None, None]], -1)
    c, s = np.cos(p["theta"]), np.sin(p["theta"])
    rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)  # (N, 2, 2)
    inv_var = np.exp(-2 * p["log_scale"])
    sigma_inv = rot @ (inv_var[:, :, None] * np.swapaxes(rot, 1, 2))
    q = np.einsum("nhwi,nij,nhwj->nhw", d, sigma_inv, d)
    w = np.where(q < 9.0, p["opacity"][:, None, None] * np.exp(-0.5 * q), 0.0)
    col = p["color"] * p["lum"][:, None]
    total = np.einsum("nhw,nc->hwc", w, col)
    wsum = w.sum(0)
    bg = np.asarray(background, float)
    if blend == "sum":
        return total + bg
    return (total + 1e-3 * bg) / (wsum + 1e-3)[..., None]


def make_splats(rng, n=7):
    """Rotated, anisotropic splats, some near or over the borders, some spanning several tiles."""
    xy = np.array([[3.0, 4.0], [20.3, 18.7], [38.5, 35.2], [15.9, 16.1], [31.0, 6.0], [8.0, 30.0], [24.0, 24.0]])[:n]
    log_scale = np.log(np.array([[2.0, 5.0], [6.0, 2.5], [3.0, 3.0], [1.2, 4.0], [4.0, 1.5], [7.0, 3.0], [2.2, 2.8]]))[:n]
    return {
        "xy": xy,
        "log_scale": log_scale,
        "theta": rng.uniform(-np.pi, np.pi, n),
        "color": rng.uniform(0.05, 0.9, (n, 3)),
        "lum": rng.uniform(0.7, 1.2, n),
        "opacity": rng.uniform(0.4, 1.0, n),
    }


def to_params(p, blend, background=(0.1, 0.2, 0.3)):
    return GaussParams(**p, width=W, height=H, blend=blend, background=background)


@pytest.mark.parametrize("blend", ["sum", "normalized"])
def test_forward_matches_reference(device, rng, blend):
    p = make_splats(rng)
    renderer = GaussRenderer(device, W, H, blend, background=(0.1, 0.2, 0.3))
    frame = renderer.forward(to_params(p, blend))
    ref = reference_render({k: v.astype(np.float32).astype(float) for k, v in p.items()}, W, H, blend)
    np.testing.assert_allclose(frame.image, ref, atol=2e-5, rtol=1e-4)
    assert np.ptp(ref) > 0.5  # the scene is not trivially flat
    # where no splat reaches, both blends show exactly the background colour
    empty = frame.weight == 0
    assert 0 < empty.sum() < empty.size
    np.testing.assert_allclose(frame.image[empty], np.broadcast_to([0.1, 0.2, 0.3], (empty.sum(), 3)), atol=1e-6)


def test_forward_on_selected_tiles_only(device, rng):
    p = to_params(make_splats(rng), "normalized")
    renderer = GaussRenderer(device, W, H, "normalized", background=(0.1, 0.2, 0.3))
    full = renderer.forward(p).image
    part = renderer.forward(p, tiles=np.array([1, 4], np.int32)).image  # tiles (1,0) and (1,1)
    np.testing.assert_array_equal(part[:32, 16:32], full[:32, 16:32])
    assert not part[:, :16].any() and not part[32:].any()


def test_binning_covers_every_touching_tile(device, rng):
    n = 300
    xy = rng.uniform(-10, 110, (n, 2))
    log_scale = np.log(rng.uniform(0.3, 12, (n, 2)))
    theta = rng.uniform(-3, 3, n)
    params = GaussParams(xy, log_scale, theta, np.ones((n, 3)), np.ones(n), np.ones(n), width=100, height=70)
    renderer = GaussRenderer(device, 100, 70)
    frame = renderer.forward(params)
    b, boxes = frame.binning, np.empty(n, SPLAT_BOX_DTYPE)
    cl.enqueue_copy(device.queue, boxes, frame.packed.boxes)  # the pixel boxes splat_prepare computed
    x0, y0, x1, y1 = (boxes[name] for name in ("x0", "y0", "x1", "y1"))
    assert b.tiles_x == 7 and b.tiles_y == 5
    assert np.all(np.diff(b.entry_tile) >= 0)
    # brute force: splat i belongs to tile t iff their pixel rectangles intersect, listed in splat order
    for t in range(b.tiles_x * b.tiles_y):
        tx, ty = t % b.tiles_x, t // b.tiles_x
        hit = (x0 < tx * 16 + 16) & (x1 > tx * 16) & (y0 < ty * 16 + 16) & (y1 > ty * 16) & (x1 > x0) & (y1 > y0)
        listed = b.entry_splat[b.tile_start[t] : b.tile_start[t + 1]]
        np.testing.assert_array_equal(listed, np.nonzero(hit)[0])
        np.testing.assert_array_equal(b.entry_tile[b.tile_start[t] : b.tile_start[t + 1]], t)
    # the box holds every pixel centre inside the 3-sigma ellipse ...
    ys, xs = np.mgrid[0:70, 0:100] + 0.5
    for i in range(n):
        c, s = np.cos(theta[i]), np.sin(theta[i])
        dx, dy = xs - xy[i, 0], ys - xy[i, 1]
        u, v = (c * dx + s * dy) / np.exp(log_scale[i, 0]), (-s * dx + c * dy) / np.exp(log_scale[i, 1])
        yy, xx = np.nonzero(u * u + v * v < 9)
        assert np.all((xx >= x0[i]) & (xx < x1[i]) & (yy >= y0[i]) & (yy < y1[i]))
    # ... and is the float64 box around the ellipse's extents x +- 3 sqrt(Sxx), y +- 3 sqrt(Syy)
    sx2, sy2 = np.exp(2 * log_scale[:, 0]), np.exp(2 * log_scale[:, 1])
    c2, s2 = np.cos(theta) ** 2, np.sin(theta) ** 2
    rx, ry = 3 * np.sqrt(c2 * sx2 + s2 * sy2), 3 * np.sqrt(s2 * sx2 + c2 * sy2)
    ref = np.stack([np.ceil(xy[:, 0] - rx - 0.5), np.ceil(xy[:, 1] - ry - 0.5), np.floor(xy[:, 0] + rx + 0.5), np.floor(xy[:, 1] + ry + 0.5)], 1)
    ref = np.clip(ref, 0, [100, 70, 100, 70])
    box = np.stack([x0, y0, x1, y1], 1)
    assert np.abs(box - ref).max() <= 1 and np.mean(box == ref) > 0.99


def fd_gradient(p, blend, loss, target, name, index, h):
    def value(delta):
        q = {k: v.copy() for k, v in p.items()}
        q[name][index] += delta
        return loss_and_grad(loss, reference_render(q, W, H, blend), target)[0]

    return (value(h) - value(-h)) / (2 * h)


STEPS = {"xy": 1e-4, "log_scale": 1e-5, "theta": 1e-5, "color": 1e-5, "lum": 1e-5, "opacity": 1e-5}


@pytest.mark.parametrize("blend", ["sum", "normalized"])
@pytest.mark.parametrize("loss", ["l2", "l1", "l1-ssim"])
def test_backward_matches_finite_differences(device, rng, blend, loss):
    p = make_splats(rng)
    p = {k: v.astype(np.float32).astype(float) for k, v in p.items()}
    target = np.random.default_rng(7).uniform(0, 1, (H, W, 3))
    renderer = GaussRenderer(device, W, H, blend, background=(0.1, 0.2, 0.3))
    frame = renderer.forward(to_params(p, blend))
    _, d_image = loss_and_grad(loss, frame.image.astype(float), target)
    grads = renderer.backward(frame, d_image.astype(np.float32))
    for name in GROUPS:
        g = grads[name]
        assert g.shape == p[name].shape
        for index in np.ndindex(*p[name].shape):
            fd = fd_gradient(p, blend, loss, target, name, index, STEPS[name])
            scale = np.abs(g).max()
            assert abs(g[index] - fd) <= 2e-3 * scale + 1e-3 * abs(fd), (name, index, g[index], fd)


def test_ssim_gradient_and_identity(rng):
    x = rng.uniform(0, 1, (12, 13, 3))
    y = np.clip(x + rng.normal(0, 0.1, x.shape), 0, 1)
    assert ssim(y, y) == pytest.approx(1.0, abs=1e-12)
    value, grad = ssim(x, y, with_grad=True)
    assert value < 0.99
    for index in [(0, 0, 0), (5, 6, 1), (11, 12, 2), (3, 10, 0)]:
        e = np.zeros_like(x)
        e[index] = 1e-6
        fd = (ssim(x + e, y) - ssim(x - e, y)) / 2e-6
        assert grad[index] == pytest.approx(fd, rel=1e-5, abs=1e-9)


def test_losses_and_psnr():
    x = np.full((4, 4, 3), 0.5)
    y = np.full((4, 4, 3), 0.4)
    assert loss_and_grad("l2", x, y)[0] == pytest.approx(0.01)
    assert loss_and_grad("l1", x, y)[0] == pytest.approx(0.1)
    assert psnr(x, y) == pytest.approx(20.0)
    mask = np.zeros((4, 4), bool)
    mask[0, 0] = True
    value, grad = loss_and_grad("l2", x, y, mask)
    assert value == pytest.approx(0.01) and np.count_nonzero(grad) == 3
