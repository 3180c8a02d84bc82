"""The command line under hostile input: docs/errors-and-writes.md's promise, checked on reproducers and by hypothesis.

The promise: any argument list ends with exit 0, 1 (run-time failure) or 2 (bad input); an error is
exactly one `clrender: ...` line on stderr with control characters escaped; never a traceback; and
a command that fails leaves the folder as it was (no partial output, no temp file).

The first half pins each defect of issue 14 as a test; the second half generates argument lists
for every subcommand (profile ci: ~150 cases; --hypothesis-profile=long: 2,000+) and damaged
.npz / image files.
"""

from __future__ import annotations

import os
import signal
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest

from clrender.cli import main
from clrender.image.files import read_image, write_image
from clrender.outputs import TEMP_MARK

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

TINY_SCENE = """name = "tiny"
width = 12
height = 9
background = [0.5, 0.6, 0.9]
[[cameras]]
position = [0, 0, 0]
look_at = [0, 0, -1]
[[lights]]
position = [3, 4, 2]
[[objects]]
type = "sphere"
center = [0, 0, -4]
radius = 1
"""


# ----------------------------------------------------------------------------- helpers
def run(capfd, *argv):
    """main() in-process; returns (exit code, stderr) with stderr captured at the file descriptor."""
    rc = main([str(a) for a in argv])
    return rc, capfd.readouterr().err


