"""tools/kernel_asm.py: out-of-line calls read from the driver's compiled binary, and the path tracer's hot kernel
holding no call to a math builtin.

Where the device's binaries hold no machine code this tool can read (PoCL's `binaries` and Oclgrind's are LLVM
IR; PoCL's machine code sits in its kernel cache), the device tests skip saying so."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tools import kernel_asm  # noqa: E402

# `objdump -d -r` of two functions, as Intel's runtime compiles a call (callee in the movabs's relocation) and as
# a plain object calls (a direct call whose relocation follows)
OBJDUMP = textwrap.dedent("""\
    0000000000000000 <k>:
       0:|push   %rbp
       4:|movabs $0x0,%rax
    |||6: R_X86_64_64|__ocl_svml_z0_sinf16
       e:|vmovaps %zmm16,%zmm0
      14:|call   *%rax
      16:|vaddps %zmm1,%zmm0,%zmm0{%k1}
      1c:|movabs $0x0,%rcx
    |||1e: R_X86_64_64|.lrodata.cst4
      26:|call   *%rax
      28:|ret
    0000000000000030 <plain>:
      30:|addss  %xmm2,%xmm3
      34:|call   39 <plain+0x9>
    |||35: R_X86_64_PLT32|floorf-0x4
      39:|ret
    """).replace("|", "\t")  # objdump separates with tabs


def test_calls_and_registers_parsed_from_objdump():
    functions = kernel_asm.parse_objdump(OBJDUMP)
    k, plain = functions["k"], functions["plain"]
    assert dict(k.calls) == {"__ocl_svml_z0_sinf16": 2}  # the register still holds the callee at the second call
    assert k.vector_regs == {0, 1, 16} and k.widest == "zmm" and k.mask_regs == {1}
    assert dict(plain.calls) == {"floorf": 1} and plain.widest == "xmm" and plain.vector_regs == {2, 3}


def test_compiled_functions_map_to_their_kernel():
    for compiled in ("render_path", "__Vectorized_.render_path", "_pocl_kernel_render_path_workgroup", "_pocl_kernel_render_path_workgroup_fast"):
        assert kernel_asm.kernel_of(compiled) == "render_path"


SOURCE = """
#define DET_MATH {det}
#include "mathf.h"
__kernel void probe_sin(__global float *x) {{ int i = get_global_id(0); x[i] = SIN(x[i]) + EXP(x[i]); }}
"""


def functions_or_skip(device, det: int):
    program = device.build(SOURCE.format(det=det), "asm_probe.cl")
    functions = kernel_asm.program_functions(program)
    if functions is None:
        pytest.skip(f"{device.name}: its program binaries hold no machine code tools/kernel_asm.py can read")
    return functions


def test_builtin_sin_is_a_call_and_mathf_is_not(device):
    """The tool sees a driver's out-of-line sin and exp (Intel's runtime calls SVML for them), and mathf.h's
    versions leave none."""
    builtin = functions_or_skip(device, 0)["probe_sin"]
    if builtin.call_count == 0:
        pytest.skip(f"{device.name} inlines its sin and exp builtins: nothing to tell apart")
    assert any("sin" in callee for callee in builtin.calls), builtin.calls
    assert functions_or_skip(device, 1)["probe_sin"].call_count == 0


# Calls the path tracer's kernels may keep: Intel's runtime divides 8 or 16 lanes' integers by a library routine (in
# render_path the pixel index to x and y, once a work-item; in render_path_lanes also the texture and environment
# lookups' wrapping remainders).  No float math.
ALLOWED_IN_PATH = {f"__ocl_svml_z0_{op}{n}" for op in ("idiv", "irem", "udiv", "urem") for n in (8, 16)}


@pytest.mark.slow
def test_render_path_calls_no_math_builtin(device):
    """Compiles the path tracer as a render does (the lane schedule, the default on a CPU, or the megakernel); fails when
    its kernel gains an out-of-line call (a builtin sin, exp, memcpy, ...) beyond the integer division above."""
    from clrender.scene.scene import Scene
    from clrender.trace.renderer import Renderer
    from clrender.trace.tracer import Tracer

    from tests.reference import path_scenes

    scene = Scene.from_dict(path_scenes.cornell_box(4))
    Renderer(scene, tracer=Tracer(scene, device=device), integrator="path", spp=1, width=4, height=4, seed=0).run()
    programs = [p for (name, _), p in device._programs.items() if name == "path.cl"]
    assert programs
    for program in programs:
        functions = kernel_asm.program_functions(program)
        if functions is None:
            pytest.skip(f"{device.name}: its program binaries hold no machine code tools/kernel_asm.py can read")
        kernels = [name for name in ("render_path", "render_path_lanes") if name in functions]
        assert kernels
        for name in kernels:
            assert set(functions[name].calls) <= ALLOWED_IN_PATH, (name, dict(functions[name].calls))
