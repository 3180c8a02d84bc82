"""tools/: the mutation kit's anchors resolve on today's code, and render_hashes prints one hash per item.

A mutant of tools/mutants.toml names a function and a line pattern inside it; when a refactor moves
that line away (or makes the pattern ambiguous), the test for that mutant's id fails here, instead of
the mutant going stale silently: re-anchor it in tools/mutants.toml (`python -m tools.mutants --list`).
"""

import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tools import mutants as kit  # noqa: E402

MUTANTS = kit.load()


def test_the_table_loads_with_unique_ids_and_known_files():
    assert len(MUTANTS) >= 100
    assert len({m.id for m in MUTANTS}) == len(MUTANTS)
    assert {m.id for m in MUTANTS} >= {"sanity-kernel", "sanity-host"}
    for m in MUTANTS:
        assert (ROOT / m.file).is_file(), f"{m.id}: no file {m.file}"
        assert m.tests and all(t.endswith(".py") for t in m.tests), m.id


@pytest.mark.parametrize("m", MUTANTS, ids=[m.id for m in MUTANTS])
def test_every_anchor_resolves_to_exactly_one_line_and_the_mutant_changes_only_that_line(m):
    text = (ROOT / m.file).read_text()
    r = kit.resolve(m, text)
    assert r.line is not None, f"{m.id} is stale ({r.problem}): re-anchor it in tools/mutants.toml"
    before, after = text.split("\n"), kit.apply(m, text).split("\n")
    assert len(after) == len(before)
    changed = [i for i, (a, b) in enumerate(zip(before, after)) if a != b]
    assert changed == [r.line]
    assert m.line in before[r.line] and m.old in before[r.line]


@pytest.mark.parametrize("m", MUTANTS, ids=[m.id for m in MUTANTS])
def test_every_mutants_test_files_exist_once_under_tests(m):
    found, missing = kit.find_tests(ROOT, m.tests)
    assert not missing, f"{m.id}: test files {missing} not found once under tests/ (renamed? update tools/mutants.toml)"