def assert_one_line_error(rc, err, code=2, *words):
    assert rc == code, err
    assert err.startswith("clrender: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    for word in words:
        assert word in err, err


def png_bytes(width: int, height: int, rows: bytes | None = None) -> bytes:
    """A grey 8-bit PNG written by hand: its header may promise any size (a 'PNG bomb')."""

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    rows = rows if rows is not None else b"\0" * (1 + width) * min(height, 4)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def make_inputs(folder: Path) -> dict[str, Path]:
    """Small good and bad input files every test may point the CLI at."""
    ys, xs = np.mgrid[0:10, 0:14] / 10.0
    photo = np.stack([xs / 1.4, ys, 0.5 + 0.4 * np.sin(6 * xs)], axis=-1).astype(np.float32)
    files = {"png": folder / "in.png", "jpg": folder / "in.jpg", "exr": folder / "in.exr"}
    for path in files.values():
        write_image(path, photo)
    good_png = files["png"].read_bytes()
    files["trunc_png"] = folder / "trunc.png"
    files["trunc_png"].write_bytes(good_png[: len(good_png) // 2])
    files["trunc_jpg"] = folder / "trunc.jpg"
    files["trunc_jpg"].write_bytes(files["jpg"].read_bytes()[:40])
    files["bomb"] = folder / "bomb.png"  # a header claiming 10^10 pixels over a few bytes
    files["bomb"].write_bytes(png_bytes(100_000, 100_000))
    files["scene"] = folder / "tiny.toml"
    files["scene"].write_text(TINY_SCENE)
    files["npz"] = folder / "p.npz"
    n = 6
    rng = np.random.default_rng(7)
    np.savez(
        files["npz"],
        xy=rng.uniform(0, 14, (n, 2)),
        log_scale=np.zeros((n, 2)),
        theta=np.zeros(n),
        color=rng.uniform(0, 1, (n, 3)),
        lum=np.ones(n),
        opacity=np.full(n, 0.8),
        width=14,
        height=10,
        blend="normalized",
        background=np.zeros(3),
    )
    files["existing"] = folder / "existing.png"
    files["existing"].write_bytes(good_png)
    files["dir"] = folder / "adir.png"  # a folder whose name looks like an image
    files["dir"].mkdir()
    files["file"] = folder / "afile"
    files["file"].write_text("a file, not a folder")
    return files


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else b"<dir>") for p in sorted(folder.rglob("*"))}


def temp_files(folder: Path) -> list[str]:
    return [p.name for p in folder.rglob("*") if TEMP_MARK in p.name or ".tmp" in p.name]


@pytest.fixture
def inputs(tmp_path):
    return make_inputs(tmp_path)


# ----------------------------------------------------------------------------- reproducers: outputs
@pytest.mark.parametrize(
    "command",
    [
        ["render", "{scene}", "--width", "8", "--height", "6"],
        ["convolve", "{png}", "{out}", "box_blur_3"],
        ["splat", "voronoi", "{png}", "--splats", "4"],
        ["splat", "gauss", "{png}", "--splats", "4", "--epochs", "1"],
        ["splat", "render", "{npz}"],
    ],
)
def test_output_that_is_a_folder_is_one_line_exit_2(inputs, tmp_path, capfd, command):
    argv = [a.format(scene=inputs["scene"], png=inputs["png"], npz=inputs["npz"], out=inputs["dir"]) for a in command]
    if "{out}" not in command:
        argv += ["-o", str(inputs["dir"])]
    before = snapshot(tmp_path)
    rc, err = run(capfd, *argv, "--overwrite")
    assert_one_line_error(rc, err, 2, "folder")
    assert snapshot(tmp_path) == before


@pytest.mark.parametrize(
    "command, first, second",
    [
        (["render", "{scene}", "--aa", "edge_detect", "--width", "8", "--height", "6", "--edges-out", "{same}", "-o", "{same}"], "-o", "--edges-out"),
        (["splat", "gauss", "{png}", "--splats", "4", "--epochs", "1", "--curve", "{same}", "-o", "{same}"], "-o", "--curve"),
    ],
)
def test_two_outputs_naming_one_file_are_refused(inputs, tmp_path, capfd, command, first, second):
    names = {"scene": inputs["scene"], "png": inputs["png"], "same": tmp_path / "o.png"}
    before = snapshot(tmp_path)
    rc, err = run(capfd, *[a.format(**names) for a in command])
    assert_one_line_error(rc, err, 2, "both name")
    assert snapshot(tmp_path) == before


def test_voronoi_sites_into_a_missing_folder_writes_nothing(inputs, tmp_path, capfd):
    before = snapshot(tmp_path)
    rc, err = run(capfd, "splat", "voronoi", inputs["png"], "-o", tmp_path / "v.png", "--splats", "4", "--save-sites", tmp_path / "afile" / "s.npz")
    assert rc == 2 and err.count("\n") == 1
    assert snapshot(tmp_path) == before


# ----------------------------------------------------------------------------- reproducers: splat render's .npz
def _params(**change):
    n = 5
    data = dict(
        xy=np.full((n, 2), 5.0),
        log_scale=np.zeros((n, 2)),
        theta=np.zeros(n),
        color=np.full((n, 3), 0.5),
        lum=np.ones(n),
        opacity=np.full(n, 0.9),
        width=14,
        height=10,
        blend="sum",
        background=np.zeros(3),
    )
    data.update(change)
    return data


@pytest.mark.parametrize(
    "damage, words",
    [
        ("truncated", ["cannot read splat parameters"]),
        ("empty", ["cannot read splat parameters"]),
        ("npy", ["cannot read splat parameters"]),
        ({"theta": np.zeros(3)}, ["theta", "shape"]),  # mismatched lengths gave an IndexError
        ({"xy": np.full((5, 2), np.nan)}, ["xy", "NaN"]),  # exited 0 with a black image
        (
            {
                "xy": np.zeros((4, 3)),
                "log_scale": np.zeros((4, 2)),
                "theta": np.zeros(4),
                "color": np.zeros((4, 3)),
                "lum": np.ones(4),
                "opacity": np.ones(4),
            },
            ["xy", "shape"],
        ),
        ({"color": np.full((5, 3), 1e39)}, ["color"]),  # beyond float32: inf
        ({"width": 0}, ["width"]),
        ({"height": 10**9}, ["height"]),
        ({"blend": "glow"}, ["blend"]),
        ({"opacity": np.array(["a"] * 5)}, ["opacity"]),
    ],
)
def test_splat_render_refuses_a_damaged_params_file(inputs, tmp_path, capfd, damage, words):
    bad = tmp_path / "bad.npz"
    if damage == "truncated":
        bad.write_bytes(inputs["npz"].read_bytes()[:300])
    elif damage == "empty":
        bad.write_bytes(b"")
    elif damage == "npy":
        with open(bad, "wb") as f:
            np.save(f, np.zeros((5, 2)))
    else:
        np.savez(bad, **_params(**damage))
    out = tmp_path / "o.png"
    rc, err = run(capfd, "splat", "render", bad, "-o", out)
    assert_one_line_error(rc, err, 2, *words)
    assert not out.exists() and not temp_files(tmp_path)


def test_splat_render_of_good_params_still_works(inputs, tmp_path, capfd):
    rc, err = run(capfd, "splat", "render", inputs["npz"], "-o", tmp_path / "o.png", "--width", "28")
    assert rc == 0, err
    image = read_image(tmp_path / "o.png").pixels
    assert image.shape == (20, 28, 3) and image.max() > 0


# ----------------------------------------------------------------------------- reproducers: numbers
@pytest.mark.parametrize(
    "command",
    [["splat", "gauss", "{png}", "-o", "{out}", "--splats", "4", "--epochs", "1"], ["splat", "voronoi", "{png}", "-o", "{out}", "--splats", "4"]],
)
@pytest.mark.parametrize("seed", ["-1", str(2**32)])
def test_seed_out_of_range_is_exit_2(inputs, tmp_path, capfd, command, seed):
    argv = [a.format(png=inputs["png"], out=tmp_path / "o.png") for a in command]
    rc, err = run(capfd, *argv, "--seed", seed)
    assert_one_line_error(rc, err, 2, "--seed", "2**32-1")
    assert not (tmp_path / "o.png").exists()


@pytest.mark.parametrize("lr", ["inf", "nan", "-inf", "1e300"])
def test_learning_rate_must_be_finite(inputs, tmp_path, capfd, lr):
    rc, err = run(capfd, "splat", "gauss", inputs["png"], "-o", tmp_path / "o.png", "--splats", "4", "--epochs", "2", "--lr", lr)
    assert_one_line_error(rc, err, 2, "--lr")
    assert not (tmp_path / "o.png").exists()


def test_sweep_learning_rates_must_be_finite(inputs, capfd):
    rc, err = run(capfd, "splat", "sweep", inputs["png"], "--splats", "4", "--lrs", "1", "inf")
    assert_one_line_error(rc, err, 2, "--lrs")


# ----------------------------------------------------------------------------- reproducers: damaged images
@pytest.mark.parametrize("name", ["trunc_png", "trunc_jpg", "bomb"])
@pytest.mark.parametrize(
    "command",
    [
        ["convolve", "{src}", "{out}", "box_blur_3"],
        ["splat", "voronoi", "{src}", "-o", "{out}", "--splats", "3"],
        ["splat", "gauss", "{src}", "-o", "{out}", "--splats", "3", "--epochs", "1"],
    ],
)
def test_damaged_or_huge_input_image_is_one_line(inputs, tmp_path, capfd, name, command):
    """libpng prints its own lines straight to fd 2; they are caught, and the first becomes the reason."""
    out = tmp_path / "o.png"
    rc, err = run(capfd, *[a.format(src=inputs[name], out=out) for a in command])
    assert_one_line_error(rc, err, 2, str(inputs[name].name))
    assert not out.exists()


def test_a_real_png_bomb_is_refused_by_its_header(tmp_path, capfd):
    """8200 x 8200 zero pixels compress to 66 KB; MAX_READ_PIXELS refuses them before allocating 800 MB."""
    side = 8200
    bomb = tmp_path / "bomb.png"
    bomb.write_bytes(png_bytes(side, side, rows=b"\0" * (1 + side) * side))
    assert bomb.stat().st_size < 200_000
    rc, err = run(capfd, "convolve", bomb, tmp_path / "o.png", "box_blur_3")
    assert_one_line_error(rc, err, 2, "8200x8200", "67108864 pixels")


# ----------------------------------------------------------------------------- reproducers: the error boundary
def test_control_characters_are_escaped_and_long_values_cut(tmp_path, capfd):
    hostile = "\x1b[31mred\nsecond line" + "x" * 5000
    for scene, code in ((hostile[:40] + ".toml", 2), (hostile + ".toml", 1)):  # 1: the OS says the name is too long
        rc, err = run(capfd, "render", scene, "-o", tmp_path / "o.png")
        assert_one_line_error(rc, err, code)
        assert "\x1b" not in err and "x1b[31mred" in err and "nsecond line" in err  # shown escaped
        assert len(err) < 700  # 5 KB of value is cut to 200 characters


def test_an_unexpected_exception_is_one_line_naming_a_bug(monkeypatch, capfd):
    from clrender.commands import devices

    def broken(args):
        raise TypeError("unhashable type: 'list'")

    monkeypatch.setattr(devices, "run", broken)
    rc, err = run(capfd, "devices")
    assert_one_line_error(rc, err, 1, "bug", "--debug", "CLRENDER_DEBUG=1", "TypeError")
    with pytest.raises(TypeError):
        main(["--debug", "devices"])
    monkeypatch.setenv("CLRENDER_DEBUG", "1")
    with pytest.raises(TypeError):
        main(["devices"])


@pytest.mark.parametrize(
    "exc, code, words",
    [
        (OSError(28, "No space left on device"), 1, ["No space left on device"]),
        (OSError(), 1, ["OSError"]),  # never an empty reason
        (MemoryError(), 1, ["out of memory"]),
        (KeyboardInterrupt(), 130, ["interrupted"]),
    ],
)
def test_run_time_failures_are_one_line_with_a_reason(monkeypatch, capfd, exc, code, words):
    from clrender.commands import devices

    def failing(args):
        raise exc

    monkeypatch.setattr(devices, "run", failing)
    rc, err = run(capfd, "devices")
    assert_one_line_error(rc, err, code, *words)
    assert not err.rstrip().endswith(":")


@pytest.mark.parametrize("where", ["before", "after"])
def test_memory_estimate_refuses_before_allocating(tmp_path, capfd, where):
    out = tmp_path / "big.png"
    command = ["render", "refract1", "--width", "4096", "--height", "4096", "-o", out]
    limit = ["--max-memory", "300M"]
    rc, err = run(capfd, *(limit + command if where == "before" else command + limit))
    assert_one_line_error(rc, err, 2, "4096x4096", "GiB", "--max-memory is 300 MiB")
    assert not out.exists()


def test_memory_estimate_uses_what_is_available(monkeypatch, tmp_path, capfd):
    from clrender import memory

    monkeypatch.setattr(memory, "available_bytes", lambda: 100 << 20)
    rc, err = run(capfd, "render", "refract1", "--width", "64", "--height", "64", "-o", tmp_path / "o.png")
    assert_one_line_error(rc, err, 2, "only 100 MiB is available")


def test_render_bytes_grow_with_pixels_and_triangles():
    from clrender import memory

    small = memory.render_bytes(100, 100)
    assert memory.render_bytes(200, 100) - small == 100 * 100 * memory.RENDER_BYTES_PER_PIXEL
    assert memory.render_bytes(100, 100, triangles=1000) - small == 1000 * memory.BYTES_PER_TRIANGLE
    # the dense generator's cap is what memory.py allows, about 5 GiB, not the 24 GiB of 50 M triangles
    from clrender.scene.meshes import MAX_DENSE_TRIANGLES

    assert MAX_DENSE_TRIANGLES * memory.BYTES_PER_TRIANGLE < 6 * 2**30


@pytest.mark.parametrize("text, value", [("2G", 2 << 30), ("512M", 512 << 20), ("1.5GiB", 3 << 29), ("1048576", 1 << 20)])
def test_memory_sizes_parse(text, value):
    from clrender.memory import parse_size

    assert parse_size(text) == value


@pytest.mark.parametrize("text", ["lots", "-1G", "1K", "nan", ""])
def test_bad_memory_size_is_exit_2(capfd, text):
    rc, err = run(capfd, "--max-memory", text, "devices")
    assert_one_line_error(rc, err, 2, "--max-memory")


# ----------------------------------------------------------------------------- hypothesis: argument lists
HOSTILE_TEXT = [
    "",
    "-",
    "--",
    "\x1b[31mred",
    "line\nbreak",
    "\u00e9t\u00e9",
    "x" * 3000,
    "../../nowhere",
    "\udcff",
    "1e999",
    "nan",
    "-inf",
    "0x10",
    " 3",
    "\u202e",
]
INTS = ["0", "1", "2", "3", "-1", "-7", "64", "65", "4096", str(2**31), str(2**32), str(10**30)]
FLOATS = ["0", "0.5", "1", "2.5", "-1", "nan", "inf", "-inf", "1e-300", "1e300", "3.4e39"]
FILE_NAMES = [
    "in.png",
    "in.jpg",
    "in.exr",
    "trunc.png",
    "trunc.jpg",
    "bomb.png",
    "p.npz",
    "tiny.toml",
    "existing.png",
    "adir.png",
    "afile",
    "afile/x.png",
    "missing.png",
    "nofolder/o.png",
    "o.png",
    "o.exr",
    "o.txt",
    "o",
    "o.npz",
    "o.csv",
    "e.png",
    "c.png",
]


def values(kind):
    pools = {"int": INTS, "float": FLOATS, "file": FILE_NAMES, "text": []}
    known = [st.sampled_from(pools[kind])] * 2 if pools[kind] else []
    return st.one_of(*known, st.sampled_from(HOSTILE_TEXT), st.text(max_size=12))


# (flag, kind of value or None for a switch); positional arguments come from POSITIONALS
OPTIONS = {
    "render": [
        ("-o", "file"),
        ("--overwrite", None),
        ("--camera", "int"),
        ("--width", "int"),
        ("--height", "int"),
        ("--aa", "text"),
        ("--sampler", "text"),
        ("--samples", "int"),
        ("--pixel-filter", "text"),
        ("--thickness", "float"),
        ("--contrast", "float"),
        ("--edges-out", "file"),
        ("--light-samples", "int"),
        ("--max-depth", "int"),
        ("--fresnel", None),
        ("--no-bvh", None),
        ("--seed", "int"),
        ("--filter", "text"),
        ("--aov", "text"),
        ("--aov-out", "file"),
        ("--list", None),
    ],
    "convolve": [("--space", "text"), ("--overwrite", None), ("--list", None)],
    "splat gauss": [
        ("-o", "file"),
        ("--splats", "int"),
        ("--epochs", "int"),
        ("--init", "text"),
        ("--learn", "text"),
        ("--blend", "text"),
        ("--optimizer", "text"),
        ("--loss", "text"),
        ("--seed", "int"),
        ("--max-splats", "int"),
        ("--batch", "int"),
        ("--lr", "float"),
        ("--time-budget", "float"),
        ("--save-params", "file"),
        ("--log", "file"),
        ("--curve", "file"),
        ("--overwrite", None),
    ],
    "splat render": [("-o", "file"), ("--width", "int"), ("--overwrite", None)],
    "splat sweep": [
        ("--splats", "int"),
        ("--epochs", "int"),
        ("--lrs", "float"),
        ("--batches", "int"),
        ("--time-budget", "float"),
        ("--csv", "file"),
        ("--seed", "int"),
        ("--overwrite", None),
    ],
    "splat voronoi": [
        ("-o", "file"),
        ("--overwrite", None),
        ("--splats", "int"),
        ("--method", "text"),
        ("--init", "text"),
        ("--colors", "text"),
        ("--lloyd", "int"),
        ("--train", "int"),
        ("--seed", "int"),
        ("--edges", None),
        ("--save-sites", "file"),
    ],
    "devices": [("--device", "text")],
}
# sensible values, so that many generated cases get past parsing and really run
SENSIBLE = {
    "--aa": ["none", "full", "edge_detect"],
    "--sampler": ["uniform", "random", "stratified", "sobol"],
    "--pixel-filter": ["box", "tent", "gaussian"],
    "--filter": ["box_blur_3", "gauss_blur_5", "brighten_1.5"],
    "--aov": ["depth", "normal,id", "edges"],
    "--space": ["linear", "stored"],
    "--init": ["uniform", "random", "gradient"],
    "--learn": ["scale-lum", "all", "seed"],  # seed: the old name of scale-lum
    "--blend": ["sum", "normalized"],
    "--optimizer": ["adam", "sgd"],
    "--loss": ["l2", "l1"],
    "--method": ["naive", "grid"],
    "--colors": ["sample", "mean"],
    "--width": ["8", "12", "1"],
    "--height": ["6", "9", "1"],
    "--splats": ["3", "8"],
    "--epochs": ["1", "2"],
    "--samples": ["1", "2"],
    "--lloyd": ["0", "1"],
    "--train": ["0", "2"],
    "--time-budget": ["0.5"],
}
POSITIONALS = {
    "render": [["tiny.toml"], ["refract1"], ["tiny.toml", "1", "edge_detect", "stratified", "2"], []],
    "convolve": [
        ["in.png", "o.png", "box_blur_3"],
        ["in.exr", "o.exr", "gauss_blur_5", "brighten_2"],
        ["in.jpg", "in.jpg", "edge_detect_1"],
        ["in.png"],
    ],
    "splat gauss": [["in.png"], ["in.jpg"]],
    "splat render": [["p.npz"], ["in.png"]],
    "splat sweep": [["in.png"]],
    "splat voronoi": [["in.png"], ["in.exr"]],
    "devices": [[]],
}
# keeps every generated case cheap: a few splats and epochs, a tiny image, unless a value says otherwise
DEFAULTS = {
    "render": ["--width", "12", "--height", "9"],
    "splat gauss": ["--splats", "4", "--epochs", "2"],
    "splat sweep": ["--splats", "3", "--epochs", "1", "--lrs", "1", "--batches", "0", "--time-budget", "1"],
    "splat voronoi": ["--splats", "4"],
    "splat render": ["--width", "16"],
    "convolve": [],
    "devices": [],
}


@st.composite
def argument_lists(draw):
    command = draw(st.sampled_from(sorted(OPTIONS)))
    argv = command.split() + list(draw(st.sampled_from(POSITIONALS[command])))
    if draw(st.integers(0, 4)) == 0:
        argv += draw(st.lists(values("text"), max_size=2))  # stray positionals
    argv += DEFAULTS[command]
    for flag, kind in draw(st.lists(st.sampled_from(OPTIONS[command]), max_size=5)):
        if kind is None:
            argv.append(flag)
            continue
        pool = values(kind)
        if flag in SENSIBLE:  # two times in three a value that makes sense, so that cases run
            pool = st.one_of(st.sampled_from(SENSIBLE[flag]), st.sampled_from(SENSIBLE[flag]), pool)
        argv += [flag, draw(pool)]
    if draw(st.integers(0, 9)) == 0:
        argv.insert(draw(st.integers(0, len(argv))), draw(st.sampled_from(["--bogus", "-x", "--", "-o"])))
    return ["-q", "--max-memory", "600M"] + argv


class Hang(BaseException):
    """A case ran past its time limit (a BaseException, so main()'s boundary does not turn it into a line)."""


def run_case(argv, folder: Path, capfd, seconds=120):
    """Run one generated command in `folder`; returns (rc, stderr)."""

    def alarm(signum, frame):
        raise Hang(" ".join(argv))

    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(seconds)
    cwd = os.getcwd()
    os.chdir(folder)
    try:
        rc = main(argv)
    finally:
        os.chdir(cwd)
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    return rc, capfd.readouterr().err


RUN_TIME_FAILURES: list[str] = []  # the exit-1 lines the fuzzer met, printed at the end (pytest -s)


def check_case(argv, folder: Path, capfd, run_time_failures=None):
    """The promise, for one argument list."""
    before = snapshot(folder)
    rc, err = run_case(argv, folder, capfd)
    if rc == 1 and run_time_failures is not None:
        run_time_failures.append(err.strip()[:160])
    assert rc in (0, 1, 2), (argv, rc, err)
    assert "Traceback" not in err and "internal error" not in err, (argv, err)
    assert not temp_files(folder), (argv, temp_files(folder))
    if rc != 0:
        assert err.startswith("clrender: ") and err.count("\n") == 1, (argv, err)
        assert "\x1b" not in err, (argv, err)
        assert snapshot(folder) == before, (argv, "a failed command changed the folder")
    else:
        for name in set(snapshot(folder)) - set(before):
            path = folder / name
            if path.suffix == ".exr":  # colour must be finite; a depth AOV is inf where nothing was hit
                image = read_image(path)
                colour = [i for i, c in enumerate(image.channel_names) if c in ("R", "G", "B")]
                assert np.isfinite(image.pixels[..., colour]).all(), (argv, name)
    return rc


def _examples(ci: int) -> int:
    return ci if settings.get_current_profile_name() != "long" else 2_400


CASES: dict[str, dict[int, int]] = {}  # kind of case -> exit code -> count, printed at the end (pytest -s)


def count(kind: str, rc: int) -> None:
    codes = CASES.setdefault(kind, {})
    codes[rc] = codes.get(rc, 0) + 1


@pytest.fixture(scope="module")
def fuzz_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("fuzz")
    template = root / "template"
    template.mkdir()
    make_inputs(template)
    yield root
    for kind, codes in CASES.items():
        print(f"\nCLI fuzz, {kind}: {sum(codes.values())} cases, exit codes {dict(sorted(codes.items()))}")
    for line in sorted(set(RUN_TIME_FAILURES))[:10]:
        print(f"  exit 1: {line}")


def fresh_folder(root: Path) -> Path:
    import shutil
    import tempfile

    folder = Path(tempfile.mkdtemp(dir=root))
    shutil.copytree(root / "template", folder, dirs_exist_ok=True)
    return folder


@settings(max_examples=_examples(120), suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow], deadline=None)
@given(argv=argument_lists())
# regressions the fuzzer (and issue 14) found: a folder as output, a surrogate in a file name,
# two outputs naming one file, an out-of-range seed
@example(argv=["-q", "render", "tiny.toml", "--width", "8", "--height", "6", "-o", "adir.png", "--overwrite"])
@example(argv=["-q", "convolve", "in.png", "\udcff.png", "box_blur_3"])
@example(argv=["-q", "splat", "gauss", "in.png", "--splats", "3", "--epochs", "1", "-o", "o.png", "--curve", "o.png"])
@example(argv=["-q", "splat", "voronoi", "in.png", "-o", "o.png", "--seed", "-1"])
@example(argv=["-q", "render", "tiny.toml", "--aov", "depth", "-o", "o.png", "--aov-out", "o.png"])
@example(argv=["-q", "--max-memory", "600M", "render", "tiny.toml", "--width", "12", "--height", "9", "--aov", "depth"])
def test_any_argument_list_keeps_the_promise(argv, fuzz_root, capfd):
    folder = fresh_folder(fuzz_root)
    rc = check_case(argv, folder, capfd, run_time_failures=RUN_TIME_FAILURES)
    count("argument list", rc)


