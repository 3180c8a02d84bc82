"""The early check every non-image output goes through (splats, sites, logs, videos): one refusal per reason."""

import os

import numpy as np
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


def test_more_channels_than_the_format_holds_is_bad_input_not_a_full_disk(tmp_path, capfd):
    """A 16-channel EXR converted to PNG said "is the disk full?": the reason is the channel count."""
    from clrender.cli import main
    from clrender.image.files import write_image

    many = tmp_path / "many.exr"
    write_image(many, np.random.default_rng(6).uniform(0, 1, (6, 8, 16)).astype(np.float32))
    rc = main(["convolve", str(many), str(tmp_path / "out.png"), "box_blur_3"])
    err = capfd.readouterr().err
    assert rc == 2, err
    assert err == f"clrender: output {str(tmp_path / 'out.png')!r} cannot hold 16 channels: PNG allows 1, 2, 3 or 4 (.exr or .tif take any number)\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["many.exr"]


@pytest.mark.parametrize("name, channels", [("a.hdr", 4), ("a.webp", 1), ("a.bmp", 2), ("a.pfm", 4)])
def test_the_python_api_refuses_a_channel_count_the_writer_cannot_store(tmp_path, name, channels):
    from clrender.image.files import write_image

    with pytest.raises(UsageError, match=f"cannot hold {channels} channels"):
        write_image(tmp_path / name, np.zeros((2, 2, channels), np.float32))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name, channels", [("a.png", 2), ("a.hdr", 3), ("a.exr", 16), ("a.tif", 5), ("a.pfm", 1)])
def test_every_allowed_channel_count_round_trips(tmp_path, name, channels):
    from clrender.image.files import read_image, write_image

    pixels = np.random.default_rng(7).uniform(0, 1, (3, 4, channels)).astype(np.float32)
    write_image(tmp_path / name, pixels)
    assert read_image(tmp_path / name).pixels.shape == (3, 4, channels)
