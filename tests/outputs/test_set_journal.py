"""A set of outputs killed (SIGKILL) among its renames is finished by the next write into its folder.

A child process writes a set of three files and kills itself with SIGKILL at a chosen rename onto a
final name (os.replace / os.link are wrapped in the child only): that is the narrow window a
`kill -9` of a render hit (o.png new, o.aov.exr and o.edges.png old).  The folder may be mixed
right after the kill; after the next write into it, it holds the old set or the new set.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from clrender.image.files import write_image
from clrender.outputs import TEMP_MARK

REPO = Path(__file__).resolve().parents[2]
NAMES = ("o.npz", "o.aov.npz", "o.edges.npz")

CHILD = textwrap.dedent(
    """
    import os, signal, sys
    from pathlib import Path

    import numpy as np

    from clrender import outputs

    folder, overwrite, kill_at, fail_third = Path(sys.argv[1]), sys.argv[2] == "1", int(sys.argv[3]), sys.argv[4] == "1"
    renames = [0]  # renames (or links) onto a final name so far

    def killing(real):
        def call(src, dst, *args, **kwargs):
            if not os.path.basename(str(dst)).startswith("."):  # a final name, not a hidden one
                if renames[0] == kill_at:
                    os.kill(os.getpid(), signal.SIGKILL)
                renames[0] += 1
            return real(src, dst, *args, **kwargs)
        return call

    os.replace, os.link = killing(os.replace), killing(os.link)
    if fail_third:  # the third file is refused as it is placed: the set is undone
        real_place = outputs._Staged.place

        def place(self, overwrite):
            if self.final.name == "o.edges.npz":
                raise PermissionError(13, "Permission denied", str(self.final))
            return real_place(self, overwrite)

        outputs._Staged.place = place
    with outputs.output_set(overwrite=overwrite):
        for name in ("o.npz", "o.aov.npz", "o.edges.npz"):
            outputs.save_npz(folder / name, x=np.full(3, 2.0))
    """
)


def run_child(folder: Path, *, overwrite: bool, kill_at: int, fail_third: bool = False) -> int:
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    args = [sys.executable, "-c", CHILD, str(folder), str(int(overwrite)), str(kill_at), str(int(fail_third))]
    done = subprocess.run(args, env=env, capture_output=True, text=True, timeout=120)
    return done.returncode


def contents(folder: Path) -> list[float | None]:
    """Each output's value: 1.0 the old set, 2.0 the new one, None absent."""
    return [float(np.load(folder / n)["x"][0]) if (folder / n).exists() else None for n in NAMES]


def hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if TEMP_MARK in p.name)


def next_write(folder: Path) -> None:
    write_image(folder / "next.png", np.zeros((2, 2, 3), np.float32))


@pytest.mark.parametrize("kill_at", [0, 1, 2])
def test_a_set_killed_among_its_renames_is_completed_by_the_next_write(tmp_path, kill_at):
    for name in NAMES:
        np.savez(tmp_path / name, x=np.full(3, 1.0))
    assert run_child(tmp_path, overwrite=True, kill_at=kill_at) == -signal.SIGKILL
    assert contents(tmp_path) == [2.0] * kill_at + [1.0] * (3 - kill_at)  # the kill hit the window
    assert any(name.endswith(".journal") for name in hidden(tmp_path))
    next_write(tmp_path)
    assert contents(tmp_path) == [2.0, 2.0, 2.0]
    assert hidden(tmp_path) == []


def test_a_new_set_killed_among_its_links_is_completed_by_the_next_write(tmp_path):
    """Without --overwrite the names are claimed by links; a kill after the first leaves one file of three."""
    assert run_child(tmp_path, overwrite=False, kill_at=1) == -signal.SIGKILL
    assert contents(tmp_path) == [2.0, None, None]
    next_write(tmp_path)
    assert contents(tmp_path) == [2.0, 2.0, 2.0]
    assert hidden(tmp_path) == []


def test_a_set_killed_while_being_undone_is_undone_by_the_next_write(tmp_path):
    """The third file is refused, the set is being undone, and the kill comes at the first restoring rename."""
    for name in NAMES:
        np.savez(tmp_path / name, x=np.full(3, 1.0))
    assert run_child(tmp_path, overwrite=True, kill_at=2, fail_third=True) == -signal.SIGKILL
    assert contents(tmp_path) == [2.0, 2.0, 1.0]
    next_write(tmp_path)
    assert contents(tmp_path) == [1.0, 1.0, 1.0]
    assert hidden(tmp_path) == []


def test_a_recovery_leaves_a_living_writers_journal_alone(tmp_path):
    """A journal names its writer's pid: while that process runs, its commit is its own business."""
    journal = tmp_path / f".clrender-set.{os.getpid()}.abcd1234{TEMP_MARK}.journal"
    journal.write_text('{"roll": "back", "overwrite": true, "journals": [], "entries": []}')
    next_write(tmp_path)
    assert journal.exists()


def test_a_set_spread_over_two_folders_is_finished_from_either(tmp_path):
    """The journal is written into every folder of the set; a write into any of them finishes it all."""
    CHILD_TWO = CHILD.replace('for name in ("o.npz", "o.aov.npz", "o.edges.npz")', 'for name in ("o.npz", "sub/o.aov.npz", "o.edges.npz")')
    (tmp_path / "sub").mkdir()
    env = dict(os.environ, PYTHONPATH=str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    done = subprocess.run([sys.executable, "-c", CHILD_TWO, str(tmp_path), "0", "1", "0"], env=env, capture_output=True, timeout=120)
    assert done.returncode == -signal.SIGKILL
    assert (tmp_path / "o.npz").exists() and not (tmp_path / "sub" / "o.aov.npz").exists()
    next_write(tmp_path / "sub")
    assert all((tmp_path / n).exists() for n in ("o.npz", "sub/o.aov.npz", "o.edges.npz"))
    assert hidden(tmp_path) == [] and hidden(tmp_path / "sub") == []


@pytest.mark.parametrize("fail_at", [1, 2])
def test_an_overwriting_set_refused_between_its_renames_puts_every_old_file_back(tmp_path, monkeypatch, fail_at):
    """In-process, no kill: the rename onto the second or third name fails after the first ones have
    replaced their old files.  The commit is undone from the old files' backups: every old file is back,
    byte for byte, and no hidden name (new file, backup or journal) is left."""
    from clrender import outputs

    for i, name in enumerate(NAMES):
        np.savez(tmp_path / name, x=np.full(3, 1.0), which=np.int64(i))
    old = {name: (tmp_path / name).read_bytes() for name in NAMES}
    real_replace, renames = os.replace, []

    def replace(src, dst, *args, **kwargs):
        if not os.path.basename(str(dst)).startswith("."):  # onto a final name
            renames.append(os.path.basename(str(dst)))
            if len(renames) == fail_at + 1:  # this one only: the undo's renames go through
                raise OSError(28, "No space left on device", str(dst))
        return real_replace(src, dst, *args, **kwargs)

    monkeypatch.setattr(os, "replace", replace)
    with pytest.raises(OSError, match="No space left"):
        with outputs.output_set(overwrite=True):
            for name in NAMES:
                outputs.save_npz(tmp_path / name, x=np.full(3, 2.0))
    # the first fail_at outputs were replaced before the failure, then restored (not just removed)
    assert renames[: fail_at + 1] == list(NAMES[: fail_at + 1])
    assert {name: (tmp_path / name).read_bytes() for name in NAMES} == old
    assert contents(tmp_path) == [1.0, 1.0, 1.0]
    assert hidden(tmp_path) == []
