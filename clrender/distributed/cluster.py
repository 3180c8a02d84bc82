"""Connecting to a Dask cluster: an existing scheduler, or a LocalCluster on this machine.

Dask is an optional extra (`pip install 'clrender[distributed]'`); without
it, asking for a cluster is a usage error with the install line.

PoCL reads its thread count when OpenCL starts in a process, so it has to be
in the worker's environment before the worker imports pyopencl: LocalCluster
passes `env` to each worker's nanny.  For workers started by hand, set
POCL_MAX_PTHREAD_COUNT (and POCL_CPU_MAX_CU_NUM, its newer name) in the
shell that runs `dask worker`.

Connecting has a real deadline (`Deadlines.connect`): a first look at the
address opens a TCP connection and asks the scheduler who it is, so a port
that refuses (exit 2), a server that accepts and never answers (exit 1) and
one that answers in another protocol (exit 2) each end in one line instead of
Dask's own handshake, which waits without limit.  Only tcp:// is spoken here:
a TLS or UCX cluster needs security settings clrender does not take, so make
that Client yourself and pass `client=` in Python.
"""

from __future__ import annotations

import asyncio
import logging
import os
import sys
import threading
import time
from contextlib import contextmanager

from ..errors import RenderFailure, UsageError, first_line, shown
from .deadlines import Deadlines, current

log = logging.getLogger(__name__)

INSTALL_HINT = "a Dask cluster needs the distributed extra: pip install 'clrender[distributed]'"
SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"
SCHEMES = ("tcp",)  # what --scheduler may name; tls:// and ucx:// need settings clrender does not take
DEFAULT_PORT = 8786  # Dask's scheduler port, when the address has none
QUIET = logging.CRITICAL  # Dask's own log level in clrender's LocalCluster: the user sees clrender's lines only


def require_dask():
    """The `distributed` module, or a UsageError that says how to install it."""
    try:
        import distributed
    except ImportError:
        raise UsageError(INSTALL_HINT) from None
    return distributed


def pocl_env(threads: int) -> dict:
    """Environment that limits PoCL's CPU device to `threads` threads (old and new variable names), and Intel's
    OpenCL CPU runtime too (its TBB workers), when a worker runs on that."""
    # and one BLAS thread: OpenBLAS threads spin-wait after a matrix product and steal PoCL's cores
    return {
        "POCL_MAX_PTHREAD_COUNT": str(threads),
        "POCL_CPU_MAX_CU_NUM": str(threads),
        "CL_CONFIG_CPU_TBB_NUM_WORKERS": str(threads),
        "OPENBLAS_NUM_THREADS": "1",
    }


def scheduler_address(scheduler: str | None) -> str | None:
    """`scheduler`, else $DASK_SCHEDULER_ADDRESS, else None (no cluster asked for)."""
    return scheduler or os.environ.get(SCHEDULER_ENV) or None


def cores() -> int:
    """CPU cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0)) or 1
    except (AttributeError, OSError):  # not Linux
        return os.cpu_count() or 1


def max_local_workers() -> tuple[int, str]:
    """How many single-thread worker processes this machine can hold, and why: one a core, each
    about memory.BASE_BYTES (an interpreter with numpy, pyopencl, PoCL and Dask)."""
    from ..memory import BASE_BYTES, available_bytes, format_bytes

    n, why = cores(), f"{cores()} CPU core(s)"
    available = available_bytes()
    if available is not None:
        n = min(n, available // BASE_BYTES)
        why += f", {format_bytes(available)} of memory available at about {format_bytes(BASE_BYTES)} a worker"
    return max(1, int(n)), why


def check_workers(workers: int) -> None:
    limit, why = max_local_workers()
    if not 1 <= workers <= limit:
        raise UsageError(f"--workers {workers} is not possible here; allowed: 1 to {limit} ({why})")


def host_port(address: str) -> tuple[str, int]:
    """(host, port) of a tcp:// or bare HOST:PORT address; UsageError naming what is allowed."""
    scheme, sep, location = address.rpartition("://")
    allowed = "tcp://HOST:PORT or HOST:PORT"
    if sep and scheme not in SCHEMES:
        raise UsageError(
            f"scheduler address {shown(address)} uses {shown(scheme)}; allowed: {allowed} "
            "(for tls:// or ucx://, make a dask Client with its security settings and pass client= in Python)"
        )
    from distributed.comm.addressing import parse_host_port

    try:
        host, port = parse_host_port(location, default_port=DEFAULT_PORT)
    except (ValueError, TypeError):
        host, port = "", -1
    if not host or not 0 < int(port) < 65536:
        raise UsageError(f"scheduler address {shown(address)} is not valid; allowed: {allowed}")
    return host, int(port)


def _within(seconds: float, work):
    """work() in a helper thread, given at most `seconds`: (True, value) or (False, None) when late.
    Its exception is raised here.  A late helper is left to finish (or hang) on its own, as a daemon."""
    box = {}

    def target():
        try:
            box["value"] = work()
        except BaseException as exc:  # noqa: BLE001 - handed to the caller as is
            box["error"] = exc

    helper = threading.Thread(target=target, name="clrender-connect", daemon=True)
    helper.start()
    helper.join(seconds)
    if helper.is_alive():
        return False, None
    if "error" in box:
        raise box["error"]
    return True, box["value"]


