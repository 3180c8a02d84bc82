"""Faults while writing: signals at random moments, a full disk, a read-only folder, two writers.

In every case each output is the old file, the new file, or absent -- never a truncated file --
no temp file is left beside it, and a command's several outputs are the old set or the new set.
"""

from __future__ import annotations

import errno
import os
import random
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from clrender.cli import main
from clrender.image.files import write_image
from clrender.outputs import TEMP_MARK, OutputSet, output_set, save_npz

from tests.clitools import default_sigint

REPO = Path(__file__).resolve().parents[2]
RENDER = ["render", "refract1", "--width", "96", "--height", "72", "--aa", "edge_detect", "--samples", "2"]


def clrender(*argv, cwd, **kwargs):
    """Start `python -m clrender ARGV` in cwd; the package comes from this checkout."""
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.Popen(
        [sys.executable, "-m", "clrender", "-q", *map(str, argv)],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=default_sigint,
        **kwargs,
    )


SIGTERM_BIT = 1 << (signal.SIGTERM - 1)  # in /proc/PID/status SigCgt, the mask of caught signals


def wait_for_handlers(proc, timeout: float = 120.0) -> None:
    """Return once clrender's SIGINT/SIGTERM handlers are installed in `proc` (its package's first lines).

    Before that Python itself is starting (`site`, the editable-install finder): a SIGINT then is
    Python's own KeyboardInterrupt, which no program can catch, so the tests' random moments start
    here.  The sign is read from outside: bare Python catches only SIGINT, clrender adds SIGTERM
    (after SIGINT), so a caught SIGTERM means both handlers are in place."""
    status = Path(f"/proc/{proc.pid}/status")
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        assert proc.poll() is None, f"exited ({proc.returncode}) before its signal handlers were installed"
        match = re.search(r"^SigCgt:\s*([0-9a-f]+)", status.read_text(), re.M)
        if int(match.group(1), 16) & SIGTERM_BIT:
            return
        time.sleep(0.001)
    raise AssertionError(f"no signal handlers after {timeout} s")


def leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if TEMP_MARK in p.name or ".tmp" in p.name)


def files(folder: Path, names) -> dict[str, bytes | None]:
    return {n: (folder / n).read_bytes() if (folder / n).exists() else None for n in names}


@pytest.fixture(scope="module")
def new_render(tmp_path_factory):
    """The outputs of an uninterrupted run, and how long it takes."""
    folder = tmp_path_factory.mktemp("reference")
    start = time.perf_counter()
    proc = clrender(*RENDER, "-o", "out.png", "--edges-out", "edges.png", cwd=folder)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    return files(folder, ["out.png", "edges.png"]), time.perf_counter() - start


def old_set(folder: Path) -> dict[str, bytes]:
    """A previous render's outputs: valid images that differ from the new ones."""
    rng = np.random.default_rng(1)
    for name in ("out.png", "edges.png"):
        write_image(folder / name, rng.uniform(0, 1, (72, 96, 3)).astype(np.float32))
    return files(folder, ["out.png", "edges.png"])


def interrupt_render(folder: Path, signum: int, after: float, new: dict) -> tuple[int, str]:
    old = old_set(folder)
    proc = clrender(*RENDER, "-o", "out.png", "--edges-out", "edges.png", "--overwrite", cwd=folder)
    wait_for_handlers(proc)
    time.sleep(after)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=300)
    now = files(folder, ["out.png", "edges.png"])
    for name, content in now.items():
        assert content in (old[name], new[name]), f"{name} is neither the old nor the new file after signal {signum} at {after:.2f}s"
    if signum != signal.SIGKILL:  # SIGKILL cannot be held off, so only the catchable signals promise whole sets
        assert now in (old, new), f"a mixed set after signal {signum} at {after:.2f}s"
        assert not leftovers(folder), leftovers(folder)
    else:
        # a SIGKILL while files are being placed can leave hidden files and a journal named after the
        # dead writer (see clrender/outputs.py); the next write into the folder finishes the set
        assert all(f".{proc.pid}." in name for name in leftovers(folder)), leftovers(folder)
        write_image(folder / "next.png", np.zeros((2, 2, 3), np.float32))
        assert files(folder, ["out.png", "edges.png"]) in (old, new), f"a mixed set after SIGKILL at {after:.2f}s"
        assert not leftovers(folder), leftovers(folder)
    return proc.returncode, err


