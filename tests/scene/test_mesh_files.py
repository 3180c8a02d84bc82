"""Damaged mesh files are bad input: one line naming the file and the fault, exit 2, nothing written
(issue 23: a PLY face index out of range was an IndexError, -1 rendered silently with a wrapped
index, and undecodable text reported trimesh's missing optional module)."""

import pytest

from tests.clitools import run_cli

PLY = """ply
format ascii 1.0
element vertex 3
property float x
property float y
property float z
element face 1
property list uchar int vertex_indices
end_header
0 0 -3
1 0 -3
0 1 -3
3 0 1 {last}
"""


def render_mesh(capsys, tmp_path, name):
    (tmp_path / "s.toml").write_text(f'[[objects]]\ntype = "mesh"\nfile = "{name}"\n')
    out = tmp_path / "o.png"
    code, stdout, err = run_cli(capsys, "render", str(tmp_path / "s.toml"), "--width", "8", "--height", "6", "-o", str(out))
    return code, stdout, err, out


@pytest.mark.parametrize("last", [3, 7, -1, -2147483648])
def test_a_ply_face_index_outside_the_vertices_is_refused(capsys, tmp_path, last):
    (tmp_path / "m.ply").write_text(PLY.format(last=last))
    code, stdout, err, out = render_mesh(capsys, tmp_path, "m.ply")
    assert code == 2 and stdout == "" and not out.exists()
    assert (
        err
        == f"clrender: {tmp_path / 's.toml'}: objects[0].file: mesh '{tmp_path / 'm.ply'}' has face index {last}; allowed: 0 to 2 (its vertices)\n"
    )


def test_a_good_ply_renders(capsys, tmp_path):
    (tmp_path / "m.ply").write_text(PLY.format(last=2))
    code, stdout, err, out = render_mesh(capsys, tmp_path, "m.ply")
    assert code == 0 and out.is_file(), err


def test_undecodable_text_is_named_as_such_not_as_a_missing_module(capsys, tmp_path):
    (tmp_path / "m.obj").write_bytes(b"garbage \x00\xff\xfe binary stuff\n")
    code, stdout, err, out = render_mesh(capsys, tmp_path, "m.obj")
    assert code == 2 and stdout == "" and not out.exists()
    # without charset_normalizer trimesh cannot decode the bytes; with it (requests brings it) they decode to no faces
    named = f"objects[0].file: cannot parse mesh '{tmp_path / 'm.obj'}' as OBJ (not text in a known encoding)\n"
    empty = f"objects[0].file: mesh '{tmp_path / 'm.obj'}' has no triangles\n"
    assert err.endswith(named) or err.endswith(empty), err
    assert err.count("\n") == 1 and "module" not in err
