"""Reading a TOML scene file within bounds that are checked before the parser runs.

Python's tomllib keeps, for every dotted key, the prefixes of that key: a key of
k parts costs time and memory in k^2, so a 60 KB line `a.a.a. ... = 1` took 3.6 GB
and 11 s to parse.  No valid scene nests deeper than scene.py's MAX_NESTING, so a
key with more parts than that is refused before parsing, as is a file larger than
MAX_SCENE_BYTES (a scene at scene.py's MAX_VALUES limit is about 10 MB of TOML).
"""

from __future__ import annotations

import functools
import os
import re
import tomllib
from pathlib import Path

from ..errors import UsageError

MAX_SCENE_BYTES = 16 * 2**20  # a TOML scene file; the largest parses in seconds, in under 1 GB

_SEGMENT = r"""(?:[A-Za-z0-9_-]++|"(?:[^"\\\n]|\\.)*+"|'[^'\n]*+')"""  # a bare, basic or literal key part
_STRINGS_AND_COMMENTS = r'''"""(?:[^"\\]|\\.|"(?!""))*+"""|\'\'\'(?:[^']|'(?!''))*+\'\'\'|"(?:[^"\\\n]|\\.)*+"|'[^'\n]*+'|\#[^\n]*+'''


@functools.cache
def _tokens(max_parts: int) -> re.Pattern:
    """A dotted key of more than `max_parts` parts, or a string or comment, matched whole so that nothing
    inside them is taken for a key.  A key starts a line (after `[` or `[[` in a table header) or follows
    `{` or `,` in an inline table."""
    deep = rf"(?P<deep>(?:^|[\[{{,])[ \t\[]*+{_SEGMENT}(?:[ \t]*+\.[ \t]*+{_SEGMENT}){{{max_parts}}})"
    return re.compile(f"{deep}|{_STRINGS_AND_COMMENTS}", re.MULTILINE)


def read_toml(path: Path, where: str, max_key_parts: int) -> dict:
    """The parsed TOML file at `path` (named `where` in messages), refused before parsing when it is larger
    than MAX_SCENE_BYTES or a dotted key has more than `max_key_parts` parts.  Raises tomllib.TOMLDecodeError
    and UnicodeDecodeError as tomllib does."""
    with open(path, "rb") as f:
        # read() of n bytes allocates n at once: ask for the file's size, and never more than the limit
        size = os.fstat(f.fileno()).st_size
        data = f.read(min(size, MAX_SCENE_BYTES) + 1)
        if len(data) > size:  # it grew, or the system does not tell its size (/proc): read on, within the limit
            data += f.read(MAX_SCENE_BYTES + 1 - len(data))
    if len(data) > MAX_SCENE_BYTES:
        raise UsageError(f"{where}: the scene file is larger than {MAX_SCENE_BYTES // 2**20} MiB; allowed: at most {MAX_SCENE_BYTES} bytes")
    text = data.decode("utf-8")  # TOML is UTF-8
    for match in _tokens(max_key_parts).finditer(text):
        if match.group("deep"):
            line = text.count("\n", 0, match.start("deep")) + 1
            raise UsageError(f"{where}: line {line}: a dotted key of more than {max_key_parts} parts; allowed: at most {max_key_parts}")
    return tomllib.loads(text)
