"""The path tracer's Sobol sampler (kernels/sobol.h, RenderSettings.path_sampler): the generator against an
integer Sobol written here from its direction numbers, the scrambled points' stratification (every power-of-two
prefix of a pixel's samples is a (0,m,2)-net in each pair of dimensions), uniformity and independence over pixels
and between pairs (chi-square), unbiased renders (the exact closed box, the float64 reference) and the same bits on
any tiling.

Statistics: each chi-square test and z-test here has a false-alarm probability of at most ALPHA = 0.001 for a seed
drawn at random; the seeds are fixed, so each test is deterministic."""

import numpy as np
import pytest
from scipy.stats import chi2

from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.sampling import path_draws, sequence_points
from clrender.trace.tracer import Tracer

from tests.pathtools import assert_expected, closed_box, closed_box_radiance, lamp_over_floor, mixed_scene
from tests.reference import pathtracer as pt
from tests.reference.ztest import two_sample_z

ALPHA = 1e-3
TWO_32 = 2.0**32


# ------------------------------------------------------------------ an independent Sobol (integers, no clrender)
def direction_numbers(dim: int) -> list[int]:
    """The 32 direction numbers v_k (as 32-bit fractions) of Sobol dimension 0 or 1.  Dimension 0: v_k = 2^(31-k),
    the van der Corput sequence.  Dimension 1: primitive polynomial x + 1 (degree 1, Joe-Kuo's first row: m_1 = 1),
    whose recurrence m_k = 2 m_{k-1} xor m_{k-1} gives v_k = v_{k-1} xor (v_{k-1} >> 1), v_1 = 2^31."""
    if dim == 0:
        return [1 << (31 - k) for k in range(32)]
    m = [1]
    for _ in range(31):
        m.append((2 * m[-1]) ^ m[-1])
    return [m[k] << (31 - k) for k in range(32)]


def sobol_reference(indices, dim: int) -> np.ndarray:
    """x_i = xor of v_k over the set bits k of i (the direct, not Gray-code, construction), as uint32."""
    v = direction_numbers(dim)
    out = []
    for i in indices:
        x, k = 0, 0
        while i:
            if i & 1:
                x ^= v[k]
            i >>= 1
            k += 1
        out.append(x)
    return np.array(out, np.uint32)


def test_unscrambled_points_are_the_sobol_sequence(device):
    """Coordinates 0 and 1 of the kernel's unscrambled sequence equal the reference bit for bit: the first 4096
    indices and a scatter of large ones (all 32 index bits in use); the first points are the textbook ones."""
    first = np.arange(4096)
    got = sequence_points([0], 4096, [0, 1], scrambled=False, device=device)[0]
    for dim in (0, 1):
        np.testing.assert_array_equal(got[:, dim], sobol_reference(first, dim))
    assert got[:4, 0].tolist() == [0, 1 << 31, 1 << 30, 3 << 30] and got[:4, 1].tolist() == [0, 1 << 31, 3 << 30, 1 << 30]
    for start in (123456789, (1 << 31) + 7, (1 << 32) - 64):
        got = sequence_points([0], 64, [0, 1], first=start, scrambled=False, device=device)[0]
        for dim in (0, 1):
            np.testing.assert_array_equal(got[:, dim], sobol_reference(range(start, start + 64), dim))


# ------------------------------------------------------------------ stratification
def is_net(points: np.ndarray, m: int) -> bool:
    """Whether 2^m points (uint32 pairs) put exactly one point in every elementary interval of area 2^-m:
    [a / 2^j, (a+1) / 2^j) x [b / 2^(m-j), (b+1) / 2^(m-j)) for every j = 0..m."""
    for j in range(m + 1):
        cell = (points[:, 0].astype(np.int64) >> (32 - j)) << (m - j) | (points[:, 1].astype(np.int64) >> (32 - (m - j)) if m > j else 0)
        if len(np.unique(cell)) != 1 << m:
            return False
    return True


