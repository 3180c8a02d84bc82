"""`clrender devices --measure`: a number for every CPU device, cached, and the default marked by the measured rule.

The measurement itself is replaced by fixed fake speeds (no timing is asserted, nothing is rendered)."""

import pytest

from clrender import device as device_module
from clrender import device_speed
from clrender.commands import devices as devices_command
from clrender.device import _describe, cpu_devices
from clrender.device_speed import Speed

from tests.clitools import run_cli


@pytest.fixture
def fake_speeds(tmp_path, monkeypatch):
    """A fresh cache folder; every CPU device compiles; measure() gives the i-th CPU device (loader order) i+1 Msamples/s
    and 10(i+1) Mrays/s, so the last one listed is the fastest by far. The names measured are appended to the list returned."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv("CLRENDER_DEVICE", raising=False)
    monkeypatch.setattr(device_speed, "_warned", set())
    monkeypatch.setattr(device_module, "_cannot_compile", lambda dev: None)
    monkeypatch.setattr(devices_command, "_cannot_compile", lambda dev: None)
    names = [_describe(d) for d in cpu_devices()]
    if not names:
        pytest.skip("no OpenCL CPU device here")
    measured = []

    def measure(spec, runs=device_speed.RUNS):
        measured.append(spec)
        i = names.index(spec)
        return Speed(float(i + 1), 10.0 * (i + 1))

    monkeypatch.setattr(devices_command, "measure", measure)
    return names, measured


def _cpu_lines(out: str, names: list) -> dict:
    return {line[2:].split("  [")[0]: line for line in out.splitlines() if line[2:].split("  [")[0] in names}


def test_measure_prints_one_line_per_cpu_device_with_its_numbers_and_stars_the_fastest(capsys, fake_speeds):
    names, measured = fake_speeds
    code, out, err = run_cli(capsys, "devices", "--measure")
    assert code == 0 and err == "", err
    assert measured == names
    lines = _cpu_lines(out, names)
    assert sorted(lines) == sorted(names)
    for i, name in enumerate(names):
        assert lines[name].endswith(f"  [path {i + 1:.3f} Msamples/s, Whitted {10.0 * (i + 1):.2f} Mrays/s]"), lines[name]
    starred = [line for line in out.splitlines() if line.startswith("* ")]
    assert starred == [lines[names[-1]]]  # the fastest measured, the static order's first notwithstanding


def test_later_runs_show_the_cached_numbers_without_measuring(capsys, fake_speeds, monkeypatch):
    names, measured = fake_speeds
    run_cli(capsys, "devices", "--measure")
    monkeypatch.setattr(devices_command, "measure", lambda *a, **k: pytest.fail("measured again"))
    code, out, err = run_cli(capsys, "devices")
    assert code == 0 and err == ""
    lines = _cpu_lines(out, names)
    assert all(" Msamples/s, Whitted " in lines[name] for name in names)


def test_a_device_that_cannot_compile_is_listed_with_why_and_not_measured(capsys, fake_speeds, monkeypatch):
    names, measured = fake_speeds
    monkeypatch.setattr(devices_command, "_cannot_compile", lambda dev: "error: unknown target CPU 'generic'" if _describe(dev) == names[0] else None)
    code, out, err = run_cli(capsys, "devices", "--measure")
    assert code == 0 and measured == names[1:]
    assert _cpu_lines(out, names)[names[0]].endswith("  [not measured: error: unknown target CPU 'generic']")


def test_a_corrupt_cache_file_is_one_line_on_stderr_and_the_listing_still_comes(capsys, fake_speeds):
    names, _ = fake_speeds
    path = device_speed.cache_path()
    path.parent.mkdir(parents=True)
    path.write_text('{"format": 1, "speeds": ')
    code, out, err = run_cli(capsys, "devices")
    assert code == 0 and "Traceback" not in err
    assert err.count("\n") == 1 and err.startswith("clrender: ignoring the device speed cache "), err
    assert sorted(_cpu_lines(out, names)) == sorted(names)
    code, out, err = run_cli(capsys, "devices", "--measure")  # measuring rewrites it
    assert code == 0 and all("Msamples/s" in line for line in _cpu_lines(out, names).values())
    assert device_speed.load() != {}


def test_a_cache_folder_that_cannot_be_written_is_one_line_and_exit_1(capsys, fake_speeds):
    folder = device_speed.cache_path().parent
    folder.parent.mkdir(parents=True)
    folder.write_text("a file where the cache folder goes")
    code, out, err = run_cli(capsys, "devices", "--measure")
    assert code == 1 and "Traceback" not in err
    assert err.count("\n") == 1 and err.startswith(f"clrender: cannot write the device speed cache {folder / 'device-speed.json'}: "), err


def test_oclgrind_is_listed_as_the_checker_never_measured_nor_starred(capsys, fake_speeds):
    names, measured = fake_speeds
    checkers = [_describe(d) for d in device_module.all_devices() if device_module.is_simulator(d)]
    if not checkers:
        pytest.skip("Oclgrind is not installed here")
    code, out, err = run_cli(capsys, "devices", "--measure")
    assert code == 0 and err == "", err
    assert not set(checkers) & set(measured)
    lines = {line[2:].split("  [")[0]: line for line in out.splitlines()}
    for name in checkers:
        assert lines[name] == f"  {name}  [{devices_command.CHECKER_NOTE}]"
