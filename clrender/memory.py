"""Peak memory, estimated from the settings before anything large is allocated.

The figures are bytes per pixel and per triangle measured as peak RSS growth
(`/usr/bin/time -f %M`, PoCL CPU device, whose buffers are host memory too):

    render, --aa none or full          ~150 B/pixel  (2048 x 2048: +603 MiB)
    render, --aa edge_detect           ~275 B/pixel  (+1.08 GiB)
    render, edge_detect + all AOVs     ~340 B/pixel  (+1.32 GiB)
    dense mesh, load + BVH + trace     ~580 B/triangle (1 M triangles: +540 MiB)

Each constant below rounds its figure up.  A job whose estimate exceeds the
memory available now (MemAvailable) or --max-memory is refused with the
figure (exit 2) instead of dying half-way with a MemoryError.
"""

from __future__ import annotations

import os
import re

from .errors import UsageError, shown

RENDER_BYTES_PER_PIXEL = 176  # image, path ids, shadow, frame and device copies, sRGB conversion
EDGE_AA_BYTES_PER_PIXEL = 144  # edge_detect adds the ID/colour comparisons, mask and resample buffers
AOV_BYTES_PER_PIXEL = 80  # kernel AOV record (8 floats) and the EXR channels
FILTER_BYTES_PER_PIXEL = 6 * 12  # convolution working copies of an RGB float image
BYTES_PER_TRIANGLE = 640  # vertices, faces, normals, BVH build and device arrays
BASE_BYTES = 256 << 20  # the interpreter, numpy, pyopencl and PoCL themselves
MAX_TRIANGLES = 8_000_000  # about 4.8 GiB: generators and mesh files stop here whatever memory says

MAX_MEMORY: int | None = None  # the CLI's --max-memory, in bytes (None: what is available)

_SIZE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([kmgt]?)(i?b?)\s*$", re.IGNORECASE)


def parse_size(text: str) -> int:
    """'512M', '2G', '1.5GiB', '1000000' (bytes) -> bytes; UsageError otherwise."""
    match = _SIZE.match(str(text))
    if not match:
        raise UsageError(f"memory size {shown(text)} is not valid; allowed: a number with K, M, G or T, e.g. 2G")
    number, unit = float(match.group(1)), match.group(2).upper()
    value = int(number * 1024 ** " KMGT".index(unit or " "))
    if value < 1 << 20:
        raise UsageError(f"memory size {shown(text)} is below 1 MiB; allowed: at least 1M")
    return value


def available_bytes() -> int | None:
    """Memory the kernel says can be had now without swapping (MemAvailable), else free pages."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def limit_bytes(max_memory: int | None = None) -> tuple[int | None, str]:
    """The budget to check against and where it comes from."""
    if max_memory is None:
        max_memory = MAX_MEMORY
    if max_memory is None and os.environ.get("CLRENDER_MAX_MEMORY"):
        max_memory = parse_size(os.environ["CLRENDER_MAX_MEMORY"])
    available = available_bytes()
    if max_memory is not None and (available is None or max_memory <= available):
        return max_memory, "--max-memory"
    return available, "available"


def require(need: int, what: str, max_memory: int | None = None) -> None:
    """UsageError naming the estimate when `what` would need more than the budget."""
    limit, source = limit_bytes(max_memory)
    if limit is not None and need > limit:
        budget = f"--max-memory is {format_bytes(limit)}" if source == "--max-memory" else f"only {format_bytes(limit)} is available"
        raise UsageError(f"{what} needs about {format_bytes(need)} of memory but {budget}; use a smaller size")


def render_bytes(width: int, height: int, triangles: int = 0, *, aa: str = "none", aovs: int = 0, filters: int = 0, extra_images: int = 0) -> int:
    """Peak bytes of one render with these settings (see the table at the top)."""
    per_pixel = RENDER_BYTES_PER_PIXEL
    if aa == "edge_detect":
        per_pixel += EDGE_AA_BYTES_PER_PIXEL
    if aovs:
        per_pixel += AOV_BYTES_PER_PIXEL
    if filters:
        per_pixel += FILTER_BYTES_PER_PIXEL
    per_pixel += 16 * extra_images  # an extra written image: its pixels and the 8-bit copy
    return BASE_BYTES + width * height * per_pixel + triangles * BYTES_PER_TRIANGLE


def triangles_bytes(triangles: int) -> int:
    return BASE_BYTES + triangles * BYTES_PER_TRIANGLE


def format_bytes(n: int) -> str:
    if n >= 2**30:
        return f"{n / 2**30:.1f} GiB"
    return f"{n / 2**20:.0f} MiB"
