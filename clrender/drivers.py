"""The OpenCL CPU drivers a pip install can bring, and making the loader see them.

Two CPU drivers install from PyPI:
- PoCL (`pyopencl[pocl]`, always installed), whose ICD file pyopencl's loader finds by itself;
- Intel's OpenCL CPU runtime (the `fast` extra: `intel-opencl-rt`, `intel-cmplr-lib-rt`), whose package
  puts `libintelocl.so` in the environment's `lib/` and an ICD file that names its build machine's path.

`register_pip_runtimes()` makes the loader see Intel's runtime; `clrender.device` calls it when it is
imported, before the process's first OpenCL call (the loader reads `OCL_ICD_VENDORS` then, once). It
writes a folder of ICD files, one line each (a library's path), under the user's cache folder, keeps the
ICD files the loader read before, and points `OCL_ICD_VENDORS` at the folder. A variable already set by the user is left alone, unless it names no
Intel runtime and one is installed, in which case that folder's files are kept beside it.
`tools/intel_opencl.py` prints the same as an `export` line for a shell.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

INTEL_PACKAGE = "intel-opencl-rt"
INTEL_LIBRARY = "libintelocl.so"
SYSTEM_VENDORS = Path("/etc/OpenCL/vendors")


def find_intel_library() -> Path | None:
    """libintelocl.so in this environment's lib/ (where the pip packages put it), else from intel-opencl-rt's file list."""
    for prefix in dict.fromkeys((sys.prefix, sys.base_prefix)):
        path = Path(prefix) / "lib" / INTEL_LIBRARY
        if path.is_file():
            return path.resolve()
    from importlib import metadata

    try:
        for f in metadata.files(INTEL_PACKAGE) or []:
            if f.name == INTEL_LIBRARY:
                path = Path(f.locate()).resolve()
                if path.is_file():
                    return path
    except metadata.PackageNotFoundError:
        pass
    return None


def previous_icds() -> list[Path]:
    """The ICD files the loader reads without our folder: $OCL_ICD_VENDORS (a folder or one file), else /etc/OpenCL/vendors."""
    current = os.environ.get("OCL_ICD_VENDORS")
    where = Path(current) if current else SYSTEM_VENDORS
    if where.is_file():
        return [where]
    return sorted(where.glob("*.icd")) if where.is_dir() else []


def usable(line: str) -> bool:
    """An ICD line worth keeping: not Intel's runtime again, and not an absolute path that is missing here."""
    if not line:
        return False
    if Path(line).name.startswith(INTEL_LIBRARY):  # ours, or the package's own ICD with a build machine's path
        return False
    return not os.path.isabs(line) or Path(line).exists()


def vendor_lines(intel: Path) -> dict[str, str]:
    """ICD file name -> its line: Intel's runtime, and every usable one the loader read before."""
    lines = {"intel.icd": str(intel)}
    for i, icd in enumerate(previous_icds()):
        try:
            line = icd.read_text().strip()
        except OSError:
            continue
        if usable(line):
            lines[f"kept{i}-{icd.name}"] = line
    return lines


def write_vendors(folder: Path, intel: Path) -> None:
    """Fill `folder` with the ICD files of vendor_lines(intel), replacing the .icd files it had."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = vendor_lines(intel)
    for old in folder.glob("*.icd"):
        old.unlink()
    for name, line in lines.items():
        (folder / name).write_text(line + "\n")


def _names_intel(where: str) -> bool:
    path = Path(where)
    files = [path] if path.is_file() else sorted(path.glob("*.icd")) if path.is_dir() else []
    for icd in files:
        try:
            line = icd.read_text().strip()
        except OSError:
            continue
        if Path(line).name.startswith(INTEL_LIBRARY) and Path(line).exists():
            return True
    return False


def register_pip_runtimes() -> Path | None:
    """Point OCL_ICD_VENDORS at a folder that adds a pip-installed Intel runtime; the folder, or None if nothing was done.

    Call before the process's first OpenCL call. Errors writing the folder leave the loader as it was."""
    intel = find_intel_library()
    current = os.environ.get("OCL_ICD_VENDORS")
    if intel is None or (current and _names_intel(current)):
        return None
    import hashlib
    import tempfile

    from platformdirs import user_cache_dir

    lines = vendor_lines(intel)
    digest = hashlib.sha256(repr(sorted(lines.items())).encode()).hexdigest()[:16]
    folder = Path(user_cache_dir("clrender")) / "opencl-vendors" / digest  # named by its contents: written once, never changed
    try:
        if not folder.is_dir():
            folder.parent.mkdir(parents=True, exist_ok=True)
            staging = Path(tempfile.mkdtemp(dir=folder.parent))
            for name, line in lines.items():
                (staging / name).write_text(line + "\n")
            try:
                staging.rename(folder)
            except OSError:  # another process made it first
                for f in staging.iterdir():
                    f.unlink()
                staging.rmdir()
    except OSError:
        return None
    os.environ["OCL_ICD_VENDORS"] = str(folder)
    return folder
