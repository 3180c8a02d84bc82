"""Out-of-line calls and vector registers of each compiled kernel, read from the driver's binary.

    python -m tools.kernel_asm                    # a tiny path-traced Cornell box and Whitted refract1, then every kernel built
    python -m tools.kernel_asm --only render_path # one kernel (fnmatch patterns on the kernel name)

A call in hot code spills every live vector register and, for a math builtin, runs the driver's own rounding.
What a binary holds depends on the driver:
  * Intel's OpenCL CPU runtime: `program.binaries` is an ELF whose section `.ocl.obj` is an x86-64 relocatable
    object with one function per kernel (and the `__Vectorized_.` copy that runs 16 work-items in zmm lanes);
    a call is `movabs $0, %reg` (relocated to the callee) then `call *%reg`, so the callee is read from the
    relocation;
  * PoCL: its kernel cache, ~/.cache/pocl/kcache/*/*/KERNEL/*/KERNEL.so (a shared object), not `binaries`;
    `pocl_objects` finds them;
  * others (Oclgrind keeps LLVM IR): unreadable here, `object_code` returns None.
The disassembly is `objdump -d -r` (binutils).
"""

from __future__ import annotations

import argparse
import fnmatch
import re
import shutil
import struct
import subprocess
import sys
import tempfile
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

VECTOR_REG = re.compile(r"%([xyz])mm(\d+)")
MASK_REG = re.compile(r"%k([1-7])\b")
FUNCTION = re.compile(r"^[0-9a-f]+ <(.+)>:$")
RELOC = re.compile(r"^\s*[0-9a-f]+: R_X86_64_\w+\s+(\S+?)(?:[-+]0x[0-9a-f]+)?$")
INSTR = re.compile(r"^\s*[0-9a-f]+:\s+(?:[0-9a-f]{2} )+\s*(\S+)\s*(.*)$")


@dataclass
class FunctionAsm:
    """One function of a compiled object: its calls by callee, and the vector registers it names."""

    name: str
    instructions: int = 0
    calls: Counter = field(default_factory=Counter)
    vector_regs: set = field(default_factory=set)  # register numbers, any width
    widest: str = ""  # "zmm", "ymm", "xmm" or ""
    mask_regs: set = field(default_factory=set)

    @property
    def call_count(self) -> int:
        return sum(self.calls.values())


def elf_sections(blob: bytes) -> dict[str, bytes]:
    """The named sections of a 64-bit little-endian ELF image."""
    if blob[:4] != b"\x7fELF" or blob[4] != 2:
        return {}
    shoff = struct.unpack_from("<Q", blob, 0x28)[0]
    entsize, count, names_index = struct.unpack_from("<HHH", blob, 0x3A)
    headers = [struct.unpack_from("<IIQQQQ", blob, shoff + i * entsize) for i in range(count)]
    names_at = headers[names_index][4]
    out = {}
    for name, _type, _flags, _addr, offset, size in headers:
        key = blob[names_at + name :].split(b"\0", 1)[0].decode()
        out[key] = blob[offset : offset + size]
    return out


def object_code(binary: bytes) -> bytes | None:
    """The machine-code object inside a driver's program binary, or None where this cannot be read."""
    sections = elf_sections(binary)
    if ".ocl.obj" in sections:  # Intel's CPU runtime
        return sections[".ocl.obj"]
    if sections.get(".text") is not None:  # a plain object or shared library (PoCL's kernel cache)
        return binary
    return None


def disassemble(obj: bytes) -> dict[str, FunctionAsm]:
    """Every function of an x86-64 object, from `objdump -d -r`."""
    if shutil.which("objdump") is None:
        raise RuntimeError("objdump (binutils) is not installed")
    with tempfile.NamedTemporaryFile(suffix=".o") as f:
        f.write(obj)
        f.flush()
        text = subprocess.run(["objdump", "-d", "-r", "--no-show-raw-insn", f.name], capture_output=True, text=True, check=True).stdout
    return parse_objdump(text)


