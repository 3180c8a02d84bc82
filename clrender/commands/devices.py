"""`clrender devices`: list the OpenCL devices, which one is the default, and each CPU driver's measured speed."""

from __future__ import annotations

import sys

from .. import device_speed
from ..device import _cannot_compile, _describe, all_devices, cpu_devices, default_device_name, is_simulator
from . import add_device_argument

EXAMPLES = """examples:
  clrender devices                     # '* ' marks the device every command uses by default
  clrender devices --measure           # time a small render on each CPU driver (cached), then list
  CLRENDER_DEVICE=oclgrind clrender devices   # Oclgrind, the checker, seen and picked
"""

DESCRIPTION = """List the OpenCL devices as '<platform>: <device>'; * marks the one in use.  A CPU device's
measured speed follows in brackets where one is cached for its driver version and this CPU.
The default device, when neither --device nor $CLRENDER_DEVICE names one, is the first CPU driver
that compiles, in the order Intel's OpenCL CPU runtime, PoCL, others; a driver measured more than 10%
faster (by the geometric mean of its two rates) than that order's first, itself measured, goes first.
Oclgrind, the OpenCL simulator that checks every memory access, is seen only with
CLRENDER_DEVICE=oclgrind, and listed as the checker."""


CHECKER_NOTE = "the checker: a simulator that checks every memory access; never the default, never measured"


def add_parser(sub):
    p = sub.add_parser(
        "devices",
        help="list OpenCL devices (the one --device would pick is marked *) and CPU drivers' measured speeds",
        epilog=EXAMPLES,
        description=DESCRIPTION,
    )
    add_device_argument(p)
    p.add_argument(
        "--measure",
        action="store_true",
        help="render a small fixed path-traced and Whitted workload on each CPU device (compile apart, median of "
        f"{device_speed.RUNS} runs) and cache the result; later runs show it without measuring",
    )
    p.set_defaults(run=run)


def run(args):
    notes = measure_all() if args.measure else {}
    cached = device_speed.load()
    speeds = {_describe(d): cached.get(device_speed.key(d)) for d in cpu_devices()}
    chosen = default_device_name(args.device)
    for dev in all_devices():
        name = _describe(dev)
        line = ("* " if name == chosen else "  ") + name
        if is_simulator(dev):
            line += f"  [{CHECKER_NOTE}]"
        elif speeds.get(name) is not None:
            line += f"  [{speeds[name].describe()}]"
        elif name in notes:
            line += f"  [{notes[name]}]"
        print(line)


def measure_all() -> dict[str, str]:
    """Measure and cache every CPU device that compiles; '<platform>: <device>' -> why not, for the others."""
    notes = {}
    for dev in cpu_devices():
        name = _describe(dev)
        reason = _cannot_compile(dev)
        if reason is not None:
            notes[name] = f"not measured: {reason}"
            continue
        if sys.stderr.isatty():
            sys.stderr.write(f"clrender: measuring {name} (the first time compiles kernels)...\n")
        device_speed.save(dev, measure(name))
    return notes


def measure(spec: str, runs: int = device_speed.RUNS) -> device_speed.Speed:
    """Render device_speed.WORKLOAD on the device `spec` names: one untimed run (compiles), then the median of `runs` trace times."""
    import statistics

    from ..trace.renderer import Renderer

    def median_rate(settings: dict, work) -> float:
        Renderer("refract1", device=spec, **settings).run()  # compile; pyopencl keeps the binary for next time
        rates = []
        for _ in range(runs):
            result = Renderer("refract1", device=spec, **settings).run()
            rates.append(work(result) / max(result.timings["trace"], 1e-9) / 1e6)
        return statistics.median(rates)

    p = device_speed.WORKLOAD["path"]
    path = median_rate(p, lambda r: p["width"] * p["height"] * r.samples_per_pixel)
    whitted = median_rate(device_speed.WORKLOAD["whitted"], lambda r: r.rays)
    return device_speed.Speed(path, whitted)