def test_a_later_write_removes_temp_files_left_by_a_killed_writer(tmp_path):
    """Only files named after a process that is gone: a running writer's temp file stays."""
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    left = tmp_path / f".out.png.{dead.pid}.abcd1234{TEMP_MARK}"
    running = tmp_path / f".out.png.{os.getpid()}.abcd1234{TEMP_MARK}.png"
    left.write_bytes(b"half")
    running.write_bytes(b"half")
    write_image(tmp_path / "out.png", np.zeros((2, 2, 3), np.float32))
    assert not left.exists() and running.exists()


def check_exit(signum, rc, err):
    if signum == signal.SIGKILL:
        assert rc in (-signal.SIGKILL, 0)
        return
    assert "Traceback" not in err, err
    assert rc in (0, 128 + signum), (rc, err)
    if rc != 0:
        assert err.count("\n") == 1 and err.startswith("clrender: "), err


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGKILL])  # SIGTERM: test_signals_at_many_moments
def test_a_signal_mid_render_leaves_old_or_new_outputs(tmp_path, new_render, signum):
    new, seconds = new_render
    after = random.Random(int(signum)).uniform(0.2, 1.0) * seconds  # from when the handlers are in place
    rc, err = interrupt_render(tmp_path, signum, after, new)
    check_exit(signum, rc, err)


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_signals_at_many_moments(tmp_path, new_render, signum):
    """Seeded moments per signal (8, or $CLRENDER_FAULT_MOMENTS) across the whole run, imports and final write included.

    The moments start once clrender's handlers are installed (wait_for_handlers): before Python runs
    clrender's first line, nothing can catch a signal (Python itself prints a traceback from its
    `site` import), though nothing has been written either."""
    new, seconds = new_render
    moments = random.Random(1000 + int(signum))
    for i in range(int(os.environ.get("CLRENDER_FAULT_MOMENTS", "8"))):
        folder = tmp_path / f"run{i}"
        folder.mkdir()
        after = moments.uniform(0, 1.1 * seconds)
        rc, err = interrupt_render(folder, signum, after, new)
        check_exit(signum, rc, err)


@pytest.mark.parametrize("share", [0.0, 0.1, 0.4])
def test_ctrl_c_while_starting_is_one_line(tmp_path, share):
    """SIGINT during the imports (the first second) printed a KeyboardInterrupt traceback."""
    proc = clrender("render", "refract1", "-o", "o.png", cwd=tmp_path)
    wait_for_handlers(proc)
    time.sleep(share)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    if proc.returncode != 0:  # a fast machine may have finished
        assert proc.returncode == 130 and err == "clrender: interrupted\n", (proc.returncode, err)
    assert not leftovers(tmp_path)


# ----------------------------------------------------------------------------- a full disk
@pytest.fixture
def small_disk(tmp_path):
    """A 256 KiB tmpfs (needs mount rights, as root in a container); skipped where mounting is refused."""
    mount_point = tmp_path / "small"
    mount_point.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=256k", "tmpfs", str(mount_point)], capture_output=True)
    if done.returncode != 0:
        pytest.skip("cannot mount a tmpfs here")
    yield mount_point
    subprocess.run(["umount", "-l", str(mount_point)], check=False)


def test_render_onto_a_full_disk_is_exit_1_with_a_reason(small_disk, capfd):
    """A full disk exited 2 (the bad-input code) with an empty reason."""
    old = old_set(small_disk)
    rc = main(
        ["-q", *RENDER[:2], "--width", "640", "--height", "480", "-o", str(small_disk / "out.exr"), "--overwrite"]
    )  # a 3.5 MiB float EXR cannot fit in 256 KiB
    err = capfd.readouterr().err
    assert rc == 1, err
    assert err.startswith("clrender: ") and err.count("\n") == 1 and "out.exr" in err
    assert "space" in err.lower() or "disk" in err.lower(), err
    assert files(small_disk, ["out.png", "edges.png"]) == old and not (small_disk / "out.exr").exists()
    assert not leftovers(small_disk)


