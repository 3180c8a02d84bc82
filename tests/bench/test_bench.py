"""The benchmark harnesses: `python -m bench` lists them and nothing else, and smoke tests of their --quick modes."""

import csv
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


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


def bench_modules():
    """bench/NAME.py files that define main(argv): the benchmarks."""
    import ast

    names = []
    for path in sorted((ROOT / "bench").glob("*.py")):
        tree = ast.parse(path.read_text())
        if path.stem != "__main__" and any(isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body):
            names.append(path.stem)
    return names


def test_bench_lists_exactly_its_benchmarks_and_holds_nothing_else():
    proc = subprocess.run([sys.executable, "-m", "bench"], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    listed = proc.stderr.split("{", 1)[1].split("}", 1)[0].split("|")
    assert sorted(listed) == bench_modules()
    # besides the benchmarks: the package, its dispatcher and their shared helpers, nothing else (tools/ holds the tools)
    others = {p.name for p in (ROOT / "bench").glob("*.py")} - {f"{n}.py" for n in listed}
    assert others == {"__init__.py", "__main__.py", "common.py"}


def test_every_listed_benchmark_imports_and_has_a_main():
    names = bench_modules()
    code = f"import importlib; [callable(importlib.import_module('bench.' + n).main) or exit(1) for n in {names!r}]"
    proc = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr


@pytest.mark.parametrize("name, command", [("mutants", "python -m tools.mutants"), ("render_hashes", "python tools/render_hashes.py")])
def test_the_tools_that_moved_out_of_bench_say_where_they_went(name, command):
    proc = subprocess.run([sys.executable, "-m", "bench", name, "--list"], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2 and command in proc.stderr, proc.stderr


@pytest.mark.slow
def test_path_harness_quick_run_measures_mitsuba_and_says_when_clrender_cannot_path_trace(tmp_path):
    """`bench path --peer mitsuba --quick`: Mitsuba's two variants on both scenes; clrender's row once its path
    integrator exists (issue 25), a one-line note until then.  Skips without Mitsuba."""
    from tests.reference.mitsuba_scenes import unavailable

    reason = unavailable("llvm_ad_rgb")
    if reason:
        pytest.skip(reason)
    proc = subprocess.run(
        [sys.executable, "-m", "bench", "path", "--peer", "mitsuba", "--quick", "--out", str(tmp_path)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(open(tmp_path / "path.csv")))
    renderers = {r["renderer"] for r in rows}
    assert {"mitsuba llvm_ad_rgb", "mitsuba scalar_rgb"} <= renderers
    assert {r["scene"] for r in rows} == {"cornell_box", "wizard_cat"}
    assert all(float(r["msamples_per_s"]) > 0 for r in rows)
    assert ("clrender" in renderers) != ("path integrator is not available" in proc.stdout)
    assert (tmp_path / "path.png").stat().st_size > 1000
    if "clrender" in renderers:  # clrender beside Mitsuba llvm, and their brightness compared
        assert (tmp_path / "path_wizard_cat_pair.png").stat().st_size > 1000
        assert proc.stdout.count("block means over") == 2


def test_path_bench_lights_wizard_cat_physically_as_bright_at_the_cat():
    """bench/path.py's physical_lights: the area light's inverse-square irradiance at camera 3's look-at point,
    radiance c I' times A cos(theta_l) / d^2 (a small light: 1.2 square at distance 5.2), is the pi c I of
    falloff "none" within the small-light approximation's 1%; the directional light's pi c I stays."""
    import math

    import numpy as np

    from bench.path import wizard_cat_scene
    from clrender.scene.scene import Scene

    before, after = Scene.load("wizard_cat").lights, wizard_cat_scene(3).lights
    focus = np.asarray(Scene.load("wizard_cat").camera(3).look_at, float)
    assert [light.falloff for light in after] == ["inverse_square"] * len(before)
    for old, new in zip(before, after):
        if old.type == "directional":
            assert new.intensity == pytest.approx(math.pi * old.intensity)
            continue
        a, b = np.asarray(new.edge_a, float), np.asarray(new.edge_b, float)
        # the irradiance of the parallelogram by midpoint quadrature (64 x 64 cells), light travelling along n = a x b
        s = (np.arange(64) + 0.5) / 64
        points = np.asarray(new.position, float) + s[:, None, None] * a + s[None, :, None] * b
        d = focus - points
        dist = np.linalg.norm(d, axis=-1)
        n = np.cross(a, b)
        cos_l = (d @ n) / (np.linalg.norm(n) * dist)
        irradiance = new.intensity * np.mean(cos_l / dist**2) * np.linalg.norm(n)  # per unit colour, normal incidence
        assert irradiance == pytest.approx(math.pi * old.intensity, rel=0.01)


@pytest.mark.slow  # a bench subprocess: minutes on a cold kernel cache
def test_rays_harness_compares_end_to_end_queries_with_embree_at_equal_threads(tmp_path):
    """`bench rays --peer embree`: the user queries of clrender and Embree (two threads each) on the same rays,
    clrender's ratio per ray kind, and Mrays/s against the batch size; an unknown peer is refused (exit 2)."""
    pytest.importorskip("embreex")
    args = ["--peer", "embree", "--size", "32", "--runs", "1", "--no-build", "--threads", "2", "--out", str(tmp_path)]
    proc = subprocess.run([sys.executable, "-m", "bench", "rays", *args], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    tools = list(csv.DictReader(open(tmp_path / "rays_end_to_end.csv")))
    assert [(r["tool"], r["threads"]) for r in tools] == [("clrender", "2"), ("embree", "2")]
    for kind in ("primary", "shadow", "incoherent"):
        ratio = float(tools[0][f"{kind}_mrays"]) / float(tools[1][f"{kind}_mrays"])
        assert float(tools[0][f"{kind}_vs_embree"]) == pytest.approx(ratio, rel=1e-3)
    assert [int(r["batch"]) for r in csv.DictReader(open(tmp_path / "rays_batches.csv"))] == [256, 1024]
    bad = subprocess.run([sys.executable, "-m", "bench", "rays", "--peer", "optix"], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and "allowed: a comma list of embree, open3d" in bad.stderr


def test_assets_glb_is_read_back_by_clrender_with_its_uvs_and_three_textures(tmp_path):
    """bench/assets.py writes its GLB by hand: clrender reads the same triangles, UVs and texels (base colour
    sRGB-decoded, metallic-roughness and normal map linear), so the load-time numbers are of the asset described."""
    import numpy as np

    from bench.assets import grid, make_model, torus, wood
    from clrender.scene.scene import Scene
    from clrender.scene.textures import srgb_to_linear

    made = make_model(tmp_path / "model.glb", 2000, 64)
    scene = Scene.from_file(tmp_path / "model.glb")
    mesh = scene.objects[0]
    _, _, uvs, faces = torus(*grid(2000))
    assert made["triangles"] == len(faces) == len(mesh.faces)
    np.testing.assert_allclose(mesh.uvs, uvs, atol=1e-6)
    base, mr, normal = wood(64)
    texels = {t.pixels.shape: t for t in scene.textures}
    assert len(scene.textures) == 3 and list(texels) == [(64, 64, 4)]
    got = sorted((t.pixels[..., :3] for t in scene.textures), key=lambda p: float(p[..., 2].mean()))
    want = sorted([srgb_to_linear(base / 255.0), mr / 255.0, normal / 255.0], key=lambda p: float(p[..., 2].mean()))
    for g, w in zip(got, want):
        np.testing.assert_allclose(g, w, atol=1e-6)


@pytest.mark.slow
def test_assets_harness_times_the_load_phases_and_renders_beside_mitsuba(tmp_path):
    """`bench assets --quick [--peer mitsuba]`: one row of load phases (they add up to the time to the first image),
    the device bytes of three 256^2 float4 textures, and (with Mitsuba) the side-by-side picture and its z-test line."""
    from tests.reference import mitsuba_scenes

    args = ["--quick", "--out", str(tmp_path)]
    if mitsuba_scenes.unavailable("llvm_ad_rgb") is None:
        args += ["--peer", "mitsuba"]
    proc = subprocess.run([sys.executable, "-m", "bench", "assets", *args], cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    (row,) = csv.DictReader(open(tmp_path / "assets.csv"))
    assert int(row["texture_bytes"]) == 3 * 256 * 256 * 16
    phases = sum(float(row[k]) for k in ("load_s", "bvh_s", "setup_s", "first_pass_s"))
    assert phases <= float(row["to_first_image_s"]) + 1e-6
    if "--peer" in args:
        assert (tmp_path / "assets_pair.png").stat().st_size > 1000
        assert ": pass" in proc.stdout, proc.stdout


@pytest.mark.slow
def test_whitted_harness_matches_mitsuba_direct_rays_to_clrenders_and_reports_consistent_ratios(tmp_path):
    """`bench whitted --quick`: for both variants Mitsuba direct's emitter_samples is the whole number whose
    counted rays come nearest clrender's counted rays (within half an emitter sample per camera ray), and the
    speedup columns are the ratios of the columns beside them.  Skips without Mitsuba's LLVM variant."""
    from tests.reference.mitsuba_scenes import unavailable

    reason = unavailable("llvm_ad_rgb")
    if reason:
        pytest.skip(reason)
    proc = subprocess.run(
        [sys.executable, "-m", "bench", "whitted", "--quick", "--out", str(tmp_path)], cwd=ROOT, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    rows = {r["variant"]: r for r in csv.DictReader(open(tmp_path / "whitted.csv"))}
    assert list(rows) == ["opaque", "glass"]
    camera_mrays = 64 * 64 * 4 / 1e6
    for r in rows.values():
        ours, theirs = float(r["clrender_mrays"]), float(r["mitsuba_mrays"])
        assert ours > camera_mrays and int(r["emitter_samples"]) >= 1 and int(r["bsdf_samples"]) == 0
        assert abs(theirs - ours) <= camera_mrays / 2 + 1e-9  # each emitter sample adds at most one ray per camera ray
        ours_rate, theirs_rate = ours / float(r["clrender_s"]), theirs / float(r["mitsuba_s"])
        assert float(r["speedup_mrays_per_s"]) == pytest.approx(ours_rate / theirs_rate, rel=1e-3)
        assert float(r["speedup_wall"]) == pytest.approx(float(r["mitsuba_s"]) / float(r["clrender_s"]), rel=1e-3)
        assert (tmp_path / f"whitted_{r['variant']}_pair.png").stat().st_size > 1000
    # the glass sphere's refracted and reflected rays are clrender's only extra work
    assert float(rows["glass"]["clrender_mrays"]) > float(rows["opaque"]["clrender_mrays"])
    assert "directional-light weight" in proc.stdout


def test_whitted_harness_without_mitsuba_says_how_to_install_it_in_one_line(tmp_path):
    """A `mitsuba` that cannot be imported (a stand-in package first on the path): exit 2, one line naming the extra."""
    fake = tmp_path / "mitsuba"
    fake.mkdir()
    (fake / "__init__.py").write_text("raise ImportError('stand-in: no mitsuba here')\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tmp_path), str(ROOT)])}
    proc = subprocess.run(
        [sys.executable, "-m", "bench", "whitted", "--out", str(tmp_path / "out")], cwd=ROOT, capture_output=True, text=True, timeout=120, env=env
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.count("\n") == 1 and "pip install -e '.[reference]'" in proc.stderr, proc.stderr
    assert not (tmp_path / "out").exists()


def test_whitted_bench_solves_emitter_samples_for_the_nearest_ray_count():
    """equal_work_emitter_samples: rays = P (1 + e r_e + b r_b); the whole e >= 1 nearest the target."""
    from bench.whitted import equal_work_emitter_samples, mitsuba_rays

    rates = {"emitter": 0.5, "bsdf": 0.25}
    assert mitsuba_rays(1000, rates, 7, 2) == 1000 * (1 + 3.5 + 0.5)
    assert equal_work_emitter_samples(1000 * (1 + 3.5), 1000, rates, 0) == 7
    assert equal_work_emitter_samples(1000 * (1 + 3.5 + 0.5) + 240, 1000, rates, 2) == 7  # 0.48 of a sample above: 7
    assert equal_work_emitter_samples(1000 * (1 + 3.5) + 260, 1000, rates, 0) == 8
    assert equal_work_emitter_samples(900, 1000, rates, 0) == 1  # fewer rays than the camera's alone: at least one sample
