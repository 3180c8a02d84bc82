"""Mutation testing: put one small deliberate bug into the code, run the tests that should notice it.

    python -m tools.mutants                  # every mutant, one at a time (from the repository root)
    python -m tools.mutants --list           # the list, and whether each anchor resolves to one line
    python -m tools.mutants --only ID [ID …] # just these (ids or fnmatch patterns, e.g. 'packet-*')
    python -m tools.mutants --jobs 2         # two mutants at a time (the default is 1)
    python -m tools.mutants --only mirror-off --tests test_render.py   # does this file alone catch it?

The mutants are data, in tools/mutants.toml.  Each names a file, an anchor (a function and a
line pattern inside it), the text in that line to replace and its replacement, what the bug is,
and the test files that should catch it.  The anchor resolves in two steps:

1. the function: in a .py file the `def` or `class` of that name (or dotted path, `Class.method`),
   found with ast; in a .cl/.h file the C function whose signature line (at column 0) names it, to
   its closing brace, or the `#define` of that name with its continuation lines;
2. the line: the one line of that function that contains the pattern (plain text, not a regex).

The function must exist exactly once and the pattern occur in exactly one of its lines, and `old`
exactly once in that line (it defaults to the whole pattern); otherwise the mutant is *stale*: it is
never run, `--list` says why, and tests/tools/test_tools.py fails, so a refactor that moves a mutant's
code out from under it fails the suite instead of silently dropping the mutant.  Test files are
named by file name and found anywhere under tests/, so moving them into subfolders keeps them.

The harness snapshots the working tree once (git's tracked files plus untracked ones git does not
ignore, as they are on disk now, uncommitted edits included) into a temporary folder, and for every
mutant copies that snapshot, changes the one line, and runs its test files there with
`python -m pytest -x -q -m "not slow"`, the copy as the working directory and on PYTHONPATH (for
tests that start `python -m clrender` elsewhere), so the copy's clrender/ is imported before the
editable install's, and its kernels/ are built (clrender/package_data.py finds them beside the
package); the harness checks this before it starts, and the `sanity-*` mutants must be killed too.
The repository itself is never modified.

A mutant is *killed* when the tests fail (or time out), *survived* when they pass.  Results go to
out/mutants/mutants.{md,csv}.  Documented in docs/testing.md, with every survivor explained.
"""

from __future__ import annotations

import argparse
import ast
import fnmatch
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import tomllib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
TABLE = Path(__file__).resolve().with_name("mutants.toml")
DEFAULT_PYTHON = ROOT / ".venv" / "bin" / "python"


@dataclass(frozen=True)
class Mutant:
    id: str
    file: str  # path relative to the repository root
    function: str  # the enclosing function (or #define) by name
    line: str  # text that occurs in exactly one line of that function (after `after`'s line, when given)
    old: str  # text in that line to replace (once)
    new: str
    what: str  # the bug, in words
    tests: tuple  # test file names (found under tests/)
    after: str = ""  # text of one line of the function; the mutant's line is then the first match below it


@dataclass(frozen=True)
class Resolution:
    line: int | None  # 0-based index of the line the mutant changes, None when it does not resolve
    problem: str  # why not, "" when it does


# ------------------------------------------------------------------ the table


def load(path: Path = TABLE) -> list[Mutant]:
    """The mutants of tools/mutants.toml, their test groups expanded."""
    data = tomllib.loads(path.read_text())
    groups = data.get("tests", {})

    def expand(names, seen=()):
        out = []
        for name in names:
            if name in groups:
                if name in seen:
                    raise ValueError(f"{path.name}: test group {name!r} includes itself")
                out += expand(groups[name], (*seen, name))
            elif name.endswith(".py"):
                out.append(name)
            else:
                raise ValueError(f"{path.name}: {name!r} is neither a test group ({', '.join(groups)}) nor a .py file")
        return out

    mutants = []
    for row in data["mutant"]:
        unknown = set(row) - {"id", "file", "anchor", "old", "new", "what", "tests"}
        if unknown or not {"function", "line"} <= set(row.get("anchor", {})) <= {"function", "line", "after"}:
            raise ValueError(f"{path.name}: mutant {row.get('id')!r} has keys {sorted(row)} (anchor: function, line, after)")
        anchor = row["anchor"]
        mutants.append(
            Mutant(
                id=row["id"],
                file=row["file"],
                function=anchor["function"],
                line=anchor["line"],
                old=row.get("old", anchor["line"]),
                new=row["new"],
                what=row["what"],
                tests=tuple(dict.fromkeys(expand(row["tests"]))),
                after=anchor.get("after", ""),
            )
        )
    ids = [m.id for m in mutants]
    duplicates = sorted({i for i in ids if ids.count(i) > 1})
    if duplicates:
        raise ValueError(f"{path.name}: duplicate mutant ids {duplicates}")
    return mutants


