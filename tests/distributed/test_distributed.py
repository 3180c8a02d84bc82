"""Rendering on a Dask cluster gives the local bytes: tiles, edge-pixel chunks and turntable frames as tasks.

One LocalCluster of two single-thread worker processes serves the module
(starting one costs ~1.5 s); the kill-a-worker test starts its own.  The
reference is always the local renderer in this process, never the code
under test.
"""

import math
import os
import signal
import socket
import sys
import threading
import time
from dataclasses import replace

import numpy as np
import pytest

import clrender
from clrender.cli import main
from clrender.distributed.payload import join, split
from clrender.errors import UsageError
from clrender.scene.camera import Camera
from clrender.scene.scene import Scene
from clrender.trace.turntable import frame_scene, orbit, render_turntable

from tests.clitools import default_sigint
from tests.scenetools import copies_scene

distributed = pytest.importorskip("distributed")
crd = pytest.importorskip("clrender.distributed")
from clrender.distributed.cluster import pocl_env  # noqa: E402

TINY = dict(width=48, height=32, tile_size=16)  # 6 tiles: work for both workers


def local_cluster(workers=2):
    import logging

    return distributed.LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0", silence_logs=logging.ERROR, env=pocl_env(1)
    )


@pytest.fixture(scope="module")
def cluster():
    with local_cluster() as c:
        yield c


@pytest.fixture(scope="module")
def client(cluster):
    with distributed.Client(cluster) as c:
        yield c


def scheduler_tasks(client) -> int:
    return client.run_on_scheduler(lambda dask_scheduler: len(dask_scheduler.tasks))


def wait_for(condition, seconds=10.0):
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.05)
    return True


# ------------------------------------------------------------------ the same bytes
@pytest.mark.parametrize("aa", ["none", "full", "edge_detect"])
def test_distributed_render_is_byte_identical_to_local(client, aa):
    settings = dict(TINY, aa=aa, samples=3, seed=7)
    renderer = crd.DistributedRenderer("refract1", client=client, **settings)
    result = renderer.run()
    local = clrender.Renderer("refract1", **settings).run()
    assert result.image.tobytes() == local.image.tobytes()
    assert np.array_equal(result.path_ids, local.path_ids)
    assert result.rays == local.rays and result.node_visits == local.node_visits
    tasks = {t["task"] for t in renderer.task_log}
    n_tiles = math.ceil(48 / 16) * math.ceil(32 / 16)
    assert sum(t["task"] == "trace" for t in renderer.task_log) == n_tiles
    if aa == "edge_detect":  # the compacted edge pixels went out as tasks too
        assert np.array_equal(result.edge_mask, local.edge_mask) and result.edge_mask.any()
        assert tasks == {"trace", "edges"}
    else:
        assert tasks == {"trace"}


def test_aovs_come_back_from_the_workers_too(client):
    settings = dict(TINY, aa="edge_detect", samples=2, aovs=("depth", "normal", "albedo", "id", "edges"))
    remote = crd.run("refract1", client=client, **settings)
    local = clrender.Renderer("refract1", **settings).run()
    assert set(remote.aovs) == set(local.aovs) == set(settings["aovs"])
    for name in settings["aovs"]:
        assert remote.aovs[name].tobytes() == local.aovs[name].tobytes(), name


def test_workers_build_each_scene_once(client):
    scene = Scene.load("refract1")
    first = crd.DistributedRenderer(scene, client=client, **TINY, seed=101)
    first.run()
    again = crd.DistributedRenderer(scene, client=client, **TINY, seed=101)
    again.run()
    # a worker builds the Tracer and kernels on its first task only (at most one build per worker)
    assert sum(t["setup"] > 0 for t in first.task_log) <= 2
    assert all(t["setup"] == 0 for t in again.task_log)
    assert {t["device"] for t in again.task_log} == {clrender.device.get_device().name}


