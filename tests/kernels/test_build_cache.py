"""A lock on the program cache that a killed process left is removed before a build; a live one is kept."""

import os
import subprocess
import sys
import time

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


def test_a_lock_just_taken_is_kept(tmp_path):
    (tmp_path / "lock").touch()  # a lookup between its os.open and the moment its holder is seen
    assert not build_cache.clear_stale_lock(tmp_path)


def test_a_build_after_a_killed_holder_does_not_wait(device, tmp_path, monkeypatch):
    monkeypatch.setattr(build_cache, "folder", lambda: tmp_path)
    aged(tmp_path / "lock", 60)
    start = time.perf_counter()
    device.build("__kernel void k(__global int *a) { a[0] = 7; }", "k.cl")
    assert time.perf_counter() - start < 30  # pyopencl would wait 60 s on the lock, then fail
    assert not (tmp_path / "lock").exists()
