"""The render summary's primitive count: an instanced scene says how many instances, and the triangles they stand for."""

from types import SimpleNamespace

from clrender.commands.render import primitive_count

from tests.scenetools import copies_scene


def test_an_instanced_scene_counts_its_instances_and_their_triangles(tmp_path):
    scene = copies_scene(tmp_path, 30)  # 30 copies of a 1280-face ball
    tracer = SimpleNamespace(n_prims=0, n_instances=30, instances=SimpleNamespace(shapes=[object()]))
    text = primitive_count(tracer, scene)
    assert text == "0 primitives + 30 instances of 1 mesh (38,400 triangles and 0 spheres in all)"


def test_a_flat_scene_counts_its_primitives():
    assert primitive_count(SimpleNamespace(n_prims=2, n_instances=0), None) == "2 primitives"


def test_the_real_tracer_of_30_copies_reports_30_instances(tmp_path):
    from clrender.trace.tracer import Tracer

    scene = copies_scene(tmp_path, 30)
    text = primitive_count(Tracer(scene, instancing=True), scene)
    assert "30 instances of 1 mesh" in text and "38,400 triangles" in text
