"""`clrender devices`: list the OpenCL devices and which one is the default."""

from __future__ import annotations

from ..device import get_device, list_devices
from . import add_device_argument

EXAMPLES = """examples:
  clrender devices                     # '* ' marks the device every command uses by default
  clrender devices --device oclgrind   # which device --device oclgrind would pick
"""


def add_parser(sub):
    p = sub.add_parser(
        "devices",
        help="list OpenCL devices (the one --device would pick is marked *)",
        epilog=EXAMPLES,
        description="List the OpenCL devices as '<platform>: <device>'; * marks the one in use.",
    )
    add_device_argument(p)
    p.set_defaults(run=run)


def run(args):
    chosen = get_device(args.device).name
    for name in list_devices():
        print(("* " if name == chosen else "  ") + name)
