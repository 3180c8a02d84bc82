"""Every file clrender writes goes through here: written aside, then put in place whole.

A file is written into an unnamed temporary file in the target's folder
(Linux O_TMPFILE: if the process dies, even by SIGKILL, the kernel frees it
and no temp file is left), or into a hidden named temp file where the
filesystem has no O_TMPFILE.  Only a finished file gets the final name:

- without overwrite, by a hard link, which fails if the name exists, so the
  no-clobber check happens *at* the final step and of two writers to one new
  path exactly one succeeds;
- with overwrite, by os.replace (atomic: readers see the old file or the new).

Several outputs of one command form a set (`output_set`): every file is
written first, then all are put in place; if any step fails, the ones already
placed are undone, so the folder holds the old set or the new one.

Placing with overwrite (and a set's placing) needs hidden *named* files for a
few system calls, since Linux cannot rename an unnamed file over an existing
one.  They are named `.NAME.PID.XXXXXXXX.clrender-tmp` after the writer's pid.
A set is placed under a journal (`.clrender-set.PID.XXXXXXXX.clrender-tmp.journal`
in each of its folders) that names every new file and every old one, written
before the first rename.  Catchable signals wait until the set is placed; a
SIGKILL among the renames leaves the journal, and the next write into that
folder (remove_stale_temps) finishes the set forward (or back, if it was being
undone) and removes the hidden files whose process is gone.  So between a
`kill -9` and the next write into the folder, a set can be seen mixed; after
it, the folder holds the old set or the new one.

    with output_set(overwrite=args.overwrite):
        write_image(out, pixels)            # staged, not yet visible
        save_npz(params_path, xy=xy)        # staged
    # both in place here, or neither if anything above raised
"""

from __future__ import annotations

import contextlib
import contextvars
import csv
import dataclasses
import errno
import json
import os
import re
import signal
import tempfile
import weakref
from collections.abc import Callable
from pathlib import Path

from .errors import RenderFailure, UsageError

# the output set that writes join while a `with output_set(...)` block runs
_LIVE: weakref.WeakSet[OutputSet] = weakref.WeakSet()  # sets with staged files, for discard_all
_CURRENT: contextvars.ContextVar[OutputSet | None] = contextvars.ContextVar("clrender_output_set", default=None)
TEMP_MARK = ".clrender-tmp"  # part of every named temp file's name (tests look for it)
# ".NAME.PID.XXXXXXXX.clrender-tmp[.ext]": which process left a named temp file
_TEMP_NAME = re.compile(r"^\..*\.(\d+)\.[A-Za-z0-9_]+" + re.escape(TEMP_MARK) + r"(\.[^.]*)?$")


