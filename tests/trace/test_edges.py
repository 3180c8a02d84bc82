"""Edge masks from object IDs: the seed's up/left/up-left rule on hand-made buffers, disc dilation
against a brute-force distance computation, reflection and shadow edges, and bad input."""

import math

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.trace import edges
from clrender.trace.edges import dilate, disc, edge_mask, edge_pixels, overlay_edges


def picture(text: str) -> np.ndarray:
    """A bool mask written as rows of '#' (True) and '.' (False)."""
    return np.array([[c == "#" for c in row] for row in text.split()], bool)


def brute_force_dilate(mask: np.ndarray, L: float) -> np.ndarray:
    """Every pixel whose squared distance to some True pixel is <= L^2, from all pairs."""
    H, W = mask.shape
    ys, xs = np.nonzero(mask)
    gy, gx = np.mgrid[0:H, 0:W]
    d2 = (gy[..., None] - ys) ** 2 + (gx[..., None] - xs) ** 2  # (H, W, n) integer squared distances
    return (d2 <= L * L).any(axis=-1) if len(ys) else np.zeros_like(mask)


# ---- the seed's rule on hand-made ID buffers --------------------------------------------


def test_square_marks_top_left_boundary_and_just_past_bottom_right():
    ids = np.full((8, 8), -1, np.int32)
    ids[2:5, 2:5] = 7  # a 3x3 square, rows 2-4, columns 2-4
    # Row 2 and column 2 of the square: the pixel above / left is background.
    # Row 5 (x 2..5) and column 5 (y 2..5): the pixel above / left / up-left is in the square.
    expected = picture("""
        ........
        ........
        ..####..
        ..#..#..
        ..#..#..
        ..####..
        ........
        ........
    """)
    np.testing.assert_array_equal(edge_pixels(ids), expected)
    np.testing.assert_array_equal(edge_mask(ids, thickness=0), expected)


def test_diagonal_line():
    ids = np.where(np.eye(6, dtype=bool), 3, 0).astype(np.int32)  # object 3 on x == y
    # On the line the pixel above differs (not at (0, 0), which has no neighbours);
    # right of it the left pixel is the line; below it the pixel above is the line.
    expected = picture("""
        .#....
        ###...
        .###..
        ..###.
        ...###
        ....##
    """)
    np.testing.assert_array_equal(edge_pixels(ids), expected)


def test_anti_diagonal_line_uses_the_up_left_neighbour():
    y, x = np.mgrid[0:6, 0:6]
    ids = np.where(x + y == 5, 4, 0).astype(np.int32)  # object 4 on x + y == 5
    # x + y == 5, 6: above or left differs; x + y == 7: only the up-left pixel is on the line.
    expected = picture("""
        .....#
        ....##
        ...###
        ..###.
        .###..
        ###...
    """)
    np.testing.assert_array_equal(edge_pixels(ids), expected)
    assert np.array_equal(expected, (x + y >= 5) & (x + y <= 7))


def test_one_pixel_object():
    ids = np.zeros((5, 5), np.int32)
    ids[2, 2] = 1
    expected = picture("""
        .....
        .....
        ..##.
        ..##.
        .....
    """)
    np.testing.assert_array_equal(edge_pixels(ids), expected)


def test_row_and_column_zero_compare_only_existing_neighbours():
    ids = np.zeros((4, 4), np.int32)
    ids[0, 2:] = 5  # top row changes at x = 2: only the left neighbour exists there
    ids[2:, 0] = 6  # left column changes at y = 2: only the pixel above exists there
    expected = picture("""
        ..#.
        ..##
        ##..
        .#..
    """)
    np.testing.assert_array_equal(edge_pixels(ids), expected)


def test_uniform_image_has_no_edges_and_tiny_images_work():
    assert not edge_pixels(np.full((5, 7), 2, np.int32)).any()
    assert not edge_pixels(np.zeros((1, 1), np.int32)).any()
    assert edge_pixels(np.array([[0, 1]], np.int32)).tolist() == [[False, True]]
    assert edge_pixels(np.array([[0], [1]], np.int32)).tolist() == [[False], [True]]
    assert edge_pixels(np.zeros((0, 3), np.int32)).shape == (0, 3)


def test_edges_match_a_direct_per_pixel_reference(rng):
    ids = rng.integers(-1, 3, size=(9, 11, 3)).astype(np.int32)
    ids[..., 0] = rng.integers(0, 2, size=(9, 11))
    got = edge_pixels(ids, shadow_edges=False)
    H, W, _ = ids.shape
    expected = np.zeros((H, W), bool)
    for y in range(H):  # the rule, pixel by pixel, straight from its definition
        for x in range(W):
            for dy, dx in ((-1, 0), (0, -1), (-1, -1)):
                if y + dy >= 0 and x + dx >= 0 and not np.array_equal(ids[y, x], ids[y + dy, x + dx]):
                    expected[y, x] = True
    np.testing.assert_array_equal(got, expected)


