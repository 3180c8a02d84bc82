"""`clrender` command line: subcommands render, convolve, splat {gauss,render,sweep,voronoi}, devices, warmup.

Errors are one line on stderr, `clrender: <what was wrong and what is
allowed>`: exit 2 for bad input (UsageError), 1 for a failure at run time
(RenderFailure, OSError such as a full disk, out of memory), 130 for Ctrl-C,
143 for SIGTERM.  Anything else is a bug: one line says so and how to see
the traceback (--debug or CLRENDER_DEBUG=1).  Each subcommand lives in
clrender/commands/<name>.py and registers itself with
`add_parser(subparsers)`, setting `run` to the function that does the work.
"""

# SIGINT and SIGTERM are handled from the package's first line when clrender runs as a program
# (clrender/__init__.py, which imports nothing heavy); main() takes over with _on_signal.
import os
import signal
import sys

_RUN_AS_PROGRAM = os.path.basename(sys.argv[0] if sys.argv else "") in ("clrender", "clrender.exe", "__main__.py", "-m")

import argparse
import logging
import threading

from . import progress
from .errors import EXIT_FAILURE, EXIT_INTERRUPTED, EXIT_USAGE, STDERR_FD, RenderFailure, UsageError, one_line, shown

EXIT_TERMINATED = 128 + signal.SIGTERM
EXIT_BROKEN_PIPE = 128 + 13  # how a shell reports a tool killed by SIGPIPE (signal.SIGPIPE: not on Windows)


class Terminated(BaseException):
    """SIGTERM, raised like KeyboardInterrupt so cleanup runs on the way out."""


class ArgumentParser(argparse.ArgumentParser):
    """argparse with one-line errors (exit 2) and defaults shown in --help."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message):  # argparse calls this for bad arguments
        sys.stderr.write(f"clrender: {one_line(message)} (see '{self.prog} --help')\n")
        sys.exit(EXIT_USAGE)


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Shows each option's default and keeps worked examples laid out as written."""

    def _get_help_string(self, action):
        # an option whose help states its default in words ("default: the scene's") shows only that,
        # never a second "(default: None)"; positionals and required options have no default
        if "default" in (action.help or "") or not action.option_strings or action.required:
            return action.help
        return super()._get_help_string(action)


