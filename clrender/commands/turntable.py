"""`clrender render SCENE --turntable K -o frames/`: K frames orbiting the camera's look-at point.

Frames are named OUT/frame_0000.png, frame_0001.png, ...
(clrender.trace.turntable.FRAME_PATTERN), or by a pattern given as -o with a
{:04d}-style field, e.g. -o 'shots/{:03d}.exr'.  The folder -o is created
(its parent must exist, as for any output file); a pattern's folder must exist.
With --video the frames also go, in order, into an H.264 video (the ffmpeg
that imageio-ffmpeg ships on PyPI: browsers play H.264, not OpenCV's mp4v);
one turn lasts --turn-seconds (4 by default) unless --fps is given.
On --scheduler / --workers each frame is one task.  Frames are staged as they
finish (unnamed temporary files, clrender/outputs.py) and all put in place at
the end, the folder with them: an interrupted (Ctrl-C) or failed turntable
leaves no frame, no video and no empty folder.
"""

from __future__ import annotations

import contextlib
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import RenderFailure, UsageError, first_line, shown
from ..outputs import check_file_output, check_writable
from . import scene_defaults

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv")


TURN_SECONDS = 4.0  # a turn of the default video lasts this long: 36 frames play at 9 fps, 96 at 24
MIN_FPS, MAX_FPS = 0.1, 240.0  # frame rates the video may have (a frame every 10 s to 240 a second)
MAX_TURN_SECONDS = 3600.0
# ffmpeg, its input closed, has at most a few frames left to encode: a wait this long means it hangs
ENCODER_FINISH_SECONDS = 120.0


def add_turntable_arguments(p):
    g = p.add_argument_group("turntable")
    g.add_argument(
        "--turntable",
        type=int,
        default=None,
        metavar="K",
        help="render K frames orbiting the camera's look-at point into the folder -o "
        "(frame_0000.png, frame_0001.png, ...) (default: one image, no turntable)",
    )
    g.add_argument(
        "--video",
        default=None,
        metavar="OUT.mp4",
        help="with --turntable: also write the frames as an H.264 video (.mp4, .mov, .mkv or .avi; browsers play .mp4) (default: no video)",
    )
    g.add_argument(
        "--turn-seconds",
        type=float,
        default=None,
        metavar="S",
        help=f"with --video: one turn of the video lasts S seconds, so it plays at K/S frames per second "
        f"(default: {TURN_SECONDS:g}; e.g. --turntable 36 plays at 9 fps)",
    )
    g.add_argument(
        "--fps",
        type=float,
        default=None,
        help=f"with --video: frames per second instead of --turn-seconds, from {MIN_FPS:g} to {MAX_FPS:g} (default: K / --turn-seconds)",
    )


def video_fps(frames: int, fps: float | None, turn_seconds: float | None) -> float:
    """The video's frame rate: --fps as given, else K frames over one turn of --turn-seconds."""
    if fps is not None and turn_seconds is not None:
        raise UsageError("give --fps or --turn-seconds, not both (--fps sets the rate, --turn-seconds the length of a turn)")
    if fps is not None:
        if not MIN_FPS <= fps <= MAX_FPS:  # NaN fails too
            raise UsageError(f"--fps {fps:g} must be from {MIN_FPS:g} to {MAX_FPS:g} frames per second")
        return fps
    seconds = TURN_SECONDS if turn_seconds is None else turn_seconds
    if not 0 < seconds <= MAX_TURN_SECONDS:
        raise UsageError(f"--turn-seconds {seconds:g} must be more than 0 and at most {MAX_TURN_SECONDS:g}")
    rate = frames / seconds
    if not MIN_FPS <= rate <= MAX_FPS:
        raise UsageError(
            f"--turntable {frames} frames in a {seconds:g} s turn is {rate:g} frames per second; "
            f"allowed: {MIN_FPS:g} to {MAX_FPS:g} (change --turn-seconds, or give --fps)"
        )
    return rate


