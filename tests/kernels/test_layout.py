"""The values and records shared by host and kernels (clrender/layout.py) reach every kernel build, and no
kernel file keeps a copy of its own: a build without them stops with #error."""

import re

import numpy as np
import pyopencl as cl
import pytest

from clrender import layout
from clrender.device import build_options, kernel_dir
from clrender.trace.tracer import trace_defines

KERNEL_FILES = ("trace.cl", "splat_gauss.cl", "splat_voronoi.cl")
INT_NAMES = [name for name, value in layout.DEFINES.items() if isinstance(value, int)]

N = len(INT_NAMES)
REPORT = f"""
#include "common.h"
#include "sampling.h"
__kernel void report(__global int *ints, __global float *eps) {{
    const int values[] = {{{", ".join(INT_NAMES)}}};
    for (int i = 0; i < {N}; i++) ints[i] = values[i];
    ints[{N}] = (int)(PRIM_ROWS * sizeof(float4));
    ints[{N + 1}] = (int)(MATERIAL_ROWS * sizeof(float4));
    ints[{N + 2}] = (int)(LIGHT_ROWS * sizeof(float4));
    ints[{N + 3}] = (int)(ID_RECORD * sizeof(int));
    eps[0] = EPS;
}}
"""


def test_the_kernels_see_the_hosts_values_and_record_sizes(device):
    program = cl.Program(device.context, REPORT).build(options=[f"-I{kernel_dir()}", *build_options(trace_defines())])
    ints, eps = np.zeros(len(INT_NAMES) + 4, np.int32), np.zeros(1, np.float32)
    ints_buf, eps_buf = device.empty(ints.nbytes), device.empty(eps.nbytes)
    program.report(device.queue, (1,), None, ints_buf, eps_buf)
    cl.enqueue_copy(device.queue, ints, ints_buf)
    cl.enqueue_copy(device.queue, eps, eps_buf)
    assert dict(zip(INT_NAMES, ints.tolist())) == {name: layout.DEFINES[name] for name in INT_NAMES}
    assert ints[-4:].tolist() == [
        layout.PRIM_SLOT_DTYPE.itemsize,
        layout.MATERIAL_DTYPE.itemsize,
        layout.LIGHT_DTYPE.itemsize,
        layout.ID_RECORD_DTYPE.itemsize,
    ]
    assert eps[0] == np.float32(layout.SPLAT_EPS)


def test_every_record_is_as_long_as_the_rows_the_kernels_read():
    from clrender.trace.bvh import NODE_DTYPE

    assert layout.SPLAT_GRAD_DTYPE.itemsize == 4 * layout.SPLAT_NGRAD
    assert layout.ID_RECORD_DTYPE.itemsize == 4 * layout.ID_RECORD
    assert layout.PRIM_SLOT_DTYPE.itemsize == 16 * layout.PRIM_ROWS
    assert layout.MATERIAL_DTYPE.itemsize == 16 * layout.MATERIAL_ROWS
    assert layout.LIGHT_DTYPE.itemsize == 16 * layout.LIGHT_ROWS
    assert NODE_DTYPE.itemsize == 16 * layout.BVH_NODE_ROWS


def test_record_fields_are_whole_float4_rows_in_the_kernels_order():
    for dtype, rows in (
        (layout.LIGHT_DTYPE, layout.LIGHT_ROWS),
        (layout.MATERIAL_DTYPE, layout.MATERIAL_ROWS),
        (layout.PRIM_SLOT_DTYPE, layout.PRIM_ROWS),
    ):
        assert [dtype.fields[name][1] for name in dtype.names] == [16 * row for row in range(rows)]
    assert layout.ID_RECORD_DTYPE.fields["facet"][1] == 4 * layout.PATH_LEN


@pytest.mark.parametrize("filename", KERNEL_FILES)
def test_a_build_without_the_shared_values_stops_with_an_error(device, filename):
    source = (kernel_dir() / filename).read_text()
    with pytest.raises(cl.RuntimeError, match="is missing"):
        cl.Program(device.context, source).build(options=[f"-I{kernel_dir()}", "-cl-std=CL1.2"])


def test_no_kernel_file_defines_a_shared_value_itself():
    pattern = re.compile(r"^\s*#\s*define\s+({})\b".format("|".join(layout.DEFINES)), re.MULTILINE)
    for path in sorted(kernel_dir().glob("*.[ch]*")):
        assert not pattern.findall(path.read_text()), f"{path.name} defines {pattern.findall(path.read_text())}"


def test_a_variant_cannot_override_a_shared_value():
    with pytest.raises(ValueError, match="PATH_LEN"):
        build_options({"PATH_LEN": 4})
