"""Waiting for our tasks on a Dask cluster: results as they finish, within deadlines.

`collect` is the one place clrender waits for tasks.  Two things make it safe:

- It tracks the futures on *their own client's* event loop.  Dask's
  `as_completed` uses the process's default client's loop unless given one;
  when that is another client (a `with Client(...)` block elsewhere in the
  process), the futures' completion events are set on one loop thread and
  waited on from another, and asyncio's events are not thread-safe: the
  wake-up can be lost and the render waits forever with its tasks done.
  That was the hang in tests/distributed/test_distributed.py (docs/distributed.md).
- A watchdog: after `Deadlines.stall` seconds without a finished task it asks
  the scheduler for our tasks' states, and fails in one line when the
  scheduler does not know them, has no worker to run them, has finished them
  without this client hearing of it, or does not answer.  A task that is
  merely slow keeps the render going.
"""

from __future__ import annotations

import time

from ..errors import RenderFailure, first_line, shown
from .deadlines import Deadlines, current

POLL_SECONDS = 0.02  # between looks at the finished queue: short next to any task, cheap when idle


def _reason(exc: BaseException) -> str:
    return first_line(str(exc)) or type(exc).__name__


def scatter(client, data, broadcast: bool = False, deadlines: Deadlines | None = None):
    """client.scatter, or a RenderFailure when the scheduler has no worker to take the data in time."""
    d = current(deadlines)
    try:
        return client.scatter(data, hash=False, broadcast=broadcast, timeout=d.stall)
    except (TimeoutError, OSError) as exc:
        raise RenderFailure(
            f"could not send the data to the Dask scheduler at {shown(client.scheduler.address)}'s workers within {d.stall:g} s ({_reason(exc)})"
        ) from None


def release(futures) -> None:
    """Drop our hold on the futures: the scheduler forgets (and stops) what nobody else wants.

    Unlike `client.cancel` this sends one message and waits for nothing, so Ctrl-C or a failure
    is never held up by a scheduler that does not answer."""
    for future in futures:
        try:
            future.release()
        except Exception:  # noqa: BLE001 - a client already closed has nothing left to release
            pass


def _ask(client, keys: list, what: str, d: Deadlines) -> dict:
    """The scheduler's state of each key (None: it does not know it), within d.ask seconds."""
    try:
        return client.sync(client.scheduler.get_task_status, keys=keys, callback_timeout=d.ask)
    except Exception as exc:  # noqa: BLE001 - a timeout, a closed connection: all mean no answer
        raise RenderFailure(
            f"no {what} task finished for {d.stall:g} s and the Dask scheduler at {shown(client.scheduler.address)} "
            f"did not answer within {d.ask:g} s ({_reason(exc)})"
        ) from None


def _check(client, waiting: set, before: dict, what: str, d: Deadlines) -> dict:
    """Fail when the scheduler cannot or will not finish what we wait for; else the states seen now."""
    keys = sorted(waiting)
    states = _ask(client, keys, what, d)
    where = f"the Dask scheduler at {shown(client.scheduler.address)}"
    unknown = [k for k in keys if states.get(k) is None]
    if unknown:
        raise RenderFailure(
            f"no {what} task finished for {d.stall:g} s and {where} does not know {len(unknown)} of the {len(keys)} "
            f"this client waits for (e.g. {shown(unknown[0])}): they were released, forgotten or never received"
        )
    # the same state at two looks d.stall apart: not a passing moment
    for state, story in (("no-worker", "has no worker that can run"), ("memory", "finished, but this client was never told of,")):
        stuck = [k for k in keys if states[k] == state and before.get(k) == state]
        if stuck:
            raise RenderFailure(f"{where} {story} {len(stuck)} {what} task(s) for over {d.stall:g} s (e.g. {shown(stuck[0])})")
    return states


def collect(client, futures: list, what: str, deadlines: Deadlines | None = None):
    """Yield (i, result) for futures[i] as each finishes, in any order; a failed task raises its error.

    Raises RenderFailure when a task is cancelled on the scheduler, or when the watchdog finds that
    nothing would ever finish (see the module's docstring)."""
    from distributed import as_completed

    d = current(deadlines)
    index = {f.key: i for i, f in enumerate(futures)}
    waiting = set(index)
    finished = as_completed(futures, loop=client.loop, with_results=True)  # loop=: see the docstring
    last = time.monotonic()  # the last progress, or the last look at the scheduler
    states: dict = {}
    while waiting:
        if not finished.has_ready():
            if time.monotonic() - last >= d.stall:
                states = _check(client, waiting, states, what, d)
                last = time.monotonic()
            time.sleep(POLL_SECONDS)
            continue
        future, result = next(finished)  # a failed task's error is raised here, as itself
        if future.status == "cancelled":
            raise RenderFailure(f"the Dask scheduler cancelled {what} task {shown(future.key)} ({_reason(result)})")
        waiting.discard(future.key)
        last, states = time.monotonic(), {}
        yield index[future.key], result
