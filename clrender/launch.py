"""Kernels called by their parameters' names.

A kernel's parameters are declared once, in its `__kernel` signature in kernels/; `kernel_signatures`
reads them from the source, and `Kernel` takes keyword arguments, checks them against that list
(every name given once, buffers where the kernel takes pointers, values that fit its scalar and
record types) and the count against what the driver reports (`num_args`), then enqueues:

    knl = device.kernel("trace.cl", "refract_rays", defines)
    knl(queue, (n,), None, n=n, d=d_buf, normals=n_buf, eta=eta_buf, out=out_buf)

A wrong name or a missing argument is a TypeError naming it, never a silently shifted launch.

A caller that launches one kernel many times with mostly the same arguments (a Tracer's ray
queries) takes `knl.bound()`: a kernel object of its own whose arguments, set and checked by name,
stay set between launches, so that a launch sets only what changed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from .layout import records

try:
    import pyopencl as cl
except ImportError:  # pragma: no cover - device.py reports the missing install
    cl = None

_QUALIFIERS = {"__global", "global", "__local", "local", "__constant", "constant", "const", "restrict", "__private"}
_SCALARS = {"int": np.int32, "uint": np.uint32, "float": np.float32}
_VECTOR = re.compile(r"^(int|uint|float)(2|4|8|16)$")  # not 3: a float3 argument takes 16 bytes


@dataclass(frozen=True)
class Param:
    name: str
    type: str  # the C type without qualifiers and pointer star: "float4", "int", "RenderParams"
    pointer: bool


def kernel_signatures(source: str) -> dict[str, tuple[Param, ...]]:
    """Every `__kernel`'s parameters in `source`, by kernel name."""
    source = re.sub(r"/\*.*?\*/", " ", source, flags=re.S)
    source = re.sub(r"//[^\n]*", " ", source)
    found = {}
    for match in re.finditer(r"__kernel\s+(?:__attribute__\s*\(\(.*?\)\)\s+)?void\s+(\w+)\s*\(([^)]*)\)", source):
        text = match.group(2)
        if "#" in text:
            raise ValueError(f"kernel {match.group(1)}: a preprocessor line inside its parameter list cannot be read")
        params = []
        for declaration in filter(None, (part.strip() for part in text.split(","))):
            words = [w for w in declaration.replace("*", " * ").split() if w not in _QUALIFIERS]
            params.append(Param(words[-1], " ".join(w for w in words[:-1] if w != "*"), "*" in words))
        found[match.group(1)] = tuple(params)
    return found


class Kernel:
    """A built kernel whose launches name every argument (see the module docstring)."""

    def __init__(self, kernel, params: tuple[Param, ...]):
        if kernel.num_args != len(params):
            raise RuntimeError(f"kernel {kernel.function_name}: the driver reports {kernel.num_args} arguments, its source declares {len(params)}")
        self.kernel = kernel
        # held so bound() can make the kernel again: Intel's runtime invalidates a program whose last Python
        # handle is released although its kernels live on (PoCL keeps it), and kernel.program then fails
        self.program = kernel.program
        self.params = params
        self.name = kernel.function_name
        self._records = {record.c_name: record.dtype for record in records()}
        for p in params:
            if not p.pointer and p.type not in _SCALARS and not _VECTOR.match(p.type) and p.type not in self._records:
                raise TypeError(f"kernel {self.name}: parameter {p.name} has type {p.type}, which the launcher cannot pass")

    def __call__(self, queue, global_size, local_size, *positional, **args):
        if positional:
            raise TypeError(f"kernel {self.name}: arguments are passed by name ({', '.join(p.name for p in self.params)}), not by position")
        names = [p.name for p in self.params]
        missing = [n for n in names if n not in args]
        unknown = [n for n in args if n not in names]
        if missing or unknown:
            raise TypeError(f"kernel {self.name}: missing {missing}, unknown {unknown}; it takes {', '.join(names)}")
        values = [self._value(p, args[p.name]) for p in self.params]
        return self.kernel(queue, global_size, local_size, *values)

    def _value(self, p: Param, value):
        where = f"kernel {self.name}: argument {p.name} ({p.type}{' *' if p.pointer else ''})"
        if p.pointer:
            if value is not None and not isinstance(value, (cl.MemoryObjectHolder, cl.LocalMemory)):
                raise TypeError(f"{where} must be a buffer, not {type(value).__name__}")
            return value
        if p.type in self._records:
            array = np.asarray(value)
            if array.dtype != self._records[p.type] or array.shape != ():
                raise TypeError(f"{where} must be one record of its layout.py dtype, not {array.dtype} {array.shape}")
            return array
        vector = _VECTOR.match(p.type)
        if vector:
            array = np.asarray(value, dtype=_SCALARS[vector.group(1)])
            lanes = int(vector.group(2))
            if array.shape != (lanes,):
                raise TypeError(f"{where} must hold {lanes} values, not shape {array.shape}")
            return array
        kind = _SCALARS[p.type]
        if kind is np.float32:
            if not isinstance(value, (int, float, np.integer, np.floating)) or isinstance(value, bool):
                raise TypeError(f"{where} must be a real number, not {value!r}")
            return np.float32(value)
        if not isinstance(value, (int, np.integer, bool, np.bool_)):
            raise TypeError(f"{where} must be an integer, not {value!r}")
        info = np.iinfo(kind)
        if not info.min <= int(value) <= info.max:
            raise TypeError(f"{where}: {int(value)} does not fit")
        return kind(value)

    def bound(self) -> BoundKernel:
        """A copy of this kernel whose arguments stay set between launches (see BoundKernel)."""
        return BoundKernel(self)


class BoundKernel:
    """A Kernel's own cl.Kernel (a Kernel's is shared by every caller of Device.kernel) whose arguments,
    set by name with the checks of Kernel, stay set between launches: `set(**args)`, then `enqueue`."""

    def __init__(self, kernel: Kernel):
        self.spec = kernel
        self.kernel = cl.Kernel(kernel.program, kernel.name)
        self.index = {p.name: (i, p) for i, p in enumerate(kernel.params)}
        self.values: dict = {}  # what each argument was last set to (kept: an object's id is not reused)

    def set(self, **args) -> None:
        unknown = [n for n in args if n not in self.index]
        if unknown:
            raise TypeError(f"kernel {self.spec.name}: unknown {unknown}; it takes {', '.join(self.index)}")
        for name, value in args.items():
            if name in self.values and self.values[name] is value:
                continue  # the same buffer as last time: already set
            i, p = self.index[name]
            self.kernel.set_arg(i, self.spec._value(p, value))
            self.values[name] = value

    def enqueue(self, queue, global_size, local_size):
        if len(self.values) != len(self.index):
            missing = [n for n in self.index if n not in self.values]
            raise TypeError(f"kernel {self.spec.name}: missing {missing}; it takes {', '.join(self.index)}")
        return cl.enqueue_nd_range_kernel(queue, self.kernel, global_size, local_size)