def probe(address: str, seconds: float) -> dict:
    """Ask the server at `address` who it is, within `seconds` in all; its identity (a dict).

    Refused for `seconds` (retried: a scheduler may be starting): UsageError.  Accepted but silent:
    RenderFailure.  Anything but a Dask scheduler's answer: UsageError."""
    host, port = host_port(address)
    deadline = time.monotonic() + seconds
    stage = ["connect"]
    where = f"the Dask scheduler at {shown(address)}"

    async def look() -> dict:
        from distributed.comm import connect as dask_connect

        pause, reason = 0.02, ""
        while True:  # the TCP connection first, so "nobody there" and "not answering" read differently
            try:
                _, writer = await asyncio.wait_for(asyncio.open_connection(host, port), max(0.01, deadline - time.monotonic()))
                writer.close()
                break
            except (TimeoutError, OSError) as exc:
                reason = first_line(str(exc)) or type(exc).__name__
                if time.monotonic() + pause >= deadline:
                    raise UsageError(f"cannot reach {where} within {seconds:g} s ({reason})") from None
                await asyncio.sleep(pause)
                pause = min(0.5, pause * 2)
        stage[0] = "answer"
        comm = await dask_connect(f"tcp://{host}:{port}", timeout=max(0.01, deadline - time.monotonic()))
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    def run():
        try:
            return asyncio.run(asyncio.wait_for(look(), max(0.01, deadline - time.monotonic())))
        except TimeoutError:
            return None

    try:
        done, answer = _within(seconds + 1.0, run)
    except (UsageError, RenderFailure):
        raise
    except Exception as exc:  # noqa: BLE001 - a malformed frame: struct.error, ValueError, msgpack's errors...
        if stage[0] == "connect":
            raise UsageError(f"cannot reach {where} within {seconds:g} s ({first_line(str(exc)) or type(exc).__name__})") from None
        kind = type(exc).__name__ if type(exc).__module__ == "builtins" else f"{type(exc).__module__}.{type(exc).__name__}"
        raise UsageError(f"{shown(address)} did not answer as a Dask scheduler does ({kind}: {first_line(str(exc))})") from None
    if not done or answer is None:
        if stage[0] == "connect":
            raise UsageError(f"cannot reach {where} within {seconds:g} s")
        raise RenderFailure(f"{where} accepted the connection but did not answer within {seconds:g} s")
    if not isinstance(answer, dict) or answer.get("type") != "Scheduler":
        kind = answer.get("type") if isinstance(answer, dict) else type(answer).__name__
        raise UsageError(f"{shown(address)} is not a Dask scheduler (it says it is {shown(kind)}); allowed: a scheduler's address")
    return answer


def _client_for(distributed, address: str, d: Deadlines):
    """A Client of the scheduler at `address`, checked first (probe) and bounded by d.connect."""
    probe(address, d.connect)
    where = f"the Dask scheduler at {shown(address)}"
    try:  # set_as_default=False: clrender's client never becomes the one other code in the process gets
        done, client = _within(d.connect, lambda: distributed.Client(address, timeout=d.connect, set_as_default=False))
    except (OSError, TimeoutError, ValueError) as exc:
        reason = first_line(str(exc)) or type(exc).__name__
        raise UsageError(f"cannot reach {where} within {d.connect:g} s ({reason})") from None
    if not done:
        raise RenderFailure(f"{where} answered but did not take this client within {d.connect:g} s")
    return client


@contextmanager
def connect(
    scheduler: str | None = None,
    workers: int | None = None,
    pocl_threads: int | None = None,
    timeout: float | None = None,
    announce: bool = True,
    deadlines: Deadlines | None = None,
):
    """A dask Client to `scheduler`, or to a new LocalCluster of `workers` single-thread processes.

    Each local worker's PoCL device gets `pocl_threads` threads (default: this
    machine's cores shared out between the workers, at least 1).  `timeout`
    (seconds) overrides `deadlines.connect`.
    """
    if workers is not None and scheduler:
        raise UsageError(f"give either --scheduler ({shown(scheduler)}) or --workers ({workers}), not both")
    distributed = require_dask()  # first: without the extra, the install line is the answer
    if workers is not None:
        check_workers(workers)
    if pocl_threads is not None and not 1 <= pocl_threads <= 1024:
        raise UsageError(f"PoCL threads {pocl_threads} must be from 1 to 1024")
    d = current(deadlines)
    if timeout is not None:
        from dataclasses import replace

        d = replace(d, connect=timeout)
    address = None if workers is not None else scheduler_address(scheduler)
    if address is not None:
        host_port(address)  # a bad address is refused before anything is started
    cluster = None
    if workers is not None:
        threads = pocl_threads or max(1, cores() // workers)
        # Ctrl-C ends the program at once (cli.py); multiprocessing's resource tracker, started with
        # this interpreter's -W options, would then print a multi-line warning about semaphores
        if "ignore:resource_tracker:UserWarning" not in sys.warnoptions:
            sys.warnoptions.append("ignore:resource_tracker:UserWarning")
        cluster = distributed.LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=QUIET, env=pocl_env(threads)
        )
        client = distributed.Client(cluster, set_as_default=False)
        where = f"a LocalCluster of {workers} worker(s), {threads} PoCL thread(s) each"
    else:
        client = _client_for(distributed, address, d)
        where = f"the scheduler at {address}"
    try:
        if announce:
            log.info("rendering on %s; dashboard %s", where, client.dashboard_link)  # the CLI shows it on stderr
        yield client
    finally:
        client.close(timeout=d.close)
        if cluster is not None:
            cluster.close(timeout=d.close)