def test_list_says_every_mutant_resolves():
    proc = subprocess.run([sys.executable, "-m", "tools.mutants", "--list"], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert f"{len(MUTANTS)} mutants, {len(MUTANTS)} resolve to exactly one line, 0 stale" in proc.stdout
    assert len(re.findall(r"ok, line \d+", proc.stdout)) == len(MUTANTS)


# ---------------------------------------------------------------- the resolver on small files

PY = """\
def f(x):
    y = x + 1
    return y


class A:
    @staticmethod
    def f(x):
        return x * 2

    def g(self):
        return 3
"""

C = """\
/* a comment with a brace { and a prototype-looking line */
INLINE float area(float a, float b);

INLINE float area(float a, float b) {
    const char *s = "}";   /* a brace in a string is not the end */
    if (a > b) {
        return a * b;
    }
    return b * a;
}

__kernel void k(__global float *out,
                int n)
{
    out[0] = area(1.0f, 2.0f);
    out[1] = 1.0f / (n * n);
    out[2] = 1.0f / (n * n);
}

#define SQUARE(x) \\
    ((x) * \\
     (x))
#define CUTOFF 9.0f
"""


def mutant(file, function, line, old=None, new="X", after=""):
    return kit.Mutant("m", file, function, line, line if old is None else old, new, "", ("test_x.py",), after)


@pytest.mark.parametrize(
    "function, line, expected",
    [
        ("f", "y = x + 1", None),  # two defs named f: ambiguous
        ("A.f", "return x * 2", 9),
        ("g", "return 3", 12),
        ("A.g", "return 3", 12),
        ("A", "return 3", 12),  # a class is a function-like scope too
        ("A.g", "return x * 2", None),  # outside g
        ("h", "return 3", None),
    ],
)
def test_python_anchors(function, line, expected):
    r = kit.resolve(mutant("a.py", function, line), PY)
    assert (r.line + 1 if r.line is not None else None) == expected, r.problem


@pytest.mark.parametrize(
    "function, line, after, expected",
    [
        ("area", "return a * b;", "", 7),  # the definition, not the prototype; past the brace in a string
        ("area", "return b * a;", "", 9),
        ("k", "area(1.0f, 2.0f)", "", 15),  # a signature over two lines, its brace on a third
        ("k", "1.0f / (n * n);", "", None),  # two identical lines ...
        ("k", "1.0f / (n * n);", "area(1.0f", 16),  # ... told apart by a line above: the first below it
        ("k", "1.0f / (n * n);", "out[1]", 17),  # (strictly below)
        ("SQUARE", "(x))", "", 22),  # a #define with its continuation lines
        ("CUTOFF", "9.0f", "", 23),
        ("area", "out[0]", "", None),  # not inside area
        ("nothing", "return", "", None),
    ],
)
def test_c_anchors(function, line, after, expected):
    r = kit.resolve(mutant("a.cl", function, line, after=after), C)
    assert (r.line + 1 if r.line is not None else None) == expected, r.problem


def test_old_must_occur_once_in_the_line_and_new_stay_on_it():
    assert kit.resolve(mutant("a.cl", "k", "out[1] = 1.0f / (n * n);", old="n"), C).problem.startswith("old text found 2 times")
    assert kit.resolve(mutant("a.cl", "k", "out[1] = 1.0f / (n * n);", old="(n * n)", new="n;\nn"), C).problem == "the new text spans lines"
    m = mutant("a.cl", "k", "out[1] = 1.0f / (n * n);", old="(n * n)", new="n")
    assert kit.apply(m, C).split("\n")[15] == "    out[1] = 1.0f / n;"
    with pytest.raises(ValueError, match="stale"):
        kit.apply(replace(m, function="nothing"), C)


def test_a_file_that_does_not_parse_is_stale_not_a_crash():
    assert "does not parse" in kit.resolve(mutant("a.py", "f", "x"), "def f(:\n").problem


def test_test_groups_expand_in_order_without_repeats(tmp_path):
    table = tmp_path / "m.toml"
    table.write_text(
        '[tests]\na = ["test_1.py", "test_2.py"]\nb = ["test_3.py", "a"]\n\n'
        '[[mutant]]\nid = "x"\nfile = "f.py"\nanchor = { function = "f", line = "y" }\nnew = "z"\nwhat = "w"\ntests = ["test_2.py", "b"]\n'
    )
    (m,) = kit.load(table)
    assert m.tests == ("test_2.py", "test_3.py", "test_1.py") and m.old == "y"
    table.write_text(table.read_text().replace('tests = ["test_2.py", "b"]', 'tests = ["nope"]'))
    with pytest.raises(ValueError, match="neither a test group"):
        kit.load(table)


# ---------------------------------------------------------------- the README's code map and render_hashes


def test_the_code_map_names_every_file_in_tools():
    readme = (ROOT / "README.md").read_text()
    section = next(line for line in readme.splitlines() if line.startswith("- `tools/`"))
    start = readme.index(section)
    block = readme[start : readme.find("\n- ", start + 1)]
    missing = [p.name for p in sorted((ROOT / "tools").iterdir()) if p.is_file() and f"`{p.name}`" not in block]
    assert not missing, f"README's code map (- `tools/`) does not name {missing}"


def test_render_hashes_prints_one_hash_line_per_item_the_same_each_run():
    command = [sys.executable, "tools/render_hashes.py", "--only", "splat-gauss", "voronoi", "*:refract1"]
    runs = [subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=300) for _ in range(2)]
    for proc in runs:
        assert proc.returncode == 0, proc.stderr
    lines = runs[0].stdout.splitlines()
    assert runs[1].stdout.splitlines() == lines
    rows = [line.split() for line in lines]
    assert all(len(r) == 3 and re.fullmatch(r"[0-9a-f]{64}", r[2]) for r in rows), lines
    items = {(r[0], r[1]) for r in rows}
    assert len(items) == len(rows)  # one line per item
    for aov in ("depth", "normal", "albedo", "id", "edges"):
        assert ("aov:refract1", aov) in items
    assert {r[0] for r in rows} == {"render:refract1", "path:refract1", "aov:refract1", "edges:refract1", "splat-gauss", "voronoi"}
    assert {r[1] for r in rows if r[0] == "path:refract1"} == {"box", "aovs", "tent"}
    assert {r[1] for r in rows if r[0] == "render:refract1"} == {"none", "full", "edge_detect"}
    assert len({r[2] for r in rows if r[0] == "splat-gauss"}) == 4  # both blends' images and gradients differ


# ---------------------------------------------------------------- intel_opencl.py


def test_intel_opencl_keeps_the_icd_files_read_before_and_drops_stale_ones(tmp_path, monkeypatch):
    from tools import intel_opencl

    before, fake_lib = tmp_path / "before", tmp_path / "libother.so"
    before.mkdir()
    fake_lib.write_bytes(b"")
    (before / "other.icd").write_text(f"{fake_lib}\n")
    (before / "by-name.icd").write_text("libOpenCL-vendor.so.1\n")  # a bare name: found on the loader's path
    (before / "gone.icd").write_text(f"{tmp_path / 'missing.so'}\n")
    (before / "intel-cpu.icd").write_text("/opt/build/lib/libintelocl.so\n")  # the package's own, a build machine's path
    monkeypatch.setenv("OCL_ICD_VENDORS", str(before))
    folder, intel = tmp_path / "vendors", tmp_path / "libintelocl.so"
    folder.mkdir()
    (folder / "old.icd").write_text("left from an earlier run\n")
    intel_opencl.write_vendors(folder, {"intel.icd": intel})
    lines = sorted(p.read_text().strip() for p in folder.glob("*.icd"))
    assert lines == sorted([str(intel), str(fake_lib), "libOpenCL-vendor.so.1"])


def test_intel_opencl_prints_an_export_line_or_the_pip_line(tmp_path):
    proc = subprocess.run([sys.executable, "tools/intel_opencl.py", "--dir", str(tmp_path)], cwd=ROOT, capture_output=True, text=True, timeout=60)
    if proc.returncode == 1:  # the runtime is not installed in this environment
        assert "pip install intel-opencl-rt intel-cmplr-lib-rt" in proc.stderr and not proc.stdout
        return
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == f"export OCL_ICD_VENDORS={tmp_path}"
    library = Path((tmp_path / "intel.icd").read_text().strip())
    assert library.name == "libintelocl.so" and library.is_file()
