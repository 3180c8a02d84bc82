"""The drivers the loader is made to see (clrender/drivers.py) and the default device's choice among them (device.py)."""

from types import SimpleNamespace

import pyopencl as cl
import pytest

from clrender import device as device_module
from clrender import drivers
from clrender.errors import RenderFailure, UsageError


def test_registering_intel_writes_a_vendor_folder_that_keeps_the_loaders_earlier_files(tmp_path, monkeypatch):
    intel, other = tmp_path / "libintelocl.so", tmp_path / "libother.so"
    intel.write_bytes(b"")
    other.write_bytes(b"")
    before = tmp_path / "before"
    before.mkdir()
    (before / "other.icd").write_text(f"{other}\n")
    monkeypatch.setattr(drivers, "find_intel_library", lambda: intel)
    monkeypatch.setattr(drivers, "find_oclgrind_library", lambda: None)
    monkeypatch.setenv("OCL_ICD_VENDORS", str(before))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    folder = drivers.register_runtimes()
    assert folder is not None and str(folder).startswith(str(tmp_path / "cache"))
    assert sorted(p.read_text().strip() for p in folder.glob("*.icd")) == sorted([str(intel), str(other)])
    assert drivers.os.environ["OCL_ICD_VENDORS"] == str(folder)
    assert drivers.register_runtimes() is None  # the loader sees it already: nothing more to do


def test_without_intels_runtime_or_oclgrind_the_loader_is_left_alone(tmp_path, monkeypatch):
    monkeypatch.setattr(drivers, "find_intel_library", lambda: None)
    monkeypatch.setattr(drivers, "find_oclgrind_library", lambda: None)
    monkeypatch.setenv("OCL_ICD_VENDORS", str(tmp_path))
    assert drivers.register_runtimes() is None
    assert drivers.os.environ["OCL_ICD_VENDORS"] == str(tmp_path)


def _libraries(tmp_path, *names):
    paths = [tmp_path / "lib" / name for name in names]
    for path in paths:
        path.parent.mkdir(exist_ok=True)
        path.write_bytes(b"")
    return paths


def installed(monkeypatch, tmp_path, intel, oclgrind, vendors):
    """This machine as the test sets it: those libraries installed (None: not), the loader reading `vendors`, Oclgrind
    asked for, and the vendor folder written under tmp_path."""
    monkeypatch.setattr(drivers, "find_intel_library", lambda: intel)
    monkeypatch.setattr(drivers, "find_oclgrind_library", lambda: oclgrind)
    monkeypatch.setenv("CLRENDER_DEVICE", "oclgrind")
    monkeypatch.setenv("OCL_ICD_VENDORS", str(vendors))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))


def test_debians_oclgrind_without_an_icd_file_is_added_beside_the_loaders_files_when_asked_for(tmp_path, monkeypatch):
    oclgrind, pocl = _libraries(tmp_path, "liboclgrind-rt-icd.so", "libpocl.so.2.10.0")
    before = tmp_path / "before"
    before.mkdir()
    (before / "pocl.icd").write_text(f"{pocl}\n")
    (before / "by-name.icd").write_text("libOpenCL-vendor.so.1\n")  # a bare name: found on the loader's path
    installed(monkeypatch, tmp_path, intel=None, oclgrind=oclgrind, vendors=before)
    folder = drivers.register_runtimes()
    assert folder is not None and drivers.os.environ["OCL_ICD_VENDORS"] == str(folder)
    assert {p.name: p.read_text().strip() for p in folder.glob("*.icd")} == {
        "oclgrind.icd": str(oclgrind),
        "kept0-by-name.icd": "libOpenCL-vendor.so.1",
        "kept1-pocl.icd": str(pocl),
    }
    assert drivers.register_runtimes() is None