# ----------------------------------------------------------------------------- hypothesis: damaged files
@st.composite
def damaged(draw, data: bytes):
    """The bytes of a good file with a few bytes changed, a cut, or both."""
    data = bytearray(data)
    for _ in range(draw(st.integers(0, 4))):
        data[draw(st.integers(0, len(data) - 1))] = draw(st.integers(0, 255))
    if draw(st.booleans()):
        data = data[: draw(st.integers(0, len(data)))]
    return bytes(data)


GOOD_FILES: dict[str, bytes] = {}


def good_bytes(name: str) -> bytes:
    if not GOOD_FILES:
        import tempfile

        with tempfile.TemporaryDirectory() as folder:
            files = make_inputs(Path(folder))
            for key in ("png", "jpg", "exr", "npz"):
                GOOD_FILES[key] = files[key].read_bytes()
    return GOOD_FILES[name]


@settings(max_examples=_examples(40), suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow], deadline=None)
@given(data=st.data(), kind=st.sampled_from(["png", "jpg", "exr"]))
def test_damaged_image_input_keeps_the_promise(data, kind, fuzz_root, capfd):
    folder = fresh_folder(fuzz_root)
    (folder / f"bad.{kind}").write_bytes(data.draw(damaged(good_bytes(kind))))
    command = data.draw(
        st.sampled_from([["convolve", f"bad.{kind}", "o.png", "box_blur_3"], ["splat", "voronoi", f"bad.{kind}", "-o", "o.png", "--splats", "2"]])
    )
    rc = check_case(["-q", *command], folder, capfd)
    assert rc in (0, 2)
    count("damaged image", rc)


