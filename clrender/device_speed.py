"""How fast each OpenCL CPU driver renders on this machine: a small fixed workload, measured on request, cached.

`clrender devices --measure` (clrender/commands/devices.py, `measure`) renders WORKLOAD on every CPU device (once to compile, not timed, then RUNS
timed runs; the median of each), and stores the result in the user's cache folder under a key made of the
driver's platform name and version, its driver version, the device name and the host's CPU model, so an
upgraded driver or another CPU is measured afresh and never inherits an old number.  `clrender.device` reads
the cache to choose the default device (docs/command-line.md, "Devices"); nothing here runs on an ordinary
render.  A cache file that cannot be read is ignored, with one line on stderr, once a process.
"""

from __future__ import annotations

import json
import math
import os
import platform
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from .errors import RenderFailure

CACHE_FORMAT = 1  # the file's own layout
WORKLOAD_VERSION = 1  # bump when WORKLOAD changes: older numbers then measure something else
WORKLOAD = {  # the bundled refract1 scene, about 0.2 s and 0.1 s a run on one core (compile time apart)
    "path": dict(integrator="path", width=160, height=120, spp=8, max_depth=4),
    "whitted": dict(width=320, height=240, aa="none"),
}
RUNS = 3  # timed runs per workload; the median is kept


@dataclass(frozen=True)
class Speed:
    """One device's measured throughput on WORKLOAD."""

    path: float  # million camera paths (pixels x spp) a second, path tracer
    whitted: float  # million rays a second (camera, reflected, refracted, shadow), Whitted

    @property
    def score(self) -> float:
        """The geometric mean of the two rates: what the default device's rule compares."""
        return math.sqrt(self.path * self.whitted)

    def describe(self) -> str:
        return f"path {self.path:.3f} Msamples/s, Whitted {self.whitted:.2f} Mrays/s"


def cache_path() -> Path:
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("clrender")) / "device-speed.json"


def cpu_model() -> str:
    """The host CPU's model name (/proc/cpuinfo's `model name`, else platform.processor())."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def key(dev) -> str:
    """The cache key of an OpenCL device: driver name and version, device, CPU model, workload version."""
    plat = dev.platform
    parts = (plat.name.strip(), plat.version.strip(), dev.driver_version.strip(), dev.name.strip(), cpu_model(), f"workload {WORKLOAD_VERSION}")
    return " | ".join(parts)


_warned: set[str] = set()


def load() -> dict[str, Speed]:
    """The cached speeds by key; {} if there is no cache, or (with one line on stderr) an unreadable one."""
    path = cache_path()
    try:
        raw = path.read_bytes()
    except (FileNotFoundError, NotADirectoryError):  # no cache yet
        return {}
    except OSError as exc:
        return _ignored(path, exc.strerror or str(exc))
    try:
        data = json.loads(raw)  # bytes: bad UTF-8 is a ValueError here too
        if data.get("format") != CACHE_FORMAT:
            return _ignored(path, f"format {data.get('format')!r}, not {CACHE_FORMAT}")
        return {k: Speed(float(v["path"]), float(v["whitted"])) for k, v in data["speeds"].items()}
    except (ValueError, TypeError, KeyError, AttributeError) as exc:
        return _ignored(path, f"not a device-speed file ({type(exc).__name__})")


def _ignored(path: Path, why: str) -> dict:
    if str(path) not in _warned:
        _warned.add(str(path))
        sys.stderr.write(f"clrender: ignoring the device speed cache {path}: {why}; 'clrender devices --measure' rewrites it\n")
    return {}


def lookup(dev) -> Speed | None:
    """The cached speed of `dev` on this CPU with its current driver, or None."""
    return load().get(key(dev))


def save(dev, speed: Speed) -> None:
    """Store `speed` for `dev`, keeping the other entries (an unreadable file is replaced); written atomically.
    A cache folder that cannot be written is a RenderFailure (one line, exit 1)."""
    speeds = load()
    speeds[key(dev)] = speed
    path = cache_path()
    data = {"format": CACHE_FORMAT, "speeds": {k: {"path": s.path, "whitted": s.whitted} for k, s in sorted(speeds.items())}}
    staging = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, staging = tempfile.mkstemp(dir=path.parent, prefix=".device-speed-")
        with os.fdopen(fd, "w") as f:
            json.dump(data, f, indent=1)
        os.replace(staging, path)
    except OSError as exc:
        if staging is not None and os.path.exists(staging):
            os.unlink(staging)
        raise RenderFailure(f"cannot write the device speed cache {path}: {exc.strerror or exc}") from exc