def frame_paths(output: str | None, scene_name: str, frames: int) -> list[Path]:
    """Where each frame goes: a {}-pattern as given, else FRAME_PATTERN inside the folder `output`."""
    from ..trace.turntable import FRAME_PATTERN

    if output and "{" in output:
        try:
            return [Path(output.format(k)) for k in range(frames)]
        except (IndexError, KeyError, ValueError) as exc:
            raise UsageError(f"frame pattern {shown(output)} is not a valid {{:04d}}-style pattern ({exc})") from None
    folder = Path(output or f"{scene_name}_turntable")
    if folder.exists() and not folder.is_dir():
        raise UsageError(f"-o {shown(output)} is a file; --turntable writes a folder of frames (give a folder such as frames/)")
    if folder.suffix and not folder.is_dir():
        raise UsageError(
            f"--turntable writes a folder of frames; -o {shown(output)} looks like a file "
            "(give a folder such as frames/, or a pattern such as 'frames/{:04d}.png')"
        )
    return [folder / FRAME_PATTERN.format(k) for k in range(frames)]


def check_frame_folder(folder: Path) -> bool:
    """True when the frames' folder is to be created (by the output set, when the frames are placed):
    like any output file's folder, its parent must exist and be writable."""
    if folder.is_dir():
        return False
    check_writable(folder, overwrite=False, option="-o")
    return True


class _Video:
    """Frames into an H.264 video in order (they may arrive out of order), through ffmpeg's stdin.

    ffmpeg picks the container by the file name's extension and rewrites the file's start at the
    end (faststart), so the video is encoded into a private temporary folder and copied into the
    output set when it is done (an output set's staged files have no name yet).
    """

    def __init__(self, path: Path, fps: float):
        self.path = path
        self.fps = fps
        self.folder = tempfile.TemporaryDirectory(prefix="clrender-video-")
        self.temp = os.path.join(self.folder.name, f"video{path.suffix}")
        self.log = os.path.join(self.folder.name, "ffmpeg.log")
        self.encoder = None
        self.pending: dict = {}
        self.next = 0

    def _start(self, width: int, height: int):
        import subprocess

        command = [
            ffmpeg_exe(),
            *("-hide_banner", "-nostdin", "-loglevel", "error", "-y"),
            *("-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{width}x{height}", "-framerate", f"{self.fps:.6g}", "-i", "-"),
            *("-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2"),  # 4:2:0 H.264 needs even sides
            *("-c:v", "libx264", "-pix_fmt", "yuv420p", "-crf", "18", "-threads", "2"),
            *(("-movflags", "+faststart") if self.path.suffix.lower() in (".mp4", ".mov") else ()),
            self.temp,
        ]
        with open(self.log, "wb") as log:
            self.encoder = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=log)

    def add(self, k: int, srgb8: np.ndarray):
        self.pending[k] = srgb8
        while self.next in self.pending:
            frame = self.pending.pop(self.next)
            if self.encoder is None:
                self._start(frame.shape[1], frame.shape[0])
            try:
                self.encoder.stdin.write(np.ascontiguousarray(frame[..., :3]).tobytes())
            except BrokenPipeError:
                self._failed()
            self.next += 1

    def _wait(self) -> int:
        """ffmpeg's exit status, within ENCODER_FINISH_SECONDS (then it is killed: a RenderFailure)."""
        import subprocess

        try:
            return self.encoder.wait(timeout=ENCODER_FINISH_SECONDS)
        except subprocess.TimeoutExpired:
            self.encoder.kill()
            self.encoder.wait()
            raise RenderFailure(f"cannot write the video {shown(self.path)}: ffmpeg did not finish within {ENCODER_FINISH_SECONDS:g} s") from None

    def _failed(self):
        self._wait()
        with open(self.log, errors="replace") as log:
            said = first_line(log.read(4096), "no message")
        raise RenderFailure(f"cannot write the video {shown(self.path)}: ffmpeg exited with {self.encoder.returncode} ({said})")

    def finish(self):
        """Stage the finished video in the current output set."""
        import shutil

        from ..outputs import write_file

        try:
            self.encoder.stdin.close()
        except BrokenPipeError:
            pass
        if self._wait() != 0:
            self._failed()
        self.encoder = None
        write_file(self.path, lambda staged: shutil.copyfile(self.temp, staged))

    def close(self):
        if self.encoder is not None:
            self.encoder.kill()
            self.encoder.wait()
            if self.encoder.stdin:
                with contextlib.suppress(OSError):
                    self.encoder.stdin.close()
        self.folder.cleanup()