def test_workers_run_pocl_with_the_thread_count_they_were_given(client):
    from clrender.device import get_device

    names = client.run(lambda: get_device().name)
    if not all(name.startswith("Portable Computing Language") for name in names.values()):
        # pocl_env's variables are PoCL's; another runtime (Intel's reports every core whatever its
        # CL_CONFIG_CPU_TBB_NUM_WORKERS) has no such device query to check
        pytest.skip(f"pocl_env limits PoCL's threads; the workers run on {sorted(set(names.values()))}")
    units = client.run(lambda: get_device().device.max_compute_units)
    assert set(units.values()) == {1}


def test_scene_travels_as_a_dict_and_arrays_and_comes_back_equal():
    scene = Scene.load("wizard_cat")
    payload = split(scene)
    import json

    json.dumps(payload.description)  # plain data: no file paths or objects to resolve on the worker
    back = join(payload)
    assert back.cameras == scene.cameras and back.lights == scene.lights and back.materials == scene.materials
    for a, b in zip(scene.objects, back.objects):
        assert type(a) is type(b)
        for name in ("vertices", "faces", "vertex_normals"):
            if hasattr(a, name) and getattr(a, name) is not None:
                assert np.array_equal(getattr(a, name), getattr(b, name))
    assert split(back).key == payload.key
    moved = replace(scene, objects=list(scene.objects))
    mesh = next(o for o in moved.objects if hasattr(o, "vertices"))
    moved.objects[moved.objects.index(mesh)] = replace(mesh, vertices=mesh.vertices + 1e-6)
    assert split(moved).key != payload.key  # the cache key follows the geometry, not the name


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_an_environment_map_travels_with_the_scene(client, tmp_path, integrator):
    """The map's texels ship in the payload: the workers render the local bytes with the file gone."""
    import OpenImageIO as oiio

    texels = np.random.default_rng(4).uniform(0, 2, (8, 16, 3)).astype(np.float32)
    out = oiio.ImageOutput.create(str(tmp_path / "sky.exr"))
    out.open(str(tmp_path / "sky.exr"), oiio.ImageSpec(16, 8, 3, "float"))
    out.write_image(texels)
    out.close()
    data = {
        "cameras": [{"position": [0, 0, 4], "look_at": [0, 0, 0], "fov": 50}],
        "environment": {"file": "sky.exr", "rotation": 20, "intensity": 1.5},
        "materials": {"m": {"diffuse": [0.5, 0.5, 0.5], "mirror": 0.5}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}],
    }
    scene = Scene.from_dict(data, base_dir=tmp_path)
    (tmp_path / "sky.exr").unlink()
    payload = split(scene)
    assert np.array_equal(join(payload).environment_map.texels, texels)
    settings = dict(TINY, integrator=integrator, seed=3, **({"spp": 4} if integrator == "path" else {}))
    remote = crd.DistributedRenderer(scene, client=client, **settings).run()
    local = clrender.Renderer(scene, **settings).run()
    assert remote.image.tobytes() == local.image.tobytes()


# ------------------------------------------------------------------ turntable
def test_orbit_keeps_distance_and_height_and_turns_by_equal_angles():
    cam = Camera(position=(3.0, 2.0, 1.0), look_at=(0.5, -0.5, -4.0), up=(0.0, 1.0, 0.0), fov=50)
    cams = orbit(cam, 8)
    assert cams[0] == cam
    centre = np.array(cam.look_at)
    offsets = [np.array(c.position) - centre for c in cams]
    for off, c in zip(offsets, cams):
        assert c.look_at == cam.look_at and c.up == cam.up and c.fov == cam.fov
        assert np.linalg.norm(off) == pytest.approx(np.linalg.norm(offsets[0]), rel=1e-12)
        assert off[1] == pytest.approx(offsets[0][1], abs=1e-12)  # height along up
    flat = [np.array([o[0], o[2]]) for o in offsets]
    for a, b in zip(flat, flat[1:] + flat[:1]):
        assert math.acos(np.dot(a, b) / np.linalg.norm(a) / np.linalg.norm(b)) == pytest.approx(2 * math.pi / 8)
    assert np.allclose(flat[4], -flat[0], atol=1e-12)  # half-way round: the opposite side
    # counter-clockwise seen from above (+y): x -> -z -> -x
    assert np.cross(np.append(offsets[0], 0)[:3], offsets[2])[1] > 0


