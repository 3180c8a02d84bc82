"""Command-line options for running on a Dask cluster (--scheduler, --workers, --pocl-threads, --stall-timeout).

Commands add these with `add_cluster_arguments(parser)` and get a client (or
None, for this process) from `cluster_client(args)`.  Needs the extra
`pip install 'clrender[distributed]'`; see docs/distributed.md.
"""

from __future__ import annotations

from contextlib import contextmanager


def add_cluster_arguments(p, tiles: bool = True):
    g = p.add_argument_group("cluster (pip install 'clrender[distributed]'; see docs/distributed.md)")
    g.add_argument(
        "--scheduler",
        default=None,
        metavar="ADDRESS",
        help="run on the Dask scheduler at ADDRESS, e.g. tcp://10.0.0.5:8786 (default: $DASK_SCHEDULER_ADDRESS; unset: this process)",
    )
    g.add_argument(
        "--workers",
        type=int,
        default=None,
        metavar="N",
        help="start a Dask LocalCluster of N single-thread worker processes on this machine (default: no local cluster)",
    )
    g.add_argument("--pocl-threads", type=int, default=None, metavar="T", help="PoCL threads per --workers process (default: CPU cores / N)")
    g.add_argument(
        "--stall-timeout",
        default=None,
        metavar="SECONDS",
        help="when no task has finished for SECONDS, ask the scheduler whether it still knows ours and stop "
        "with one line if not (default: $CLRENDER_STALL_TIMEOUT, else 60)",
    )
    if not tiles:
        return
    g.add_argument(
        "--tile-size",
        type=int,
        default=None,
        metavar="PIXELS",
        help="tiles (one task each on a cluster) are PIXELS x PIXELS; the image does not depend on it (default: 128)",
    )


def cluster_requested(args) -> bool:
    from ..distributed.cluster import scheduler_address

    return args.workers is not None or scheduler_address(args.scheduler) is not None


@contextmanager
def cluster_client(args):
    """A dask Client for --scheduler / --workers, or None when neither was asked for."""
    if not cluster_requested(args):
        if getattr(args, "stall_timeout", None) is not None:
            import sys

            sys.stderr.write("warning: --stall-timeout changes nothing without --workers or --scheduler\n")
        yield None
        return
    from dataclasses import replace

    from ..distributed.cluster import connect
    from ..distributed.deadlines import Deadlines, seconds, using

    deadlines = Deadlines.from_env()
    if getattr(args, "stall_timeout", None) is not None:
        deadlines = replace(deadlines, stall=seconds(args.stall_timeout, "--stall-timeout"))
    with using(deadlines), connect(args.scheduler, args.workers, args.pocl_threads, announce=not args.quiet) as client:
        yield client


@contextmanager
def renderer_for(args, scene, settings):
    """The local Renderer, or a DistributedRenderer on the cluster the options name."""
    if getattr(args, "tile_size", None) is not None:
        from dataclasses import replace

        settings = replace(settings, tile_size=args.tile_size)
    with cluster_client(args) as client:
        if client is None:
            from ..trace.renderer import Renderer

            yield Renderer(scene, settings)
        else:
            from ..distributed import DistributedRenderer

            yield DistributedRenderer(scene, settings, client)
