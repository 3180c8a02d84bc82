"""PLY triangle strips (`element tristrips`, a `vertex_indices` list with -1 between runs), as igea.ply stores
its faces: read into the triangles written out by hand below, each run's winding alternating from its first."""

import numpy as np
import pytest

from clrender.scene.ply_strips import strip_faces
from clrender.scene.scene import Scene, load_mesh_file

# a 2 x 3 grid of points, y up: 0 1 / 2 3 / 4 5, so (0, 1, 2) faces +z
POINTS = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0, 2, 0], [1, 2, 0]], np.float32)
STRIPS = [[0, 1, 2, 3, 4, 5, -1, 3, 2, 5], [1, 3, 3, 5]]  # a run of 6, then a run of 3; then a run with a repeat
# by hand: run 0 1 2 3 4 5 -> (0 1 2) (2 1 3) (2 3 4) (4 3 5); run 3 2 5 -> (3 2 5); 1 3 3 5 -> (1 3 3) (3 3 5) dropped
EXPECTED = [[0, 1, 2], [2, 1, 3], [2, 3, 4], [4, 3, 5], [3, 2, 5]]


def test_strip_faces_alternate_winding_and_restart_at_minus_one():
    assert strip_faces([0, 1, 2, 3, 4, 5, -1, 3, 2, 5]).tolist() == EXPECTED
    assert strip_faces([1, 3, 3, 5]).tolist() == []  # degenerate turns dropped
    assert strip_faces([0, 1]).tolist() == [] and strip_faces([]).shape == (0, 3)


def test_every_strip_triangle_of_the_grid_faces_the_same_way():
    f = strip_faces([0, 1, 2, 3, 4, 5])
    p = POINTS.astype(np.float64)
    normals = np.cross(p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]])
    assert np.all(normals[:, 2] > 0)


def write_ply(path, binary: bool):
    header = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0", f"element vertex {len(POINTS)}"]
    header += [f"property float {a}" for a in "xyz"] + [f"element tristrips {len(STRIPS)}", "property list int int vertex_indices", "end_header"]
    head = ("\n".join(header) + "\n").encode()
    if binary:
        body = POINTS.astype("<f4").tobytes() + b"".join(np.array([len(s), *s], "<i4").tobytes() for s in STRIPS)
    else:
        body = "".join(" ".join(map(str, p)) + "\n" for p in POINTS.tolist()) + "".join(f"{len(s)} {' '.join(map(str, s))}\n" for s in STRIPS)
        body = body.encode()
    path.write_bytes(head + body)
    return path


@pytest.mark.parametrize("binary", [False, True])
def test_a_ply_of_triangle_strips_is_read(tmp_path, binary):
    path = write_ply(tmp_path / "strips.ply", binary)
    tm = load_mesh_file(path, "test")
    assert tm.faces.tolist() == EXPECTED
    np.testing.assert_array_equal(tm.vertices, POINTS)
    scene = Scene.load(str(path))  # a bare mesh file, framed
    assert scene.triangle_count == len(EXPECTED)