def test_turntable_frames_match_local_renders_of_their_cameras(client):
    scene = Scene.load("refract1")
    settings = clrender.RenderSettings(**TINY, camera=2, aa="edge_detect", samples=2)
    frames = crd.turntable(scene, settings, frames=3, client=client)
    cameras = orbit(scene.camera(2), 3)
    for k, image in enumerate(frames):
        local = clrender.render(frame_scene(scene, cameras[k]), replace(settings, camera=1))
        assert image.tobytes() == local.tobytes()
    assert frames[0].tobytes() == clrender.render(scene, settings).tobytes()  # frame 0 is the camera itself
    assert [img.tobytes() for _, img in render_turntable(scene, settings, 3)] == [f.tobytes() for f in frames]


def test_cli_turntable_writes_frames_and_video(client, tmp_path):
    import cv2

    out = tmp_path / "frames"
    video = tmp_path / "tt.mp4"
    rc = main(
        [
            "-q",
            "render",
            "refract1",
            "--camera",
            "2",
            "--width",
            "40",
            "--height",
            "30",
            "--turntable",
            "3",
            "-o",
            str(out),
            "--video",
            str(video),
            "--scheduler",
            client.scheduler.address,
        ]
    )
    assert rc == 0
    assert sorted(p.name for p in out.iterdir()) == ["frame_0000.png", "frame_0001.png", "frame_0002.png"]
    local = tmp_path / "local.png"
    assert main(["-q", "render", "refract1", "--camera", "2", "--width", "40", "--height", "30", "-o", str(local)]) == 0
    assert (out / "frame_0000.png").read_bytes() == local.read_bytes()
    capture = cv2.VideoCapture(str(video))
    shapes = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        shapes.append(frame.shape)
    assert shapes == [(30, 40, 3)] * 3
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary files left


def test_interrupted_turntable_leaves_no_frames(tmp_path, monkeypatch):
    import clrender.trace.turntable as tt

    real = tt.render_turntable

    def interrupted(*args, **kwargs):
        for k, image in real(*args, **kwargs):
            if k == 2:
                raise KeyboardInterrupt
            yield k, image

    monkeypatch.setattr(tt, "render_turntable", interrupted)
    out = tmp_path / "frames"
    rc = main(
        ["-q", "render", "refract1", "--width", "16", "--height", "12", "--turntable", "4", "-o", str(out), "--video", str(tmp_path / "tt.mp4")]
    )
    assert rc == 130
    assert list(tmp_path.iterdir()) == []  # the frames folder is created only with the frames (commands/turntable.py)


# ------------------------------------------------------------------ errors and cancelling
def test_cli_render_on_a_scheduler_writes_the_local_bytes(client, tmp_path):
    args = ["-q", "render", "refract1", "--width", "40", "--height", "30", "--aa", "edge_detect", "--samples", "2"]
    assert main(args + ["-o", str(tmp_path / "local.png")]) == 0
    assert main(args + ["-o", str(tmp_path / "dist.png"), "--scheduler", client.scheduler.address]) == 0
    assert (tmp_path / "dist.png").read_bytes() == (tmp_path / "local.png").read_bytes()


def test_a_worker_side_error_is_the_local_one_line_error(client, tmp_path, capsys):
    base = ["render", "refract1", "--width", "16", "--height", "12", "--device", "no-such-device"]
    assert main(base + ["-o", str(tmp_path / "a.png")]) == 2
    local_err = capsys.readouterr().err.strip().splitlines()
    assert main(["-q"] + base + ["-o", str(tmp_path / "b.png"), "--scheduler", client.scheduler.address]) == 2
    remote_err = capsys.readouterr().err.strip().splitlines()
    assert len(local_err) == 1 and remote_err == local_err
    assert "no OpenCL device matches 'no-such-device'" in local_err[0]
    assert list(tmp_path.iterdir()) == []


