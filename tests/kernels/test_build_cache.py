"""A lock on the program cache that a killed process left is removed before a build; a live one is kept."""

import os
import subprocess
import sys
import time
import warnings

from clrender import build_cache


def aged(path, seconds):
    path.touch()
    then = time.time() - seconds
    os.utime(path, (then, then))
    return path


def test_a_lock_no_live_process_holds_is_removed(tmp_path):
    lock = aged(tmp_path / "lock", 60)
    assert build_cache.clear_stale_lock(tmp_path) and not lock.exists()
    assert not build_cache.clear_stale_lock(tmp_path)  # nothing left to remove


def test_a_lock_a_live_process_holds_open_is_kept(tmp_path):
    lock = aged(tmp_path / "lock", 60)
    holder = subprocess.Popen(
        [sys.executable, "-c", f"import sys, time; f = open({str(lock)!r}); print(1, flush=True); time.sleep(60)"], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "1"  # it has the file open
        assert build_cache.held_open(lock)
        assert not build_cache.clear_stale_lock(tmp_path) and lock.exists()
    finally:
        holder.kill()
        holder.wait()
    assert build_cache.clear_stale_lock(tmp_path)  # its holder gone, the lock is stale


def test_a_lock_left_a_moment_ago_is_removed(tmp_path):
    """A process killed while it held the lock, just before the next build (CI's signal tests kill at random moments)."""
    (tmp_path / "lock").touch()
    assert build_cache.clear_stale_lock(tmp_path) and not (tmp_path / "lock").exists()


def test_a_lock_released_and_taken_again_in_the_blink_is_kept(tmp_path, monkeypatch):
    """Between a holder's close and its unlink the lock has no holder; the next one taken is another file."""
    lock = tmp_path / "lock"
    lock.touch()

    def released_and_taken(_seconds):
        lock.unlink()
        lock.touch()

    monkeypatch.setattr(build_cache.time, "sleep", released_and_taken)
    assert not build_cache.clear_stale_lock(tmp_path) and lock.exists()


def test_a_build_after_a_killed_holder_does_not_wait(device, tmp_path, monkeypatch):
    monkeypatch.setattr(build_cache, "folder", lambda: tmp_path)
    aged(tmp_path / "lock", 60)
    start = time.perf_counter()
    device.build("__kernel void k(__global int *a) { a[0] = 7; }", "k.cl")
    assert time.perf_counter() - start < 30  # pyopencl would wait 60 s on the lock, then fail
    assert not (tmp_path / "lock").exists()


def test_a_broken_cache_entry_builds_from_source(device, tmp_path, monkeypatch):
    """A cache file a killed process left half-written: pyopencl warns and builds from source, clrender does not fail."""
    import pickle

    import pyopencl.cache

    lookups = []

    def truncated(*args):
        lookups.append(args)
        raise pickle.UnpicklingError("pickle data was truncated")

    monkeypatch.setattr(build_cache, "folder", lambda: tmp_path)
    monkeypatch.delenv("PYOPENCL_CACHE_FAILURE_FATAL", raising=False)
    monkeypatch.setattr(pyopencl.cache, "retrieve_from_cache", truncated)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        program = device.build("__kernel void k(__global int *a) { a[0] = 7; }", "k.cl")
    assert program.k is not None
    if lookups:  # the driver's builds go through pyopencl's cache (Intel's runtime; PoCL keeps its own): it said why it built
        assert any("caching failed" in str(w.message) for w in caught)
