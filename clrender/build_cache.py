"""The folder where pyopencl keeps built programs for clrender, and its lock.

pyopencl keeps a driver's built binaries on disk (for drivers without a cache of their own: Intel's CPU runtime,
Oclgrind) and takes the folder's lock file, created with O_EXCL, for each lookup. A process killed while it holds the
lock (SIGKILL during a render's first second, or a timeout's kill) leaves the file behind, and from then on every
build in every process waits a minute for it and fails. `clear_stale_lock` removes such a lock before a build: one
that no live process has open and that is older than a lookup's blink. clrender keeps its programs in its own cache
folder, so it knows where the lock is."""

from __future__ import annotations

import os
import time
from pathlib import Path

STALE_AFTER_S = 2.0  # a lock this old with no holder is left by a dead process, not being released


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
    cache = folder()
    clear_stale_lock(cache)
    return str(cache)


def clear_stale_lock(cache: Path) -> bool:
    """Remove `cache`'s lock if a dead process left it; whether one was removed."""
    lock = cache / "lock"
    try:
        age = time.time() - lock.stat().st_mtime
    except OSError:
        return False
    if age < STALE_AFTER_S or held_open(lock):
        return False
    try:
        lock.unlink()
    except OSError:
        return False
    return True
