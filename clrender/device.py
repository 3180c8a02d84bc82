"""OpenCL device selection and the per-process cache of built programs.

The default is the fastest CPU driver found, by the rule of `_ranked_cpus` (docs/command-line.md,
"Devices"): Intel's OpenCL CPU runtime, then PoCL, then other CPU drivers (never Oclgrind, the simulator
that checks memory accesses: `is_simulator`), unless cached measurements
(`clrender devices --measure`, clrender/device_speed.py) show another more than SPEED_MARGIN faster; the
first of those that compiles a probe kernel.  `CLRENDER_DEVICE` or `--device` picks another by a substring
of "<platform name>: <device name>" (case-insensitive), e.g. "nvidia" or "gpu".

Programs are built once per process for each (file, defines) pair and their
kernels fetched once; variants are chosen with -D options, never by pasting
source strings together.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import build_cache
from .drivers import register_runtimes
from .errors import RenderFailure, UsageError, first_line, library_messages
from .launch import Kernel, kernel_signatures
from .layout import DEFINES as LAYOUT_DEFINES
from .layout import c_header, c_value
from .package_data import data_dir
from .thread_stack import raise_default_thread_stack

try:
    import pyopencl as cl
except ImportError as exc:  # pragma: no cover - depends on the installation
    cl = None
    _IMPORT_ERROR = exc

register_runtimes()  # before any OpenCL call of the process, by us or by the caller
raise_default_thread_stack()  # before a driver starts its worker threads (thread_stack.py)

INSTALL_HINT = "install PoCL with: pip install 'pyopencl[pocl]'"
FAST_HINT = "install Intel's OpenCL CPU runtime (the `fast` extra) with: pip install intel-opencl-rt intel-cmplr-lib-rt"


HOST_ALIGN = 4096  # bytes: a page, more than any driver asks of a USE_HOST_PTR buffer


def aligned_zeros(shape, dtype) -> np.ndarray:
    """np.zeros(shape, dtype) starting at a multiple of HOST_ALIGN bytes (numpy's own start 16 bytes into a page)."""
    dtype = np.dtype(dtype)
    count = int(np.prod(shape))
    raw = np.zeros(count * dtype.itemsize + HOST_ALIGN, np.uint8)
    skip = -raw.ctypes.data % HOST_ALIGN
    return raw[skip : skip + count * dtype.itemsize].view(dtype).reshape(shape)


@dataclass
class Device:
    """A context and in-order queue on one OpenCL device, plus its program cache."""

    context: cl.Context
    queue: cl.CommandQueue
    device: cl.Device
    _programs: dict = field(default_factory=dict, repr=False)
    _kernels: dict = field(default_factory=dict, repr=False)
    compile_seconds: float = 0.0  # total time spent building programs so far

    @property
    def name(self) -> str:
        return f"{self.device.platform.name.strip()}: {self.device.name.strip()}"

    def program(self, filename: str, defines: dict | None = None) -> cl.Program:
        """The built program for kernels/<filename> with -D<k>=<v> options (cached), after clrender/layout.py's
        generated header (the shared values and the records' structs)."""
        key = (filename, tuple(sorted((defines or {}).items())))
        prg = self._programs.get(key)
        if prg is None:
            prg = self._programs[key] = self.build(kernel_source(filename), filename, defines)
        return prg

    def build(self, source: str, filename: str, defines: dict | None = None) -> cl.Program:
        """Build `source` (not cached) as Device.program builds a kernel file: the layout header first,
        kernels/ on the include path, -D<k>=<v> for `defines`."""
        # `#line` keeps the compiler's messages pointing at the file's own lines
        source = f'{c_header()}#line 1 "{filename}"\n{source}'
        options = [f"-I{kernel_dir()}", "-cl-std=CL1.2", *build_options(defines)]
        start = time.perf_counter()
        try:
            with compile_notice(self), library_messages():  # PoCL's clang also prints "1 error generated."; the log is in exc
                prg = cl.Program(self.context, source).build(options=options, cache_dir=build_cache.ready())
        except cl.RuntimeError as exc:
            logging.getLogger(__name__).debug("build log of kernels/%s:\n%s", filename, exc)
            first_error = first_line(str(exc), prefer="error:") or "no build log"
            raise RenderFailure(f"building kernels/{filename} failed on {self.name}: {first_error}") from exc
        self.compile_seconds += time.perf_counter() - start
        return prg

    def kernel(self, filename: str, name: str, defines: dict | None = None) -> Kernel:
        """Kernel `name` of kernels/<filename>, fetched once and kept, called with its parameters by name."""
        key = (filename, name, tuple(sorted((defines or {}).items())))
        knl = self._kernels.get(key)
        if knl is None:
            signature = kernel_signatures(kernel_source(filename))[name]
            knl = self._kernels[key] = Kernel(getattr(self.program(filename, defines), name), signature)
        return knl

    def to_device(self, array: np.ndarray, writable: bool = False) -> cl.Buffer:
        """A read-only (or read-write) buffer holding a copy of `array` (at least one byte)."""
        array = np.ascontiguousarray(array)
        mf = cl.mem_flags
        if array.nbytes == 0:
            array = np.zeros(1, dtype=array.dtype if array.dtype.itemsize else np.uint8)
        return cl.Buffer(self.context, (mf.READ_WRITE if writable else mf.READ_ONLY) | mf.COPY_HOST_PTR, hostbuf=array)

    def adopt(self, array: np.ndarray) -> cl.Buffer:
        """A read-only buffer of `array`: on a CPU device its own memory (USE_HOST_PTR: no second copy
        at the peak of a big upload) when it is HOST_ALIGN-aligned (`aligned_zeros`; PoCL 3.0 crashed
        on unaligned ones), else a copy.  The caller keeps `array` alive, unchanged, as long as the
        buffer (pyopencl does not hold it)."""
        if array.nbytes == 0 or not self.device.type & cl.device_type.CPU or array.ctypes.data % HOST_ALIGN:
            return self.to_device(array)
        return cl.Buffer(self.context, cl.mem_flags.READ_ONLY | cl.mem_flags.USE_HOST_PTR, hostbuf=np.ascontiguousarray(array))

    def empty(self, nbytes: int) -> cl.Buffer:
        """An uninitialised read-write buffer of `nbytes` (at least one byte)."""
        return cl.Buffer(self.context, cl.mem_flags.READ_WRITE, size=max(int(nbytes), 1))

    def host_buffer(self, array: np.ndarray) -> cl.Buffer:
        """A write-only buffer backed by `array`'s own memory (USE_HOST_PTR): on a CPU device
        kernels write straight into it; `sync_to_host` before reading `array`."""
        return cl.Buffer(self.context, cl.mem_flags.WRITE_ONLY | cl.mem_flags.USE_HOST_PTR, hostbuf=array)

    def sync_to_host(self, buffer: cl.Buffer, array: np.ndarray) -> None:
        """Make `array` hold what kernels wrote to its `host_buffer` (a no-op copy on a CPU)."""
        mapped, _ = cl.enqueue_map_buffer(self.queue, buffer, cl.map_flags.READ, 0, array.shape, array.dtype, is_blocking=True)
        mapped.base.release(self.queue)

    def check_fits(self, nbytes: int, what: str) -> None:
        """Refuse an allocation the device cannot hold, before making it."""
        limit = min(self.device.max_mem_alloc_size, self.device.global_mem_size)
        if nbytes > limit:
            raise UsageError(
                f"{what} needs {nbytes / 2**20:.0f} MiB but the device {self.name!r} allows at most {limit / 2**20:.0f} MiB in one buffer"
            )


COMPILE_NOTICE_SECONDS = 1.5  # a build still running after this long is a cold one: say so, once a process
_compile_notice = {"said": False, "open": 0}


@contextlib.contextmanager
def compile_notice(device: Device):
    """Around a kernel build: if it is still running after COMPILE_NOTICE_SECONDS, one line on stderr (once a
    process, not under -q) saying that kernels are being compiled, so a cold start does not look like a hang.
    A build from pyopencl's binary cache ends before the line is due; nested uses start one timer."""
    from . import progress

    if _compile_notice["said"] or _compile_notice["open"] or progress.SHOW is False:
        yield
        return

    def say():
        if not _compile_notice["said"] and progress.SHOW is not False:
            _compile_notice["said"] = True
            sys.stderr.write(f"clrender: compiling kernels for {device.name} (first run; cached afterwards)...\n")
            sys.stderr.flush()

    timer = threading.Timer(COMPILE_NOTICE_SECONDS, say)
    timer.daemon = True
    _compile_notice["open"] += 1
    timer.start()
    try:
        yield
    finally:
        timer.cancel()
        _compile_notice["open"] -= 1


def build_options(defines: dict | None = None) -> list[str]:
    """-D options for a build variant; the shared values come in clrender/layout.py's header, not here."""
    clash = set(defines or {}) & set(LAYOUT_DEFINES)
    if clash:
        raise ValueError(f"{sorted(clash)} are fixed in clrender/layout.py, not per build")
    return [f"-D{k}={c_value(v)}" for k, v in sorted((defines or {}).items())]


def kernel_source(filename: str) -> str:
    return (kernel_dir() / filename).read_text()


def kernel_dir() -> Path:
    """Folder of the installed .cl sources (the top-level kernels/ in a checkout)."""
    return data_dir("kernels")


def _describe(dev) -> str:
    return f"{dev.platform.name.strip()}: {dev.name.strip()}"


def _platforms() -> list:
    """Every OpenCL platform (a pip-installed Intel runtime among them, and Oclgrind where asked for: drivers.py, at import)."""
    try:
        return cl.get_platforms()
    except cl.Error:
        return []


def all_devices() -> list:
    """Every OpenCL device visible to this process, in the loader's order."""
    if cl is None:
        return []
    return [d for p in _platforms() for d in p.get_devices()]


def list_devices() -> list[str]:
    """'<platform>: <device>' for every OpenCL device visible to this process."""
    return [_describe(d) for d in all_devices()]


def _pick(spec: str | None):
    if cl is None:
        raise UsageError(f"pyopencl is not importable ({_IMPORT_ERROR}); {INSTALL_HINT}")
    devices = [d for p in _platforms() for d in p.get_devices()]
    if not devices:
        raise UsageError(f"no OpenCL platform or device found; {INSTALL_HINT}")
    if spec:
        matches = [d for d in devices if spec.lower() in _describe(d).lower()]
        if not matches:
            found = "; ".join(_describe(d) for d in devices)
            raise UsageError(f"no OpenCL device matches {spec!r}; available: {found}")
        return matches[0]
    return _default_cpu(devices)


def _is_pocl_cpu(dev) -> bool:
    return "portable computing language" in dev.platform.name.lower() and bool(dev.type & cl.device_type.CPU)


def _is_intel_cpu(dev) -> bool:
    return "intel" in dev.platform.name.lower() and bool(dev.type & cl.device_type.CPU)


def is_simulator(dev) -> bool:
    """Oclgrind, the OpenCL simulator that checks every memory access: it calls itself a CPU device but runs
    about 1000x slower than a CPU driver, so it is never the default and never measured; CLRENDER_DEVICE=oclgrind picks it (drivers.py)."""
    return "oclgrind" in dev.platform.name.lower()


def _is_cpu_driver(dev) -> bool:
    return bool(dev.type & cl.device_type.CPU) and not is_simulator(dev)


SPEED_MARGIN = 1.10  # a measured driver displaces the static order's first only when this much faster (noise apart)


def _static_rank(dev) -> int:
    """Intel's runtime 0 (0.72x PoCL's CPU time on render_path: issue 35), PoCL 1, any other CPU driver 2."""
    return 0 if _is_intel_cpu(dev) else 1 if _is_pocl_cpu(dev) else 2


def _speeds(cpus: list) -> list:
    """The cached speed (device_speed.Speed) of each device, None where it was not measured."""
    from . import device_speed

    cached = device_speed.load()
    return [cached.get(device_speed.key(d)) for d in cpus] if cached else [None] * len(cpus)


def _ranked_cpus(devices: list) -> list:
    """The CPU drivers' devices (not the simulator), the default's candidates first: the static order (_static_rank; the loader's order
    among equals), except that the fastest measured device moves to the front when the static first was
    measured too and the other's score is more than SPEED_MARGIN times its own."""
    cpus = sorted((d for d in devices if _is_cpu_driver(d)), key=_static_rank)
    speeds = _speeds(cpus)
    if not cpus or speeds[0] is None:
        return cpus
    best = max(range(len(cpus)), key=lambda i: (speeds[i].score if speeds[i] else -1.0, -i))
    if speeds[best].score > SPEED_MARGIN * speeds[0].score:
        cpus.insert(0, cpus.pop(best))
    return cpus


def _default_cpu(devices: list):
    """The first of _ranked_cpus(devices) that can compile for this CPU.

    PoCL 3.0 (the newest on PyPI) compiles with LLVM 14, which names the host CPU for its code generator
    and does not know AMD's Zen 5 (family 26): there every build fails with "unknown target CPU
    'generic'". A one-line probe build tells, before any work is done on the device."""
    candidates = _ranked_cpus(devices)
    if not candidates:
        found = "; ".join(_describe(d) for d in devices)
        raise UsageError(
            f"the PoCL CPU device was not found (available: {found}); {INSTALL_HINT}, or choose a device with --device / CLRENDER_DEVICE"
        )
    failures = []
    for dev in candidates:
        reason = _cannot_compile(dev)
        if reason is None:
            return dev
        failures.append(f"{_describe(dev)}: {reason}")
    raise RenderFailure(f"no OpenCL CPU device can compile kernels here ({'; '.join(failures)}); {FAST_HINT}, or choose a device with --device")


def cpu_devices() -> list:
    """Every OpenCL CPU driver's device visible to this process (not the simulator: is_simulator), in the loader's order."""
    return [d for d in all_devices() if _is_cpu_driver(d)]


def default_device_name(spec: str | None = None) -> str:
    """'<platform>: <device>' of the device get_device(spec) would pick now (chosen afresh, not the process's cached one)."""
    with _signal_handlers_kept():
        return _describe(_pick(_named(spec)))


def _named(spec: str | None) -> str | None:
    """The device `spec` names, else $CLRENDER_DEVICE's, else None: the default CPU driver."""
    return spec if spec is not None else os.environ.get("CLRENDER_DEVICE") or None


_PROBE = "__kernel void probe(__global int *a) { a[get_global_id(0)] = 1; }"


def _cannot_compile(dev) -> str | None:
    """None if `dev` builds a one-line kernel, else the first line of why not."""
    try:
        with _signal_handlers_kept(), library_messages():
            cl.Program(cl.Context([dev]), _PROBE).build(cache_dir=build_cache.ready())
    except cl.Error as exc:
        return first_line(str(exc), prefer="error:") or "the build failed"
    return None


_DEVICES: dict[str, Device] = {}


def get_device(spec: str | None = None) -> Device:
    """The Device for `spec` (default: $CLRENDER_DEVICE, else the fastest CPU driver: _default_cpu), made once per process."""
    spec = _named(spec)
    key = spec or ""
    if key not in _DEVICES:
        with _signal_handlers_kept():
            dev = _pick(spec)
            ctx = cl.Context([dev])
        _DEVICES[key] = Device(ctx, cl.CommandQueue(ctx), dev)
    return _DEVICES[key]


@contextlib.contextmanager
def _signal_handlers_kept():
    """PoCL's LLVM installs its own SIGINT/SIGTERM handlers when the platform starts; put Python's back.

    Without this, Ctrl-C after the first get_device() was lost or killed the process silently
    (LLVM's handler restores the default action and re-raises), and KeyboardInterrupt never came.
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    saved = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for signum, handler in saved.items():
            if handler is not None:
                signal.signal(signum, handler)
                signal.siginterrupt(signum, False)  # as LLVM had it: a signal does not fail a system call
