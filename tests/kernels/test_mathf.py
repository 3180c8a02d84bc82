"""kernels/mathf.h's deterministic float32 functions against float64 numpy, over each function's whole range.

Arguments: random float32 bit patterns (every exponent, denormals included, both signs), a dense grid over the
range the renderer uses, and the special values (+-0, +-inf, NaN, the smallest denormal, the largest float,
huge arguments for sin and cos).  Errors are in ulp of the float32 nearest the exact result (numpy's float64
function of the float32 argument: its own error, about 2^-29 ulp here, is far below the bounds).  The bounds are
the ones mathf.h's comment and docs/math.md state; a function that breaks one fails here with the argument."""

from __future__ import annotations

import numpy as np
import pytest

from clrender.mathf_probe import evaluate, lane_functions

FLT_MAX = float(np.finfo(np.float32).max)
SPECIALS = np.array(
    [0.0, -0.0, np.inf, -np.inf, np.nan, 1e-45, -1e-45, 1.1754942e-38, 1.1754944e-38, FLT_MAX, -FLT_MAX, 1.0, -1.0, 0.5, 2.0,
     np.pi / 2, np.pi, 2 * np.pi, 1e4, 1e8, 1e15, 1e22, 1e30, 1e38, 16367173.0 * 2.0**72, 255.99998, 256.0],
    np.float32,
)  # fmt: skip


def ulp_error(got: np.ndarray, exact: np.ndarray) -> np.ndarray:
    """|got - exact| in ulp of the float32 nearest `exact` (the smallest denormal's at least); 0 where both are
    the same infinity or both NaN; inf where one is NaN and the other not."""
    got = got.astype(np.float64)
    with np.errstate(all="ignore"):
        nearest = np.clip(np.abs(exact), 0, FLT_MAX).astype(np.float32)
        ulp = np.where(nearest == np.float32(FLT_MAX), 2.0**104, np.maximum(np.spacing(nearest).astype(np.float64), 2.0**-149))
        beyond = np.abs(exact) > FLT_MAX * (1 + 2.0**-25)  # rounds to inf in float32
        exact = np.where(beyond, np.copysign(np.inf, exact), exact)
        err = np.abs(got - exact) / ulp
    same = (got == exact) | (np.isnan(got) & np.isnan(exact))
    err[same] = 0.0
    err[np.isnan(got) != np.isnan(exact)] = np.inf
    return err


def random_floats(rng, n: int) -> np.ndarray:
    """n float32 of random bits, finite, half of them negative: every exponent equally often."""
    x = rng.integers(0, 2**32, n, dtype=np.uint64).astype(np.uint32).view(np.float32)
    return x[np.isfinite(x)]


def arguments(name: str, n: int, seed: int = 5) -> np.ndarray:
    rng = np.random.default_rng(seed)
    dense = {"sin": (-300, 300), "cos": (-300, 300), "exp": (-110, 90), "log": (0, 4), "acos": (-1, 1), "asin": (-1, 1)}[name]
    x = np.concatenate([random_floats(rng, n), np.linspace(*dense, n, dtype=np.float32), SPECIALS, -SPECIALS])
    if name in ("acos", "asin"):
        x = np.concatenate([x, rng.uniform(-1, 1, n).astype(np.float32)])
    return x


REFERENCES = {"sin": np.sin, "cos": np.cos, "exp": np.exp, "log": np.log, "acos": np.arccos, "asin": np.arcsin}
BOUNDS_ULP = {"sin": 2.5, "cos": 2.5, "exp": 2.0, "log": 2.0, "acos": 3.0, "asin": 3.0}  # as mathf.h states
SMALL_SINCOS_ABS = 2.0**-35  # sin and cos: absolute error where |result| < 2^-12


def check_unary(name: str, n: int, device) -> float:
    x = arguments(name, n)
    got = evaluate(name, x, device=device)
    with np.errstate(all="ignore"):
        exact = REFERENCES[name](x.astype(np.float64))
    err = ulp_error(got, exact)
    if name in ("sin", "cos"):  # near a zero of sin or cos the bound is absolute
        small = np.abs(exact) < 2.0**-12
        assert np.all(np.abs(got[small] - exact[small]) <= SMALL_SINCOS_ABS), name
        err[small] = 0.0
    worst = int(np.argmax(err))
    assert err[worst] <= BOUNDS_ULP[name], f"{name}({x[worst]!r}) = {got[worst]!r}, exact {exact[worst]!r}: {err[worst]:.2f} ulp"
    return float(err.max())


@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_unary_within_bound(device, name):
    check_unary(name, 1 << 14, device)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(REFERENCES))
def test_unary_within_bound_dense(device, name):
    check_unary(name, 1 << 22, device)


