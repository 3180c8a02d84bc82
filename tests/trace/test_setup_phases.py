"""No hidden setup (issue 37): tangents are made only for meshes whose material has a normal map, and every setup
phase is in RenderResult.timings, the slow ones named in the command line's summary."""

import time

import numpy as np
import pytest
from PIL import Image

import clrender.trace.geometry as geometry
import clrender.trace.tracer as tracer_module
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import Tracer

from tests.clitools import run_cli

CARD_OBJ = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
SETUP_PHASES = {"bvh", "geometry", "attributes", "textures", "upload", "compile"}


def textured_scene(tmp_path, normal_map: bool) -> dict:
    """A quad with UVs and a base-colour texture; with normal_map, a flat normal map too."""
    Image.fromarray(np.full((2, 2, 3), 200, np.uint8)).save(tmp_path / "c.png")
    Image.fromarray(np.broadcast_to(np.array([128, 128, 255], np.uint8), (2, 2, 3)).copy()).save(tmp_path / "n.png")
    material = {"base_color": [0.5, 0.5, 0.5], "base_color_texture": "c", **({"normal_texture": "n"} if normal_map else {})}
    return {
        "width": 8,
        "height": 8,
        "cameras": [{"position": [0, 0, 3], "look_at": [0, 0, 0], "fov": 40}],
        "textures": {"c": {"file": "c.png"}, "n": {"file": "n.png"}},
        "materials": {"m": material},
        "lights": [{"type": "directional", "direction": [0, 0, -1]}],
        "objects": [{"type": "quad", "corner": [-1, -1, 0], "edge_a": [2, 0, 0], "edge_b": [0, 2, 0], "material": "m"}],
    }


def no_tangents(*args, **kwargs):
    raise AssertionError("tangents were generated")


@pytest.mark.parametrize("instancing", [False, True])
def test_a_scene_without_normal_maps_computes_no_tangents(device, tmp_path, monkeypatch, instancing):
    """The textured quad renders with the tangent generator raising; with a normal map it is called (so the stub
    is on the path that generates them).  Twice placed, the quad is an instanced shape when instancing is on."""
    from clrender.trace.instancing import find_instances

    monkeypatch.setattr(geometry, "vertex_tangents", no_tangents)
    (tmp_path / "card.obj").write_text(CARD_OBJ)
    for normal_map in (False, True):
        data = textured_scene(tmp_path, normal_map)
        card = {"type": "mesh", "file": "card.obj", "material": "m"}
        data["objects"] = [{**card, "translate": [-1.2, 0, 0]}, {**card, "translate": [1.2, 0, 0]}]
        scene = Scene.from_dict(data, base_dir=tmp_path)
        assert len(find_instances(scene).shapes) == 1
        if normal_map:
            with pytest.raises(AssertionError, match="tangents were generated"):
                Tracer(scene, device=device, instancing=instancing).upload_shading()
        else:
            result = Renderer(scene, tracer=Tracer(scene, device=device, instancing=instancing)).run()
            assert result.image.max() > 0.05


def test_the_timings_name_every_setup_phase_and_account_for_the_setup_time(device, tmp_path):
    scene = Scene.from_dict(textured_scene(tmp_path, True), base_dir=tmp_path)
    start = time.perf_counter()
    renderer = Renderer(scene, tracer=Tracer(scene, device=device))
    wall = time.perf_counter() - start
    timings = renderer.run().timings
    assert SETUP_PHASES <= set(timings)
    setup = sum(v for k, v in timings.items() if k not in ("trace", "edges", "resample"))
    # what the phases leave out is argument checks and small bookkeeping: well under 0.5 s on any machine
    assert wall - 0.5 <= setup <= wall + 1e-6


def test_a_slow_setup_phase_is_named_in_the_summary(tmp_path, capsys, monkeypatch):
    """Texture packing made to take 0.15 s shows as `textures 0.15s` (a phase under 0.1 s stays out of the line)."""
    real = tracer_module.pack_textures

    def slow(*args):
        time.sleep(0.15)
        return real(*args)

    monkeypatch.setattr(tracer_module, "pack_textures", slow)
    (tmp_path / "s.toml").write_text(
        '[[objects]]\ntype = "sphere"\ncenter = [0, 0, -5]\nradius = 1\n[[lights]]\ntype = "point"\nposition = [0, 5, 0]\n'
    )
    code, _, err = run_cli(capsys, "render", str(tmp_path / "s.toml"), "--width", "8", "--height", "6", "-o", str(tmp_path / "s.png"))
    assert code == 0, err
    summary = err.strip().splitlines()[-1]
    assert ", textures 0.1" in summary and summary.index("bvh ") < summary.index("textures ") < summary.index("compile ")
    assert "upload " not in summary and "emitters " not in summary


def test_a_query_only_tracer_uploads_no_shading(device, tmp_path, monkeypatch):
    """Ray queries on a textured, normal-mapped scene decode no texture, make no tangents and upload no materials:
    the shading's records come only when a render asks for them (Tracer.upload_shading)."""

    def refused(*args, **kwargs):
        raise AssertionError("shading records were made for a ray query")

    monkeypatch.setattr(tracer_module, "pack_textures", refused)
    monkeypatch.setattr(geometry, "vertex_tangents", refused)
    scene = Scene.from_dict(textured_scene(tmp_path, True), base_dir=tmp_path)
    tracer = Tracer(scene, device=device)
    t, prim, obj = tracer.intersect(np.array([[0.0, 0.0, 3.0]]), np.array([[0.0, 0.0, -1.0]]))
    assert t[0] == pytest.approx(3.0) and prim[0] >= 0 and obj[0] == 0
    assert tracer.occluded(np.array([[0.0, 0.0, 3.0]]), np.array([[0.0, 0.0, -1.0]]), 10.0)[0]
    with pytest.raises(AssertionError, match="shading records"):
        tracer.upload_shading()
