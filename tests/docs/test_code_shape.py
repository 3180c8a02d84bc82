"""The code's shape (STYLE.md, issue 34): no host function (clrender/, bench/, tools/) and no kernel function
(kernels/) is longer than 80 lines, and no `__kernel` takes more than 12 arguments.

Python functions are read with `ast` (every def, nested ones and methods included, from the `def` line to the
last line of its body). Kernel sources are scanned on their own here, without clrender's parser: comments, string
literals and preprocessor lines (macros included) blanked, braces matched in every branch of each conditional, and
every `{` at file level that follows a parameter list opens a function, counted from its signature's first line to
its closing brace."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
HOST = [ROOT / name for name in ("clrender", "bench", "tools")]
KERNELS = sorted(p for p in (ROOT / "kernels").iterdir() if p.suffix in (".cl", ".h"))
LONGEST = 80  # lines, signature to last line
MAX_KERNEL_ARGUMENTS = 12

# Functions allowed to be longer for now, each with its reason. An entry whose function has come within the limit
# (or is gone) fails test_every_exemption_is_still_needed, so that it is removed.
EXEMPT: set[str] = set()  # functions allowed past LONGEST while they are being split (none now)


def python_functions(text: str):
    """(qualified name, first line, length) of every function of a Python source."""

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                yield f"{prefix}{child.name}", child.lineno, child.end_lineno - child.lineno + 1
                yield from visit(child, f"{prefix}{child.name}.")
            elif isinstance(child, ast.ClassDef):
                yield from visit(child, f"{prefix}{child.name}.")
            else:
                yield from visit(child, prefix)

    yield from visit(ast.parse(text), "")


def c_lines(text: str):
    """(directive, code) for each line of a C source: the directive's word ("if", "else", "define", ...) on a
    preprocessor line, whose code is then empty (continuation lines too: macros are skipped), else None and the
    line with comments and string or character literals replaced by spaces."""
    keep_lines = lambda m: re.sub(r"[^\n]", " ", m.group(0))  # noqa: E731
    text = re.sub(r"/\*.*?\*/|//[^\n]*|\"(?:\\.|[^\"\\\n])*\"|'(?:\\.|[^'\\\n])*'", keep_lines, text, flags=re.S)
    continued = False
    for line in text.split("\n"):
        directive = continued or line.lstrip().startswith("#")
        word = re.match(r"\s*#\s*(\w*)", line).group(1) if directive and not continued else None
        continued = directive and line.rstrip().endswith("\\")
        yield word, "" if directive else line


def c_functions(text: str):
    """(name, first line, length, declaration) of every function defined at file level of a C source, in every
    branch of its conditionals: each `#elif`/`#else` branch starts at the brace depth its `#if` had, and every branch
    must end at the same depth. A `{` at depth 0 whose declaration ends in a parameter list opens a function (not a
    struct or an initialiser); its first line is that of the declaration's first word after the last `;` or `}`."""
    depth, branches, pending, first, head = 0, [], "", None, None  # branches: [depth at #if, depth a branch ended at]
    for number, (word, code) in enumerate(c_lines(text), start=1):
        if word in ("if", "ifdef", "ifndef"):
            branches.append([depth, None])
        elif word in ("elif", "else", "endif"):
            at, end = branches[-1]
            assert end is None or depth == end, f"line {number}: the branches of a conditional end at different brace depths"
            branches[-1][1], depth = depth, at if word != "endif" else depth
            if word == "endif":
                branches.pop()
        for ch in code + "\n":
            if depth == 0 and ch not in "{};":
                pending += ch
                first = number if first is None and not ch.isspace() else first
            if ch == "{":
                head = (pending, first) if depth == 0 else head
                depth += 1
            elif ch == "}":
                depth -= 1
                assert depth >= 0, f"line {number}: a '}}' closes nothing"
                if depth == 0:
                    signature = re.search(r"(\w+)\s*\(([^()]*(?:\([^()]*\)[^()]*)*)\)\s*$", head[0])
                    if signature:
                        yield signature.group(1), head[1], number - head[1] + 1, head[0]
                    pending, first = "", None
            elif ch == ";" and depth == 0:
                pending, first = "", None
    assert depth == 0 and not branches, "a '{' or an #if left open at the end of the file"


