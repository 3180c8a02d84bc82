"""The CPU drivers a pip install brings (clrender/drivers.py) and the default device's choice among them (device.py)."""

from types import SimpleNamespace

import pyopencl as cl
import pytest

from clrender import device as device_module
from clrender import drivers
from clrender.errors import RenderFailure


def test_registering_intel_writes_a_vendor_folder_that_keeps_the_loaders_earlier_files(tmp_path, monkeypatch):
    intel, other = tmp_path / "libintelocl.so", tmp_path / "libother.so"
    intel.write_bytes(b"")
    other.write_bytes(b"")
    before = tmp_path / "before"
    before.mkdir()
    (before / "other.icd").write_text(f"{other}\n")
    monkeypatch.setattr(drivers, "find_intel_library", lambda: intel)
    monkeypatch.setenv("OCL_ICD_VENDORS", str(before))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    folder = drivers.register_pip_runtimes()
    assert folder is not None and str(folder).startswith(str(tmp_path / "cache"))
    assert sorted(p.read_text().strip() for p in folder.glob("*.icd")) == sorted([str(intel), str(other)])
    assert drivers.os.environ["OCL_ICD_VENDORS"] == str(folder)
    assert drivers.register_pip_runtimes() is None  # the loader sees it already: nothing more to do


def test_without_intels_runtime_the_loader_is_left_alone(tmp_path, monkeypatch):
    monkeypatch.setattr(drivers, "find_intel_library", lambda: None)
    monkeypatch.setenv("OCL_ICD_VENDORS", str(tmp_path))
    assert drivers.register_pip_runtimes() is None
    assert drivers.os.environ["OCL_ICD_VENDORS"] == str(tmp_path)


def _fake(platform: str, kind=cl.device_type.CPU):
    return SimpleNamespace(platform=SimpleNamespace(name=platform, version="1.0"), name="cpu", driver_version="1.0", type=kind)


def test_the_default_is_intels_runtime_where_both_compile_and_nothing_is_measured(monkeypatch):
    pocl, intel = _fake("Portable Computing Language"), _fake("Intel(R) OpenCL")
    monkeypatch.setattr(device_module, "_cannot_compile", lambda dev: None)
    monkeypatch.setattr(device_module, "_speeds", lambda cpus: [None] * len(cpus))
    assert device_module._default_cpu([pocl, intel]) is intel  # the faster (docs/command-line.md, "Devices")


def test_the_default_is_pocl_where_it_is_the_only_cpu_driver(monkeypatch):
    pocl, gpu = _fake("Portable Computing Language"), _fake("NVIDIA CUDA", cl.device_type.GPU)
    monkeypatch.setattr(device_module, "_cannot_compile", lambda dev: None)
    monkeypatch.setattr(device_module, "_speeds", lambda cpus: [None] * len(cpus))
    assert device_module._default_cpu([gpu, pocl]) is pocl


def test_the_default_falls_back_to_another_cpu_driver_when_pocl_cannot_compile_for_this_cpu(monkeypatch):
    pocl, gpu, intel = _fake("Portable Computing Language"), _fake("NVIDIA CUDA", cl.device_type.GPU), _fake("Intel(R) OpenCL")
    monkeypatch.setattr(device_module, "_cannot_compile", lambda dev: "error: unknown target CPU 'generic'" if dev is pocl else None)
    assert device_module._default_cpu([pocl, gpu, intel]) is intel


def test_no_cpu_driver_that_compiles_is_one_line_naming_each_reason_and_the_fix(monkeypatch):
    pocl = _fake("Portable Computing Language")
    monkeypatch.setattr(device_module, "_cannot_compile", lambda dev: "error: unknown target CPU 'generic'")
    with pytest.raises(RenderFailure) as caught:
        device_module._default_cpu([pocl])
    message = str(caught.value)
    assert "\n" not in message and "unknown target CPU 'generic'" in message and "pip install intel-opencl-rt" in message


def test_the_chosen_default_device_builds_kernels(device):
    assert device_module._cannot_compile(device.device) is None
