"""The early check every non-image output goes through (splats, sites, logs, videos): one refusal per reason."""

import os

import pytest

from clrender.errors import UsageError
from clrender.outputs import check_file_output


def test_a_writable_new_file_with_an_allowed_extension_passes(tmp_path):
    assert check_file_output(tmp_path / "sites.NPZ", overwrite=False, suffixes=(".npz",)) == tmp_path / "sites.NPZ"


@pytest.mark.parametrize(
    "name, reason",
    [
        ("folder", "is a folder"),
        ("sites.csv", "must end in .npz"),
        ("old.npz", "already exists; pass --overwrite"),
        ("missing/sites.npz", "does not exist"),
    ],
)
def test_each_unwritable_output_is_refused_with_its_reason(tmp_path, name, reason):
    (tmp_path / "folder").mkdir()
    (tmp_path / "old.npz").write_bytes(b"")
    with pytest.raises(UsageError, match=reason) as refused:
        check_file_output(tmp_path / name, overwrite=False, suffixes=(".npz",), option="--save-sites")
    assert str(refused.value).startswith("--save-sites ") or "of --save-sites" in str(refused.value)


def test_overwrite_allows_an_existing_file(tmp_path):
    (tmp_path / "old.npz").write_bytes(b"")
    check_file_output(tmp_path / "old.npz", overwrite=True, suffixes=(".npz",))


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_a_read_only_folder_is_refused(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o500)
    try:
        with pytest.raises(UsageError, match="is not writable"):
            check_file_output(folder / "a.npz", overwrite=False, suffixes=(".npz",))
    finally:
        folder.chmod(0o700)