def kernel_arguments(declaration: str) -> int | None:
    """The number of parameters of a `__kernel` declaration, None for any other function."""
    if not re.search(r"\b__kernel\b", declaration):
        return None
    parameters = re.search(r"\(([^()]*)\)\s*$", declaration).group(1)
    return len([p for p in parameters.split(",") if p.strip() not in ("", "void")])


def long_python_functions():
    for path in sorted(p for folder in HOST for p in folder.rglob("*.py")):
        for name, line, length in python_functions(path.read_text(encoding="utf-8")):
            if length > LONGEST:
                yield f"{path.relative_to(ROOT).as_posix()}::{name}", line, length


def test_no_host_function_is_longer_than_80_lines():
    long = [f"{name} (line {line}: {length} lines)" for name, line, length in long_python_functions() if name not in EXEMPT]
    assert not long, f"longer than {LONGEST} lines: {long}"


def test_every_exemption_is_still_needed():
    assert set(EXEMPT) - {name for name, _, _ in long_python_functions()} == set()


@pytest.mark.parametrize("path", KERNELS, ids=[p.name for p in KERNELS])
def test_no_kernel_function_is_longer_than_80_lines(path):
    long = [f"{name} (line {line}: {length} lines)" for name, line, length, _ in c_functions(path.read_text()) if length > LONGEST]
    assert not long, f"{path.name}: longer than {LONGEST} lines: {long}"


@pytest.mark.parametrize("path", KERNELS, ids=[p.name for p in KERNELS])
def test_no_kernel_takes_more_than_12_arguments(path):
    arguments = {name: kernel_arguments(declaration) for name, _, _, declaration in c_functions(path.read_text())}
    too_many = {name: n for name, n in arguments.items() if n is not None and n > MAX_KERNEL_ARGUMENTS}
    assert not too_many, f"{path.name}: kernels with more than {MAX_KERNEL_ARGUMENTS} arguments: {too_many}"


def test_the_scanners_see_what_they_must():
    """The C scan finds functions whatever their return type and in every branch of a conditional, skips macros,
    structs and initialisers, counts lines from the signature to the closing brace and a kernel's parameters; the
    Python scan names methods and nested functions."""
    source = (
        "#define TWICE(x) \\\n  { (x) + (x); }\n"
        "typedef struct { float a; } Rec;\n"
        "__constant float TABLE[2] = {1.0f, 2.0f};\n"
        "/* float commented(void) { */\n"
        "INLINE float3 twice(float3 v,\n"
        "                    int n)\n"
        "{\n"
        '    const char *s = "}";\n'
        "#if A\n    if (n) {\n#else\n    if (!n) {\n#endif\n        v *= 2;\n    }\n"
        "    return v;\n"
        "}\n"
        "#ifdef B\nfloat one(void) { return 1.0f; }\n#else\nfloat one(void)\n{\n    return 2.0f;\n}\n#endif\n"
        "__kernel void k(__global float *a, int n) { a[0] = n; }\n"
    )
    found = [(name, line, length, kernel_arguments(declaration)) for name, line, length, declaration in c_functions(source)]
    assert found == [("twice", 6, 13, None), ("one", 20, 1, None), ("one", 22, 4, None), ("k", 27, 1, 2)]
    tree = "class A:\n    def f(self):\n        def g():\n            pass\n\n        return g\n\n\ndef h():\n    pass\n"
    assert list(python_functions(tree)) == [("A.f", 2, 5), ("A.f.g", 3, 2), ("h", 9, 2)]
