"""The docs as a newcomer reads them: runnable commands run, links resolve, the README stays short.

A shell code block whose info string is `sh runnable` (```` ```sh runnable ````) in README.md or
docs/*.md is run here, line by line, in a fresh temporary folder, with the interpreter's bin folder
(the venv's `clrender` and `python`) first on PATH and `.venv/bin/` in a command replaced by that
folder. Each command must exit 0 and leave the files it names with `-o`. Mark only commands that
take seconds and need nothing outside the repository (docs/testing.md, "Runnable commands in the
docs"); the set-up commands, which make venvs, are not marked.
"""

import os
import re
import shlex
import subprocess
import sys
import unicodedata
from pathlib import Path

import pytest

from tests.docstools import DOCS, README, ROOT, code_blocks, scan

SHELLS = {"sh", "bash", "shell", "console"}
MARKER = "runnable"
README_MAX_LINES = 150
README_MAX_LINE_CHARS = 200
LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")


def commands(lines):
    """The shell commands of a block: continuation lines joined, blank and comment lines dropped."""
    out, pending = [], ""
    for line in lines:
        if line.rstrip().endswith("\\"):
            pending += line.rstrip()[:-1] + " "
            continue
        command = (pending + line).strip()
        pending = ""
        if command and not command.startswith("#"):
            out.append(command)
    return out


def runnable_blocks():
    found = []
    for path in DOCS:
        for line, info, body in code_blocks(path):
            if info and info[0] in SHELLS and MARKER in info[1:]:
                found.append(pytest.param(commands(body), id=f"{path.relative_to(ROOT)}:{line}"))
    return found


BLOCKS = runnable_blocks()


def named_outputs(command):
    """The paths a command names with -o / --output (what it promises to write)."""
    words = shlex.split(command, comments=True)
    outputs = []
    for i, word in enumerate(words):
        if word in ("-o", "--output") and i + 1 < len(words):
            outputs.append(words[i + 1])
        elif word.startswith("--output="):
            outputs.append(word.split("=", 1)[1])
    return outputs


def test_there_are_runnable_commands_in_the_readme_and_docs():
    ids = [block.id for block in BLOCKS]
    assert any(i.startswith("README.md:") for i in ids), "the README's tour should carry the `sh runnable` marker"
    assert any(i.startswith("docs") for i in ids)


@pytest.mark.slow
@pytest.mark.parametrize("block", BLOCKS)
def test_runnable_commands_run(block, tmp_path):
    bindir = Path(sys.executable).parent  # the venv's bin folder (not resolved: a venv's python is a link)
    env = dict(os.environ, PATH=f"{bindir}{os.pathsep}{os.environ.get('PATH', '')}")
    env.pop("CLRENDER_DEBUG", None)
    assert block, "a block marked runnable holds no command"
    for command in block:
        command = command.replace(".venv/bin/", f"{bindir}/")
        proc = subprocess.run(["bash", "-c", command], cwd=tmp_path, env=env, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, f"{command!r} exited {proc.returncode}:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
        for output in named_outputs(command):
            assert (tmp_path / output).exists(), f"{command!r} did not write {output}"


def test_the_set_up_commands_are_the_readmes_first_code_block_and_ci_runs_the_second():
    """CI and newcomers copy these two lines; .ci/run runs the second one verbatim."""
    first = code_blocks(README)[0]
    lines = [line for line in first[2] if line.strip()]
    assert first[1][:1] == ["sh"] and MARKER not in first[1], "the set-up commands make venvs: not runnable here"
    assert len(lines) == 2
    # with the `fast` extra: Intel's runtime renders where PoCL 3.0 compiles nothing (AMD Zen 5)
    assert lines[0].startswith("python3 -m venv .venv && .venv/bin/pip install -q '.[fast]' && ")
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert lines[1] in ci
    assert lines[1].endswith("-m pytest -q"), "the README's test command names no marker: setup.cfg's addopts pick the fast suite"
    slow = ".venv/bin/python -m pytest -q -m slow"
    assert slow in ci and ci.index(slow) > ci.index(lines[1]), ".ci/run runs the slow tests after the README's command"


def collected(*args):
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pytest",
            "--collect-only",
            "-q",
            "--noconftest",
            "-p",
            "no:randomly",
            "-p",
            "no:cacheprovider",
            *args,
            "tests/docs/test_docs_commands.py",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    return [line for line in proc.stdout.splitlines() if "::" in line]


def test_a_plain_pytest_run_deselects_the_slow_tests_and_minus_m_slow_selects_them():
    """The README's command (no -m) runs the fast suite; `-m slow`, as .ci/run passes it, overrides the default."""
    plain, slow = collected(), collected("-m", "slow")
    assert plain and not any("test_runnable_commands_run" in test for test in plain)
    assert slow and all("test_runnable_commands_run" in test for test in slow)


def test_readme_is_short():
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines; at most {README_MAX_LINES}"
    long = [(n, len(line)) for n, line in enumerate(lines, 1) if len(line) > README_MAX_LINE_CHARS]
    assert not long, f"README.md lines over {README_MAX_LINE_CHARS} characters (line, length): {long}"


def slug(heading):
    """GitHub's anchor for a heading: lower case, punctuation and symbols dropped, spaces to hyphens."""
    text = re.sub(r"`([^`]*)`", r"\1", heading)
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text).strip().lower()
    kept = "".join(c for c in text if c in " -_" or unicodedata.category(c)[0] in "LMN" or unicodedata.category(c) == "Pc")
    return kept.replace(" ", "-")