def build_parser() -> ArgumentParser:
    from .commands import convert, convolve, devices, render, splat, warmup

    parser = ArgumentParser(
        prog="clrender",
        description="Ray tracing, convolution filters and image splatting on OpenCL (PoCL by default).",
        epilog="example:\n  clrender render refract1 -o refract1.png\n  clrender convolve in.jpg out.jpg box_blur_33",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bars or timings")
    parser.add_argument("-v", "--verbose", action="store_true", help="progress bars even off a terminal")
    parser.add_argument("--debug", action="store_true", help="show the traceback of an unexpected error (also CLRENDER_DEBUG=1)")
    parser.add_argument(
        "--max-memory",
        type=_memory_size,
        default=None,
        metavar="SIZE",
        help="refuse a job whose estimated peak memory exceeds SIZE (e.g. 2G; also CLRENDER_MAX_MEMORY) (default: the memory available now)",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=ArgumentParser)
    sub.required = True
    for module in (render, convert, convolve, splat, devices, warmup):
        module.add_parser(sub)
    return parser


def _memory_size(text: str) -> int:
    from .memory import parse_size

    try:
        return parse_size(text)
    except UsageError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def main(argv=None) -> int:
    """Run one command; every failure ends here as one line and an exit code."""
    code = _main(argv)
    if _RUN_AS_PROGRAM and argv is None:
        # Leave now: interpreter shutdown (PoCL's teardown, a fraction of a second) runs with the
        # default signal actions, so a Ctrl-C then would kill the finished program silently (-2).
        try:
            sys.stdout.flush()
        except OSError:  # the reader of our stdout has gone (`| head`): quiet, as Unix tools are
            code = _quiet_broken_pipe() if _stdout_is_closed_pipe() else code
        try:
            sys.stderr.flush()
        except OSError:  # a closed pipe: nothing more can be said
            pass
        os._exit(code)
    return code


def _main(argv) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv or os.environ.get("CLRENDER_DEBUG", "") not in ("", "0")
    argv = _global_options_first(argv)
    with _signals_raise():
        try:
            return _run(argv)
        except SystemExit as exc:  # argparse: --help (0) or a bad argument (2, its line already written)
            return exc.code if isinstance(exc.code, int) else EXIT_USAGE
        except KeyboardInterrupt:
            return _fail("interrupted", EXIT_INTERRUPTED)
        except Terminated:
            return _fail("terminated", EXIT_TERMINATED)
        except UsageError as exc:
            return _fail(str(exc), EXIT_USAGE)
        except RenderFailure as exc:
            return _fail(str(exc), EXIT_FAILURE)
        except BrokenPipeError as exc:
            if not _stdout_is_closed_pipe():  # another pipe (an encoder's stdin): a failure like any
                if debug:
                    raise
                return _fail(describe_os_error(exc), EXIT_FAILURE)
            return _quiet_broken_pipe()
        except MemoryError:
            if debug:
                raise
            return _fail("out of memory; use a smaller image or fewer primitives (see --max-memory)", EXIT_FAILURE)
        except OSError as exc:
            if debug:
                raise
            return _fail(describe_os_error(exc), EXIT_FAILURE)
        except Exception as exc:
            if debug:
                raise
            if _is_device_error(exc):
                return _fail(f"OpenCL failed: {exc}", EXIT_FAILURE)
            return _fail(
                f"internal error (a bug in clrender): {type(exc).__name__}: {exc}; run again with --debug or CLRENDER_DEBUG=1 for the traceback",
                EXIT_FAILURE,
            )


_FLAGS_ANYWHERE = ("--debug", "-q", "--quiet", "-v", "--verbose")


def _global_options_first(argv: list) -> list:
    """--debug, -q, -v and --max-memory are accepted anywhere on the line (e.g. after the subcommand,
    where no subcommand has options of those names), up to a `--` that ends the options."""
    front, rest, i = [], [], 0
    while i < len(argv):
        a = argv[i]
        if a == "--":
            rest += argv[i:]
            break
        if a in _FLAGS_ANYWHERE or a.startswith("--max-memory="):
            front.append(a)
        elif a == "--max-memory" and i + 1 < len(argv):
            front += argv[i : i + 2]
            i += 1
        else:
            rest.append(a)
        i += 1
    return front + rest


def _run(argv) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    import numpy  # noqa: F401 - loaded now, so that threadpool_limits finds its BLAS
    from threadpoolctl import threadpool_limits

    from . import memory

    # --max-memory and -q/-v hold for this command only: a program (or a test) that runs several commands
    # and then the library in one process keeps its own settings
    before = memory.MAX_MEMORY, progress.SHOW
    memory.MAX_MEMORY = args.max_memory
    if args.quiet:
        progress.SHOW = False
    elif args.verbose:
        progress.SHOW = True
    _show_library_notes(quiet=args.quiet)
    # numpy's OpenBLAS threads spin-wait after a matrix product and steal the cores PoCL runs the
    # kernels on; the host work never needs them.  Scoped to the command, not the environment.
    try:
        with threadpool_limits(limits=1, user_api="blas"):
            return int(args.run(args) or 0)
    finally:
        memory.MAX_MEMORY, progress.SHOW = before


class _StderrHandler(logging.StreamHandler):
    """Writes to whatever sys.stderr is when a record comes (tests swap it)."""

    @property
    def stream(self):
        return sys.stderr

    @stream.setter
    def stream(self, value):
        pass


def _show_library_notes(quiet: bool) -> None:
    """The library logs its notes (logging.getLogger("clrender....")); the command line shows them on
    stderr as plain lines, unless --quiet (warnings still show)."""
    log = logging.getLogger("clrender")
    if not any(isinstance(h, _StderrHandler) for h in log.handlers):
        handler = _StderrHandler()
        handler.setFormatter(logging.Formatter("%(message)s"))
        log.addHandler(handler)
        log.propagate = False
    log.setLevel(logging.WARNING if quiet else logging.INFO)


def describe_os_error(exc: OSError) -> str:
    """'cannot write out.png: No space left on device', never an empty reason."""
    reason = exc.strerror or str(exc) or type(exc).__name__
    name = exc.filename
    if isinstance(name, str) and name.startswith("/proc/self/fd/"):
        name = None  # a temp file's handle says nothing to the user
    return f"{shown(name)}: {reason}" if name else reason


def _stdout_is_closed_pipe() -> bool:
    """True when stdout is a pipe whose reader has gone (`clrender render --list | head -1`):
    poll reports POLLERR on such a pipe, never on a file, terminal or open pipe."""
    import select

    try:
        poll = select.poll()
        poll.register(sys.stdout.fileno(), select.POLLOUT)
        return any(events & select.POLLERR for _, events in poll.poll(0))
    except (AttributeError, OSError, ValueError):  # no poll (Windows), no file descriptor (a test's capture)
        return False


def _quiet_broken_pipe() -> int:
    """Exit as a Unix tool whose reader went away: no message, 141.  stdout now points at devnull
    (Python's advice), so the flush at interpreter exit cannot fail a second time."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):
        pass
    return EXIT_BROKEN_PIPE


def _is_device_error(exc: Exception) -> bool:
    return type(exc).__module__.split(".")[0] in ("pyopencl",)


def _fail(message: str, code: int) -> int:
    sys.stderr.write(f"clrender: {one_line(message)}\n")
    sys.stderr.flush()
    return code


class _signals_raise:
    """While main() runs, SIGINT and SIGTERM end the command (main thread only).

    As the program: one line and exit 130/143 at once, temp files discarded; an exception
    raised at a random bytecode can break a C extension's import (nanobind aborts).  Called
    in-process (tests, scripts): KeyboardInterrupt / Terminated, caught by main().  Either way
    a signal that arrives while outputs are being put in place waits until they all are.
    """

    def __enter__(self):
        self.saved = {}
        if threading.current_thread() is threading.main_thread():
            for signum in (signal.SIGINT, signal.SIGTERM):
                if signal.getsignal(signum) is signal.SIG_IGN:
                    continue  # ignored when we started (nohup, a background job of a script): keep it so
                self.saved[signum] = signal.signal(signum, _on_signal)
                if _RUN_AS_PROGRAM:  # signal.signal() drops SA_RESTART; EINTR would fail a kernel build
                    signal.siginterrupt(signum, False)
        return self

    def __exit__(self, *exc):
        for signum, handler in self.saved.items():
            signal.signal(signum, handler)
        return False


def _on_signal(signum, frame):
    # no import here: the signal may arrive while clrender.outputs itself is being imported
    outputs = sys.modules.get("clrender.outputs")
    hold = getattr(outputs, "hold_signal", None)
    if hold is not None and hold(signum):
        return
    if _RUN_AS_PROGRAM:
        discard = getattr(outputs, "discard_all", None)
        if discard is not None:
            discard()
        os.write(STDERR_FD[0], b"clrender: interrupted\n" if signum == signal.SIGINT else b"clrender: terminated\n")
        os._exit(128 + signum)
    raise KeyboardInterrupt() if signum == signal.SIGINT else Terminated()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