def ffmpeg_exe() -> str:
    """The ffmpeg program imageio-ffmpeg ships (a static build with libx264), or IMAGEIO_FFMPEG_EXE."""
    try:
        import imageio_ffmpeg
    except ImportError:
        raise RenderFailure("--video needs imageio-ffmpeg (pip install imageio-ffmpeg), which ships ffmpeg") from None
    try:
        return imageio_ffmpeg.get_ffmpeg_exe()
    except RuntimeError as exc:
        raise RenderFailure(f"--video found no ffmpeg: {first_line(str(exc))}") from None


def _srgb8(image: np.ndarray, display=None) -> np.ndarray:
    from ..image.files import srgb8

    return srgb8(image, display)


def run_turntable(args, settings, display=None) -> int:
    """K frames into a folder (and a video); `display`: the PNG/JPEG frames' exposure and tone curve."""
    from ..image.files import check_output_path, write_display_image
    from ..outputs import output_set
    from ..progress import progress
    from ..scene.scene import Scene
    from ..trace.turntable import MAX_FRAMES, render_turntable
    from .cluster import cluster_client

    k_frames = args.turntable
    if k_frames is None:
        raise UsageError("--video needs --turntable K")
    if not 1 <= k_frames <= MAX_FRAMES:
        raise UsageError(f"--turntable {k_frames} must be from 1 to {MAX_FRAMES} frames")
    for option, name in ((args.edges_out, "--edges-out"), (getattr(args, "aov", None), "--aov")):
        if option:
            raise UsageError(f"{name} is for single renders; --turntable writes only the frames")
    if args.filter:
        from ..image import filters

        for name in args.filter:
            filters.parse(name)
    from ..scene import staging

    scene = staging.load(args.scene, staging.Stage.from_args(args)) if hasattr(args, "env") else Scene.load(args.scene)  # --env, --ground, --up
    settings = scene_defaults(args, settings, scene) if hasattr(args, "positional_args") else settings  # as a single render has them
    # every check before anything is created: a refused option leaves no folder behind
    paths = frame_paths(args.output, Path(args.scene).stem, k_frames)
    new_folder = paths[0].parent if args.output is None or "{" not in args.output else None
    if new_folder is None or not check_frame_folder(new_folder):  # frames into an existing folder
        new_folder = None
        for path in paths:
            check_output_path(path, overwrite=args.overwrite)
    video_path = fps = None
    for value, option in ((args.fps, "--fps"), (args.turn_seconds, "--turn-seconds")):
        if value is not None and not args.video:
            sys.stderr.write(f"warning: {option} changes nothing without --video\n")
    if args.video:
        video_path = check_file_output(args.video, overwrite=args.overwrite, suffixes=VIDEO_SUFFIXES, option="--video")
        fps = video_fps(k_frames, args.fps, args.turn_seconds)
        ffmpeg_exe()
    settings = settings.validate(scene)

    video = _Video(video_path, fps) if video_path else None
    try:
        # every frame is staged as it finishes and all are put in place together at the end (the new
        # folder with them), so an interrupted or failed turntable leaves none of its files behind
        with output_set(overwrite=args.overwrite) as outputs, cluster_client(args) as client:
            if new_folder is not None:
                outputs.add_folder(new_folder)
            if client is None:
                frames = render_turntable(scene, settings, k_frames)
            else:
                from ..distributed import iter_turntable

                frames = iter_turntable(scene, settings, k_frames, client)
            with progress(total=k_frames, desc="frames", unit="frame") as bar:
                for k, image in frames:
                    if args.filter:
                        image = filters.apply(image, *args.filter)
                    write_display_image(paths[k], image, display=display)
                    if video is not None:
                        video.add(k, _srgb8(image, display))
                    bar.update()
            if video is not None:
                video.finish()
    finally:
        if video is not None:
            video.close()
    print(paths[0].parent if args.output is None or "{" not in args.output else args.output)
    if video_path:
        print(video_path)
    if not args.quiet:
        sys.stderr.write(f"{scene.name}: {k_frames} turntable frames, {settings.width}x{settings.height}\n")
    return 0
