"""`render --turntable K -o folder/ [--video v.mp4]`: folders like any output's, checks before anything
is created, a frame rate in a sane range, and an H.264 video whose turn lasts a few seconds."""

from __future__ import annotations

import math
import re
import subprocess

import numpy as np
import pytest

from clrender.cli import main
from clrender.commands.turntable import MAX_FPS, MIN_FPS, TURN_SECONDS, ffmpeg_exe, video_fps
from clrender.errors import UsageError
from clrender.image.files import read_image

TINY = ["-q", "render", "refract1", "--camera", "2", "--width", "16", "--height", "12"]


def one_line(capfd) -> str:
    err = capfd.readouterr().err
    assert err.count("\n") == 1 and err.startswith("clrender: "), err
    return err


def test_a_frame_folder_under_a_missing_folder_is_refused_like_a_file(tmp_path, capfd, monkeypatch):
    """`-o a/b/x.png` refused the missing a/b, while `--turntable -o a/b/c/` created it."""
    monkeypatch.chdir(tmp_path)
    assert main([*TINY, "-o", "a/b/x.png"]) == 2
    assert "folder 'a/b' of output 'a/b/x.png' does not exist" in one_line(capfd)
    assert main([*TINY, "--turntable", "2", "-o", "a/b/c/"]) == 2
    assert "folder 'a/b' of -o 'a/b/c' does not exist" in one_line(capfd)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "option, reason",
    [
        (["--video", "v.gif"], "must end in .mp4"),
        (["--video", "v.mp4", "--fps", "1e9"], f"must be from {MIN_FPS:g} to {MAX_FPS:g}"),
        (["--video", "v.mp4", "--fps", "nan"], f"must be from {MIN_FPS:g} to {MAX_FPS:g}"),
        (["--video", "v.mp4", "--fps", "0"], f"must be from {MIN_FPS:g} to {MAX_FPS:g}"),
        (["--video", "v.mp4", "--fps", "12", "--turn-seconds", "2"], "not both"),
        (["--video", "v.mp4", "--turn-seconds", "-1"], "must be more than 0"),
    ],
)
def test_a_refused_video_option_is_one_line_and_creates_nothing(tmp_path, capfd, monkeypatch, option, reason):
    """A refused `--video v.gif` left an empty frames folder; `--fps 1e9` printed encoder lines and
    blamed a missing encoder (exit 1) for what is bad input."""
    monkeypatch.chdir(tmp_path)
    assert main([*TINY, "--turntable", "2", "-o", "frames", *option]) == 2
    assert reason in one_line(capfd)
    assert list(tmp_path.iterdir()) == []


def test_the_default_frame_rate_makes_a_turn_last_a_few_seconds():
    """12 frames at 24 fps made a 0.5 s clip: by default one turn lasts TURN_SECONDS."""
    assert 2 <= TURN_SECONDS <= 10
    assert video_fps(12, None, None) == 12 / TURN_SECONDS
    assert video_fps(36, None, 6.0) == 6.0
    assert video_fps(12, 24.0, None) == 24.0
    with pytest.raises(UsageError, match="frames per second"):
        video_fps(10_000, None, None)  # 2500 fps: too fast to play


def test_an_interrupted_turntable_leaves_no_folder(tmp_path, monkeypatch):
    """The folder is created with the frames, so a Ctrl-C before they are placed leaves nothing."""
    import clrender.trace.turntable as tt

    real = tt.render_turntable

    def interrupted(*args, **kwargs):
        for k, image in real(*args, **kwargs):
            if k == 1:
                raise KeyboardInterrupt
            yield k, image

    monkeypatch.setattr(tt, "render_turntable", interrupted)
    assert main([*TINY, "--turntable", "3", "-o", str(tmp_path / "frames"), "--video", str(tmp_path / "v.mp4")]) == 130
    assert list(tmp_path.iterdir()) == []


def test_the_video_is_h264_one_turn_long_and_shows_the_frames(tmp_path, capfd):
    """mp4v, which browsers do not play, is now H.264 (yuv420p); 12 frames last TURN_SECONDS; an odd
    width is padded to even; the first decoded frame is frame_0000.png up to the codec's loss."""
    import cv2
    import imageio_ffmpeg

    frames, video = tmp_path / "frames", tmp_path / "v.mp4"
    argv = ["-q", "render", "refract1", "--camera", "2", "--width", "33", "--height", "24"]
    assert main([*argv, "--turntable", "12", "-o", str(frames), "--video", str(video)]) == 0
    assert capfd.readouterr().out.split() == [str(frames), str(video)]
    assert len(list(frames.iterdir())) == 12
    probe = subprocess.run([ffmpeg_exe(), "-hide_banner", "-i", str(video)], capture_output=True, text=True).stderr
    assert re.search(r"Video: h264 .*yuv420p.*34x24", probe), probe
    count, seconds = imageio_ffmpeg.count_frames_and_secs(str(video))
    assert count == 12 and math.isclose(seconds, TURN_SECONDS, abs_tol=0.05)
    ok, first = cv2.VideoCapture(str(video)).read()
    assert ok
    expected = np.round(read_image(frames / "frame_0000.png").pixels * 255)
    decoded = first[:, :33, ::-1].astype(np.float64)  # BGR to RGB, without the padding column
    assert np.abs(decoded - expected).mean() < 4.0  # 8-bit levels; a wrong or shifted frame is far more
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_an_encoder_that_never_finishes_is_one_line_within_the_deadline(tmp_path, capfd, monkeypatch):
    """An ffmpeg that reads every frame and then hangs: the wait for it has a deadline, after which it is
    killed and the command fails in one line, leaving neither frames nor video."""
    hang = tmp_path / "ffmpeg"
    hang.write_text("#!/bin/sh\ncat > /dev/null\nexec sleep 600\n")
    hang.chmod(0o755)
    monkeypatch.setenv("IMAGEIO_FFMPEG_EXE", str(hang))
    monkeypatch.setattr("clrender.commands.turntable.ENCODER_FINISH_SECONDS", 0.5)
    frames, video = tmp_path / "frames", tmp_path / "v.mp4"
    assert main([*TINY, "--turntable", "2", "-o", str(frames), "--video", str(video)]) == 1
    assert "ffmpeg did not finish within 0.5 s" in one_line(capfd)
    assert not frames.exists() and not video.exists()