def test_params_on_a_full_disk_keep_the_good_file(tmp_path, monkeypatch, capfd):
    """`splat gauss --save-params p.npz --overwrite` on a full disk turned a good p.npz into a 12 KiB invalid zip.

    The disk fills while the archive is written: the writer's file object raises ENOSPC part-way."""
    import builtins

    import clrender.outputs as outputs

    photo = tmp_path / "in.png"
    write_image(photo, np.random.default_rng(2).uniform(0, 1, (12, 16, 3)).astype(np.float32))
    good = {"params.npz": None, "fit.csv": None, "out.png": None}
    assert (
        main(
            [
                "-q",
                "splat",
                "gauss",
                str(photo),
                "-o",
                str(tmp_path / "out.png"),
                "--splats",
                "4",
                "--epochs",
                "2",
                "--save-params",
                str(tmp_path / "params.npz"),
                "--log",
                str(tmp_path / "fit.csv"),
            ]
        )
        == 0
    )
    good = files(tmp_path, list(good) + ["out.curve.png"])

    real_open = builtins.open

    class FillsUp:
        def __init__(self, f):
            self.f, self.written = f, 0

        def write(self, data):
            self.written += len(data)
            if self.written > 2000:
                raise OSError(errno.ENOSPC, "No space left on device")
            return self.f.write(data)

        def __getattr__(self, name):
            return getattr(self.f, name)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.f.close()

    def full_open(path, mode="r", *args, **kwargs):
        f = real_open(path, mode, *args, **kwargs)
        return FillsUp(f) if str(path).startswith("/proc/self/fd/") and "w" in mode else f

    monkeypatch.setattr(outputs, "open", full_open, raising=False)
    rc = main(
        [
            "-q",
            "splat",
            "gauss",
            str(photo),
            "-o",
            str(tmp_path / "out.png"),
            "--splats",
            "6",
            "--epochs",
            "3",
            "--save-params",
            str(tmp_path / "params.npz"),
            "--log",
            str(tmp_path / "fit.csv"),
            "--overwrite",
        ]
    )
    err = capfd.readouterr().err
    assert rc == 1 and err.count("\n") == 1 and "No space left on device" in err, err
    assert files(tmp_path, list(good)) == good  # the old set, every file of it
    assert not leftovers(tmp_path)


def fill_up(folder: Path, leave: int) -> None:
    """Fill the filesystem of `folder` until fewer than `leave` bytes are free."""
    with open(folder / "filler", "wb") as f:
        try:
            while True:
                free = os.statvfs(folder).f_bavail * os.statvfs(folder).f_frsize
                if free <= leave:
                    break
                f.write(b"\0" * min(4096, free - leave))
                f.flush()
        except OSError as exc:
            assert exc.errno == errno.ENOSPC


@pytest.mark.parametrize("name", ["t.png", "t.jpg"])
def test_an_image_onto_a_nearly_full_disk_fails_and_keeps_the_good_file(small_disk, name):
    """libpng wrote a 0-byte t.png into the last 1-2 KB and clrender exited 0 (with --overwrite the good
    file was replaced by the empty one); libjpeg exited 1 without a word."""
    good = small_disk / name
    write_image(good, np.random.default_rng(5).uniform(0, 1, (48, 64, 3)).astype(np.float32))
    old = good.read_bytes()
    fill_up(small_disk, leave=1536)
    proc = clrender(*RENDER[:2], "--width", "64", "--height", "48", "-o", name, "--overwrite", cwd=small_disk)
    out, err = proc.communicate(timeout=300)  # a process of its own: libjpeg's exit(1) ended the caller
    assert proc.returncode == 1, err
    assert out == "" and err.count("\n") == 1 and err.startswith(f"clrender: cannot write {name!r}: No space left on device"), err
    assert "disk full" in err
    assert good.read_bytes() == old
    assert not leftovers(small_disk)