def parse_objdump(text: str) -> dict[str, FunctionAsm]:
    functions: dict[str, FunctionAsm] = {}
    current = None
    loaded: dict[str, str] = {}  # register -> the symbol its last movabs was relocated to
    pending = None  # the register of a movabs whose relocation line follows
    for line in text.splitlines():
        m = FUNCTION.match(line)
        if m:
            current = functions.setdefault(m.group(1), FunctionAsm(m.group(1)))
            loaded, pending = {}, None
            continue
        if current is None:
            continue
        r = RELOC.match(line)
        if r:
            if pending:
                loaded[pending] = r.group(1)
            elif current.calls.get("?pending"):  # a direct call's relocation
                current.calls["?pending"] -= 1
                if not current.calls["?pending"]:
                    del current.calls["?pending"]
                current.calls[r.group(1)] += 1
            pending = None
            continue
        parts = re.match(r"^\s*[0-9a-f]+:\s+(\S+)\s*(.*)$", line)
        if not parts:
            continue
        op, args = parts.group(1), parts.group(2)
        current.instructions += 1
        pending = None
        if op == "movabs" and args.startswith("$0x0,%"):
            pending = args.split(",%")[1]
        if op.startswith("call"):
            target = args.strip()
            if target.startswith("*%"):
                current.calls[loaded.get(target[2:], "indirect")] += 1
            elif "<" in target:
                callee = target[target.index("<") + 1 : target.rindex(">")]
                if callee.startswith(current.name + "+") or re.fullmatch(r"\.?[\w.]*\+0x[0-9a-f]+", callee):
                    current.calls["?pending"] += 1  # the relocation on the next line names it
                else:
                    current.calls[callee] += 1
            else:
                current.calls["?pending"] += 1
        for kind, number in VECTOR_REG.findall(args):
            current.vector_regs.add(int(number))
            if "xyz".index(kind) > "xyz".index(current.widest[0] if current.widest else "x") or not current.widest:
                current.widest = kind + "mm"
        current.mask_regs.update(int(k) for k in MASK_REG.findall(args))
    for fn in functions.values():
        if "?pending" in fn.calls:
            fn.calls["unresolved"] += fn.calls.pop("?pending")
    return functions


def program_functions(program) -> dict[str, FunctionAsm] | None:
    """The functions of a built pyopencl program (its first device's binary), or None where unreadable."""
    obj = object_code(program.binaries[0])
    return None if obj is None else disassemble(obj)


def pocl_objects(kernel: str) -> list[Path]:
    """PoCL's cached builds of `kernel`, newest first."""
    found = Path.home().glob(f".cache/pocl/kcache/*/*/{kernel}/*/{kernel}.so")
    return sorted(found, key=lambda p: p.stat().st_mtime, reverse=True)


def kernel_of(function: str) -> str:
    """The kernel a compiled function belongs to: Intel's `__Vectorized_.render_path`, PoCL's
    `_pocl_kernel_render_path_workgroup` -> render_path."""
    if function.startswith("__Vectorized_."):
        return function.split(".", 1)[1]
    if function.startswith("_pocl_kernel_"):
        return re.sub(r"_workgroup(_fast)?$", "", function[len("_pocl_kernel_") :])
    return function


def build_sample_programs(size: int = 8):
    """Render a tiny path-traced Cornell box and a tiny Whitted refract1, so the device holds their programs."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from clrender.device import get_device
    from clrender.trace.renderer import Renderer

    from tests.reference import path_scenes

    Renderer(path_scenes.cornell_box(size), integrator="path", spp=1, width=size, height=size, seed=0).run()
    Renderer("refract1", width=size, height=size).run()
    return get_device()


def report(device, only=("*",)) -> list[tuple[str, str, FunctionAsm]]:
    """(program file, function, its FunctionAsm) for each kernel function of every program `device` built."""
    rows = []
    for (filename, _defines), program in device._programs.items():
        names = set(program.kernel_names.split(";"))
        functions = program_functions(program)
        if functions is None and "portable computing language" in device.name.lower():
            functions = {}  # PoCL: the newest cached build of each kernel (the last variant built)
            for name in names:
                found = pocl_objects(name)
                if found:
                    functions.update(disassemble(found[0].read_bytes()))
        for name, fn in sorted((functions or {}).items()):
            if kernel_of(name) in names and any(fnmatch.fnmatch(kernel_of(name), p) for p in only):
                rows.append((filename, name, fn))
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tools.kernel_asm", description=__doc__.split("\n")[0])
    ap.add_argument("--only", nargs="+", default=["*"], help="kernel name patterns (fnmatch)")
    ap.add_argument("--size", type=int, default=8, help="the sample renders' width and height")
    args = ap.parse_args(argv)
    device = build_sample_programs(args.size)
    rows = report(device, args.only)
    if not rows:
        print(f"{device.name}: no readable machine code in this driver's binaries (see this module's docstring)")
        return 1
    print(f"{device.name}")
    print(f"{'program':<12} {'function':<36} {'instrs':>7} {'calls':>6} {'vregs':>6} {'widest':>6} {'masks':>5}  callees")
    for filename, name, fn in rows:
        callees = ", ".join(f"{c} {n}" for c, n in fn.calls.most_common())
        counts = f"{fn.instructions:>7} {fn.call_count:>6} {len(fn.vector_regs):>6} {fn.widest:>6} {len(fn.mask_regs):>5}"
        print(f"{filename:<12} {name:<36} {counts}  {callees}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
