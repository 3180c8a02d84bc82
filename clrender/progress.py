"""Progress bars on stderr, silent when stderr is not a terminal (scripts, CI)."""

from __future__ import annotations

import sys

from tqdm import tqdm

# Set by the CLI's -q / -v; None means "show only on a terminal".
SHOW: bool | None = None


def progress(iterable=None, *, total=None, desc=None, unit="it", **kwargs):
    """A tqdm bar on stderr that stays quiet off a terminal or under -q."""
    show = SHOW if SHOW is not None else sys.stderr.isatty()
    return tqdm(iterable, total=total, desc=desc, unit=unit, file=sys.stderr, disable=not show, leave=False, dynamic_ncols=True, **kwargs)