@settings(max_examples=_examples(40), suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow], deadline=None)
@given(data=st.data())
@example(data=None)  # placeholder replaced below: the whole good file must still render
def test_damaged_params_file_keeps_the_promise(data, fuzz_root, capfd):
    folder = fresh_folder(fuzz_root)
    (folder / "bad.npz").write_bytes(good_bytes("npz") if data is None else data.draw(damaged(good_bytes("npz"))))
    rc = check_case(["-q", "splat", "render", "bad.npz", "-o", "o.png"], folder, capfd)
    assert rc in (0, 2)
    count("damaged npz", rc)
    if data is None:
        assert rc == 0


def test_exr_header_with_bytes_that_are_not_utf8(inputs, tmp_path, capfd):
    """Found by the fuzzer: OpenImageIO's error text quoted a damaged attribute type byte for byte,
    and decoding it (pybind11, UTF-8) raised UnicodeDecodeError.  Cuts around the damage, one of
    which (21 bytes into displayWindow) reproduced it."""
    good = inputs["exr"].read_bytes()
    at = good.find(b"displayWindow\x00box2i")
    damaged_exr = good[:at] + b"displayWindow\x00\x80ox2i" + good[at + len(b"displayWindow\x00box2i") :]
    for cut in range(at, at + 60, 3):
        bad = tmp_path / "bad.exr"
        bad.write_bytes(damaged_exr[:cut])
        rc, err = run(capfd, "convolve", bad, tmp_path / "o.png", "box_blur_3")
        assert_one_line_error(rc, err, 2, "bad.exr")
        assert not (tmp_path / "o.png").exists()


def test_exr_channel_name_that_is_not_text(inputs, tmp_path, capfd):
    """Found by the long fuzz run: a channel named by the byte 0x80 read as None, and writing it back
    failed in OpenImageIO ("basic_string: construction from null")."""
    good = inputs["exr"].read_bytes()
    at = good.find(b"G\x00\x02\x00\x00\x00", good.find(b"chlist"))
    (tmp_path / "bad.exr").write_bytes(good[:at] + b"\x80" + good[at + 1 :])
    rc, err = run(capfd, "convolve", tmp_path / "bad.exr", tmp_path / "o.png", "box_blur_3")
    assert_one_line_error(rc, err, 2, "channel names are damaged")
    assert not (tmp_path / "o.png").exists()
