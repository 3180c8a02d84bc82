"""The tests mirror the package (issue 24): each test file sits in a folder named for what it tests, and no
test module imports another (shared oracles live in tests/reference/, shared helpers in tests/*tools.py)."""

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parents[1]
FOLDERS = {"trace", "scene", "image", "splat", "cli", "distributed", "outputs", "kernels", "docs", "tools", "bench", "packaging"}


def test_every_test_file_is_in_a_package_folder():
    misplaced = [p.relative_to(TESTS).as_posix() for p in TESTS.rglob("test_*.py") if p.parent.name not in FOLDERS]
    assert not misplaced


def test_no_test_module_imports_another():
    offenders = []
    for path in TESTS.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [node.module or ""] if isinstance(node, ast.ImportFrom) else [a.name for a in getattr(node, "names", [])]
            names += [a.name for a in node.names] if isinstance(node, ast.ImportFrom) else []
            if isinstance(node, (ast.Import, ast.ImportFrom)) and any(n.split(".")[-1].startswith("test_") for n in names):
                offenders.append(path.relative_to(TESTS).as_posix())
    assert not offenders