def test_an_encoder_that_writes_nothing_and_says_it_worked_is_a_failure(tmp_path, monkeypatch, capfd):
    """The same fault without a small disk: an encoder whose file comes out empty while it reports success."""
    import OpenImageIO

    import clrender.image.files as image_files

    class SilentEncoder:
        def open(self, name, spec):
            open(name, "wb").close()  # what libpng left on a full disk
            return True

        def write_image(self, pixels):
            return True

        def close(self):
            return True

        def geterror(self):
            return ""

    class Library:
        def __getattr__(self, name):
            return getattr(OpenImageIO, name)

        class ImageOutput:
            create = staticmethod(lambda name: SilentEncoder())

    good = tmp_path / "t.png"
    write_image(good, np.full((6, 8, 3), 0.5, np.float32))
    old = good.read_bytes()
    monkeypatch.setattr(image_files, "oiio", Library())
    rc = main(["-q", *RENDER[:2], "--width", "8", "--height", "6", "-o", str(good), "--overwrite"])
    err = capfd.readouterr().err
    assert rc == 1 and err.count("\n") == 1 and str(good) in err, err
    assert good.read_bytes() == old
    assert not leftovers(tmp_path)


# ----------------------------------------------------------------------------- a folder we may not write
def test_read_only_folder_is_one_line_and_writes_nothing(small_disk, tmp_path, capfd):
    """A read-only filesystem (chmod does not stop root, a read-only remount does)."""
    (small_disk / "keep.png").write_bytes(b"old")
    subprocess.run(["mount", "-o", "remount,ro", str(small_disk)], check=True)
    rc = main(["-q", *RENDER[:2], "--width", "8", "--height", "6", "-o", str(small_disk / "o.png")])
    err = capfd.readouterr().err
    assert rc in (1, 2) and err.count("\n") == 1 and err.startswith("clrender: "), err
    assert sorted(p.name for p in small_disk.iterdir()) == ["keep.png"]


def test_side_output_refused_at_the_last_step_undoes_the_image(tmp_path, monkeypatch, capfd):
    """`voronoi --save-sites` into a read-only folder failed with a traceback after the image was written.

    Here the sites file is refused when it is put in place (after the image was): the image is taken back."""
    import clrender.outputs as outputs

    photo = tmp_path / "in.png"
    write_image(photo, np.random.default_rng(3).uniform(0, 1, (10, 12, 3)).astype(np.float32))
    real_place = outputs._Staged.place

    def place(self, overwrite):
        if self.final.suffix == ".npz":
            raise PermissionError(errno.EACCES, "Permission denied", str(self.final))
        return real_place(self, overwrite)

    monkeypatch.setattr(outputs._Staged, "place", place)
    rc = main(["-q", "splat", "voronoi", str(photo), "-o", str(tmp_path / "cells.png"), "--splats", "5", "--save-sites", str(tmp_path / "sites.npz")])
    err = capfd.readouterr().err
    assert rc == 1 and err.count("\n") == 1 and "Permission denied" in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in.png"]


def test_output_under_a_file_is_exit_2(tmp_path, capfd):
    (tmp_path / "afile").write_text("not a folder")
    rc = main(["-q", *RENDER[:2], "--width", "8", "--height", "6", "-o", str(tmp_path / "afile" / "o.png")])
    err = capfd.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "does not exist" in err, err


