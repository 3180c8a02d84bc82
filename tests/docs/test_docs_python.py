"""The Python the docs show works as written (issue 37): every `clrender` name in a ```python block of README.md and
docs/*.md (and every `clrender.x.y` in their inline code) resolves after a plain `import clrender`, in a fresh
interpreter; blocks whose info string is `python runnable` run, each in a fresh folder (docs/testing.md)."""

import ast
import re
import subprocess
import sys
import textwrap

import pytest

from tests.docstools import DOCS, ROOT, code_blocks

DOTTED = re.compile(r"(?<![\w./])clrender(?:\.[A-Za-z_]\w*)+")
INLINE = re.compile(r"`([^`\n]+)`")


def python_blocks():
    for path in DOCS:
        for line, info, body in code_blocks(path):
            if info and info[0] == "python":
                yield f"{path.relative_to(ROOT)}:{line}", info[1:], "\n".join(body)


def named_in(block: str) -> tuple[set, set]:
    """(modules imported from clrender with the names taken from them, dotted clrender.x.y expressions) of a block."""
    imports, dotted = set(), set(DOTTED.findall(block))
    for node in ast.walk(ast.parse(textwrap.dedent(block))):
        if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "clrender":
            imports.update((node.module, alias.name) for alias in node.names)
    return imports, dotted


def inline_names() -> set:
    """clrender.x.y written in the docs' inline code (calls and attributes, not file paths)."""
    found = set()
    for path in DOCS:
        for span in INLINE.findall(path.read_text(encoding="utf-8")):
            found.update(name for name in DOTTED.findall(span) if not name.endswith((".py", ".md", ".toml")))
    return found


RESOLVE = """
import importlib, sys
import clrender
bad = []
for module, name in {imports!r}:
    try:
        getattr(importlib.import_module(module), name)
    except Exception as exc:
        bad.append(f"from {{module}} import {{name}}: {{exc!r}}")
for dotted in {dotted!r}:
    value = clrender
    try:
        for part in dotted.split(".")[1:]:
            value = getattr(value, part)
    except Exception as exc:
        bad.append(f"{{dotted}}: {{exc!r}}")
print("\\n".join(bad))
"""


def test_every_clrender_name_the_docs_show_resolves_after_a_plain_import():
    imports, dotted = set(), inline_names()
    for _, _, block in python_blocks():
        more_imports, more_dotted = named_in(block)
        imports |= more_imports
        dotted |= more_dotted
    assert "clrender.image.denoise.denoise_result" in dotted and "clrender.image.filters.apply" in dotted
    script = RESOLVE.format(imports=sorted(imports), dotted=sorted(dotted))
    proc = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.strip() == "", f"names the docs show that do not resolve:\n{proc.stdout}"


RUNNABLE = [pytest.param(block, id=where) for where, words, block in python_blocks() if "runnable" in words]


def test_there_are_runnable_python_blocks():
    assert RUNNABLE


@pytest.mark.slow
@pytest.mark.parametrize("block", RUNNABLE)
def test_runnable_python_blocks_run(block, tmp_path):
    proc = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
