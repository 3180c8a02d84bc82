"""The default device's rule by measured speed (device.py `_ranked_cpus`) and the speed cache (device_speed.py).

Fake devices and fake measurements only: no timing is asserted and nothing is rendered."""

from types import SimpleNamespace

import pyopencl as cl
import pytest

from clrender import device as device_module
from clrender import device_speed
from clrender.device_speed import Speed


def _fake(platform: str, version: str = "1.0", kind=cl.device_type.CPU, name: str = "cpu"):
    return SimpleNamespace(platform=SimpleNamespace(name=platform, version=f"OpenCL 3.0 {version}"), name=name, driver_version=version, type=kind)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A fresh user cache folder and CPU model for the speed cache; its file's path."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setattr(device_speed, "cpu_model", lambda: "Test CPU 9000")
    monkeypatch.setattr(device_speed, "_warned", set())
    return device_speed.cache_path()


def _with_speeds(monkeypatch, table: dict):
    """Measurements by device object: table maps id(device) -> Speed."""
    monkeypatch.setattr(device_module, "_speeds", lambda cpus: [table.get(id(d)) for d in cpus])
    monkeypatch.setattr(device_module, "_cannot_compile", lambda dev: None)


def test_without_measurements_the_static_order_puts_intel_first_then_pocl_then_others(monkeypatch):
    other, pocl, intel = _fake("Other CL"), _fake("Portable Computing Language"), _fake("Intel(R) OpenCL")
    gpu = _fake("NVIDIA CUDA", kind=cl.device_type.GPU)
    _with_speeds(monkeypatch, {})
    assert device_module._ranked_cpus([other, pocl, gpu, intel]) == [intel, pocl, other]
    assert device_module._default_cpu([other, pocl, gpu, intel]) is intel


def test_a_measured_driver_more_than_the_margin_faster_than_the_static_first_is_the_default(monkeypatch):
    pocl, intel = _fake("Portable Computing Language"), _fake("Intel(R) OpenCL")
    _with_speeds(monkeypatch, {id(intel): Speed(1.0, 4.0), id(pocl): Speed(1.2, 4.0)})  # scores 2.0 and 2.19: 1.095x, within
    assert device_module._default_cpu([intel, pocl]) is intel
    _with_speeds(monkeypatch, {id(intel): Speed(1.0, 4.0), id(pocl): Speed(1.2, 4.2)})  # 2.245: 1.12x, past the margin
    assert device_module._default_cpu([intel, pocl]) is pocl


def test_within_the_margin_or_with_the_static_first_unmeasured_the_static_order_stands(monkeypatch):
    pocl, intel = _fake("Portable Computing Language"), _fake("Intel(R) OpenCL")
    _with_speeds(monkeypatch, {id(intel): Speed(1.0, 4.0), id(pocl): Speed(1.05, 4.0)})  # 1.025x: noise, not a reason
    assert device_module._default_cpu([pocl, intel]) is intel
    _with_speeds(monkeypatch, {id(pocl): Speed(100.0, 100.0)})  # intel never measured: nothing to compare with
    assert device_module._default_cpu([pocl, intel]) is intel


def test_the_fastest_of_several_measured_drivers_leads_and_the_pick_is_the_same_in_any_loader_order(monkeypatch):
    pocl, intel, other = _fake("Portable Computing Language"), _fake("Intel(R) OpenCL"), _fake("Other CL")
    _with_speeds(monkeypatch, {id(intel): Speed(1.0, 1.0), id(pocl): Speed(2.0, 2.0), id(other): Speed(3.0, 3.0)})
    import itertools

    picks = {id(device_module._default_cpu(list(order))) for order in itertools.permutations([pocl, intel, other])}
    assert picks == {id(other)}
    assert device_module._ranked_cpus([pocl, intel, other]) == [other, intel, pocl]


def test_a_measured_winner_that_cannot_compile_gives_way_to_the_next(monkeypatch):
    pocl, intel = _fake("Portable Computing Language"), _fake("Intel(R) OpenCL")
    _with_speeds(monkeypatch, {id(intel): Speed(1.0, 1.0), id(pocl): Speed(5.0, 5.0)})
    monkeypatch.setattr(device_module, "_cannot_compile", lambda dev: "error: unknown target CPU 'generic'" if dev is pocl else None)
    assert device_module._default_cpu([pocl, intel]) is intel


def test_the_rule_reads_the_cache_file_by_each_devices_key(cache, monkeypatch):
    pocl, intel = _fake("Portable Computing Language"), _fake("Intel(R) OpenCL")
    monkeypatch.setattr(device_module, "_cannot_compile", lambda dev: None)
    device_speed.save(intel, Speed(1.0, 1.0))
    device_speed.save(pocl, Speed(2.0, 2.0))
    assert device_module._default_cpu([intel, pocl]) is pocl
    newer_pocl = _fake("Portable Computing Language", version="3.1")  # an upgraded driver: its old number no longer counts
    assert device_module._default_cpu([intel, newer_pocl]) is intel


def test_the_cache_keeps_each_entry_and_a_new_driver_version_or_cpu_is_not_found(cache, monkeypatch):
    intel, pocl = _fake("Intel(R) OpenCL", "2026.1"), _fake("Portable Computing Language", "3.0")
    assert device_speed.lookup(intel) is None and not cache.exists()
    device_speed.save(intel, Speed(0.5, 3.0))
    device_speed.save(pocl, Speed(0.25, 2.0))
    assert device_speed.lookup(intel) == Speed(0.5, 3.0) and device_speed.lookup(pocl) == Speed(0.25, 2.0)
    device_speed.save(intel, Speed(0.75, 3.0))  # a re-measurement replaces its own entry only
    assert device_speed.lookup(intel) == Speed(0.75, 3.0) and device_speed.lookup(pocl) == Speed(0.25, 2.0)
    assert device_speed.lookup(_fake("Intel(R) OpenCL", "2026.2")) is None  # new driver version
    assert device_speed.lookup(_fake("Intel(R) OpenCL", "2026.1", name="other cpu")) is None  # another device
    monkeypatch.setattr(device_speed, "cpu_model", lambda: "Test CPU 9001")
    assert device_speed.lookup(intel) is None  # another CPU model
    monkeypatch.setattr(device_speed, "WORKLOAD_VERSION", device_speed.WORKLOAD_VERSION + 1)
    monkeypatch.setattr(device_speed, "cpu_model", lambda: "Test CPU 9000")
    assert device_speed.lookup(intel) is None  # another workload


CORRUPT = ["{not json", '{"format": 1, "speeds": {"k": {"path": "fast"}}}', '{"format": 99, "speeds": {}}', "[1, 2]", "\udcff"]


@pytest.mark.parametrize("text", CORRUPT)
def test_a_corrupt_cache_is_ignored_with_one_line_once_and_rewritten_by_the_next_save(cache, capsys, text):
    cache.parent.mkdir(parents=True)
    cache.write_text(text, errors="surrogateescape")
    intel = _fake("Intel(R) OpenCL")
    assert device_speed.lookup(intel) is None
    assert device_speed.lookup(intel) is None
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"clrender: ignoring the device speed cache {cache}: ") and "--measure" in err, err
    device_speed.save(intel, Speed(1.0, 2.0))
    assert device_speed.lookup(intel) == Speed(1.0, 2.0)
