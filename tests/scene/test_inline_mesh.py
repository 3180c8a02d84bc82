"""A mesh can be given inline, as `vertices` and `faces`, with the same placement and checks as a file's."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene.scene import Scene

TRIANGLE = {"type": "mesh", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "faces": [[0, 1, 2]]}


def test_inline_vertices_are_placed_like_a_files():
    (mesh,) = Scene.from_dict({"objects": [{**TRIANGLE, "translate": [0, 0, -2], "scale": 2}]}).objects
    np.testing.assert_allclose(mesh.vertices, [[0, 0, -2], [2, 0, -2], [0, 2, -2]])
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2]])


@pytest.mark.parametrize(
    "change, message",
    [
        ({"faces": [[0, 1, 3]]}, r"faces\[0\].*indices from 0 to 2"),
        ({"faces": [[0, 1]]}, r"faces\[0\]"),
        ({"vertices": [[0, 0, float("nan")], [1, 0, 0], [0, 1, 0]]}, r"vertices\[0\]"),
        ({"faces": None}, "exactly one of"),
        ({"generator": "bunny"}, "exactly one of"),
    ],
)
def test_bad_inline_meshes_are_refused_naming_the_entry(change, message):
    o = {k: v for k, v in {**TRIANGLE, **change}.items() if v is not None}
    with pytest.raises(UsageError, match=message):
        Scene.from_dict({"objects": [o]})
