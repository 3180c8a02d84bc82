"""clrender's imports go one way (issue 24): no module imports another that imports it back, at the top of
a file or inside a function; in the scene package gltf.py is a reader that returns plain data and imports
nothing from scene.py."""

import ast
import subprocess
import sys
from pathlib import Path

import pytest

import clrender

ROOT = Path(clrender.__file__).parent
MODULES = {".".join(("clrender", *p.relative_to(ROOT).with_suffix("").parts)).removesuffix(".__init__"): p for p in sorted(ROOT.rglob("*.py"))}
SCENE_MODULES = sorted(m.rsplit(".", 1)[1] for m in MODULES if m.startswith("clrender.scene.") and m.count(".") == 2)


def imports(module: str) -> set:
    """The clrender modules that `module` imports anywhere in its source; `from package import name` counts
    as the submodule when `name` is one, else as the package (whose __init__ runs either way)."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([base] if base else []))
            for alias in node.names:
                found.add(f"{base}.{alias.name}" if f"{base}.{alias.name}" in MODULES else base)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
    return (found & set(MODULES)) - {module}


def test_the_package_import_graph_is_acyclic():
    # a package's __init__ may gather its submodules' names; an edge from a submodule to its own package's
    # __init__ ("from . import helper" defined there) is still an edge
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
    scene = "clrender.scene."
    assert scene + "scene" not in imports(scene + "gltf")
    assert scene + "gltf" in imports(scene + "scene")
    for reader in ("checks", "camera", "lights", "materials", "gltf", "confine"):
        assert scene + "scene" not in imports(scene + reader)


@pytest.mark.parametrize("module", SCENE_MODULES)
def test_each_module_imports_first_in_a_fresh_interpreter(module):
    done = subprocess.run([sys.executable, "-c", f"import clrender.scene.{module}"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
