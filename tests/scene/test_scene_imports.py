"""The scene package's imports go one way (issue 24): gltf.py is a reader that returns plain data and
imports nothing from scene.py, and no module of clrender/scene imports another that imports it back,
at the top of a file or inside a function."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import clrender.scene

PACKAGE = Path(clrender.scene.__file__).parent
MODULES = sorted(p.stem for p in PACKAGE.glob("*.py") if p.stem != "__init__")


def imports(module: str) -> set:
    """The modules of clrender/scene that `module` imports anywhere in its source (relative or absolute)."""
    tree = ast.parse((PACKAGE / f"{module}.py").read_text(encoding="utf-8"))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 1 or node.module and node.module.startswith("clrender.scene"):
                base = (node.module or "") if node.level == 1 else node.module.removeprefix("clrender.scene").lstrip(".")
                if base:
                    found.add(base.split(".")[0])
                else:  # from . import gltf
                    found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.Import):
            found.update(a.name.split(".")[2] for a in node.names if a.name.startswith("clrender.scene."))
    return found & set(MODULES)


def test_the_scene_package_import_graph_is_acyclic():
    graph = {m: imports(m) for m in MODULES}
    done, on_path = set(), []

    def visit(module):
        if module in on_path:
            cycle = on_path[on_path.index(module) :] + [module]
            pytest.fail(f"import cycle: {' -> '.join(cycle)}")
        if module in done:
            return
        on_path.append(module)
        for other in sorted(graph[module]):
            visit(other)
        on_path.pop()
        done.add(module)

    for module in MODULES:
        visit(module)


def test_gltf_reads_files_without_scene_and_scene_imports_gltf():
    assert "scene" not in imports("gltf")
    assert "gltf" in imports("scene")
    assert "scene" not in set().union(*(imports(m) for m in ("checks", "camera", "lights", "materials", "gltf", "confine")))


@pytest.mark.parametrize("module", MODULES)
def test_each_module_imports_first_in_a_fresh_interpreter(module):
    done = subprocess.run([sys.executable, "-c", f"import clrender.scene.{module}"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
