"""The wheel carries the kernels and the scenes inside the package."""

import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_wheel_contains_kernels_and_scenes(tmp_path):
    subprocess.run(
        [sys.executable, "-m", "build", "--wheel", "--no-isolation", "--outdir", str(tmp_path), str(ROOT)], check=True, capture_output=True
    )
    wheel = next(tmp_path.glob("clrender-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    for cl_file in (ROOT / "kernels").glob("*.cl"):
        assert f"clrender/kernels/{cl_file.name}" in names
    for header in (ROOT / "kernels").glob("*.h"):
        assert f"clrender/kernels/{header.name}" in names
    for scene in [*(ROOT / "scenes").glob("*.toml"), *(ROOT / "scenes").glob("*.hdr")]:  # the scenes, and `--env studio`'s map
        assert f"clrender/scenes/{scene.name}" in names
    assert "clrender/cli.py" in names
    assert any(n.endswith("entry_points.txt") for n in names)


def test_installed_package_finds_its_kernels_and_scenes():
    from clrender.device import kernel_dir
    from clrender.scene.scene import bundled_scenes

    assert (kernel_dir() / "trace.cl").is_file()
    assert "refract1" in bundled_scenes()