# ------------------------------------------------------------------ anchors: functions, then lines


def _python_definitions(text: str) -> list[tuple[str, int, int]]:
    """(dotted name, first line, last line) of every def and class, 0-based and inclusive."""
    out = []

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                name = prefix + child.name
                first = min([child.lineno, *(d.lineno for d in child.decorator_list)])
                out.append((name, first - 1, child.end_lineno - 1))
                visit(child, name + ".")
            else:
                visit(child, prefix)

    visit(ast.parse(text), "")
    return out


def _blank_comments_and_strings(text: str) -> str:
    """C text with comments, string and character literals blanked (newlines kept), for brace counting."""

    def blank(m):
        return re.sub(r"[^\n]", " ", m.group(0))

    return re.sub(r'/\*.*?\*/|//[^\n]*|"(?:\\.|[^"\\\n])*"|\'(?:\\.|[^\'\\\n])*\'', blank, text, flags=re.S)


# a function's name, or KIND(name): a function written once and compiled once per kind (kernels/ray_walks.h)
C_SIGNATURE = re.compile(r"^(?!#|return\b|else\b|typedef\b)[A-Za-z_][\w \t\*]*?\b(?:KIND\((\w+)\)|(\w+))\s*\(")
C_DEFINE = re.compile(r"^\s*#\s*define\s+(\w+)")


def _c_definitions(text: str) -> list[tuple[str, int, int]]:
    """(name, first line, last line) of every C function definition and #define, 0-based and inclusive."""
    code = _blank_comments_and_strings(text)
    lines = code.split("\n")
    starts = [0]
    for line in lines:
        starts.append(starts[-1] + len(line) + 1)
    out = []
    for i, line in enumerate(lines):
        m = C_DEFINE.match(line)
        if m:
            last = i
            while lines[last].rstrip().endswith("\\") and last + 1 < len(lines):
                last += 1
            out.append((m.group(1), i, last))
            continue
        m = C_SIGNATURE.match(line)
        if not m:
            continue
        # a definition: its body's `{` comes before any `;` (a prototype or a statement)
        pos = starts[i] + m.end()
        brace, semi = code.find("{", pos), code.find(";", pos)
        if brace < 0 or (0 <= semi < brace):
            continue
        depth, k = 0, brace
        while k < len(code):
            if code[k] == "{":
                depth += 1
            elif code[k] == "}":
                depth -= 1
                if depth == 0:
                    break
            k += 1
        last = code.count("\n", 0, k)
        out.append((m.group(1) or m.group(2), i, last))
    return out


def definitions(file: str, text: str) -> list[tuple[str, int, int]]:
    return _python_definitions(text) if file.endswith(".py") else _c_definitions(text)


def function_spans(file: str, text: str, name: str) -> list[tuple[int, int]]:
    """Line spans of the definitions called `name` (a Python def may be named by its dotted path or its own name)."""
    return [(a, b) for full, a, b in definitions(file, text) if full == name or full.rsplit(".", 1)[-1] == name]