@pytest.mark.parametrize("m", [4, 8])
def test_every_pair_of_dimensions_is_a_net_in_each_pixel(device, m):
    """For 2^m samples of a pixel, dimensions (2p, 2p + 1) are a (0,m,2)-net: one point in each elementary interval
    of every shape.  Pairs p of the camera (0), the first vertex's slots and lights, a deep vertex, across pixels and
    seeds; samples 0 .. 2^m - 1, and the next 2^m too (a progressive pass continues the net).  A scramble or index
    shuffle that differed between a pair's two coordinates breaks this.  The Owen scramble also places each point
    anywhere in its interval: the first 16 points' offsets inside their 1/16 columns (the low 28 bits) all differ,
    where an unscrambled block of the sequence puts every point at one offset (a collision among 16 random 28-bit
    offsets has probability 120 / 2^28 = 4.5e-7 per pixel and coordinate, 1.4e-4 over this test's 320)."""
    dims = [d for p in (0, 1, (1 << 20) // 2 + 2, (1 << 20) // 2 + 6, (20 << 20) // 2 + 1) for d in (2 * p, 2 * p + 1)]
    for seed in (0, 7):
        pts = sequence_points([0, 1, 999, 65535], 2 << m, dims, seed=seed, device=device)
        for pixel in pts:
            for k in range(0, len(dims), 2):
                assert is_net(pixel[: 1 << m, k : k + 2], m), (seed, dims[k])
                assert is_net(pixel[1 << m :, k : k + 2], m), (seed, dims[k], "second block")
                for c in (k, k + 1):
                    offsets = pixel[:16, c] & np.uint32((1 << 28) - 1)
                    assert len(np.unique(offsets)) == 16, (seed, dims[c], "offsets in the intervals")


def test_the_net_check_rejects_independent_points():
    """The check itself: 256 independent uniform pairs are not a (0,8,2)-net (probability 256!/256^256 of passing)."""
    rng = np.random.default_rng(1)
    assert not is_net(rng.integers(0, 1 << 32, (256, 2), dtype=np.uint64).astype(np.uint32), 8)
    assert is_net(np.stack([sobol_reference(range(256), 0), sobol_reference(range(256), 1)], axis=1), 8)


def chi_square_p(counts: np.ndarray) -> float:
    """Upper-tail p of Pearson's chi-square for equal expected counts."""
    expected = counts.sum() / counts.size
    return float(chi2.sf(((counts - expected) ** 2 / expected).sum(), counts.size - 1))


def test_values_are_uniform_and_independent_over_pixels(device):
    """One sample index of 16384 pixels: each dimension's values in 64 bins, and pairs (a pair's own two coordinates,
    two coordinates of different pairs, the camera against the first vertex) in 16 x 16 bins, pass Pearson's
    chi-square at ALPHA each (Sidak over the 10 tests)."""
    alpha = 1 - (1 - ALPHA) ** (1 / 10)
    dims = [0, 1, 2, (1 << 20) + 4, (1 << 20) + 5, (3 << 20) + 12]
    pts = sequence_points(np.arange(16384), 1, dims, seed=3, first=5, device=device)[:, 0, :] / TWO_32
    for k in range(4):
        assert chi_square_p(np.histogram(pts[:, k], 64, (0, 1))[0]) > alpha, dims[k]
    for a, b in ((0, 1), (3, 4), (0, 2), (1, 3), (2, 5), (4, 5)):
        counts = np.histogram2d(pts[:, a], pts[:, b], 16, [[0, 1], [0, 1]])[0]
        assert chi_square_p(counts) > alpha, (dims[a], dims[b])


def test_different_pairs_are_independent_within_a_pixel(device):
    """4096 samples of one pixel: coordinate 0 of pair p against coordinate 0 of pair q, 16 x 16 bins, chi-square at
    ALPHA (Sidak over 4 tests).  Without the per-pair index shuffle both are scrambles of the same van der Corput
    value, whose leading bits are then tied (chi-square in the thousands); the shuffle must also not ruin the
    uniformity of each pair's own net (too good a fit is not rejected: the test is one-sided)."""
    alpha = 1 - (1 - ALPHA) ** (1 / 4)
    dims = [0, 2, (1 << 20) + 4, (1 << 20) + 12, (2 << 20) + 3]
    pts = sequence_points([12345], 4096, dims, seed=9, device=device)[0] / TWO_32
    for a, b in ((0, 1), (1, 2), (2, 3), (0, 4)):
        counts = np.histogram2d(pts[:, a], pts[:, b], 16, [[0, 1], [0, 1]])[0]
        assert chi_square_p(counts) > alpha, (dims[a], dims[b])


# ------------------------------------------------------------------ renders
def test_sobol_renders_are_unbiased_on_the_exact_closed_box(device):
    """tests/trace/test_path.py's closed box of albedo 0.5 emitting 1, max_depth 3 (exactly 1.9375 everywhere), with
    path_sampler "sobol": K = 8 seeds (independent scrambles) of 64 paths, per-pixel t-tests and pooled z at ALPHA."""
    loaded = Scene.from_dict(closed_box())
    tracer = Tracer(loaded, device=device)
    images = np.stack(
        [Renderer(loaded, tracer=tracer, integrator="path", path_sampler="sobol", spp=64, max_depth=3, seed=s).run().image for s in range(1, 9)]
    ).astype(np.float64)
    assert_expected(images, closed_box_radiance(0.5, 1.0, 3), "closed box, sobol")


@pytest.mark.slow
def test_sobol_lamp_over_floor_matches_the_float64_reference_with_less_variance(device):
    """tests/trace/test_path.py's lamp over a floor (direct and two bounces): K = 8 Sobol renders of 64 paths against
    the float64 reference's 8 of 64 by two_sample_z (4 x 4 blocks, ALPHA), and the Sobol renders' variance over seeds,
    summed over pixels, is below 0.8 x the independent sampler's (the point of the sampler).  Measured: 0.49; each sum
    of 768 pixel-channel variances of 8 seeds has a relative standard error of a few percent, so 0.8 is many standard
    errors from both 0.49 and 1."""
    scene = lamp_over_floor()
    loaded = Scene.from_dict(scene)
    tracer = Tracer(loaded, device=device)

    def runs(sampler):
        return np.stack(
            [Renderer(loaded, tracer=tracer, integrator="path", path_sampler=sampler, spp=64, max_depth=2, seed=s).run().image for s in range(1, 9)]
        ).astype(np.float64)

    ours = runs("sobol")
    reference = np.stack([pt.render(scene, spp=64, max_depth=2, seed=100 + s).image for s in range(8)])
    result = two_sample_z(ours, reference, block=4, alpha=ALPHA)
    assert result.passed, result.report()
    assert ours.var(axis=0, ddof=1).sum() < 0.8 * runs("independent").var(axis=0, ddof=1).sum()


def test_sobol_gives_the_same_bits_whatever_the_tiles(device):
    """The Sobol sampler keys every number by (seed, pixel, sample, dimension): tiles of 5 (ragged), 16 and 128 pixels
    give the same bytes; the independent sampler gives another image."""
    loaded = Scene.from_dict(mixed_scene())
    tracer = Tracer(loaded, device=device)
    run = lambda **s: Renderer(loaded, tracer=tracer, integrator="path", spp=4, max_depth=3, seed=7, **s).run().image  # noqa: E731
    first = run(path_sampler="sobol", tile_size=5)
    assert run(path_sampler="sobol", tile_size=16).tobytes() == first.tobytes()
    assert run(path_sampler="sobol", tile_size=128).tobytes() == first.tobytes()
    assert (run(path_sampler="independent", tile_size=5) != first).mean() > 0.5


# ------------------------------------------------------------------ the setting
@pytest.mark.parametrize(
    "kind, expected",
    [("independent", "independent"), ("stratified", "sobol"), ("multijitter", "sobol"), ("orthogonal", "sobol"), ("ldsampler", "sobol")],
)
def test_a_mitsuba_sampler_sets_the_path_sampler(tmp_path, kind, expected):
    """Mitsuba's independent sampler stays independent; its stratified and low-discrepancy ones become Sobol."""
    from clrender.scene.mitsuba_plugins import read_mitsuba

    path = tmp_path / "s.xml"
    path.write_text(f'<scene version="3.0.0"><sensor type="perspective"><sampler type="{kind}"/></sensor></scene>')
    assert read_mitsuba(path).settings["path_sampler"] == expected


@pytest.mark.parametrize(
    "kind, expected", [("independent", "independent"), ("zsobol", "sobol"), ("sobol", "sobol"), ("halton", "sobol"), ("pmj02bn", "sobol")]
)
def test_a_pbrt_sampler_sets_the_path_sampler(tmp_path, kind, expected):
    from clrender.scene.pbrt import read_pbrt_file

    path = tmp_path / "s.pbrt"
    path.write_text(f'Sampler "{kind}" "integer pixelsamples" 4\nWorldBegin\n')
    assert read_pbrt_file(path).settings["path_sampler"] == expected


def test_the_command_line_and_the_scene_key_choose_the_sampler(tmp_path, capsys):
    """--path-sampler wins over the scene's path_sampler key, which wins over the default (sobol); a bad value in
    either is one line, exit 2, nothing written."""
    from clrender.cli import build_parser
    from clrender.commands import scene_defaults
    from clrender.commands.render import settings_from_args

    from tests.clitools import run_cli

    def chosen(argv, key=None):
        data = {"width": 4, "height": 4, **({"path_sampler": key} if key else {})}
        args = build_parser().parse_args(["render", "x", "--integrator", "path", *argv])
        return scene_defaults(args, settings_from_args(args), Scene.from_dict(data)).path_sampler

    assert chosen([]) == "sobol"
    assert chosen([], "independent") == "independent"
    assert chosen(["--path-sampler", "sobol"], "independent") == "sobol"
    assert chosen(["--path-sampler", "independent"]) == "independent"
    with pytest.raises(Exception, match="path_sampler"):
        Scene.from_dict({"path_sampler": "halton"})
    scene = tmp_path / "bad.toml"
    scene.write_text('path_sampler = "halton"\n')
    code, out, err = run_cli(capsys, "render", str(scene), "--integrator", "path", "-o", str(tmp_path / "x.png"))
    assert code == 2 and err.count("\n") == 1 and "halton" in err and not (tmp_path / "x.png").exists()


# ------------------------------------------------------------------ lanes
VERTEX_DIMS = 1 << 20  # kernels/sobol.h: the dimensions a bounce vertex owns, from VERTEX_DIMS * (depth + 1)
SLOTS = {"pick": 0, "rr": 1, "bsdf": 3, "light": 7}  # sobol.h's slots, as path_draws_probe takes them


@pytest.mark.parametrize("lanes", [8, 16])
def test_the_sampler_in_lanes_gives_the_scalar_bits(device, lanes):
    """sobol.h's sequence and the path tracer's draws through its Rng, built for `lanes` points a work-item (one in
    each lane), are bit for bit the one-point-a-work-item build's, over pixels and samples whose count is no multiple
    of the lanes."""
    pixels, dims = np.arange(0, 4000, 37), [0, 1, 2, 7, VERTEX_DIMS + 3, VERTEX_DIMS + 4, (9 << 20) + 8]
    for scrambled in (True, False):
        one = sequence_points(pixels, 5, dims, seed=4, first=3, scrambled=scrambled, device=device)
        assert np.array_equal(sequence_points(pixels, 5, dims, seed=4, first=3, scrambled=scrambled, device=device, lanes=lanes), one)
    one = path_draws(pixels, 3, 4, seed=9, first=2, device=device)
    assert np.array_equal(path_draws(pixels, 3, 4, seed=9, first=2, device=device, lanes=lanes).view(np.uint32), one.view(np.uint32))


def test_the_path_tracers_draws_are_the_sequences_dimensions(device):
    """What the Rng gives at each vertex and slot is the sequence's dimension there (2-D samples: one pair, the
    first at the even dimension), u = the 32-bit fraction's top 24 bits times 2^-24."""
    pixels, samples, depth = [0, 5, 1234], 4, 3
    draws = path_draws(pixels, samples, depth, seed=2, first=1, device=device)
    for v in range(depth):
        base = VERTEX_DIMS * (v + 1)
        dims = [
            base + SLOTS["pick"],
            base + SLOTS["rr"],
            *(base + SLOTS["bsdf"] + k for k in range(3)),
            *(base + SLOTS["light"] + k for k in range(3)),
        ]
        bits = sequence_points(pixels, samples, dims, seed=2, first=1, device=device)
        want = (bits >> 8).astype(np.float64) * 2.0**-24
        np.testing.assert_array_equal(draws[:, :, v, :8], want.astype(np.float32))
    assert ((draws[..., 8] >= 0) & (draws[..., 8] < 1)).all()
