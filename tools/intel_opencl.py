"""Print the `export` line that makes Intel's OpenCL CPU runtime visible beside PoCL, for other programs.

clrender itself needs no such line: clrender/drivers.py registers the runtime before its first OpenCL call.

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
import shlex
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))  # run as a script from a checkout

from clrender.drivers import INTEL_LIBRARY as LIBRARY  # noqa: E402
from clrender.drivers import INTEL_PACKAGE as PACKAGE  # noqa: E402
from clrender.drivers import find_intel_library, write_vendors  # noqa: E402

__all__ = ["LIBRARY", "PACKAGE", "main", "write_vendors"]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dir", type=Path, help="folder for the ICD files (default: a new temporary folder)")
    args = parser.parse_args(argv)
    intel = find_intel_library()
    if intel is None:
        pip = f"{sys.executable} -m pip install {PACKAGE} intel-cmplr-lib-rt"
        print(f"{LIBRARY} not found: install Intel's OpenCL CPU runtime with: {pip}", file=sys.stderr)
        return 1
    folder = args.dir.resolve() if args.dir else Path(tempfile.mkdtemp(prefix="clrender-opencl-vendors-"))
    write_vendors(folder, {"intel.icd": intel})
    print(f"# Intel's OpenCL CPU runtime: {intel}")
    print(f"export OCL_ICD_VENDORS={shlex.quote(str(folder))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
