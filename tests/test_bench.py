"""Smoke tests of the benchmark harnesses (their --quick modes)."""

import csv
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_bvh_harness_runs_all_six_scenes_and_writes_its_outputs(tmp_path):
    proc = subprocess.run(
        [sys.executable, "-m", "bench", "bvh", "--quick", "--out", str(tmp_path)], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(open(tmp_path / "bvh.csv")))
    assert [r["scene"] for r in rows] == ["refract1", "bunny", "refract2", "wizard_tower", "wizard_hat", "wizard_cat"]
    heavy = [r for r in rows if int(r["primitives"]) >= 50_000]
    assert len(heavy) >= 2
    for r in heavy:  # the kernels' own counts, not timings: the BVH tests a tiny share of the primitives
        assert float(r["on_visits_per_ray"]) < 0.01 * float(r["off_visits_per_ray"])
    assert (tmp_path / "bvh.png").stat().st_size > 1000
    assert (tmp_path / "bvh.md").read_text().count("\n") >= 8