def test_oclgrind_stays_unseen_unless_clrender_device_names_it(tmp_path, monkeypatch):
    """Loaded, its library adds about 57 MB to every process: only a process that asks for the checker pays that."""
    (oclgrind,) = _libraries(tmp_path, "liboclgrind-rt-icd.so")
    monkeypatch.setattr(drivers, "find_intel_library", lambda: None)
    monkeypatch.setattr(drivers, "find_oclgrind_library", lambda: oclgrind)
    monkeypatch.setenv("OCL_ICD_VENDORS", str(tmp_path))
    for unset_or_other in (None, "portable"):
        if unset_or_other is None:
            monkeypatch.delenv("CLRENDER_DEVICE", raising=False)
        else:
            monkeypatch.setenv("CLRENDER_DEVICE", unset_or_other)
        assert drivers.wanted_libraries() == {} and drivers.register_runtimes() is None
    monkeypatch.setenv("CLRENDER_DEVICE", "Oclgrind")
    assert drivers.wanted_libraries() == {"oclgrind.icd": oclgrind}


def test_intel_and_oclgrind_go_in_one_folder_and_a_stale_line_for_either_is_dropped(tmp_path, monkeypatch):
    intel, oclgrind = _libraries(tmp_path, "libintelocl.so", "liboclgrind-rt-icd.so")
    before = tmp_path / "before"
    before.mkdir()
    (before / "intel-cpu.icd").write_text("/opt/build/lib/libintelocl.so.2026\n")  # the pip package's own: a build machine's path
    (before / "oclgrind.icd").write_text("liboclgrind-rt-icd.so\n")  # by name: loading it again by path would list it twice
    installed(monkeypatch, tmp_path, intel=intel, oclgrind=oclgrind, vendors=before)
    folder = drivers.register_runtimes()
    assert sorted(p.read_text().strip() for p in folder.glob("*.icd")) == sorted([str(intel), str(oclgrind)])


def test_an_oclgrind_an_icd_file_already_names_is_left_to_it(tmp_path, monkeypatch):
    (oclgrind,) = _libraries(tmp_path, "liboclgrind-rt-icd.so")
    (tmp_path / "oclgrind.icd").write_text(f"{oclgrind}\n")
    monkeypatch.setattr(drivers, "find_intel_library", lambda: None)
    monkeypatch.setattr(drivers, "find_oclgrind_library", lambda: oclgrind)
    monkeypatch.setenv("CLRENDER_DEVICE", "oclgrind")
    monkeypatch.setenv("OCL_ICD_VENDORS", str(tmp_path / "oclgrind.icd"))
    assert drivers.register_runtimes() is None
    assert drivers.os.environ["OCL_ICD_VENDORS"] == str(tmp_path / "oclgrind.icd")


def test_oclgrind_is_found_only_where_debian_puts_it(tmp_path, monkeypatch):
    monkeypatch.setattr(drivers, "OCLGRIND_LIBRARY", tmp_path / "liboclgrind-rt-icd.so")
    assert drivers.find_oclgrind_library() is None
    (tmp_path / "liboclgrind-rt-icd.so").write_bytes(b"")
    assert drivers.find_oclgrind_library() == tmp_path / "liboclgrind-rt-icd.so"


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


def test_the_simulator_is_never_the_default_nor_measured_even_where_it_is_the_fastest_measured(monkeypatch):
    oclgrind, pocl = _fake("Oclgrind", cl.device_type.ALL), _fake("Portable Computing Language")
    asked = []

    def speeds(cpus):  # the simulator, were it measured, by far the fastest
        asked.extend(cpus)
        return [SimpleNamespace(score=1000.0 if d is oclgrind else 1.0) for d in cpus]

    monkeypatch.setattr(device_module, "_cannot_compile", lambda dev: None)
    monkeypatch.setattr(device_module, "_speeds", speeds)
    assert device_module._default_cpu([oclgrind, pocl]) is pocl
    assert asked == [pocl]  # its cached speed is not even looked up
    with pytest.raises(UsageError):
        device_module._default_cpu([oclgrind])  # no CPU driver: the simulator does not stand in for one


def test_cpu_devices_leave_the_simulator_out_and_name_picks_it(monkeypatch):
    oclgrind, pocl = _fake("Oclgrind", cl.device_type.ALL), _fake("Portable Computing Language")
    monkeypatch.setattr(device_module, "all_devices", lambda: [oclgrind, pocl])
    assert device_module.cpu_devices() == [pocl]
    assert device_module.is_simulator(oclgrind) and not device_module.is_simulator(pocl)