# ---- the ID path: edges seen in reflections and refractions -----------------------------


def test_path_ids_that_differ_only_after_a_bounce_are_edges():
    H, W = 6, 8
    ids = np.full((H, W, 3), -1, np.int32)
    ids[..., 0] = 1  # a mirror fills the view: the primary IDs are all equal
    ids[:, :4, 1] = 2  # its reflection shows object 2 on the left, object 3 on the right
    ids[:, 4:, 1] = 3
    expected = np.zeros((H, W), bool)
    expected[:, 4] = True  # left (and up-left) neighbour differs at column 4
    np.testing.assert_array_equal(edge_pixels(ids), expected)
    assert not edge_pixels(ids[..., 0]).any()  # primary IDs alone see nothing
    # a path that ends (-1) where its neighbour goes on is an edge too
    ids[..., 1] = 2
    ids[3:, :, 2] = 5
    expected = np.zeros((H, W), bool)
    expected[3, :] = True
    np.testing.assert_array_equal(edge_pixels(ids), expected)


def test_k1_path_equals_plain_id_image(rng):
    ids = rng.integers(0, 3, size=(7, 9)).astype(np.int32)
    np.testing.assert_array_equal(edge_pixels(ids), edge_pixels(ids[..., None]))


# ---- shadow edges -------------------------------------------------------------------------


def test_shadow_edges_appear_only_when_enabled():
    H, W = 6, 6
    ids = np.zeros((H, W, 2), np.int32)
    shadow = np.ones((H, W, 2), np.float32)
    shadow[:, 3:, 1] = 0.25  # light 1 is partly blocked on the right half of one object
    expected = np.zeros((H, W), bool)
    expected[:, 3] = True
    np.testing.assert_array_equal(edge_pixels(ids, shadow), expected)
    np.testing.assert_array_equal(edge_pixels(ids, shadow, shadow_edges=True), expected)
    assert not edge_pixels(ids, shadow, shadow_edges=False).any()
    assert not edge_pixels(ids, None).any()
    assert not edge_mask(ids, 2.0, shadow, shadow_edges=False).any()
    np.testing.assert_array_equal(edge_mask(ids, 2.0, shadow), dilate(expected, 2.0))


def test_shadow_tolerance():
    ids = np.zeros((4, 4), np.int32)
    shadow = np.ones((4, 4, 1), np.float32)
    shadow[2:] = 1.0 - 5e-4  # a penumbra change smaller than the default tolerance
    assert not edge_pixels(ids, shadow).any()
    expected = np.zeros((4, 4), bool)
    expected[2] = True
    np.testing.assert_array_equal(edge_pixels(ids, shadow, shadow_tolerance=1e-4), expected)
    np.testing.assert_array_equal(edge_pixels(ids, shadow[..., 0], shadow_tolerance=1e-4), expected)
    assert not edge_pixels(ids, np.ones((4, 4, 0), np.float32)).any()  # a scene with no lights


# ---- thickness: discs ------------------------------------------------------------------------


def test_single_pixel_grows_as_discs():
    mask = np.zeros((9, 9), bool)
    mask[4, 4] = True
    np.testing.assert_array_equal(dilate(mask, 0), mask)
    np.testing.assert_array_equal(dilate(mask, 0.99), mask)
    assert dilate(mask, 1.0).sum() == 5  # the centre and its four neighbours
    assert dilate(mask, math.sqrt(2)).sum() == 9  # the 3x3 square: diagonals at distance sqrt(2)
    expected = picture("""
        .........
        .........
        ...###...
        ..#####..
        ..#####..
        ..#####..
        ...###...
        .........
        .........
    """)
    np.testing.assert_array_equal(dilate(mask, 2.5), expected)  # 5x5 less its corners: 21 pixels
    assert expected.sum() == 21


@pytest.mark.parametrize("method", ["cv2", "rows"])
@pytest.mark.parametrize("L", [0, 0.5, 1, math.sqrt(2), 2, 2.5, 3, 5.05, 7.9, 8, 8.5, 12.5, 17, 30.2])
def test_dilate_matches_brute_force_distances(rng, monkeypatch, method, L):
    # small radii take cv2.dilate, large ones exact row distances: force each path, both must be exact
    monkeypatch.setattr(edges, "_CV2_MAX_RADIUS", 1e9 if method == "cv2" else 0)
    mask = rng.random((33, 41)) < 0.01
    mask[0, 0] = mask[-1, -1] = mask[0, -1] = True  # corners exercise the image border
    np.testing.assert_array_equal(dilate(mask, L), brute_force_dilate(mask, L))