# ----------------------------------------------------------------------------- two writers
def test_two_sets_to_one_new_path_exactly_one_wins(tmp_path):
    """No-clobber is decided when the file is put in place: both sets pass any earlier check, one links first."""
    from clrender.errors import UsageError

    first, second = OutputSet(overwrite=False), OutputSet(overwrite=False)
    final = tmp_path / "p.npz"
    for outputs, value in ((first, 1.0), (second, 2.0)):
        outputs.write(final, lambda path, value=value: np.savez(open(path, "wb"), x=np.full(3, value)))
    first.commit()
    with pytest.raises(UsageError, match="already exists"):
        second.commit()
    assert np.load(final)["x"].tolist() == [1.0, 1.0, 1.0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.npz"]


def test_two_renders_to_one_new_path_exactly_one_succeeds(tmp_path, new_render):
    procs = [clrender(*RENDER, "-o", "out.png", "--edges-out", f"edges{i}.png", cwd=tmp_path) for i in range(2)]
    results = [(p.wait(timeout=300), p.stderr.read()) for p in procs]
    codes = sorted(rc for rc, _ in results)
    assert codes == [0, 2], results
    loser = next(err for rc, err in results if rc == 2)
    assert "already exists" in loser and loser.count("\n") == 1
    assert (tmp_path / "out.png").read_bytes() == new_render[0]["out.png"]
    # the loser's set is not half there: only the winner's edges image exists
    assert len(list(tmp_path.glob("edges*.png"))) == 1
    assert not leftovers(tmp_path)


def test_two_writers_with_overwrite_leave_one_whole_file(tmp_path):
    """Threads racing os.replace on one name: the survivor is one writer's complete file."""
    final = tmp_path / "p.npz"
    errors = []

    def writer(value):
        try:
            for _ in range(20):
                save_npz(final, overwrite=True, x=np.full(5000, value))
        except Exception as exc:  # pragma: no cover - reported below
            errors.append(exc)

    threads = [threading.Thread(target=writer, args=(v,)) for v in (1.0, 2.0)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    x = np.load(final)["x"]
    assert len(x) == 5000 and len(set(x.tolist())) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.npz"]


def test_a_failing_writer_leaves_nothing(tmp_path):
    old = tmp_path / "a.csv"
    old.write_text("old")
    with pytest.raises(RuntimeError):
        with output_set(overwrite=True):
            save_npz(tmp_path / "b.npz", x=np.zeros(2))
            raise RuntimeError("the fit failed after one output was written")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.csv"] and old.read_text() == "old"


# ----------------------------------------------------------------------------- a set of four outputs
GAUSS_OUTPUTS = ["fit.png", "fit.curve.png", "params.npz", "log.csv"]


def _classify(folder: Path, old: dict) -> dict[str, str]:
    """Each output is 'old' (byte for byte) or 'new' (different and whole: it loads to the end)."""
    import csv

    from clrender.image.files import read_image
    from clrender.splat.gauss import GaussParams

    kinds = {}
    for name in GAUSS_OUTPUTS:
        path = folder / name
        assert path.exists(), f"{name} vanished"
        if path.read_bytes() == old[name]:
            kinds[name] = "old"
            continue
        if name.endswith(".png"):
            read_image(path)
        elif name.endswith(".npz"):
            assert GaussParams.load(path).n == 6
        else:
            rows = list(csv.DictReader(open(path)))
            assert rows and int(rows[-1]["step"]) == 40
        kinds[name] = "new"
    return kinds


@pytest.mark.slow
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM, signal.SIGKILL])
def test_signals_during_a_fit_leave_the_old_set_or_the_new(tmp_path, signum):
    """`splat gauss` writes an image, its curve, the parameters and a log: after a signal at a seeded
    moment each is whole, and all four are old or all are new (after a SIGKILL, once the next write
    into the folder has finished the set's journal)."""
    photo = tmp_path / "in.png"
    write_image(photo, np.random.default_rng(4).uniform(0, 1, (24, 32, 3)).astype(np.float32))
    command = [
        "splat",
        "gauss",
        photo,
        "-o",
        "fit.png",
        "--splats",
        "6",
        "--epochs",
        "40",
        "--save-params",
        "params.npz",
        "--log",
        "log.csv",
        "--overwrite",
    ]
    start = time.perf_counter()
    first = clrender(*command, cwd=tmp_path)
    assert first.wait(timeout=300) == 0, first.stderr.read()
    seconds = time.perf_counter() - start
    moments = random.Random(2000 + int(signum))
    for i in range(int(os.environ.get("CLRENDER_FAULT_MOMENTS", "8"))):
        # an old set unlike any new one (a rerun's image and parameters would be byte-identical)
        for name in ("fit.png", "fit.curve.png"):
            write_image(tmp_path / name, np.full((4, 4, 3), i / 10, np.float32))
        np.savez(tmp_path / "params.npz", old=np.full(3, i))
        (tmp_path / "log.csv").write_text(f"old {i}\n")
        old = files(tmp_path, GAUSS_OUTPUTS)
        proc = clrender(*command, cwd=tmp_path)
        wait_for_handlers(proc)
        time.sleep(moments.uniform(0, 1.05 * seconds))
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=300)
        check_exit(signum, proc.returncode, err)
        if signum == signal.SIGKILL:  # the next write into the folder finishes a set killed among its renames
            write_image(tmp_path / "next.png", np.zeros((2, 2, 3), np.float32))
        kinds = _classify(tmp_path, old)
        assert len(set(kinds.values())) == 1, kinds
        assert not leftovers(tmp_path)
