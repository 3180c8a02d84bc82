"""How long clrender waits for a Dask cluster before it gives up with one line.

Every wait in the distributed code has one of these deadlines.  A render that
is merely slow is never cut short: the stall deadline only makes clrender ask
the scheduler whether it still knows the tasks we wait for, and only a "no"
(or no answer) ends the render.  Defaults come from the environment
(CLRENDER_CONNECT_TIMEOUT, CLRENDER_STALL_TIMEOUT); the CLI's --stall-timeout
sets them for the commands it runs (`using`).
"""

from __future__ import annotations

import math
import os
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, replace

from ..errors import UsageError, shown

CONNECT_ENV = "CLRENDER_CONNECT_TIMEOUT"
STALL_ENV = "CLRENDER_STALL_TIMEOUT"
MAX_SECONDS = 7 * 24 * 3600.0  # a week: more is a typo, not a wait


def seconds(value, what: str) -> float:
    """A positive, finite number of seconds (at most a week), or a UsageError naming `what`."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if not 0 < number <= MAX_SECONDS:  # also refuses nan and inf
        raise UsageError(f"{what} {shown(value)} is not valid; allowed: seconds above 0, at most {MAX_SECONDS:g}")
    return number


@dataclass(frozen=True)
class Deadlines:
    """Seconds clrender waits for the cluster at each step."""

    connect: float = 10.0  # reach the scheduler and hear it answer (refused, silent or not Dask: one line)
    stall: float = 60.0  # no task finished for this long: ask the scheduler whether it still knows ours
    ask: float = 10.0  # the scheduler's answer to that question, a scatter of the scene, a result's transfer
    close: float = 10.0  # closing the client and a LocalCluster

    @classmethod
    def from_env(cls) -> Deadlines:
        d = cls()
        if os.environ.get(CONNECT_ENV):
            d = replace(d, connect=seconds(os.environ[CONNECT_ENV], f"${CONNECT_ENV}"))
        if os.environ.get(STALL_ENV):
            d = replace(d, stall=seconds(os.environ[STALL_ENV], f"${STALL_ENV}"))
        return d


_CURRENT: ContextVar[Deadlines | None] = ContextVar("clrender_deadlines", default=None)


def current(deadlines: Deadlines | None = None) -> Deadlines:
    """`deadlines`, else those set by `using`, else the defaults with the environment's overrides."""
    return deadlines or _CURRENT.get() or Deadlines.from_env()


@contextmanager
def using(deadlines: Deadlines):
    """Make `deadlines` the default for every cluster wait inside the block (the CLI's options)."""
    token = _CURRENT.set(deadlines)
    try:
        yield deadlines
    finally:
        _CURRENT.reset(token)