def resolve(m: Mutant, text: str) -> Resolution:
    """The one line of `text` (m.file's contents) that the mutant changes, or why there is none."""
    try:
        spans = function_spans(m.file, text, m.function)
    except SyntaxError as e:
        return Resolution(None, f"{m.file} does not parse ({e.msg}, line {e.lineno})")
    if len(spans) != 1:
        return Resolution(None, f"function {m.function!r} defined {len(spans)} times in {m.file}")
    first, last = spans[0]
    lines = text.split("\n")
    if m.after:  # two identical lines in one function: the first one below a line that tells them apart
        marks = [i for i in range(first, last + 1) if m.after in lines[i]]
        if len(marks) != 1:
            return Resolution(None, f"`after` pattern found in {len(marks)} lines of {m.function}")
        below = [i for i in range(marks[0] + 1, last + 1) if m.line in lines[i]]
        hits = below[:1]
    else:
        hits = [i for i in range(first, last + 1) if m.line in lines[i]]
    if len(hits) != 1:
        return Resolution(None, f"line pattern found in {len(hits)} lines of {m.function}" + (" below `after`" if m.after else ""))
    count = lines[hits[0]].count(m.old)
    if count != 1:
        return Resolution(None, f"old text found {count} times in line {hits[0] + 1}")
    if "\n" in m.new:
        return Resolution(None, "the new text spans lines")
    return Resolution(hits[0], "")


def apply(m: Mutant, text: str) -> str:
    """`text` with the mutant's one line changed; ValueError when its anchor does not resolve."""
    r = resolve(m, text)
    if r.line is None:
        raise ValueError(f"mutant {m.id} is stale: {r.problem}")
    lines = text.split("\n")
    lines[r.line] = lines[r.line].replace(m.old, m.new, 1)
    return "\n".join(lines)


def resolve_in(base: Path, m: Mutant) -> Resolution:
    path = base / m.file
    if not path.is_file():
        return Resolution(None, f"no file {m.file}")
    return resolve(m, path.read_text())


def find_tests(base: Path, names) -> tuple[list[str], list[str]]:
    """(paths relative to base of the named test files found once under tests/, the names not found once)."""
    found, missing = [], []
    for name in names:
        paths = sorted(p for p in (base / "tests").rglob(name) if p.is_file())
        if len(paths) == 1:
            found.append(paths[0].relative_to(base).as_posix())
        else:
            missing.append(name)
    return found, missing


# ------------------------------------------------------------------ the harness


def snapshot(dest: Path) -> int:
    """Copy the working tree (tracked + untracked-not-ignored files, as on disk) to dest."""
    listing = (
        subprocess.run(["git", "ls-files", "-z", "--cached", "--others", "--exclude-standard"], cwd=ROOT, capture_output=True, check=True)
        .stdout.decode()
        .split("\0")
    )
    count = 0
    for rel in filter(None, dict.fromkeys(listing)):
        src = ROOT / rel
        if not src.is_file():  # deleted in the working tree
            continue
        (dest / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(src, dest / rel)
        count += 1
    return count


def pytest_command(python: Path, tests, first_failure_stops=True, deselect=()) -> list:
    return [
        str(python),
        "-m",
        "pytest",
        *(["-x"] if first_failure_stops else []),
        "-q",
        "-rfE",
        "-m",
        "not slow",
        "-p",
        "no:cacheprovider",
        "-p",
        "no:randomly",
        *[f"--deselect={d}" for d in deselect],
        *tests,
    ]


def run_tests(python: Path, cwd: Path, tests, timeout: float, **options):
    """(return code or None on timeout, seconds, output) of the tests run in cwd."""
    # PYTHONPATH too, so tests that start `python -m clrender` in another folder also run the copy
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", PYTHONPATH=str(cwd))
    start = time.perf_counter()
    proc = subprocess.Popen(
        pytest_command(python, tests, **options),
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        start_new_session=True,
    )
    try:
        out, _ = proc.communicate(timeout=timeout)
        rc = proc.returncode
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)  # the test process and anything it started
        out, _ = proc.communicate()
        rc = None
    return rc, time.perf_counter() - start, out


def first_failure(output: str) -> str:
    m = re.search(r"^(?:FAILED|ERROR) (\S+)", output, re.M)
    if m:
        return m.group(1).split(" - ")[0]
    m = re.search(r"^E\s+(.{0,80})", output, re.M)
    return m.group(1).strip() if m else ""


