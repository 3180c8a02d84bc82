"""Small command-line promises (issue 23): -q/-v after the subcommand, SCENE described with glTF,
quiet on a closed pipe, huge --max-memory refused in one line, bidi controls escaped, and a memory
budget that sees `ulimit -v` and the memory cgroup."""

import os
import subprocess
import sys
import textwrap

import pytest

from clrender import memory
from clrender.errors import escaped
from clrender.scene.scene import escape

from tests.clitools import run_cli


def render_small(capsys, tmp_path, *extra):
    out = tmp_path / "o.png"
    return run_cli(capsys, "render", "refract1", "--width", "8", "--height", "6", "-o", str(out), *extra), out


@pytest.mark.parametrize("flag", ["-q", "--quiet"])
def test_quiet_after_the_subcommand_silences_the_timings(capsys, tmp_path, flag):
    (code, stdout, err), out = render_small(capsys, tmp_path, flag)
    assert code == 0 and out.is_file(), err
    assert stdout == f"{out}\n" and err == ""


def test_verbose_after_the_subcommand_is_accepted(capsys, tmp_path):
    (code, stdout, err), out = render_small(capsys, tmp_path, "-v")
    assert code == 0 and out.is_file(), err


def test_a_quiet_flag_after_double_dash_is_not_an_option(capsys, tmp_path):
    code, _, err = run_cli(capsys, "render", "--", "-q")
    assert code == 2 and "unknown scene '-q'" in err


def test_scene_is_described_as_name_toml_gltf_or_mesh_file(capsys):
    code, help_text, _ = run_cli(capsys, "render", "--help")
    assert code == 0 and ".gltf" in help_text and ".toml" in help_text and ".obj" in help_text
    code, _, err = run_cli(capsys, "render")
    assert code == 2 and ".toml scene file, a .gltf/.glb file or a mesh file (.obj, .ply, .stl, .off)" in err
    code, _, err = run_cli(capsys, "render", "no_such_scene")
    assert code == 2 and ".gltf/.glb" in err and ".obj" in err


def test_a_closed_stdout_pipe_ends_quietly_with_141(tmp_path):
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader has gone before a byte is written, as `| head` after its line
    try:
        run = subprocess.run(
            [sys.executable, "-m", "clrender", "render", "--list"], stdout=write_end, stderr=subprocess.PIPE, cwd=tmp_path, timeout=120
        )
    finally:
        os.close(write_end)
    assert run.stderr == b""
    assert run.returncode == 141  # 128 + SIGPIPE, as a shell reports `yes | head -1`


def test_a_broken_pipe_that_is_not_stdout_is_a_run_time_failure(capsys, monkeypatch):
    from clrender.commands import devices

    def encoder_gone(args):
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(devices, "run", encoder_gone)
    code, stdout, err = run_cli(capsys, "devices")
    assert (code, stdout, err) == (1, "", "clrender: Broken pipe\n")


@pytest.mark.parametrize("size", ["9" * 5000, "9" * 30 + "T", "2000000T"])
def test_a_huge_max_memory_is_refused_in_one_line(capsys, size):
    code, stdout, err = run_cli(capsys, "--max-memory", size, "devices")
    assert code == 2 and stdout == ""
    assert err.count("\n") == 1 and "is too large; allowed: 1M to 1048576T" in err
    assert len(err) < 400  # the echoed value is cut


def test_bidi_controls_are_escaped_by_the_one_escape_function(capsys, tmp_path):
    assert escape is escaped
    assert escaped("evil\u202egnp.exe\u200b\n\x1b") == "evil\\u202egnp.exe\\u200b\\n\\x1b"
    code, _, err = run_cli(capsys, "convolve", str(tmp_path / "in\u202e.png"), str(tmp_path / "out.png"), "brighten_1.5")
    assert code == 2 and "\u202e" not in err and "\\u202e" in err


def test_ulimit_v_bounds_the_memory_available():
    # the child lowers its own address-space limit to what it uses now plus 200 MiB
    script = textwrap.dedent(
        """
        import resource
        from clrender import memory
        used = next(int(line.split()[1]) * 1024 for line in open("/proc/self/status") if line.startswith("VmSize:"))
        resource.setrlimit(resource.RLIMIT_AS, (used + (200 << 20), resource.RLIM_INFINITY))
        print(memory.address_space_bytes(), memory.available_bytes())
        """
    )
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    left, available = map(int, run.stdout.split())
    assert 150 << 20 < left <= 200 << 20  # a few pages went to reading /proc since
    assert available <= left


def write(path, text):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def test_cgroup_v2_limit_less_its_working_set(tmp_path):
    root = tmp_path / "cgroup"
    write(tmp_path / "self", "0::/user/job\n")
    write(root / "user/job/memory.max", f"{1 << 30}\n")
    write(root / "user/job/memory.current", f"{300 << 20}\n")
    write(root / "user/job/memory.stat", f"anon 123\ninactive_file {100 << 20}\nactive_file 7\n")  # page cache it can reclaim
    write(root / "user/memory.max", "max\n")
    assert memory.cgroup_bytes(root, tmp_path / "self") == (1 << 30) - (200 << 20)
    write(root / "user/memory.max", f"{600 << 20}\n")  # a parent's tighter limit holds too
    write(root / "user/memory.current", f"{500 << 20}\n")
    assert memory.cgroup_bytes(root, tmp_path / "self") == 100 << 20


def test_cgroup_v1_limit_and_no_limit(tmp_path):
    root = tmp_path / "cgroup"
    write(tmp_path / "self", "9:pids:/\n4:memory:/docker/abc\n0::/\n")
    write(root / "memory/docker/abc/memory.limit_in_bytes", f"{512 << 20}\n")
    write(root / "memory/docker/abc/memory.usage_in_bytes", f"{100 << 20}\n")
    write(root / "memory/memory.limit_in_bytes", "9223372036854771712\n")  # v1's "unlimited"
    assert memory.cgroup_bytes(root, tmp_path / "self") == 412 << 20
    (root / "memory/docker/abc/memory.limit_in_bytes").write_text("9223372036854771712\n")
    assert memory.cgroup_bytes(root, tmp_path / "self") is None


def test_a_render_is_refused_by_the_cgroup_limit(capsys, tmp_path, monkeypatch):
    root = tmp_path / "cgroup"
    write(tmp_path / "self", "0::/\n")
    write(root / "memory.max", f"{300 << 20}\n")
    write(root / "memory.current", f"{100 << 20}\n")
    monkeypatch.setattr(memory, "CGROUP_ROOT", root)
    monkeypatch.setattr(memory, "SELF_CGROUP", tmp_path / "self")
    monkeypatch.delenv("CLRENDER_MAX_MEMORY", raising=False)
    assert memory.available_bytes() == 200 << 20
    (code, stdout, err), out = render_small(capsys, tmp_path)
    assert code == 2 and not out.exists()
    assert err.startswith("clrender: ") and "only 200 MiB is available" in err


def test_max_memory_and_quiet_hold_for_one_command_only(capsys):
    """A command's --max-memory and -q do not stay behind for the library or the next command in the same process."""
    from clrender import progress

    before = memory.MAX_MEMORY, progress.SHOW
    code, _, err = run_cli(capsys, "-q", "--max-memory", "1K", "render", "refract1", "--width", "8", "--height", "8", "-o", "never.png")
    assert code == 2 and "--max-memory" in err
    assert (memory.MAX_MEMORY, progress.SHOW) == before
