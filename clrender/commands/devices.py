"""`clrender devices`: list the OpenCL devices and which one is the default."""
from __future__ import annotations

from ..device import get_device, list_devices


def add_parser(sub):
    p = sub.add_parser("devices", help="list OpenCL devices (the one --device would pick is marked *)")
    p.add_argument("--device", default=None, help="substring of '<platform>: <device>' (default: $CLRENDER_DEVICE, else PoCL CPU)")
    p.set_defaults(run=run)


def run(args):
    chosen = get_device(args.device).name
    for name in list_devices():
        print(("* " if name == chosen else "  ") + name)
