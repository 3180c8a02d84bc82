"""Shared benchmark helpers: timing medians, tables, output files, the CPU model."""

from __future__ import annotations

import csv
import platform
import statistics
import subprocess
import time
from pathlib import Path


def median_seconds(fn, runs: int) -> float:
    """Median wall time of `runs` calls of fn() (fn must wait for its own device work)."""
    times = []
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def write_table(out_dir: Path, name: str, rows: list[dict], title: str) -> str:
    """Write DIR/name.csv and DIR/name.md; return the markdown table."""
    out_dir.mkdir(parents=True, exist_ok=True)
    keys = list(rows[0])
    with open(out_dir / f"{name}.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, keys)
        writer.writeheader()
        writer.writerows(rows)
    fmt = lambda v: f"{v:.4g}" if isinstance(v, float) else str(v)
    lines = [f"| {' | '.join(keys)} |", "|" + "---|" * len(keys)]
    lines += [f"| {' | '.join(fmt(r[k]) for k in keys)} |" for r in rows]
    table = "\n".join(lines)
    (out_dir / f"{name}.md").write_text(f"# {title}\n\n{table}\n")
    return table


def cpu_model() -> str:
    """lscpu's model name (the benches report it: timings differ between the hosts' CPUs)."""
    try:
        text = subprocess.run(["lscpu"], capture_output=True, text=True, check=False).stdout
    except OSError:
        return platform.processor() or "unknown"
    names = [line.split(":", 1)[1].strip() for line in text.splitlines() if line.startswith("Model name")]
    return names[0] if names else platform.processor() or "unknown"
