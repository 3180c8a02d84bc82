"""One module per CLI subcommand; each defines add_parser(subparsers), which adds its subcommand(s)."""


def add_device_argument(p) -> None:
    """--device, the same on every command that runs kernels."""
    p.add_argument(
        "--device",
        default=None,
        help="OpenCL device, a substring of '<platform>: <device>' as 'clrender devices' lists them "
        "(default: $CLRENDER_DEVICE, else the fastest CPU driver: 'clrender devices --help')",
    )


def add_foreign_arguments(p, doing: str = "render") -> None:
    """-D and --approximate, for another renderer's scene file (Mitsuba 3 .xml, pbrt-v4 .pbrt: scene/foreign.py)."""
    p.add_argument(
        "-D",
        dest="defines",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a Mitsuba scene's $NAME parameter (repeatable; wins over <default>)",
    )
    p.add_argument(
        "--approximate",
        action="store_true",
        help=f"a foreign scene file: {doing} what clrender cannot read with documented stand-ins (listed on one line) instead of refusing it",
    )


def scene_defaults(args, settings, scene):
    """The scene's own camera, anti-aliasing and path sampler (its `default_camera`, `aa` and `path_sampler` keys) where
    the command line gives none (CAMERA and AA_TYPE are the first positionals); the scene's `aa` only for the Whitted
    integrator."""
    from dataclasses import replace

    given = len(args.positional_args)
    changes = {}
    if args.camera is None and given < 1:
        changes["camera"] = scene.default_camera
    if scene.aa is not None and args.aa is None and given < 2 and settings.integrator == "whitted":
        changes["aa"] = scene.aa
        if args.samples is None and given < 4:  # the default follows the mode, as settings_from_args has it
            changes["samples"] = 1 if scene.aa == "none" else 4
    if scene.path_sampler is not None and getattr(args, "path_sampler", None) is None:
        changes["path_sampler"] = scene.path_sampler
    if scene.path_schedule is not None and getattr(args, "path_schedule", None) is None:
        changes["path_schedule"] = scene.path_schedule
    return replace(settings, **changes)


def __getattr__(name):  # submodules load on first use: clrender.commands.X after a plain `import clrender`
    from .. import _submodule

    return _submodule(__name__, name)
