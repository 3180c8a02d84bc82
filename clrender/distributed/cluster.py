"""Connecting to a Dask cluster: an existing scheduler, or a LocalCluster on this machine.

Dask is an optional extra (`pip install 'clrender[distributed]'`); without
it, asking for a cluster is a usage error with the install line.

PoCL reads its thread count when OpenCL starts in a process, so it has to be
in the worker's environment before the worker imports pyopencl: LocalCluster
passes `env` to each worker's nanny.  For workers started by hand, set
POCL_MAX_PTHREAD_COUNT (and POCL_CPU_MAX_CU_NUM, its newer name) in the
shell that runs `dask worker`.
"""

from __future__ import annotations

import logging
import os
import sys
from contextlib import contextmanager

from ..errors import UsageError

log = logging.getLogger(__name__)

INSTALL_HINT = "a Dask cluster needs the distributed extra: pip install 'clrender[distributed]'"
CONNECT_TIMEOUT = 5.0  # seconds to reach a scheduler before giving up (exit 2)
SCHEDULER_ENV = "DASK_SCHEDULER_ADDRESS"


def require_dask():
    """The `distributed` module, or a UsageError that says how to install it."""
    try:
        import distributed
    except ImportError:
        raise UsageError(INSTALL_HINT) from None
    return distributed


def pocl_env(threads: int) -> dict:
    """Environment that limits PoCL's CPU device to `threads` threads (old and new variable names)."""
    # and one BLAS thread: OpenBLAS threads spin-wait after a matrix product and steal PoCL's cores
    return {"POCL_MAX_PTHREAD_COUNT": str(threads), "POCL_CPU_MAX_CU_NUM": str(threads), "OPENBLAS_NUM_THREADS": "1"}


def scheduler_address(scheduler: str | None) -> str | None:
    """`scheduler`, else $DASK_SCHEDULER_ADDRESS, else None (no cluster asked for)."""
    return scheduler or os.environ.get(SCHEDULER_ENV) or None


@contextmanager
def connect(
    scheduler: str | None = None, workers: int | None = None, pocl_threads: int | None = None, timeout: float | None = None, announce: bool = True
):
    """A dask Client to `scheduler`, or to a new LocalCluster of `workers` single-thread processes.

    Each local worker's PoCL device gets `pocl_threads` threads (default: this
    machine's cores shared out between the workers, at least 1).
    """
    if workers is not None and scheduler:
        raise UsageError(f"give either --scheduler ({scheduler}) or --workers ({workers}), not both")
    if workers is not None and not 1 <= workers <= 1024:
        raise UsageError(f"workers {workers} must be from 1 to 1024")
    if pocl_threads is not None and not 1 <= pocl_threads <= 1024:
        raise UsageError(f"PoCL threads {pocl_threads} must be from 1 to 1024")
    distributed = require_dask()
    timeout = CONNECT_TIMEOUT if timeout is None else timeout
    cluster = None
    if workers is not None:
        threads = pocl_threads or max(1, (os.cpu_count() or 1) // workers)
        # Ctrl-C ends the program at once (cli.py); multiprocessing's resource tracker, started with
        # this interpreter's -W options, would then print a multi-line warning about semaphores
        if "ignore:resource_tracker:UserWarning" not in sys.warnoptions:
            sys.warnoptions.append("ignore:resource_tracker:UserWarning")
        cluster = distributed.LocalCluster(
            n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=logging.ERROR, env=pocl_env(threads)
        )
        client = distributed.Client(cluster)
        where = f"a LocalCluster of {workers} worker(s), {threads} PoCL thread(s) each"
    else:
        address = scheduler_address(scheduler)
        try:
            client = distributed.Client(address, timeout=timeout)
        except (OSError, TimeoutError, ValueError) as exc:
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise UsageError(f"cannot reach the Dask scheduler at {address!r} within {timeout:g} s ({reason})") from None
        where = f"the scheduler at {address}"
    try:
        if announce:
            log.info("rendering on %s; dashboard %s", where, client.dashboard_link)  # the CLI shows it on stderr
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
