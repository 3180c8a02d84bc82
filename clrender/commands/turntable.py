"""`clrender render SCENE --turntable K -o frames/`: K frames orbiting the camera's look-at point.

Frames are named OUT/frame_0000.png, frame_0001.png, ...
(clrender.trace.turntable.FRAME_PATTERN), or by a pattern given as -o with a
{:04d}-style field, e.g. -o 'shots/{:03d}.exr'.  With --video the frames also
go, in order, into an MP4 through OpenCV's VideoWriter.  On --scheduler /
--workers each frame is one task.  Frames are staged as they finish (unnamed
temporary files, clrender/outputs.py) and all put in place at the end: an
interrupted (Ctrl-C) or failed turntable leaves no frame and no video.
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import RenderFailure, UsageError
from ..outputs import check_file_output

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".mkv")


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
        help="with --turntable: also write the frames as a video (OpenCV VideoWriter, mp4v) (default: no video)",
    )
    g.add_argument("--fps", type=float, default=24.0, help="with --video: frames per second")


def frame_paths(output: str | None, scene_name: str, frames: int) -> list[Path]:
    """Where each frame goes: a {}-pattern as given, else FRAME_PATTERN inside the folder `output`."""
    from ..trace.turntable import FRAME_PATTERN

    if output and "{" in output:
        try:
            return [Path(output.format(k)) for k in range(frames)]
        except (IndexError, KeyError, ValueError) as exc:
            raise UsageError(f"frame pattern {output!r} is not a valid {{:04d}}-style pattern ({exc})") from None
    folder = Path(output or f"{scene_name}_turntable")
    if folder.suffix and not folder.is_dir():
        raise UsageError(
            f"--turntable writes a folder of frames; -o {output!r} looks like a file "
            "(give a folder such as frames/, or a pattern such as 'frames/{:04d}.png')"
        )
    return [folder / FRAME_PATTERN.format(k) for k in range(frames)]


class _Video:
    """Frames into a video in order (they may arrive out of order).

    OpenCV picks the container by the file name's extension, so the video is
    encoded into a private temporary folder and copied into the output set
    at the end (an output set's staged files have no name yet).
    """

    def __init__(self, path: Path, fps: float):
        self.path = path
        self.fps = fps
        self.folder = tempfile.TemporaryDirectory(prefix="clrender-video-")
        self.temp = os.path.join(self.folder.name, f"video{path.suffix}")
        self.writer = None
        self.pending: dict = {}
        self.next = 0

    def add(self, k: int, srgb8: np.ndarray):
        import cv2

        self.pending[k] = srgb8
        while self.next in self.pending:
            frame = self.pending.pop(self.next)
            if self.writer is None:
                h, w = frame.shape[:2]
                self.writer = cv2.VideoWriter(self.temp, cv2.VideoWriter_fourcc(*"mp4v"), self.fps, (w, h))
                if not self.writer.isOpened():
                    raise RenderFailure(f"OpenCV cannot write the video {str(self.path)!r} (no mp4v encoder?)")
            self.writer.write(np.ascontiguousarray(frame[..., ::-1]))  # OpenCV wants BGR
            self.next += 1

    def finish(self):
        """Stage the finished video in the current output set."""
        import shutil

        from ..outputs import write_file

        self.writer.release()
        self.writer = None
        write_file(self.path, lambda staged: shutil.copyfile(self.temp, staged))

    def close(self):
        if self.writer is not None:
            self.writer.release()
        self.folder.cleanup()


def _srgb8(image: np.ndarray) -> np.ndarray:
    from ..image.files import linear_to_srgb

    return np.round(linear_to_srgb(image) * 255.0).astype(np.uint8)


def run_turntable(args, settings) -> int:
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
    scene = Scene.load(args.scene)
    paths = frame_paths(args.output, Path(args.scene).stem, k_frames)
    for path in paths:
        path.parent.mkdir(parents=True, exist_ok=True)
        check_output_path(path, overwrite=args.overwrite)
    video_path = None
    if args.video:
        video_path = check_file_output(args.video, overwrite=args.overwrite, suffixes=VIDEO_SUFFIXES, option="--video")
        if not (args.fps > 0 and np.isfinite(args.fps)):
            raise UsageError(f"--fps {args.fps} must be a positive number")
    settings = settings.validate(scene)

    video = _Video(video_path, args.fps) if video_path else None
    try:
        # every frame is staged as it finishes and all are put in place together at the end, so an
        # interrupted or failed turntable (even a killed process) leaves none of its files behind
        with output_set(overwrite=args.overwrite), cluster_client(args) as client:
            if client is None:
                frames = render_turntable(scene, settings, k_frames)
            else:
                from ..distributed import iter_turntable

                frames = iter_turntable(scene, settings, k_frames, client)
            with progress(total=k_frames, desc="frames", unit="frame") as bar:
                for k, image in frames:
                    if args.filter:
                        image = filters.apply(image, *args.filter)
                    write_display_image(paths[k], image)
                    if video is not None:
                        video.add(k, _srgb8(image))
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
