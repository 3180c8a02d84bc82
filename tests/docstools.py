"""The docs' Markdown as the docs tests read it (tests/docs/): the pages, and their fenced code blocks."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = [README, *sorted((ROOT / "docs").glob("*.md"))]
FENCE = re.compile(r"^(```+|~~~+)\s*(.*)$")


def scan(path):
    """(line number, line, the open fence's info words or None, the block's opening line) for each line."""
    fence, info, start = None, [], 0
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        stripped = line.strip()
        match = FENCE.match(stripped)
        if fence is None and match:
            fence, info, start = match.group(1), match.group(2).split(), number
            yield number, line, "open", start, info
        elif fence is not None and stripped.startswith(fence) and not stripped[len(fence) :].strip():
            fence = None
            yield number, line, "close", start, info
        else:
            yield number, line, "code" if fence else "prose", start, info


def code_blocks(path):
    """(line number of the opening fence, info string words, lines) of each fenced block."""
    blocks = {}
    for _, line, kind, start, info in scan(path):
        if kind == "open":
            blocks[start] = (start, info, [])
        elif kind == "code":
            blocks[start][2].append(line)
    return list(blocks.values())
