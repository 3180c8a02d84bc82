"""The stack size of the threads a CPU driver starts, raised before the driver starts them.

PoCL's CPU device runs each work-group on one of its worker threads, with the group's work-items' private
state (the traversal stacks of every inlined walk) on that thread's stack. The threads get the C library's
default size, which glibc takes from `ulimit -s` when the process starts, and sets to 2 MiB when that
limit is `unlimited`, as it often is in containers. The instanced, alpha-tested path kernel needs
about 3 MiB at PoCL's 64-item groups (measured with PoCL 3.1: it crashes at `ulimit -s` 2560 or unlimited
and runs at 3072), so under such a limit every render of that variant ended in a segmentation fault
(issue 38, defect 0).

`raise_default_thread_stack()` sets the process's default thread stack size to at least
`DRIVER_THREAD_STACK` through glibc's `pthread_setattr_default_np`; `clrender.device` calls it when it is
imported, before any OpenCL call starts a driver's threads. A larger default costs address space, not
memory: a thread's stack pages are committed as they are touched. Elsewhere than glibc it does nothing.
"""

from __future__ import annotations

import ctypes
import functools

DRIVER_THREAD_STACK = 16 << 20  # bytes: 5x the largest need measured (3 MiB), room for larger groups and variants
_ATTR_BYTES = 128  # room for pthread_attr_t (56 bytes on x86-64 glibc, 64 on aarch64)


@functools.cache
def _libc():
    """The C library the process runs on (its symbols, without a search: find_library would start ldconfig)."""
    try:
        libc = ctypes.CDLL(None)
    except OSError:
        return None
    return libc if hasattr(libc, "pthread_setattr_default_np") else None  # glibc 2.18 and later


def default_thread_stack() -> int | None:
    """The stack size, in bytes, that new threads of this process get; None where it cannot be read."""
    libc = _libc()
    if libc is None:
        return None
    attr = ctypes.create_string_buffer(_ATTR_BYTES)
    size = ctypes.c_size_t()
    if libc.pthread_getattr_default_np(attr) != 0:
        return None
    ok = libc.pthread_attr_getstacksize(attr, ctypes.byref(size)) == 0
    libc.pthread_attr_destroy(attr)
    return size.value if ok else None


def raise_default_thread_stack(minimum: int = DRIVER_THREAD_STACK) -> int | None:
    """Make new threads' stacks at least `minimum` bytes; the size they get afterwards (None: unknown)."""
    current = default_thread_stack()
    if current is None or current >= minimum:
        return current
    libc = _libc()
    attr = ctypes.create_string_buffer(_ATTR_BYTES)
    if libc.pthread_getattr_default_np(attr) == 0:
        if libc.pthread_attr_setstacksize(attr, ctypes.c_size_t(minimum)) == 0:
            libc.pthread_setattr_default_np(attr)
        libc.pthread_attr_destroy(attr)
    return default_thread_stack()
