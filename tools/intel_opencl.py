"""Print the `export` line that makes Intel's OpenCL CPU runtime visible beside PoCL.

    .venv/bin/pip install intel-opencl-rt intel-cmplr-lib-rt     # once: the runtime and its libraries
    eval "$(.venv/bin/python tools/intel_opencl.py)"                # then, in each shell
    .venv/bin/clrender devices                                      # Intel(R) OpenCL: ... beside PoCL

The pip packages put `libintelocl.so` in the environment's `lib/` (its own libraries, TBB and the
compiler runtime, sit beside it and are found through its RUNPATH, so no LD_LIBRARY_PATH is needed)
and an ICD file in `etc/OpenCL/vendors/` that names a build machine's path, not this one. This script
finds the library through the installed package's file list, writes a folder of ICD files (one line
each: a library's path) and prints `export OCL_ICD_VENDORS=<that folder>`.

The folder also gets the ICD files the OpenCL loader read before (those of $OCL_ICD_VENDORS, else of
/etc/OpenCL/vendors), so the platforms seen before stay seen; PoCL from `pyopencl[pocl]` stays
visible in any case, since pyopencl's loader also reads its own `pyopencl/.libs/` when
OCL_ICD_VENDORS is a folder (not when it names one file).

    python tools/intel_opencl.py [--dir DIR]     # DIR: where to write the ICD files (default: a new temp folder)

Exit status 1, with the pip line on stderr, when the runtime is not installed.
"""

from __future__ import annotations

import argparse
import os
import shlex
import sys
import tempfile
from pathlib import Path

PACKAGE = "intel-opencl-rt"
LIBRARY = "libintelocl.so"
SYSTEM_VENDORS = Path("/etc/OpenCL/vendors")


def find_library() -> Path | None:
    """libintelocl.so from the installed intel-opencl-rt, else from this environment's lib/."""
    from importlib import metadata

    try:
        for f in metadata.files(PACKAGE) or []:
            if f.name == LIBRARY:
                path = Path(f.locate()).resolve()
                if path.is_file():
                    return path
    except metadata.PackageNotFoundError:
        pass
    for prefix in dict.fromkeys((sys.prefix, sys.base_prefix)):
        path = Path(prefix) / "lib" / LIBRARY
        if path.is_file():
            return path.resolve()
    return None


def previous_icds() -> list[Path]:
    """The ICD files the loader reads without our folder: $OCL_ICD_VENDORS (a folder or one file), else /etc/OpenCL/vendors."""
    current = os.environ.get("OCL_ICD_VENDORS")
    where = Path(current) if current else SYSTEM_VENDORS
    if where.is_file():
        return [where]
    return sorted(where.glob("*.icd")) if where.is_dir() else []


def usable(line: str, intel: Path) -> bool:
    """An ICD line worth keeping: not Intel's runtime again, and not an absolute path that is missing here."""
    if not line:
        return False
    if Path(line).name.startswith(LIBRARY):  # ours, or the package's own ICD with a build machine's path
        return False
    return not os.path.isabs(line) or Path(line).exists()


def write_vendors(folder: Path, intel: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for old in folder.glob("*.icd"):
        old.unlink()
    (folder / "intel.icd").write_text(f"{intel}\n")
    for i, icd in enumerate(previous_icds()):
        try:
            line = icd.read_text().strip()
        except OSError:
            continue
        if usable(line, intel):
            (folder / f"kept{i}-{icd.name}").write_text(line + "\n")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dir", type=Path, help="folder for the ICD files (default: a new temporary folder)")
    args = parser.parse_args(argv)
    intel = find_library()
    if intel is None:
        pip = f"{sys.executable} -m pip install {PACKAGE} intel-cmplr-lib-rt"
        print(f"{LIBRARY} not found: install Intel's OpenCL CPU runtime with: {pip}", file=sys.stderr)
        return 1
    folder = args.dir.resolve() if args.dir else Path(tempfile.mkdtemp(prefix="clrender-opencl-vendors-"))
    write_vendors(folder, intel)
    print(f"# Intel's OpenCL CPU runtime: {intel}")
    print(f"export OCL_ICD_VENDORS={shlex.quote(str(folder))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