def check_imports(python: Path, copy: Path) -> None:
    """The copy's clrender and kernels are the ones used when running from the copy."""
    code = "import clrender, clrender.device as d; print(clrender.__file__); print(d.kernel_dir())"
    elsewhere = copy.parent  # as a test that runs `python -m clrender` from a temporary folder
    env = dict(os.environ, PYTHONPATH=str(copy))
    out = subprocess.run([str(python), "-c", code], cwd=copy, capture_output=True, text=True, check=True).stdout
    out += subprocess.run([str(python), "-c", code], cwd=elsewhere, env=env, capture_output=True, text=True, check=True).stdout
    paths = [Path(line).resolve() for line in out.split()]
    if not all(copy.resolve() in p.parents for p in paths):
        raise SystemExit(f"mutants: running from {copy} imports {paths}, not the copy; cannot test mutants there")


def run_mutant(m: Mutant, base: Path, work: Path, python: Path, timeout: float, skip=(), deselect=()) -> dict:
    copy = work / m.id
    shutil.copytree(base, copy)
    try:
        target = copy / m.file
        target.write_text(apply(m, target.read_text()))
        tests = [t for t in find_tests(copy, m.tests)[0] if t not in skip]
        if not tests:  # pytest with no file would run the whole suite
            return dict(id=m.id, file=m.file, what=m.what, status="error", seconds=0, detail="no test files")
        rc, seconds, out = run_tests(python, copy, tests, timeout, deselect=[d for d in deselect if d.split("::")[0] in tests])
    finally:
        shutil.rmtree(copy, ignore_errors=True)
    if rc is None:
        status, detail = "killed", f"timeout after {timeout:.0f} s"
    elif rc == 0:
        status, detail = "survived", f"{len(tests)} test files passed"
    elif rc == 5:
        status, detail = "error", "no tests collected"
    else:
        status, detail = "killed", first_failure(out) or f"pytest exit {rc}"
    return dict(id=m.id, file=m.file, what=m.what, status=status, seconds=round(seconds, 1), detail=detail)


def select(mutants, ids) -> list:
    if not ids:
        return list(mutants)
    chosen = [m for m in mutants if any(fnmatch.fnmatchcase(m.id, pattern) for pattern in ids)]
    unknown = [p for p in ids if not any(fnmatch.fnmatchcase(m.id, p) for m in mutants)]
    if unknown:
        raise SystemExit(f"mutants: no mutant matches {', '.join(unknown)} (see --list)")
    return chosen


def markdown(rows) -> str:
    lines = ["| id | file | what it breaks | result | s | first failing test |", "|---|---|---|---|---|---|"]
    lines += [f"| {r['id']} | {r['file']} | {r['what']} | {r['status']} | {r['seconds']} | {r['detail']} |" for r in rows]
    return "\n".join(lines)


def list_mutants(chosen, base: Path) -> int:
    """Print each mutant, where its anchor resolves (or why not), and its test files' state; 1 if any is stale."""
    stale = 0
    for m in chosen:
        r = resolve_in(base, m)
        _, missing = find_tests(base, m.tests)
        where = f"ok, line {r.line + 1}" if r.line is not None else f"STALE: {r.problem}"
        if missing:
            where += f"; test files not found once: {', '.join(missing)}"
        stale += r.line is None
        print(f"{m.id:32s} {m.file}:{m.function}  {where}  ({m.what})")
    print(f"{len(chosen)} mutants, {len(chosen) - stale} resolve to exactly one line, {stale} stale; {len({m.file for m in chosen})} files")
    return 1 if stale else 0


