"""The folder where pyopencl keeps built programs for clrender, and its lock.

pyopencl keeps a driver's built binaries on disk (for drivers without a cache of their own: Intel's CPU runtime,
Oclgrind) and takes the folder's lock file, created with O_EXCL, for each lookup. A process killed while it holds the
lock (SIGKILL during a render's first second, or a timeout's kill) leaves the file behind, and from then on every
build in every process waits a minute for it and fails. `clear_stale_lock` removes such a lock before a build: one
that no live process has open, seen twice a blink apart (a holder closes the file a moment before it removes it).
clrender keeps its programs in its own cache folder, so it knows where the lock is.

Any other failure of the cache (a file a killed process left half-written) makes pyopencl build from source with a
warning, not fail: pyopencl 2025's fallback reads $PYOPENCL_CACHE_FAILURE_FATAL with os.environ[...], a KeyError
where it is unset, so `ready` sets it to "" (false) unless the user set it."""

from __future__ import annotations

import os
import time
from pathlib import Path

BLINK_S = 0.05  # a live holder removes the lock within microseconds of closing it


def folder() -> Path:
    """pyopencl's program cache for clrender: <user cache>/clrender/programs (~/.cache/clrender/programs on Linux)."""
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("clrender")) / "programs"


def held_open(path: Path) -> bool:
    """Whether a live process has `path` open, read from /proc; True where that cannot be known (no /proc)."""
    proc = Path("/proc")
    if not (proc / "self" / "fd").is_dir():
        return True
    target = os.path.realpath(path)
    for fds in proc.glob("[0-9]*/fd"):
        try:
            if any(os.readlink(fd) == target for fd in fds.iterdir()):
                return True
        except OSError:  # a process that ended, or one we may not look into
            continue
    return False


def ready() -> str:
    """The folder for a build's cache_dir, a stale lock in it removed first."""
    os.environ.setdefault("PYOPENCL_CACHE_FAILURE_FATAL", "")
    cache = folder()
    clear_stale_lock(cache)
    return str(cache)


def clear_stale_lock(cache: Path) -> bool:
    """Remove `cache`'s lock if a dead process left it; whether one was removed."""
    lock = cache / "lock"
    seen = _identity(lock)
    if seen is None or held_open(lock):
        return False
    time.sleep(BLINK_S)
    if _identity(lock) != seen or held_open(lock):  # released and taken again, or taken since
        return False
    try:
        lock.unlink()
    except OSError:
        return False
    return True


def _identity(path: Path) -> tuple[int, int, int] | None:
    """What tells one lock file from the next at the same path, or None if there is none."""
    try:
        st = path.stat()
    except OSError:
        return None
    return st.st_dev, st.st_ino, st.st_ctime_ns