def atan2_arguments(n: int, seed: int = 6):
    rng = np.random.default_rng(seed)
    y = np.concatenate([random_floats(rng, n)[: n // 2], rng.uniform(-1, 1, n).astype(np.float32)])
    x = np.concatenate([random_floats(rng, n)[: n // 2], rng.uniform(-1, 1, n).astype(np.float32)])
    m = min(y.size, x.size)
    special_y, special_x = np.meshgrid(SPECIALS[:12], SPECIALS[:12])
    return np.concatenate([y[:m], special_y.ravel()]), np.concatenate([x[:m], special_x.ravel()])


@pytest.mark.parametrize("n", [pytest.param(1 << 14, id="fast"), pytest.param(1 << 22, id="dense", marks=pytest.mark.slow)])
def test_atan2_within_bound_and_c99_specials(device, n):
    y, x = atan2_arguments(n)
    got = evaluate("atan2", y, x, device=device)
    exact = np.arctan2(y.astype(np.float64), x.astype(np.float64))  # C99's atan2, signed zeros and infinities included
    err = ulp_error(got, exact)
    worst = int(np.argmax(err))
    assert err[worst] <= 3.0, f"atan2({y[worst]!r}, {x[worst]!r}) = {got[worst]!r}, exact {exact[worst]!r}"
    zeros = exact == 0
    assert np.array_equal(np.signbit(got[zeros]), np.signbit(exact[zeros]))  # atan2(-0, 1) is -0


def test_pow_within_bound_and_c99_specials(device):
    rng = np.random.default_rng(8)
    x = np.concatenate([np.abs(random_floats(rng, 1 << 14)), rng.uniform(0, 4, 1 << 14).astype(np.float32), SPECIALS, -SPECIALS])
    y = np.concatenate([rng.uniform(-30, 30, x.size - 2 * SPECIALS.size).astype(np.float32), SPECIALS, SPECIALS])
    xs, ys = np.meshgrid(np.concatenate([SPECIALS[:12], -SPECIALS[:12]]), np.array([0, -0.0, 1, -1, 2, -2, 3, -3, 0.5, np.inf, -np.inf, np.nan]))
    x, y = np.concatenate([x, xs.ravel()]).astype(np.float32), np.concatenate([y, ys.ravel()]).astype(np.float32)
    got = evaluate("pow", x, y, device=device)
    with np.errstate(all="ignore"):
        exact = np.power(x.astype(np.float64), y.astype(np.float64))  # C99's pow
        allowed = 2.0 + 2.0 * np.abs(y.astype(np.float64) * np.log(np.abs(x.astype(np.float64))))
    err = ulp_error(got, exact)
    finite = np.isfinite(allowed)
    worst = int(np.argmax(np.where(finite, err - allowed, err)))
    assert err[worst] <= (allowed[worst] if finite[worst] else 0.0), f"pow({x[worst]!r}, {y[worst]!r}) = {got[worst]!r}, exact {exact[worst]!r}"


def test_floor_and_sqrt_exact(device):
    rng = np.random.default_rng(9)
    x = np.concatenate([random_floats(rng, 1 << 15), rng.uniform(-1e7, 1e7, 1 << 15).astype(np.float32), SPECIALS, -SPECIALS])
    assert np.array_equal(evaluate("floor", x, device=device).view(np.uint32), np.floor(x).view(np.uint32))  # -0 stays -0
    with np.errstate(invalid="ignore"):
        want = np.sqrt(x)  # IEEE's correctly rounded float32 square root
    got = evaluate("sqrt", x, device=device)
    assert np.array_equal(got[~np.isnan(want)].view(np.uint32), want[~np.isnan(want)].view(np.uint32))
    assert np.all(np.isnan(got[np.isnan(want)]))


def test_sin_cos_of_huge_arguments(device):
    """Payne-Hanek reduction: the biggest floats' sines are as exact as small ones' (naive reduction by a float
    pi/2 gives garbage there)."""
    x = np.float32(2.0) ** np.arange(8, 128, dtype=np.float32) * np.float32(1.2345678)
    for name, ref in (("sin", np.sin), ("cos", np.cos)):
        err = ulp_error(evaluate(name, x, device=device), ref(x.astype(np.float64)))
        assert err.max() <= BOUNDS_ULP[name], name


@pytest.mark.parametrize("lanes", [8, 16])
def test_the_lane_forms_are_the_scalar_functions_bit_for_bit(device, lanes):
    """kernels/lanes.h's sincos_l, atan2_l, acos_l and exp_l, 8 or 16 arguments a work-item, give mathf.h's sin_det,
    cos_det, atan2_det, acos_det and exp_det bit for bit: sin and cos over |x| < 256 (their stated range: every argument the path tracer
    makes), atan2 and acos over random bit patterns, the special values and their pairs (zeros, infinities, NaN)."""
    rng = np.random.default_rng(lanes)
    x = np.concatenate([rng.uniform(-256, 256, 20000), np.float32([0.0, -0.0, 0.785398163, -0.785398163, 255.99998, 1e-30])]).astype(np.float32)
    y, b = random_floats(rng, 20000), random_floats(rng, 20000)
    y, b = y[: min(y.size, b.size)], b[: min(y.size, b.size)]
    specials = np.array(np.meshgrid(SPECIALS, SPECIALS)).reshape(2, -1).astype(np.float32)
    small = x[np.abs(x) < 256]
    got = lane_functions(small, np.ones_like(small), lanes, device)
    for column, name in ((0, "sin"), (1, "cos")):
        assert np.array_equal(got[:, column].view(np.uint32), evaluate(name, small, device=device).view(np.uint32)), name
    for a, c in ((y, b), (specials[0], specials[1])):
        got = lane_functions(a, c, lanes, device)
        for column, want in ((2, evaluate("atan2", a, c, device=device)), (3, evaluate("acos", c, device=device))):
            same = (got[:, column].view(np.uint32) == want.view(np.uint32)) | (np.isnan(got[:, column]) & np.isnan(want))
            assert same.all(), (column, a[~same][:5], c[~same][:5])
    unit = rng.uniform(-1, 1, 20000).astype(np.float32)  # acos's whole domain, densely
    got = lane_functions(unit, unit, lanes, device)[:, 3]
    assert np.array_equal(got.view(np.uint32), evaluate("acos", unit, device=device).view(np.uint32))
    for a in (rng.uniform(-110, 95, 20000).astype(np.float32), y, SPECIALS):  # exp: its range and past both ends
        got, want = lane_functions(a, 0.0, lanes, device)[:, 4], evaluate("exp", a, device=device)
        same = (got.view(np.uint32) == want.view(np.uint32)) | (np.isnan(got) & np.isnan(want))
        assert same.all(), (a[~same][:5], got[~same][:5], want[~same][:5])
