"""Peak memory, estimated from the settings before anything large is allocated.

The figures are bytes per pixel and per triangle measured as peak RSS growth
(`/usr/bin/time -f %M`, PoCL CPU device, whose buffers are host memory too):

    render, --aa none or full          ~150 B/pixel  (2048 x 2048: +603 MiB)
    render, --aa edge_detect           ~275 B/pixel  (+1.08 GiB)
    render, edge_detect + all AOVs     ~340 B/pixel  (+1.32 GiB)
    dense mesh, load + BVH + trace     ~360 B/triangle (1 M smooth triangles: 454 MB peak for a 64 x 64 render;
                                       a flat 1 M-triangle PLY: 477 MB; before the Tracer dropped its host
                                       copies, 2026-11-24: ~670 B, and 1.16 GB for the PLY)
    textures                           decoding peaks at 35 B/texel (a 3000 x 3000 PNG, sRGB), then the scene's
                                       copy, the packed buffer and the device's hold 48: 56 B/texel, checked
                                       with BASE_BYTES as each is decoded and again with the render
    --denoise (OIDN, quality high)     742 B/pixel peak RSS growth (1024 x 1024), beside the render

Each constant below rounds its figure up.  A job whose estimate exceeds the
memory available now or --max-memory is refused with the figure (exit 2)
instead of dying half-way with a MemoryError.  "Available now" is the
smallest of MemAvailable, what `ulimit -v` (RLIMIT_AS) leaves of the address
space, and what the memory cgroup (a container's limit) leaves.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from .errors import UsageError, shown

RENDER_BYTES_PER_PIXEL = 176  # image, path ids, shadow, frame and device copies, sRGB conversion
EDGE_AA_BYTES_PER_PIXEL = 144  # edge_detect adds the ID/colour comparisons, mask and resample buffers
AOV_BYTES_PER_PIXEL = 80  # kernel AOV record (8 floats) and the EXR channels
FILTER_BYTES_PER_PIXEL = 6 * 12  # convolution working copies of an RGB float image
# the path tracer's --rfilter tent/gaussian: each splat slot's float4 on the device, its host copy and the copy in
# image order; plus the gathered float64 sums and a float64 slot in flight (trace/film.py)
SPLAT_BYTES_PER_SLOT, SPLAT_BYTES_PER_PIXEL = 3 * 16, 64
BYTES_PER_TRIANGLE = 420  # the mesh and its vertex normals, the BVH build, the device arrays (docs/bvh.md, "Memory")
# a textured or vertex-coloured scene's triangles also carry uvs, colours and tangents (layout.VertexAttributes,
# 132 bytes, gathered per mesh) on the device
ATTRIBUTE_BYTES_PER_TRIANGLE = 140
TEXEL_BYTES = 56  # a texture's float4 texel: decoding's peak plus the device copy (scene/textures.py; table above)
DENOISE_BYTES_PER_PIXEL = 768  # Open Image Denoise's U-Net working memory (image/denoise.py; table above)
BASE_BYTES = 256 << 20  # the interpreter, numpy, pyopencl and a pip-installed driver (a render's process: 251 MB on Intel's)
MAX_TRIANGLES = 8_000_000  # about 4.8 GiB: generators and mesh files stop here whatever memory says

MAX_MEMORY: int | None = None  # the CLI's --max-memory, in bytes (None: what is available)
MAX_SIZE = 1 << 60  # 1024 PiB: the largest memory size accepted (more digits are a typo, not a machine)
CGROUP_ROOT = Path("/sys/fs/cgroup")  # where the cgroup files are mounted (tests point it at a fake tree)
SELF_CGROUP = Path("/proc/self/cgroup")  # which cgroup this process is in

_SIZE = re.compile(r"^\s*(\d+(?:\.\d+)?)\s*([kmgt]?)(i?b?)\s*$", re.IGNORECASE)


def parse_size(text: str) -> int:
    """'512M', '2G', '1.5GiB', '1000000' (bytes) -> bytes; UsageError otherwise."""
    match = _SIZE.match(str(text))
    if not match:
        raise UsageError(f"memory size {shown(text)} is not valid; allowed: a number with K, M, G or T, e.g. 2G")
    number, unit = float(match.group(1)), match.group(2).upper()  # 5,000 digits: inf, refused below
    value = number * 1024 ** " KMGT".index(unit or " ")
    if not value <= MAX_SIZE:
        raise UsageError(f"memory size {shown(text)} is too large; allowed: 1M to {MAX_SIZE >> 40}T")
    value = int(value)
    if value < 1 << 20:
        raise UsageError(f"memory size {shown(text)} is below 1 MiB; allowed: at least 1M")
    return value


def available_bytes() -> int | None:
    """Memory this process can have now: the smallest of `meminfo_bytes`, `address_space_bytes` and
    `cgroup_bytes` (each None when it sets no bound); None when none does."""
    bounds = [b for b in (meminfo_bytes(), address_space_bytes(), cgroup_bytes()) if b is not None]
    return min(bounds) if bounds else None


def address_space_bytes() -> int | None:
    """What `ulimit -v` (RLIMIT_AS) leaves of the address space: the limit less our virtual size now."""
    try:
        import resource

        limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    except (ImportError, AttributeError, OSError, ValueError):  # Windows has no resource module
        return None
    if limit == resource.RLIM_INFINITY or limit < 0:
        return None
    used = 0
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("VmSize:"):
                    used = int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return max(limit - used, 0)


def cgroup_bytes(root: Path | None = None, self_cgroup: Path | None = None) -> int | None:
    """What the memory cgroup still allows: the smallest limit less usage along this process's cgroup
    and its parents (v2 memory.max and memory.current, v1 memory.limit_in_bytes and
    memory.usage_in_bytes, each less the reclaimable inactive page cache of memory.stat, as the
    kubelet counts it).  None without a limit.  `root` and `self_cgroup` default to CGROUP_ROOT and
    SELF_CGROUP."""
    root = Path(CGROUP_ROOT if root is None else root)
    folders = []
    try:
        lines = Path(SELF_CGROUP if self_cgroup is None else self_cgroup).read_text().splitlines()
    except (OSError, UnicodeDecodeError):
        lines = []
    for line in lines:  # "0::/path" (v2) or "4:memory:/path" (v1)
        parts = line.split(":", 2)
        if len(parts) == 3 and (parts[1] == "" or "memory" in parts[1].split(",")):
            base = root if parts[1] == "" else root / "memory"
            here = base / parts[2].lstrip("/")
            folders += [here, *here.parents[: len(here.relative_to(base).parts)]]
    folders += [root, root / "memory"]  # inside a container our cgroup is often mounted as the root
    bounds = []
    for folder in dict.fromkeys(folders):
        for limit_name, usage_name, inactive_name in (
            ("memory.max", "memory.current", "inactive_file"),
            ("memory.limit_in_bytes", "memory.usage_in_bytes", "total_inactive_file"),
        ):
            limit = _read_int(folder / limit_name)
            if limit is None or limit >= MAX_SIZE:  # "max", or v1's 2^63 rounded down to a page: no limit
                continue
            usage = (_read_int(folder / usage_name) or 0) - (_stat_value(folder / "memory.stat", inactive_name) or 0)
            bounds.append(max(limit - max(usage, 0), 0))
    return min(bounds) if bounds else None


def _read_int(path: Path) -> int | None:
    try:
        return int(path.read_text().split()[0])
    except (OSError, ValueError, IndexError, UnicodeDecodeError):
        return None


def _stat_value(path: Path, key: str) -> int | None:
    try:
        for line in path.read_text().splitlines():
            name, _, value = line.partition(" ")
            if name == key:
                return int(value)
    except (OSError, ValueError, UnicodeDecodeError):
        pass
    return None


def meminfo_bytes() -> int | None:
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


def render_bytes(
    width: int,
    height: int,
    triangles: int = 0,
    *,
    aa: str = "none",
    aovs: int = 0,
    filters: int = 0,
    extra_images: int = 0,
    attributes: bool = False,
    splat_slots: int = 1,
    denoise: bool = False,
    texels: int = 0,
) -> int:
    """Peak bytes of one render with these settings (see the table at the top); attributes: the triangles carry
    uvs, vertex colours and tangents (a textured or vertex-coloured scene); splat_slots: the path tracer's splat
    slots per pixel (trace/film.slots; 1 for a box film); denoise: OIDN runs on the image; texels: the scene's
    texture texels (held through the render)."""
    per_pixel = RENDER_BYTES_PER_PIXEL
    if aa == "edge_detect":
        per_pixel += EDGE_AA_BYTES_PER_PIXEL
    if aovs:
        per_pixel += AOV_BYTES_PER_PIXEL
    if filters:
        per_pixel += FILTER_BYTES_PER_PIXEL
    per_pixel += 16 * extra_images  # an extra written image: its pixels and the 8-bit copy
    if splat_slots > 1:  # a path tracer's reconstruction filter wider than a pixel (trace/film.py)
        per_pixel += SPLAT_BYTES_PER_SLOT * splat_slots + SPLAT_BYTES_PER_PIXEL
    per_pixel += DENOISE_BYTES_PER_PIXEL * denoise
    per_triangle = BYTES_PER_TRIANGLE + ATTRIBUTE_BYTES_PER_TRIANGLE * attributes
    return BASE_BYTES + width * height * per_pixel + triangles * per_triangle + texels * TEXEL_BYTES


def triangles_bytes(triangles: int) -> int:
    return BASE_BYTES + triangles * BYTES_PER_TRIANGLE


def format_bytes(n: int) -> str:
    if n >= 2**30:
        return f"{n / 2**30:.1f} GiB"
    return f"{n / 2**20:.0f} MiB"
