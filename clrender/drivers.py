"""The OpenCL drivers the loader does not find by itself, and making it see them.

Two CPU drivers install from PyPI:
- PoCL (`pyopencl[pocl]`, always installed), whose ICD file pyopencl's loader finds by itself;
- Intel's OpenCL CPU runtime (the `fast` extra: `intel-opencl-rt`, `intel-cmplr-lib-rt`), whose package
  puts `libintelocl.so` in the environment's `lib/` and an ICD file that names its build machine's path.
And one checker: Oclgrind, the OpenCL simulator that checks every memory access (Debian's `oclgrind`
package), whose library Debian installs without an ICD file.  Loaded, it adds about 57 MB to every process, so it
is seen only where `CLRENDER_DEVICE` names it (`CLRENDER_DEVICE=oclgrind`), and then never the default device and
never measured (clrender.device `is_simulator`).

`register_runtimes()` makes the loader see each of `wanted_libraries()` that no ICD file it reads names;
`clrender.device` calls it when it is imported, before the process's first OpenCL call (the loader reads
`OCL_ICD_VENDORS` then, once).  It writes a folder of ICD files, one line each (a library's path), under the
user's cache folder, keeps the ICD files the loader read before ($OCL_ICD_VENDORS, set by the user or not,
else /etc/OpenCL/vendors), and points `OCL_ICD_VENDORS` at the folder.
`tools/intel_opencl.py` prints the same, for Intel's runtime, as an `export` line for a shell.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

INTEL_PACKAGE = "intel-opencl-rt"
INTEL_LIBRARY = "libintelocl.so"
OCLGRIND_LIBRARY = Path("/usr/lib/oclgrind/liboclgrind-rt-icd.so")  # Debian's oclgrind package
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


def find_oclgrind_library() -> Path | None:
    """Oclgrind's ICD library where Debian's package put it."""
    return OCLGRIND_LIBRARY if OCLGRIND_LIBRARY.is_file() else None


def oclgrind_installed() -> bool:
    """Whether Oclgrind can be asked for here: Debian's library, or an ICD file the loader reads that names it."""
    return find_oclgrind_library() is not None or any("oclgrind" in line.lower() for _, line in previous_lines())


def oclgrind_requested() -> bool:
    """Whether this process asks for Oclgrind: $CLRENDER_DEVICE names it."""
    return "oclgrind" in os.environ.get("CLRENDER_DEVICE", "").lower()


def wanted_libraries() -> dict[str, Path]:
    """The libraries installed here that the loader should see, by the name of the ICD file that names each."""
    found = {"intel.icd": find_intel_library(), "oclgrind.icd": find_oclgrind_library() if oclgrind_requested() else None}
    return {icd: library for icd, library in found.items() if library is not None}


def previous_icds() -> list[Path]:
    """The ICD files the loader reads without our folder: $OCL_ICD_VENDORS (a folder or one file), else /etc/OpenCL/vendors."""
    current = os.environ.get("OCL_ICD_VENDORS")
    where = Path(current) if current else SYSTEM_VENDORS
    if where.is_file():
        return [where]
    return sorted(where.glob("*.icd")) if where.is_dir() else []


def previous_lines() -> list[tuple[str, str]]:
    """(ICD file name, its line) of each previous_icds() file that can be read."""
    lines = []
    for icd in previous_icds():
        try:
            lines.append((icd.name, icd.read_text().strip()))
        except OSError:
            continue
    return lines


def names(line: str, library: Path) -> bool:
    """Whether an ICD line names `library`, any version of it: libintelocl.so.2026.22.10.0 names libintelocl.so."""
    stem = lambda path: Path(path).name.split(".so")[0]
    return stem(line) == stem(library)


def sees(library: Path, lines: list[tuple[str, str]]) -> bool:
    """Whether the loader reading `lines` loads `library`: a line names it by a path that exists here."""
    return any(names(line, library) and Path(line).exists() for _, line in lines)


def vendor_lines(libraries: dict[str, Path]) -> dict[str, str]:
    """ICD file name -> its line: `libraries`, and every line the loader read before that names none of them
    (which would load one twice, or not at all) and is not an absolute path that is missing here."""
    lines = {icd: str(library) for icd, library in libraries.items()}
    for i, (icd, line) in enumerate(previous_lines()):
        if line and not any(names(line, library) for library in libraries.values()) and (not os.path.isabs(line) or Path(line).exists()):
            lines[f"kept{i}-{icd}"] = line
    return lines


def write_vendors(folder: Path, libraries: dict[str, Path]) -> None:
    """Fill `folder` with the ICD files of vendor_lines(libraries), replacing the .icd files it had."""
    folder.mkdir(parents=True, exist_ok=True)
    lines = vendor_lines(libraries)
    for old in folder.glob("*.icd"):
        old.unlink()
    for name, line in lines.items():
        (folder / name).write_text(line + "\n")


def register_runtimes() -> Path | None:
    """Point OCL_ICD_VENDORS at a folder that adds each of wanted_libraries() the loader does not see yet; the
    folder, or None if nothing was done.

    Call before the process's first OpenCL call. Errors writing the folder leave the loader as it was."""
    before = previous_lines()
    missing = {icd: library for icd, library in wanted_libraries().items() if not sees(library, before)}
    if not missing:
        return None
    import hashlib
    import tempfile

    from platformdirs import user_cache_dir

    lines = vendor_lines(missing)
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