def test_dilate_of_the_square_edges_matches_brute_force():
    ids = np.zeros((20, 24), np.int32)
    ids[5:12, 6:15] = 1
    edges = edge_pixels(ids)
    for L in (0, 1, 2.5):
        np.testing.assert_array_equal(edge_mask(ids, L), brute_force_dilate(edges, L))


def test_dilate_with_huge_radius_and_empty_masks(rng):
    mask = np.zeros((5, 7), bool)
    assert not dilate(mask, 100).any()
    mask[1, 1] = True
    assert dilate(mask, 1e300).all()
    # the farthest pixel from (1, 1) is (4, 6), at distance sqrt(34) = 5.8309...
    assert dilate(mask, 5.831).all() and not dilate(mask, 5.830).all()
    assert dilate(np.zeros((0, 4), bool), 3).shape == (0, 4)


def test_mask_is_monotone_in_thickness(rng):
    ids = rng.integers(0, 2, size=(30, 30)).astype(np.int32)
    ids[rng.random((30, 30)) < 0.9] = 0  # sparse objects, so the masks do not saturate at once
    masks = [edge_mask(ids, L) for L in (0, 0.5, 1, 1.5, 2, 2.5, 4, 8, 8.5, 12, 40)]
    for thinner, thicker in zip(masks, masks[1:]):
        assert not (thinner & ~thicker).any()
    assert masks[0].sum() < masks[2].sum() < masks[6].sum() < masks[-1].sum()


def test_disc_structuring_element():
    np.testing.assert_array_equal(disc(1), picture(".#. ### .#."))
    assert disc(0).tolist() == [[True]]
    assert disc(2.5).sum() == 21


# ---- bad input --------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [-1, -0.5, float("nan"), float("inf"), -float("inf"), "1", None, True])
def test_bad_thickness_raises_usage_error(bad):
    ids = np.zeros((4, 4), np.int32)
    for call in (lambda: dilate(ids > 0, bad), lambda: edge_mask(ids, bad)):
        with pytest.raises(UsageError) as err:
            call()
        assert repr(bad) in str(err.value) and "a real number >= 0" in str(err.value)


def test_bad_buffers_raise_usage_error():
    with pytest.raises(UsageError, match="integer"):
        edge_pixels(np.zeros((4, 4), np.float32))
    with pytest.raises(UsageError, match="shape"):
        edge_pixels(np.zeros((4, 4, 2, 2), np.int32))
    with pytest.raises(UsageError, match="shadow"):
        edge_pixels(np.zeros((4, 4), np.int32), np.ones((4, 5, 1), np.float32))
    with pytest.raises(UsageError, match="a real number >= 0"):
        edge_pixels(np.zeros((4, 4), np.int32), shadow_tolerance=-1)
    with pytest.raises(UsageError, match="shape"):
        dilate(np.zeros((4, 4, 1), bool), 1)


# ---- the green picture --------------------------------------------------------------------


def test_overlay_paints_only_masked_pixels(rng):
    image = rng.random((6, 5, 3)).astype(np.float32)
    before = image.copy()
    mask = rng.random((6, 5)) < 0.3
    out = overlay_edges(image, mask)
    np.testing.assert_array_equal(out[mask], np.tile([0.0, 1.0, 0.0], (mask.sum(), 1)))
    np.testing.assert_array_equal(out[~mask], image[~mask])
    np.testing.assert_array_equal(image, before)  # the render itself is untouched
    assert out.dtype == np.float32
    np.testing.assert_array_equal(overlay_edges(image, mask, color=(1, 0, 0))[mask][:, 0], 1.0)
    with pytest.raises(UsageError):
        overlay_edges(image, mask[:, :4])


def test_contrast_pixels_follow_the_neighbour_rule_with_a_threshold():
    image = np.zeros((5, 6, 3), np.float32)
    image[:, 3:, 1] = 0.1  # a vertical step of 0.1 in green between columns 2 and 3
    image[4, 0, 0] = 0.04  # a small bump below the threshold
    mask = edges.contrast_pixels(image, 0.05)
    expected = np.zeros((5, 6), bool)
    expected[:, 3] = True  # column 3 differs from its left (and up-left) neighbour
    np.testing.assert_array_equal(mask, expected)
    assert edges.contrast_pixels(image, 0.2).sum() == 0
    assert edges.contrast_pixels(image, 0.01)[4, 0]  # the bump shows once the threshold is below it


def test_edge_mask_adds_contrast_edges_only_when_asked():
    ids = np.zeros((6, 6), np.int32)
    image = np.zeros((6, 6, 3), np.float32)
    image[3:, :, 0] = 1.0
    assert not edges.edge_mask(ids, 0, image=image, contrast=0.0).any()
    np.testing.assert_array_equal(edges.edge_mask(ids, 0, image=image, contrast=0.5)[3], np.ones(6, bool))
