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

Placing with overwrite (and keeping the old files of a set for undo) needs
hidden *named* files for a few system calls, since Linux cannot rename an
unnamed file over an existing one.  A SIGKILL inside that window (catchable
signals wait for it) leaves one such `.NAME.PID.XXXXXXXX.clrender-tmp`; it
carries the writer's pid, and the next write into that folder removes those
whose process is gone.

    with output_set(overwrite=args.overwrite):
        write_image(out, pixels)            # staged, not yet visible
        save_npz(params_path, xy=xy)        # staged
    # both in place here, or neither if anything above raised
"""

from __future__ import annotations

import contextlib
import contextvars
import csv
import errno
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

    def __init__(self, final: Path):
        self.final = final
        self.fd = None
        self.named = None
        folder = str(final.parent) or "."
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
        _LIVE.add(self)

    def write(self, final, writer: Callable[[str], None]) -> Path:
        """Stage `final`: writer(path) writes the contents to path (a temp file)."""
        final = Path(final)
        if final.is_dir():
            raise UsageError(f"output {_show(final)} is a folder; name a file inside it")
        remove_stale_temps(final.parent)
        staged = _Staged(final)
        self.staged.append(staged)
        try:
            writer(staged.path)
            staged.sync()
        except OSError as exc:
            # the writer's error names the temp file (/proc/self/fd/N) or nothing: name the output instead
            raise RenderFailure(write_failure(final, exc)) from exc
        return final

    def commit(self) -> None:
        """Place every staged file; on any failure undo the placed ones and re-raise."""
        names = [str(s.final) for s in self.staged]
        if len(set(map(os.path.abspath, names))) != len(names):
            raise UsageError(f"two outputs name the same file ({', '.join(map(_show, names))})")
        placed: list[tuple[Path, str | None]] = []  # (final, backup of the old file)
        keep_backups = len(self.staged) > 1  # a single file needs no undo: its placing is one atomic step
        with _signals_deferred():
            try:
                for s in self.staged:
                    backup = None
                    if self.overwrite and keep_backups and s.final.exists():
                        backup = _hidden_name(s.final)
                        os.link(s.final, backup)
                    try:
                        s.place(self.overwrite)
                    except BaseException:
                        if backup:
                            _unlink_quietly(backup)
                        raise
                    placed.append((s.final, backup))
            except BaseException:
                for final, backup in reversed(placed):
                    if backup:
                        os.replace(backup, final)
                    else:
                        _unlink_quietly(final)
                raise
            finally:
                self.discard()
            for _, backup in placed:
                if backup:
                    _unlink_quietly(backup)

    def discard(self) -> None:
        for s in self.staged:
            s.discard()
        self.staged = []


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
    """Remove the named temp files in `folder` whose writer no longer runs (left by a SIGKILL)."""
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
