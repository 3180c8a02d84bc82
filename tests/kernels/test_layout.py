"""The values and records shared by host and kernels (clrender/layout.py) reach every kernel build as one
generated header, the kernels see each record exactly as numpy packs it, and no kernel file keeps a copy
of its own: a build without the header stops with #error."""

import re

import numpy as np
import pyopencl as cl
import pytest

from clrender import layout
from clrender.device import build_options, kernel_dir
from clrender.trace.tracer import trace_defines

KERNEL_FILES = ("trace.cl", "splat_gauss.cl", "splat_voronoi.cl", "bvh_build.cl")
INT_NAMES = [name for name, value in layout.DEFINES.items() if isinstance(value, int)]


def _fields(record):
    return sorted(record.dtype.fields.items(), key=lambda item: item[1][1])


def _probe_source() -> str:
    """A kernel writing, for every record, sizeof and each field's offset (pyopencl's match_dtype_to_c_struct way)."""
    lines, at = [], 0
    for record in layout.records():
        lines.append(f"{{ {record.c_name} x; out[{at}] = (int)sizeof(x);")
        at += 1
        for name, _ in _fields(record):
            lines.append(f"  out[{at}] = (int)((char *)&x.{name} - (char *)&x);")
            at += 1
        lines.append("}")
    values = ", ".join(INT_NAMES)
    return (
        '#include "common.h"\n__kernel void probe(__global int *out, __global int *ints, __global float *eps) {\n'
        + "\n".join(lines)
        + f"\n const int values[] = {{{values}}};\n for (int i = 0; i < {len(INT_NAMES)}; i++) ints[i] = values[i];\n eps[0] = SPLAT_EPS;\n}}\n"
    )


def test_the_kernels_see_every_record_as_numpy_packs_it_and_the_hosts_values(device):
    expected = []
    for record in layout.records():
        expected.append((record.c_name, "sizeof", record.dtype.itemsize))
        expected += [(record.c_name, name, offset) for name, (_, offset) in _fields(record)]
    program = device.build(_probe_source(), "layout probe", trace_defines())
    out, ints, eps = np.zeros(len(expected), np.int32), np.zeros(len(INT_NAMES), np.int32), np.zeros(1, np.float32)
    bufs = [device.empty(a.nbytes) for a in (out, ints, eps)]
    program.probe(device.queue, (1,), None, *bufs)
    for host, buf in zip((out, ints, eps), bufs):
        cl.enqueue_copy(device.queue, host, buf)
    assert [(c, n, int(v)) for (c, n, _), v in zip(expected, out)] == expected
    assert dict(zip(INT_NAMES, ints.tolist())) == {name: layout.DEFINES[name] for name in INT_NAMES}
    assert eps[0] == np.float32(layout.SPLAT_EPS)


def test_a_struct_is_generated_field_by_field_with_vectors_aligned():
    record = layout.Record("Probe", np.dtype({"names": ["a", "v"], "formats": ["<f4", ("<f4", 4)], "offsets": [0, 16], "itemsize": 32}), ("v",))
    assert layout.c_struct(record) == "typedef struct {\n    float a;\n    char _pad4[12];\n    float4 v;\n} Probe;"
    misaligned = layout.Record("Bad", np.dtype([("a", "<f4"), ("v", "<f4", 4)]), ("v",))
    with pytest.raises(TypeError, match="multiple of its size"):
        layout.c_struct(misaligned)
    with pytest.raises(TypeError, match="no C type"):
        layout.c_struct(layout.Record("Wide", np.dtype([("a", "<f8")])))


@pytest.mark.parametrize("filename", KERNEL_FILES)
def test_a_build_without_the_shared_header_stops_with_an_error(device, filename):
    source = (kernel_dir() / filename).read_text()
    with pytest.raises(cl.RuntimeError, match="header is missing"):
        cl.Program(device.context, source).build(options=[f"-I{kernel_dir()}", "-cl-std=CL1.2", *build_options(trace_defines())])


def test_no_kernel_file_defines_a_shared_value_or_record_itself():
    names = [*layout.DEFINES, *(record.c_name for record in layout.records())]
    pattern = re.compile(r"^\s*#\s*define\s+({0})\b|}}\s*({0})\s*;".format("|".join(names)), re.MULTILINE)
    for path in sorted(kernel_dir().glob("*.[ch]*")):
        assert not pattern.findall(path.read_text()), f"{path.name} defines {pattern.findall(path.read_text())}"


def test_a_variant_cannot_override_a_shared_value():
    with pytest.raises(ValueError, match="PATH_LEN"):
        build_options({"PATH_LEN": 4})
