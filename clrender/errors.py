"""The kinds of failure the command line tells apart, and how values are shown in messages.

`UsageError` is bad input (a value the user can fix): the CLI prints one line
and exits 2.  `RenderFailure` is something that went wrong at run time
(a kernel build failed, the device ran out of memory): exit 1.  An OSError
(disk full, folder not writable) is a run-time failure too.  Anything else
is a bug: the CLI says so in one line and `--debug` shows the traceback.
"""

import contextlib
import os
import sys
import tempfile
import unicodedata

EXIT_USAGE = 2
EXIT_FAILURE = 1
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report it
MAX_SHOWN = 200  # characters of any echoed value kept in a message
# The terminal's stderr while a C library's messages are being caught (library_messages redirects fd 2 for a
# moment): a signal handler that says "interrupted" must write there, not into the catch.
STDERR_FD = [2]


def first_line(*texts: str, prefer: str = "") -> str:
    """The first non-empty line among the texts (libraries report one fault in several lines), or the
    first that contains `prefer` when one does (a compiler log's first "error:" line)."""
    lines = [line.strip() for text in texts for line in (text or "").splitlines() if line.strip()]
    return next((line for line in lines if prefer and prefer in line), lines[0] if lines else "")


class _Said:
    text = ""


@contextlib.contextmanager
def library_messages():
    """Catch what C libraries (libpng, the OpenCL compiler) print straight to stderr, so the CLI's error
    stays one line.  The yielded object's `text` holds the captured output once the block ends."""
    said = _Said()
    try:
        saved = os.dup(2)
    except OSError:
        yield said
        return
    with tempfile.TemporaryFile() as sink:
        try:
            sys.stderr.flush()
            STDERR_FD[0] = saved
            os.dup2(sink.fileno(), 2)
            yield said
        finally:
            os.dup2(saved, 2)
            STDERR_FD[0] = 2
            os.close(saved)
            sink.seek(0)
            said.text = sink.read(4096).decode("utf-8", "replace")


class UsageError(ValueError):
    """Bad input: the message names the value and what is allowed."""


class RenderFailure(RuntimeError):
    """A failure at run time that is not the user's input."""


class RenderWarning(UserWarning):
    """A request that changes nothing or a doubtful input that still renders (the CLI shows a `warning:` line)."""


def warn(message: str) -> None:
    """A RenderWarning pointed at the first caller outside clrender, so Python shows the user's line."""
    import warnings

    frame, level = sys._getframe(0), 1
    while frame.f_back is not None and frame.f_code.co_filename.startswith(_PACKAGE_DIR):
        frame, level = frame.f_back, level + 1
    warnings.warn(RenderWarning(message), stacklevel=level)


_PACKAGE_DIR = os.path.dirname(os.path.abspath(__file__)) + os.sep


def require(condition: bool, message: str) -> None:
    """Raise UsageError(message) unless condition holds."""
    if not condition:
        raise UsageError(message)


def escaped(text: str) -> str:
    """Control, format (bidi overrides such as U+202E, zero-width marks), line/paragraph separator and
    lone surrogate characters as escapes (ESC as \\x1b, newline as \\n, U+202E as \\u202e), so a
    message stays one inert line that reads in the order it is written.  The one rule for every
    message (scene.escape is this function)."""
    out = []
    for ch in str(text):
        if ch in _NAMED_ESCAPES:
            out.append(_NAMED_ESCAPES[ch])
        elif unicodedata.category(ch) in _ESCAPED_CATEGORIES:
            code = ord(ch)
            out.append(f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}")
        else:
            out.append(ch)
    return "".join(out)


_NAMED_ESCAPES = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}
# Cc control, Cf format (bidi controls), Zl/Zp line and paragraph separators, Cs lone surrogates
# (undecodable bytes in a file name)
_ESCAPED_CATEGORIES = ("Cc", "Cf", "Zl", "Zp", "Cs")


def cut(text: str, limit: int = MAX_SHOWN) -> str:
    """At most `limit` characters, saying how much was left out."""
    text = str(text)
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text) - limit} more characters)"


def shown(value, limit: int = MAX_SHOWN) -> str:
    """A value as a message quotes it: repr-style quotes, escaped, cut to `limit` characters."""
    text = escaped(value if isinstance(value, str) else str(value))
    return "'" + cut(text, limit) + "'"


def value_shown(value) -> str:
    """A value as a message names it: numbers, booleans and None as written (3, 2.5, True), anything
    else quoted like shown() (so the string '3' is told from the number 3)."""
    if type(value).__module__ == "numpy" and getattr(value, "shape", None) == ():
        value = value.item()  # a numpy scalar reads as the number it holds
    if value is None or isinstance(value, (bool, int, float)):
        return str(value)
    return shown(value)


def one_line(message: str, limit: int = 4 * MAX_SHOWN) -> str:
    """A whole message made safe for one terminal line."""
    return cut(escaped(message), limit)


def real_array(value, name: str):
    """`value` as a numpy array of real numbers (integers or floats, not bool, complex, text or objects), or UsageError."""
    import numpy as np  # here, not at the top: the command line's parser imports this module before anything heavy

    try:
        a = np.asarray(value)
    except (ValueError, TypeError):  # a ragged list
        raise UsageError(f"{name} must be an array of real numbers; got a ragged sequence") from None
    if a.dtype.kind not in "iuf":
        raise UsageError(f"{name} must be real numbers; got an array of {a.dtype} of shape {a.shape}")
    return a