def parse_args(argv=None):
    parser = argparse.ArgumentParser(
        prog="python -m tools.mutants", description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--list", action="store_true", help="list the mutants and whether each anchor resolves, then exit (1 if any is stale)")
    parser.add_argument("--only", nargs="+", metavar="ID", help="run only these mutants (ids or fnmatch patterns)")
    parser.add_argument("--jobs", type=int, default=1, help="mutants run at the same time")
    parser.add_argument("--tests", nargs="+", metavar="FILE", help="test files (names under tests/) to run for every chosen mutant instead")
    parser.add_argument("--timeout", type=float, default=900, help="seconds per mutant before it counts as killed")
    parser.add_argument(
        "--python",
        type=Path,
        default=DEFAULT_PYTHON if DEFAULT_PYTHON.exists() else Path(sys.executable),
        help="interpreter with pytest and the project's dependencies",
    )
    parser.add_argument("--no-baseline", action="store_true", help="skip running the unmutated tests first")
    parser.add_argument("--out", type=Path, default=ROOT / "out" / "mutants", help="folder for mutants.md and mutants.csv")
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error(f"--jobs {args.jobs} must be at least 1")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    mutants = load()
    chosen = select(mutants, args.only)
    if args.tests:
        chosen = [replace(m, tests=tuple(Path(t).name for t in args.tests)) for m in chosen]
    if args.list:
        return list_mutants(chosen, ROOT)

    with tempfile.TemporaryDirectory(prefix="clrender-mutants-") as tmp:
        base, work = Path(tmp) / "base", Path(tmp) / "work"
        base.mkdir()
        work.mkdir()
        n_files = snapshot(base)
        problems = {m.id: resolve_in(base, m).problem for m in chosen}
        runnable = [m for m in chosen if not problems[m.id]]
        stale = [m for m in chosen if problems[m.id]]
        for m in stale:
            print(f"STALE {m.id}: {problems[m.id]}; not run", flush=True)
        print(f"snapshot of {n_files} files in {base}; {len(runnable)} mutants to run, {args.jobs} at a time", flush=True)
        check_imports(args.python, base)
        broken, failing = set(), []
        if not args.no_baseline:
            broken, failing = baseline_failures(args, base, runnable)

        def one(m):
            row = run_mutant(m, base, work, args.python, args.timeout, broken, failing)
            print(f"{row['status']:9s} {m.id:32s} {row['seconds']:6.1f} s  {row['detail']}", flush=True)
            return row

        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            rows = list(pool.map(one, runnable))
    rows += [dict(id=m.id, file=m.file, what=m.what, status="stale", seconds=0, detail=problems[m.id]) for m in stale]
    order = {m.id: i for i, m in enumerate(mutants)}
    rows.sort(key=lambda r: order[r["id"]])
    write_report(args.out, rows, len(stale), sorted(broken) + failing)
    return 0


def baseline_failures(args, base: Path, runnable) -> tuple[set, list]:
    """The unmutated tests' failures: (test files that do not run, failing test ids). A test that fails without any
    mutation would "kill" every mutant: it is deselected (or its whole file left out when the file does not even run)."""
    broken, failing = set(), []
    tests = list(dict.fromkeys(t for m in runnable for t in find_tests(base, m.tests)[0]))
    start = time.perf_counter()
    for t in tests:
        rc, seconds, out = run_tests(args.python, base, [t], args.timeout, first_failure_stops=False)
        if rc == 0:
            continue
        ids = re.findall(r"^FAILED (\S+)", out, re.M)
        if rc == 1 and ids and not re.search(r"^ERROR ", out, re.M):
            failing += ids
            print(f"BASELINE FAILS {len(ids)} test(s) of {t} (e.g. {ids[0]}): deselected for every mutant", flush=True)
        else:
            broken.add(t)
            print(f"BASELINE FAILS {t} (exit {rc}, {first_failure(out)}): left out of every mutant's run", flush=True)
    print(
        f"baseline (no mutation): {len(tests) - len(broken)} of {len(tests)} test files run, "
        f"{len(failing)} failing tests deselected, {time.perf_counter() - start:.0f} s",
        flush=True,
    )
    return broken, failing


def write_report(out: Path, rows: list, n_stale: int, left_out: list) -> None:
    """mutants.md (the summary and the table) and mutants.csv in `out`; both printed."""
    killed = sum(r["status"] == "killed" for r in rows)
    ran = sum(r["status"] in ("killed", "survived") for r in rows)
    summary = (("baseline failures left out: " + ", ".join(left_out) + "\n\n") if left_out else "") + (
        f"{killed} of {ran} mutants killed ({100 * killed / max(ran, 1):.0f}%), "
        f"{sum(r['status'] == 'survived' for r in rows)} survived, {n_stale} stale, "
        f"{sum(r['status'] == 'error' for r in rows)} errors"
    )
    table = markdown(rows)
    out.mkdir(parents=True, exist_ok=True)
    (out / "mutants.md").write_text(f"# Mutants\n\n{summary}\n\n{table}\n")
    import csv

    with open(out / "mutants.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, list(rows[0]) if rows else ["id"])
        writer.writeheader()
        writer.writerows(rows)
    print(table)
    print(summary)


if __name__ == "__main__":
    sys.exit(main())