def test_a_worker_error_with_an_unpicklable_cause_still_reaches_the_client_as_itself():
    """A kernel build failure is raised from pyopencl's error, which does not pickle; Dask would then
    send a generic Exception carrying the whole build log instead of the one-line RenderFailure."""
    from distributed.core import error_message
    from distributed.protocol import pickle as dask_pickle

    from clrender.distributed.worker import task
    from clrender.errors import RenderFailure

    class Unpicklable(Exception):
        def __reduce__(self):
            raise TypeError("cannot pickle this")

    @task
    def build():
        try:
            raise Unpicklable()
        except Unpicklable as exc:
            raise RenderFailure("building kernels/trace.cl failed") from exc

    try:
        build()
    except RenderFailure as exc:
        message = error_message(exc)  # what a Dask worker sends back for a failed task
    error = dask_pickle.loads(message["exception"].data)
    assert type(error) is RenderFailure and str(error) == "building kernels/trace.cl failed"


def test_scene_errors_read_the_same_with_a_scheduler(client, tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[[objects]]\ntype = "sphere"\ncenter = [0, 0, -3]\nradius = -1\n')
    for extra in ([], ["--scheduler", client.scheduler.address]):
        assert main(["-q", "render", str(bad), "-o", str(tmp_path / "x.png")] + extra) == 2
    first, second = capsys.readouterr().err.strip().splitlines()
    assert first == second and "objects[0].radius" in first


def test_unreachable_scheduler_is_exit_2_naming_it_quickly(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("CLRENDER_CONNECT_TIMEOUT", "1")
    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        address = f"tcp://127.0.0.1:{s.getsockname()[1]}"
    start = time.monotonic()
    rc = main(["render", "refract1", "-o", str(tmp_path / "x.png"), "--scheduler", address])
    assert rc == 2 and time.monotonic() - start < 5
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and address in err[0] and "cannot reach the Dask scheduler" in err[0]
    assert list(tmp_path.iterdir()) == []


def test_scheduler_address_from_the_environment(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("CLRENDER_CONNECT_TIMEOUT", "0.5")
    monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", "tcp://127.0.0.1:9")
    assert main(["render", "refract1", "-o", str(tmp_path / "x.png")]) == 2
    assert "tcp://127.0.0.1:9" in capsys.readouterr().err


def test_without_the_extra_a_cluster_request_says_how_to_install(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import distributed -> ImportError
    assert main(["render", "refract1", "-o", str(tmp_path / "x.png"), "--workers", "2"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["clrender: a Dask cluster needs the distributed extra: pip install 'clrender[distributed]'"]
    with pytest.raises(UsageError, match=r"clrender\[distributed\]"):
        crd.render("refract1")
    # the single-machine path does not need it
    assert main(["-q", "render", "refract1", "--width", "16", "--height", "12", "-o", str(tmp_path / "y.png")]) == 0


def test_an_interrupted_render_cancels_its_tasks(client, monkeypatch):
    class InterruptingBar:
        def __init__(self, *args, **kwargs):
            pass

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def update(self, n=1):
            raise KeyboardInterrupt

    monkeypatch.setattr(crd, "progress", InterruptingBar)
    renderer = crd.DistributedRenderer("refract1", client=client, width=64, height=64, tile_size=8, aa="full", samples=4)
    with pytest.raises(KeyboardInterrupt):
        renderer.run()
    assert wait_for(lambda: scheduler_tasks(client) == 0)  # tiles and the scattered scene are gone


def test_a_turntable_stopped_early_cancels_its_frames(client):
    frames = crd.iter_turntable("refract1", frames=6, client=client, width=32, height=24)
    next(frames)
    frames.close()  # what Ctrl-C in the consumer does to the generator
    assert wait_for(lambda: scheduler_tasks(client) == 0)


# ------------------------------------------------------------------ splat fits
def small_photos():
    from clrender.testing import synthetic_photo

    return [np.ascontiguousarray(synthetic_photo(40, 24, seed=s)[..., :3], np.float32) for s in (1, 2)]


def test_gauss_fits_and_sweep_are_the_local_fits(client, device):
    from clrender.distributed.fits import fit_gauss, sweep_gauss
    from clrender.splat.fit import FitConfig, fit

    photos = small_photos()
    remote = fit_gauss(photos, FitConfig(splats=48, epochs=12, seed=5), client=client)
    for photo, result in zip(photos, remote):
        local = fit(device, photo, FitConfig(splats=48, epochs=12, seed=5))
        assert result.image.tobytes() == local.image.tobytes() and result.steps == local.steps
        assert np.array_equal(result.params.xy, local.params.xy)
    configs = [FitConfig(splats=48, epochs=8, lr=lr) for lr in (0.5, 2.0)]
    swept = sweep_gauss(photos[0], configs, client=client)
    for config, result in zip([FitConfig(splats=48, epochs=8, lr=lr) for lr in (0.5, 2.0)], swept):
        assert result.image.tobytes() == fit(device, photos[0], config).image.tobytes()
    assert swept[0].image.tobytes() != swept[1].image.tobytes()  # the learning rate mattered: order kept


def test_voronoi_splats_are_the_local_ones(client, device):
    from clrender.distributed.fits import splat_voronoi
    from clrender.splat.voronoi import VoronoiSettings, splat

    photos = small_photos()
    remote = splat_voronoi(photos, VoronoiSettings(n=30, lloyd=2, seed=4), client=client)
    for photo, result in zip(photos, remote):
        local = splat(device, photo, VoronoiSettings(n=30, lloyd=2, seed=4))
        assert result.image.tobytes() == local.image.tobytes() and np.array_equal(result.sites, local.sites)


def test_cli_splat_a_folder_of_photos_on_the_cluster(client, tmp_path):
    from clrender.image.files import write_image

    photos = tmp_path / "photos"
    photos.mkdir()
    for i, photo in enumerate(small_photos()):
        write_image(photos / f"p{i}.png", photo)
    fit = ["--splats", "30", "--epochs", "6"]
    assert main(["-q", "splat", "gauss", str(photos), "-o", str(tmp_path / "here")] + fit) == 0
    assert main(["-q", "splat", "gauss", str(photos / "*.png"), "-o", str(tmp_path / "there"), "--scheduler", client.scheduler.address] + fit) == 0
    assert (
        main(["-q", "splat", "voronoi", str(photos), "-o", str(tmp_path / "cells"), "--splats", "20", "--scheduler", client.scheduler.address]) == 0
    )
    assert main(["-q", "splat", "voronoi", str(photos / "p0.png"), "-o", str(tmp_path / "one.png"), "--splats", "20"]) == 0
    for name in ("p0.png", "p1.png"):
        assert (tmp_path / "there" / name).read_bytes() == (tmp_path / "here" / name).read_bytes()
    assert (tmp_path / "cells" / "p0.png").read_bytes() == (tmp_path / "one.png").read_bytes()


def test_splat_folder_errors(tmp_path, capsys):
    assert main(["splat", "gauss", str(tmp_path / "none" / "*.jpg"), "-o", str(tmp_path / "out")]) == 2
    assert "no images in" in capsys.readouterr().err
    from clrender.image.files import write_image

    write_image(tmp_path / "p.png", small_photos()[0])
    assert main(["splat", "gauss", str(tmp_path), "-o", str(tmp_path / "x.png")]) == 2
    assert "-o names a folder" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.png"]


# ------------------------------------------------------------------ faults
@pytest.mark.slow
def test_render_survives_a_worker_killed_mid_render():
    settings = dict(width=96, height=64, tile_size=8, aa="full", samples=6, seed=3)  # 96 tasks of ~10-50 ms
    local = clrender.Renderer("refract1", **settings).run()
    with local_cluster() as cluster, distributed.Client(cluster) as client:
        client.wait_for_workers(2)
        renderer = crd.DistributedRenderer("refract1", client=client, **settings)
        outcome = {}
        thread = threading.Thread(target=lambda: outcome.setdefault("result", renderer.run()))
        thread.start()
        assert wait_for(lambda: len(renderer.task_log) >= 4, 60)
        done_before_kill = len(renderer.task_log)
        victim = next(pid for pid in client.run(os.getpid).values() if pid in {t["pid"] for t in renderer.task_log})
        os.kill(victim, signal.SIGKILL)
        thread.join(120)
        assert not thread.is_alive()
    assert done_before_kill < 96  # the kill really came mid-render
    assert outcome["result"].image.tobytes() == local.image.tobytes()
    assert len(renderer.task_log) == 96  # every tile once on the client, though some ran twice on the cluster


@pytest.mark.slow
def test_bench_distributed_quick_runs_and_checks_bytes(tmp_path):
    import csv
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    proc = subprocess.run(
        [sys.executable, "-m", "bench", "distributed", "--quick", "--out", str(tmp_path)], cwd=root, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    rows = list(csv.DictReader(open(tmp_path / "distributed.csv")))
    assert [r["workers"] for r in rows] == ["local (this process)", "1", "2"]
    assert all(r["identical"] == "True" for r in rows) and all(int(r["tasks"]) >= 64 for r in rows)
    assert all(float(r["overhead_per_task_ms"]) > 0 for r in rows[1:])


@pytest.mark.slow
def test_ctrl_c_on_the_program_leaves_no_output_and_no_tasks(client, tmp_path):
    import subprocess

    out = tmp_path / "big.png"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "clrender",
            "render",
            "wizard_cat",
            "--width",
            "256",
            "--height",
            "192",
            "--aa",
            "full",
            "--samples",
            "6",
            "--tile-size",
            "16",
            "-o",
            str(out),
            "--scheduler",
            client.scheduler.address,
        ],
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=default_sigint,
    )
    assert wait_for(lambda: scheduler_tasks(client) > 10, 60)  # tiles are on the cluster
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 130 and err.strip().splitlines()[-1] == "clrender: interrupted"
    assert list(tmp_path.iterdir()) == []
    assert wait_for(lambda: scheduler_tasks(client) == 0, 30)  # the scheduler dropped the render's tasks


def test_a_worker_with_other_code_refuses_with_one_line(client):
    from clrender.errors import RenderFailure

    renderer = crd.DistributedRenderer("refract1", client=client, **TINY)
    renderer.payload.code = "0" * 16  # as if the client ran another version
    with pytest.raises(RenderFailure, match="runs different clrender code .* the client's 0000000000000000"):
        renderer.run()


# ------------------------------------------------------------------ waiting: the hang, the watchdog, deadlines
def test_a_render_finishes_while_another_clients_loop_is_blocked(client):
    """The cause of the old hang: Dask's as_completed tracked our futures on the *current* client's event
    loop (here a second client, as the CLI's client beside a test's fixture), so their completion events
    were set on one thread and awaited on another.  With that loop blocked, the old code could not finish;
    ours never touches another client's loop."""
    other = distributed.Client(client.scheduler.address, set_as_default=False)
    gate = threading.Event()
    release_later = threading.Timer(30, gate.set)  # lets the old code finish (and fail) instead of hanging
    try:
        other.loop.add_callback(gate.wait)  # the other client's loop thread now waits on the gate
        release_later.start()
        with other.as_current():
            image = crd.render("refract1", client=client, **TINY, aa="edge_detect", samples=2)
        finished_while_blocked = not gate.is_set()
    finally:
        gate.set()
        release_later.cancel()
        other.close()
    assert finished_while_blocked
    assert image.tobytes() == clrender.render("refract1", **TINY, aa="edge_detect", samples=2).tobytes()


@pytest.fixture
def scheduler_never_hears_of_our_tasks(monkeypatch):
    """Drop the client's task submissions for clrender's keys: futures wait for tasks the scheduler never got."""
    real = distributed.Client._send_to_scheduler

    def dropping(self, msg):
        if msg.get("op") == "update-graph" and all(str(k).startswith("clrender-") for k in msg["keys"]):
            return None
        return real(self, msg)

    monkeypatch.setattr(distributed.Client, "_send_to_scheduler", dropping)


def test_the_watchdog_stops_a_render_whose_tasks_the_scheduler_does_not_know(client, scheduler_never_hears_of_our_tasks):
    from clrender.errors import RenderFailure

    with pytest.raises(RenderFailure, match=r"no trace task finished for 0\.5 s and the Dask scheduler at .* does not know 6 of the 6"):
        crd.render("refract1", client=client, deadlines=crd.Deadlines(stall=0.5), **TINY)
    with pytest.raises(RenderFailure, match=r"no frame task finished for 0\.5 s .* does not know 2 of the 2"):
        crd.turntable("refract1", frames=2, client=client, deadlines=crd.Deadlines(stall=0.5), width=16, height=12)
    from clrender.distributed.fits import fit_gauss
    from clrender.splat.fit import FitConfig

    with pytest.raises(RenderFailure, match=r"no gauss task finished .* does not know 2 of the 2"):
        fit_gauss(small_photos(), FitConfig(splats=8, epochs=2), client=client, deadlines=crd.Deadlines(stall=0.5))
    assert wait_for(lambda: scheduler_tasks(client) == 0)  # the scattered scene and images were let go


def test_the_watchdog_is_one_line_and_exit_1_on_the_command_line(client, tmp_path, capsys, scheduler_never_hears_of_our_tasks):
    args = ["-q", "render", "refract1", "--width", "16", "--height", "12", "-o", str(tmp_path / "x.png")]
    assert main(args + ["--scheduler", client.scheduler.address, "--stall-timeout", "0.5"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "does not know 1 of the 1" in err[0] and "released, forgotten or never received" in err[0]
    assert list(tmp_path.iterdir()) == []


def test_a_slow_task_is_not_a_stall(client):
    """The watchdog asks before it fails: tasks the scheduler knows keep the render going."""
    from clrender.distributed.waiting import collect

    futures = [client.submit(time.sleep, 1.0, key=f"clrender-slow-{k}-{time.monotonic_ns()}") for k in range(2)]
    done = sorted(i for i, _ in collect(client, futures, "slow", crd.Deadlines(stall=0.2)))
    assert done == [0, 1]


@pytest.mark.parametrize("value", ["0", "-1", "nan", "inf", "soon"])
def test_stall_timeout_values_are_checked(tmp_path, capsys, value, client):
    args = ["render", "refract1", "-o", str(tmp_path / "x.png"), "--scheduler", client.scheduler.address, "--stall-timeout", value]
    assert main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"clrender: --stall-timeout '{value}' is not valid; allowed: seconds above 0, at most 604800"]


class FakeServer:
    """A TCP server on 127.0.0.1 that sends `reply` (None: nothing) to each connection; it stops by
    itself after `lifetime` seconds, or when the `with` block ends."""

    def __init__(self, reply: bytes | None, lifetime: float = 30.0):
        self.reply, self.lifetime = reply, lifetime
        self.sock = socket.socket()
        self.sock.bind(("127.0.0.1", 0))
        self.sock.listen(8)
        self.sock.settimeout(0.1)
        self.address = f"tcp://127.0.0.1:{self.sock.getsockname()[1]}"
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self.serve, daemon=True)

    def serve(self):
        deadline, conns = time.monotonic() + self.lifetime, []
        while not self.stop.is_set() and time.monotonic() < deadline:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                continue
            conns.append(conn)
            if self.reply is not None:
                conn.sendall(self.reply)
        for conn in conns:
            conn.close()
        self.sock.close()

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.stop.set()
        self.thread.join(5)


def test_a_scheduler_that_accepts_and_never_answers_is_one_line_exit_1(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("CLRENDER_CONNECT_TIMEOUT", "1")
    with FakeServer(reply=None) as server:
        assert main(["render", "refract1", "-o", str(tmp_path / "x.png"), "--scheduler", server.address]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"clrender: the Dask scheduler at '{server.address}' accepted the connection but did not answer within 1 s"]
    assert list(tmp_path.iterdir()) == []


def test_a_malformed_frame_from_a_fake_scheduler_is_one_line_exit_2(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("CLRENDER_CONNECT_TIMEOUT", "5")
    frame = (2).to_bytes(8, "little") + b"\xff" * 6  # says two frames follow, then too few bytes for their lengths
    with FakeServer(reply=frame) as server:
        assert main(["render", "refract1", "-o", str(tmp_path / "x.png"), "--scheduler", server.address]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"clrender: '{server.address}' did not answer as a Dask scheduler does (")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("address", ["tls://127.0.0.1:8786", "ucx://127.0.0.1:8786", "tcp://", "tcp://host:99999"])
def test_unsupported_scheduler_addresses_are_refused_in_one_line(tmp_path, capsys, address):
    assert main(["render", "refract1", "-o", str(tmp_path / "x.png"), "--scheduler", address]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"scheduler address '{address}'" in err[0] and "allowed: tcp://HOST:PORT or HOST:PORT" in err[0]


@pytest.mark.parametrize("workers", ["1_000", "64", "0"])
def test_workers_beyond_what_the_machine_holds_are_refused_before_starting_any(tmp_path, capsys, workers, monkeypatch):
    monkeypatch.setattr("clrender.distributed.cluster.cores", lambda: 2)
    started = []
    monkeypatch.setattr(distributed, "LocalCluster", lambda *a, **k: started.append(k))
    assert main(["render", "refract1", "-o", str(tmp_path / "x.png"), "--workers", workers]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"clrender: --workers {int(workers)} is not possible here; allowed: 1 to ")
    assert "2 CPU core(s)" in err[0] and started == [] and list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ under load
@pytest.fixture
def busy_cores():
    """One busy-loop process per core for the test's duration: killed at the end, and each stops by itself
    when this process dies or after ten minutes, so none outlives a killed test run."""
    import subprocess

    spin = "import os, time\nparent, end = os.getppid(), time.monotonic() + 600\nwhile os.getppid() == parent and time.monotonic() < end: pass"
    procs = [subprocess.Popen([sys.executable, "-c", spin]) for _ in range(os.cpu_count() or 1)]
    try:
        yield procs
    finally:
        for proc in procs:
            proc.kill()
        for proc in procs:
            proc.wait()


@pytest.mark.slow
def test_scheduler_renders_turntables_and_fits_under_cpu_load_60_times(client, tmp_path, busy_cores):
    from clrender.distributed.fits import fit_gauss
    from clrender.splat.fit import FitConfig

    args = ["-q", "render", "refract1", "--width", "24", "--height", "16", "--aa", "edge_detect", "--samples", "2"]
    assert main(args + ["-o", str(tmp_path / "local.png")]) == 0
    local = (tmp_path / "local.png").read_bytes()
    frames_here = [img.tobytes() for _, img in render_turntable(Scene.load("refract1"), clrender.RenderSettings(width=16, height=12), 2)]
    photo = small_photos()[0]
    config = FitConfig(splats=8, epochs=2, seed=1)
    fit_here = fit_gauss([photo], config, client=client)[0].image.tobytes()
    deadlines = crd.Deadlines(stall=20.0)  # a hang fails within seconds instead of holding the suite
    for i in range(60):  # the old hang came within 8 to 200 renders of this kind under this load
        out = tmp_path / f"d{i}.png"
        rc = main(args + ["-o", str(out), "--scheduler", client.scheduler.address, "--stall-timeout", "20"])
        assert rc == 0 and out.read_bytes() == local, i
        frames = crd.turntable("refract1", frames=2, client=client, deadlines=deadlines, width=16, height=12)
        assert [f.tobytes() for f in frames] == frames_here, i
        assert fit_gauss([photo], config, client=client, deadlines=deadlines)[0].image.tobytes() == fit_here, i
    assert wait_for(lambda: scheduler_tasks(client) == 0)


def test_workers_instance_a_scene_as_the_client_does(client, tmp_path):
    """A scene whose copies make a render instance by itself (trace/instancing.py AUTO_MIN_TRIANGLES): the workers
    decide as the client (renderer.instancing_for) and render the local bytes."""
    scene = copies_scene(tmp_path, 30)
    local = clrender.Renderer(scene, **TINY)
    assert local.tracer.n_instances == 30
    remote = crd.DistributedRenderer(scene, client=client, **TINY).run()
    assert remote.image.tobytes() == local.run().image.tobytes()
