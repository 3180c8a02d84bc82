"""Rules the kernel sources keep (issue 24): every function short enough to read whole, records read by
field name rather than by row number, and contract constants named rather than repeated as bare literals."""

import re

import pytest

from clrender.device import kernel_dir

FILES = sorted(p for p in kernel_dir().iterdir() if p.suffix in (".cl", ".h"))
LONGEST = 80  # lines, signature to closing brace


def functions(text: str):
    """(name, first line, length) of every function defined at column 0 (INLINE helpers and __kernels)."""
    lines = text.split("\n")
    start = None
    for i, line in enumerate(lines):
        if start is None and re.match(r"^(INLINE|__kernel|inline|static)\b[^;]*\(", line) and not line.rstrip().endswith(";"):
            start, name = i, re.search(r"(\w+)\s*\(", line).group(1)
        elif start is not None and line.startswith("}"):
            yield name, start + 1, i - start + 1
            start = None


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_every_kernel_function_fits_on_a_screen(path):
    long = [f"{name} (line {line}: {n} lines)" for name, line, n in functions(path.read_text()) if n > LONGEST]
    assert not long, f"{path.name}: longer than {LONGEST} lines: {long}"


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_records_are_read_by_field_name_not_row_number(path):
    rows = re.findall(r"\b\w+_ROWS?\b", path.read_text())
    assert not rows, f"{path.name} indexes records by row: {sorted(set(rows))}"


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_widening_factors_are_named_not_bare(path):
    """1 + 2 gamma(3) and 1 + 2^-22 (intersect.h's BOX_EXIT_WIDEN, HIT_TIE_WIDEN) appear once each, in their
    #define with its derivation, and nowhere as bare literals in code."""
    code = re.sub(r"/\*.*?\*/", "", path.read_text(), flags=re.S)
    uses = [line.strip() for line in code.splitlines() if re.search(r"(?<![\w.])1\.000000[24]f", line) and not line.lstrip().startswith("#define")]
    assert not uses, f"{path.name}: bare widening factors in {uses}"


@pytest.mark.parametrize("path", FILES, ids=[p.name for p in FILES])
def test_every_include_is_seen_by_the_binary_cache(path):
    """pyopencl's binary cache rebuilds a program when a header it includes changes, but it finds the headers with
    its own pattern, which takes no comment after the file name: an `#include "x.h" /* ... */` line leaves x.h
    untracked, and an edit to x.h alone then runs the old binary."""
    from pyopencl.cache import C_INCLUDE_RE

    lines = [line for line in path.read_text().split("\n") if re.match(r"\s*#\s*include\b", line)]
    unseen = [line for line in lines if not C_INCLUDE_RE.match(line.encode())]
    assert not unseen, f"{path.name}: includes the binary cache does not see (put the comment on the line above): {unseen}"