class _Staged:
    """One finished-but-unplaced file: an O_TMPFILE descriptor or a hidden named file."""

    def __init__(self, final: Path, folder: Path | None = None):
        self.final = final
        self.fd = None
        self.named = None
        folder = str(final.parent if folder is None else folder) or "."
        try:
            self.fd = os.open(folder, os.O_TMPFILE | os.O_RDWR, 0o666)  # umask applies
        except (AttributeError, OSError) as exc:
            if isinstance(exc, OSError) and exc.errno not in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL):
                raise
            fd, self.named = tempfile.mkstemp(prefix=_temp_prefix(final), suffix=f"{TEMP_MARK}{final.suffix}", dir=folder)
            os.close(fd)
            mask = os.umask(0)
            os.umask(mask)
            os.chmod(self.named, 0o666 & ~mask)  # mkstemp makes 0600; an output gets the usual mode

    @property
    def path(self) -> str:
        """Where a writer writes the contents (it may open and truncate it)."""
        return f"/proc/self/fd/{self.fd}" if self.fd is not None else self.named

    def sync(self) -> None:
        if self.fd is not None:
            os.fsync(self.fd)

    def link_to(self, name: str) -> None:
        """Give the contents the name `name`; FileExistsError if it exists."""
        if self.fd is not None:
            # linkat(AT_SYMLINK_FOLLOW) on /proc/self/fd/N names an O_TMPFILE file (open(2));
            # Python uses linkat with that flag only when a dir fd is passed.
            root = os.open("/", os.O_RDONLY)
            try:
                os.link(self.path, name, src_dir_fd=root, follow_symlinks=True)
            finally:
                os.close(root)
        else:
            os.link(self.named, name)

    def name_it(self) -> str:
        """A hidden name beside the final one for the contents (a journal can name it; see commit)."""
        if self.named is None or Path(self.named).parent != self.final.parent:
            hidden = _hidden_name(self.final)
            self.link_to(hidden)
            if self.named is not None:
                os.unlink(self.named)
            self.named = hidden
        return self.named

    def place(self, overwrite: bool) -> None:
        final = str(self.final)
        if not overwrite:
            try:
                self.link_to(final)
            except FileExistsError:
                raise UsageError(f"output {_show(final)} already exists; pass --overwrite to replace it") from None
            return
        if self.named is not None:
            os.replace(self.named, final)
            self.named = None
            return
        hidden = _hidden_name(self.final)
        self.link_to(hidden)
        try:
            os.replace(hidden, final)
        except BaseException:
            _unlink_quietly(hidden)
            raise

    def discard(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None
        if self.named is not None:
            _unlink_quietly(self.named)
            self.named = None


class OutputSet:
    """Files written together: all are placed, or none is."""

    def __init__(self, overwrite: bool):
        self.overwrite = overwrite
        self.staged: list[_Staged] = []
        self.folders: list[Path] = []  # made at commit (add_folder)
        _LIVE.add(self)

    def write(self, final, writer: Callable[[str], None]) -> Path:
        """Stage `final`: writer(path) writes the contents to path (a temp file)."""
        final = Path(final)
        if final.is_dir():
            raise UsageError(f"output {_show(final)} is a folder; name a file inside it")
        folder = final.parent.parent if final.parent in self.folders else final.parent
        remove_stale_temps(folder)
        staged = _Staged(final, folder)
        self.staged.append(staged)
        try:
            writer(staged.path)
            staged.sync()
        except OSError as exc:
            # the writer's error names the temp file (/proc/self/fd/N) or nothing: name the output instead
            raise RenderFailure(write_failure(final, exc)) from exc
        return final

    def commit(self) -> None:
        """Place every staged file; on any failure undo the placed ones and re-raise.

        A single file is placed in one atomic step.  A set is placed under a journal (see _Journal):
        every new file first gets a hidden name beside its target, the journal naming them all is
        written, and only then are they renamed; a process killed among the renames leaves the
        journal, and the next write into that folder finishes the set (or undoes it)."""
        names = [str(s.final) for s in self.staged]
        if len(set(map(os.path.abspath, names))) != len(names):
            raise UsageError(f"two outputs name the same file ({', '.join(map(_show, names))})")
        made: list[Path] = []
        with _signals_deferred():
            try:
                for folder in self.folders:  # folders the set creates, made at the last moment
                    try:
                        os.mkdir(folder)
                    except FileExistsError:
                        if not folder.is_dir():
                            raise
                        continue  # made by someone else meanwhile: used, and not ours to remove
                    made.append(folder)
                if len(self.staged) == 1:
                    self.staged[0].place(self.overwrite)
                elif self.staged:
                    self._commit_with_journal()
            except BaseException:
                for folder in reversed(made):
                    with contextlib.suppress(OSError):
                        os.rmdir(folder)
                raise
            finally:
                self.discard()

    def _commit_with_journal(self) -> None:
        entries = []
        journal = None
        try:
            for s in self.staged:
                new = s.name_it()
                backup = None
                if self.overwrite and os.path.lexists(s.final):
                    backup = _hidden_name(s.final)  # the old file, kept for an undo
                    os.link(s.final, backup, follow_symlinks=False)
                entries.append(_Entry(str(s.final.absolute()), os.path.abspath(new), _identity(new), backup and os.path.abspath(backup)))
            journal = _Journal(entries, self.overwrite)
            journal.save("forward")
            for s in self.staged:
                s.place(self.overwrite)
        except BaseException:
            if journal is not None and journal.saved:
                with contextlib.suppress(RenderFailure):
                    journal.save("back")  # a kill during the undo is undone by the next write, too
            _roll_back(entries)
            raise
        finally:
            _remove_names(entries)
            if journal is not None:
                journal.remove()

    def add_folder(self, folder) -> Path:
        """A folder the set creates when it is placed (its parent must exist); files staged for it wait
        in that parent, so a set that is not placed leaves no empty folder behind."""
        folder = Path(folder)
        if folder not in self.folders:
            self.folders.append(folder)
        return folder

    def discard(self) -> None:
        for s in self.staged:
            s.discard()
        self.staged = []


# ----------------------------------------------------------------------------- the journal of a set
JOURNAL_SUFFIX = TEMP_MARK + ".journal"  # ".clrender-set.PID.XXXXXXXX.clrender-tmp.journal" in each folder of a set


@dataclasses.dataclass
class _Entry:
    """One file of a set being placed: all paths absolute, so a journal in any folder finds them."""

    final: str  # the output's name
    new: str  # the hidden name holding the new contents until they are placed
    identity: tuple  # (st_dev, st_ino) of the new contents: tells our placed file from anyone's
    backup: str | None  # a hidden second name of the old file (with overwrite), for an undo

    def placed(self) -> bool:
        return _identity(self.final) == self.identity


class _Journal:
    """Which files a set is putting in place, and which way a crashed commit is to be finished.

    Written (whole, by a rename) into every folder the set writes to, after all new files have hidden
    names there and before the first output is renamed.  "forward": the new set is to be placed;
    "back": it is to be undone.  remove_stale_temps finishes a journal whose process is gone."""

    def __init__(self, entries: list[_Entry], overwrite: bool):
        self.entries, self.overwrite, self.saved = entries, overwrite, False
        token = os.urandom(4).hex()
        folders = dict.fromkeys(os.path.dirname(e.final) for e in entries)
        self.names = [os.path.join(f, f".clrender-set.{os.getpid()}.{token}{JOURNAL_SUFFIX}") for f in folders]

    def save(self, roll: str) -> None:
        text = json.dumps(
            {"roll": roll, "overwrite": self.overwrite, "journals": self.names, "entries": [dataclasses.asdict(e) for e in self.entries]}
        )
        for name in self.names:
            fd, temp = tempfile.mkstemp(prefix=f".clrender-set.{os.getpid()}.", suffix=TEMP_MARK, dir=os.path.dirname(name))
            try:
                try:
                    with open(fd, "w", closefd=False) as f:
                        f.write(text)
                    os.fsync(fd)
                finally:
                    os.close(fd)
                os.replace(temp, name)
            except OSError as exc:
                _unlink_quietly(temp)
                raise RenderFailure(write_failure(self.entries[0].final, exc)) from exc
            self.saved = True

    def remove(self) -> None:
        for name in self.names:
            _unlink_quietly(name)


def _identity(path: str) -> tuple | None:
    try:
        st = os.stat(path, follow_symlinks=False)
    except OSError:
        return None
    return (st.st_dev, st.st_ino)


def _roll_forward(entries: list[_Entry], overwrite: bool) -> None:
    """Place every new file that is not placed yet (recovery; raises where one cannot be)."""
    for e in entries:
        if e.placed():
            continue
        if not os.path.lexists(e.new):
            raise FileNotFoundError(errno.ENOENT, "the new file is gone", e.new)
        if overwrite:
            os.replace(e.new, e.final)
        else:
            os.link(e.new, e.final, follow_symlinks=False)  # FileExistsError: someone else's file now


def _roll_back(entries: list[_Entry]) -> None:
    """Put the old files back where ours were placed (best effort: every entry is tried)."""
    for e in reversed(entries):
        with contextlib.suppress(OSError):
            if e.backup and os.path.lexists(e.backup):
                os.replace(e.backup, e.final)
            elif e.placed():
                os.unlink(e.final)


def _remove_names(entries: list[_Entry]) -> None:
    for e in entries:
        for name in (e.new, e.backup):
            if name:
                with contextlib.suppress(OSError):
                    os.unlink(name)


def finish_crashed_sets(folder) -> None:
    """Finish the set commits in `folder` whose process died among its renames (kill -9): forward to
    the new set if every new file is still there, else back to the old one; then remove the journal."""
    try:
        names = [e.path for e in os.scandir(folder) if e.name.endswith(JOURNAL_SUFFIX)]
    except OSError:
        return
    for name in names:
        match = _TEMP_NAME.match(os.path.basename(name))
        if not match or _process_runs(int(match.group(1))):
            continue
        try:
            with open(name) as f:
                journal = json.load(f)
            entries = [_Entry(e["final"], e["new"], tuple(e["identity"]), e["backup"]) for e in journal["entries"]]
            journals, overwrite, roll = list(journal["journals"]), bool(journal["overwrite"]), journal["roll"]
        except (OSError, ValueError, KeyError, TypeError):
            continue  # not a journal we wrote; remove_stale_temps removes it
        if roll == "forward":
            try:
                _roll_forward(entries, overwrite)
            except OSError:
                _roll_back(entries)
        else:
            _roll_back(entries)
        _remove_names(entries)
        for other in journals:
            _unlink_quietly(other)


def write_failure(final, exc: OSError) -> str:
    """ "cannot write 'out.png': No space left on device (is the disk full?)": the file and the reason."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        reason += " (is the disk full?)"
    return f"cannot write {_show(final)}: {reason}"


def check_file_output(path, *, overwrite: bool, suffixes: tuple[str, ...], option: str = "output") -> Path:
    """Refuse a non-image output we could not write (splats, sites, a video), before any work is done:
    a folder, another extension, an existing file without --overwrite, a missing or read-only folder.
    Images go through image.files.check_output_path, which also asks the image library for a writer;
    the final no-clobber check happens when the finished file is put in place (above)."""
    from .errors import shown

    path = Path(path)
    allowed = " or ".join(suffixes)
    if path.is_dir():
        raise UsageError(f"{option} {shown(path)} is a folder; name a file ending in {allowed}")
    if path.suffix.lower() not in suffixes:
        raise UsageError(f"{option} {shown(path)} must end in {allowed}")
    return check_writable(path, overwrite=overwrite, option=option)


def check_writable(path: Path, *, overwrite: bool, option: str = "output") -> Path:
    """The part of every early output check that is about the file system: no file there
    (unless overwrite), and a folder that exists and is writable."""
    from .errors import shown

    if path.exists() and not overwrite:
        raise UsageError(f"{option} {shown(path)} already exists; pass --overwrite to replace it")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise UsageError(f"folder {shown(parent)} of {option} {shown(path)} does not exist")
    if not os.access(parent, os.W_OK):
        raise UsageError(f"folder {shown(parent)} of {option} {shown(path)} is not writable")
    return path


@contextlib.contextmanager
def output_set(overwrite: bool):
    """Writes inside the block are staged and placed together when it ends without error."""
    outputs = OutputSet(overwrite)
    token = _CURRENT.set(outputs)
    try:
        yield outputs
        _CURRENT.reset(token)
        token = None
        outputs.commit()
    finally:
        if token is not None:
            _CURRENT.reset(token)
        outputs.discard()


def write_file(final, writer: Callable[[str], None], *, overwrite: bool = True, join: bool = True) -> Path:
    """Write one output through a temp file: joins the current output set, or is placed at once.

    Inside `output_set(...)` the set's overwrite rule applies and `overwrite` is ignored;
    `join=False` places the file at once anyway (a cache, which is no output of the command).
    """
    current = _CURRENT.get() if join else None
    if current is not None:
        return current.write(final, writer)
    with output_set(overwrite) as outputs:
        return outputs.write(final, writer)


def save_npz(final, *, overwrite: bool = True, join: bool = True, **arrays) -> Path:
    """np.savez through a temp file (np.savez would add '.npz' to a name without it, so it gets a file)."""
    import numpy as np

    def writer(path):
        with open(path, "wb") as f:
            np.savez(f, **arrays)

    return write_file(final, writer, overwrite=overwrite, join=join)


def write_csv(final, rows: list[dict], *, overwrite: bool = True) -> Path:
    """A CSV table with a header row from the first row's keys."""

    def writer(path):
        with open(path, "w", newline="") as f:
            table = csv.DictWriter(f, list(rows[0]) if rows else [])
            table.writeheader()
            table.writerows(rows)

    return write_file(final, writer, overwrite=overwrite)


def _temp_prefix(final: Path) -> str:
    return f".{final.name}.{os.getpid()}."


def remove_stale_temps(folder: Path) -> None:
    """Remove the named temp files in `folder` whose writer no longer runs (left by a SIGKILL),
    after finishing the set commits such a writer left half done."""
    finish_crashed_sets(folder)
    try:
        names = [e.name for e in os.scandir(folder) if TEMP_MARK in e.name]
    except OSError:
        return  # the write itself reports an unreadable folder
    for name in names:
        match = _TEMP_NAME.match(name)
        if match and not _process_runs(int(match.group(1))):
            with contextlib.suppress(OSError):
                os.unlink(os.path.join(folder, name))


def _process_runs(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError):
        return True  # someone else's process, or not a pid: leave the file alone
    return True


def _hidden_name(final: Path) -> str:
    fd, name = tempfile.mkstemp(prefix=_temp_prefix(final), suffix=TEMP_MARK, dir=str(final.parent) or ".")
    os.close(fd)
    os.unlink(name)  # only the unique name is wanted; link() needs it absent
    return name


def _unlink_quietly(name) -> None:
    try:
        os.unlink(name)
    except FileNotFoundError:
        pass


_PLACING = [0]  # > 0 while files are being put in place
_PENDING: list[int] = []  # signals that arrived meanwhile


def hold_signal(signum: int) -> bool:
    """For a signal handler: True (and the signal is remembered) while outputs are being put in place.

    A set must not be split by Ctrl-C; the signal is raised again as soon as the set is placed.
    (A flag, not a blocked signal mask: OpenCL's worker threads would take a blocked signal instead.)
    """
    if _PLACING[0]:
        _PENDING.append(signum)
        return True
    return False


def discard_all() -> None:
    """Remove every staged temp file now (a handler about to end the process calls this)."""
    for outputs in list(_LIVE):
        outputs.discard()


@contextlib.contextmanager
def _signals_deferred():
    """Hold SIGINT/SIGTERM (see hold_signal) while files are being put in place."""
    _PLACING[0] += 1
    try:
        yield
    finally:
        _PLACING[0] -= 1
        if not _PLACING[0] and _PENDING:
            signum = _PENDING[0]
            _PENDING.clear()
            signal.raise_signal(signum)


def _show(value) -> str:
    from .errors import shown

    return shown(value)
