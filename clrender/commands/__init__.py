"""One module per CLI subcommand; each defines add_parser(subparsers), which adds its subcommand(s)."""


def add_device_argument(p) -> None:
    """--device, the same on every command that runs kernels."""
    p.add_argument(
        "--device",
        default=None,
        help="OpenCL device, a substring of '<platform>: <device>' as 'clrender devices' lists them "
        "(default: $CLRENDER_DEVICE, else PoCL's CPU device)",
    )


def __getattr__(name):  # submodules load on first use: clrender.commands.X after a plain `import clrender`
    from .. import _submodule

    return _submodule(__name__, name)