def anchors(path):
    seen, out = {}, set()
    for _, line, kind, _, _ in scan(path):
        match = HEADING.match(line) if kind == "prose" else None
        if match:
            base = slug(match.group(2))
            count = seen.get(base, 0)
            seen[base] = count + 1
            out.add(base if count == 0 else f"{base}-{count}")
    return out


def links(path):
    """(line number, target) of every Markdown link and image outside code."""
    out = []
    for number, line, kind, _, _ in scan(path):
        if kind == "prose":
            out += [(number, target) for target in LINK.findall(re.sub(r"`[^`]*`", "", line))]
    return out


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(doc):
    broken = []
    for number, target in links(doc):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # https:, mailto: ...
            continue
        file_part, _, fragment = target.partition("#")
        dest = (doc.parent / file_part).resolve() if file_part else doc
        if not dest.exists():
            broken.append(f"{doc.name}:{number}: {target} (no such file)")
        elif fragment and dest.suffix == ".md" and fragment not in anchors(dest):
            broken.append(f"{doc.name}:{number}: {target} (no heading #{fragment})")
    assert not broken, "\n".join(broken)


def code_map_groups():
    """The README's code map: each top-level item's first `path/` and the text of the item and its sub-items."""
    text = README.read_text(encoding="utf-8").split("## Code map", 1)[1].split("\n## ", 1)[0]
    groups, label = {}, None
    for line in text.splitlines():
        if line.startswith("- "):
            match = re.search(r"`([^`]+/)`", line)
            label = match.group(1) if match else None
            groups.setdefault(label, "")
        if label:
            groups[label] += line + "\n"
    return groups


def test_the_code_map_names_every_module_kernel_benchmark_and_reference():
    groups = code_map_groups()
    files = [*ROOT.glob("clrender/**/*.py"), *(p for p in ROOT.glob("kernels/*") if p.is_file()), *ROOT.glob("bench/*.py")]
    files += ROOT.glob("tests/reference/*.py")
    missing = []
    for path in sorted(files):
        if path.name == "__init__.py" and path.parent.parent.name == "clrender":
            continue  # a subpackage's __init__ (the map's first line says what they hold)
        folder = path.parent.relative_to(ROOT).as_posix() + "/"
        labels = [label for label in groups if folder.startswith(label)]
        if not labels or f"`{path.name}`" not in groups[max(labels, key=len)]:
            missing.append(path.relative_to(ROOT).as_posix())
    assert not missing, f"README's code map does not name: {missing}"
