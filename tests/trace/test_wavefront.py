"""The path tracer's wavefront schedule (kernels/wavefront.cl, clrender/trace/wavefront.py; docs/lanes.md) against its
megakernel (kernels/path.cl render_path): the same steps in another order of work, so the same bits.  Each test renders
a scene both ways and compares the image, the object ids, the AOVs and the ray and BVH-visit counts byte for byte, on
different tilings (the wavefront's slots refill from their own pixel's next sample, so a pixel's sums are made in sample
order whatever its tile).  The megakernel itself is held to the images from before the steps existed by
tools/render_hashes.py (`path:*` lines).  A wavefront whose slot took another pixel's sample, whose shadow ray added
its light at another time, or whose rng moved differently fails these."""

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene.scene import Scene
from clrender.trace.renderer import Renderer
from clrender.trace.wavefront import Wavefront

from tests.arealighttools import SCENE as AREA_LIGHT_SCENE
from tests.pathtools import AOVS, assert_same, blend_card, env_map_scene, render_both
from tests.reference import path_scenes
from tests.scenetools import copies_scene


def both(scene, megakernel_tiles: int = 64, wavefront_tiles: int = 7, **settings):
    """(megakernel result, wavefront result, the wavefront's Renderer) of `scene` with `settings`, each on its tiling."""
    return render_both(scene, "wavefront", Wavefront, megakernel_tiles, wavefront_tiles, **settings)


def test_the_wavefront_renders_the_megakernels_bits_on_another_tiling():
    """The Cornell box (Lambert walls, a rough metal and a glass sphere, an emissive quad) at 3 spp with AOVs: the
    megakernel in one 16 x 16 tile, the wavefront in 7 x 7 tiles (uneven edges)."""
    a, b, r = both(path_scenes.cornell_box(16), megakernel_tiles=16, wavefront_tiles=7, spp=3, seed=4, aovs=AOVS)
    assert_same(a, b)
    assert a.image.mean() > 0.01  # lit: the comparison is of something


def test_lane_occupancy_starts_full_never_rises_and_ends_at_zero():
    """Slots start one path each, refill while their pixel has samples left, and end once each: the live count per
    bounce starts at the slot count, never rises, and each slot stays live for at least spp bounces (a path takes one
    or more)."""
    spp = 4
    _, _, r = both(path_scenes.cornell_box(8), wavefront_tiles=8, spp=spp, seed=1)
    occupancy = r.kernel.occupancy[-1]  # the image's one tile (the first is the renderer's warm-up launch)
    live = occupancy.live
    assert live[0] == occupancy.slots == 64
    assert all(x >= y for x, y in zip(live, live[1:]))
    assert len(live) >= spp and live[spp - 1] == occupancy.slots
    assert 0 < occupancy.mean <= 1


def test_an_unknown_schedule_is_a_usage_error():
    with pytest.raises(UsageError, match="path schedule 'sideways'.*megakernel, wavefront, lanes"):
        Renderer(path_scenes.cornell_box(8), integrator="path", path_schedule="sideways")


def test_the_scene_key_chooses_the_schedule_and_refuses_others():
    data = path_scenes.cornell_box(8)
    assert Scene.from_dict({**data, "path_schedule": "wavefront"}).path_schedule == "wavefront"
    with pytest.raises(UsageError, match="path_schedule"):
        Scene.from_dict({**data, "path_schedule": "sideways"})


def spot_lens_scene() -> dict:
    """The mixed scene's spheres under a spot light and a physical point light, seen through a thin lens."""
    scene = path_scenes.mixed(12)
    scene["cameras"] = [{**scene["cameras"][0], "aperture": 0.08, "focus_distance": 3.5}]
    scene["lights"] = [
        {"type": "spot", "position": [1, 3, 1], "direction": [-0.3, -1, -0.3], "intensity": 20},
        {"type": "point", "position": [-2, 2, 2], "intensity": 6, "falloff": "inverse_square"},
    ]
    return scene


def textured_scene(tmp_path) -> Scene:
    """bench/assets.py's first picture: a textured torus, a gold sphere and a checker floor under an HDR sky."""
    from bench.assets import picture_scenes

    return Scene.from_dict(picture_scenes(tmp_path, 16, 12, 32)[0])


CASES = {
    # both samplers, a stratified pixel grid (spp = samples^2 under the independent sampler), AOVs
    "cornell-independent-stratified": (
        lambda tmp: path_scenes.cornell_box(12),
        dict(spp=4, samples=2, sampler="stratified", path_sampler="independent", aovs=AOVS),
    ),
    # the splat film (a tent wider than a pixel: SPLAT_RADIUS) and an emissive sphere
    "mixed-tent-splats": (lambda tmp: path_scenes.mixed(12), dict(spp=3, rfilter="tent")),
    # emissive triangles hidden from camera rays (HIDE_EMITTERS' look-past loop in the extend step)
    "mesh-light-hide-emitters": (lambda tmp: path_scenes.mesh_light(12), dict(spp=3, hide_emitters=True)),
    # a physical parallelogram light (NEE and BSDF rays meeting it, MIS)
    "area-light": (lambda tmp: AREA_LIGHT_SCENE, dict(spp=4, max_depth=1)),
    # an environment map, glass
    "env-map-glass": (env_map_scene, dict(spp=3, aovs=AOVS)),
    # textures, glTF metal, an HDR sky (bench/assets.py)
    "textured-assets": (textured_scene, dict(spp=2, max_depth=4)),
    # stochastic alpha (BLEND) under Sobol: alpha draws in the extend and occlude steps, a directional light
    "alpha-blend-sobol": (lambda tmp: blend_card(), dict(spp=4)),
    # the same under the independent sampler: its alpha draws have their own counter too (rng.h rng_extra)
    "alpha-blend-independent": (lambda tmp: blend_card(), dict(spp=4, path_sampler="independent")),
    # constant-environment NEE, glTF lobes, Russian roulette from the first bounce
    "environment-spheres-rr0": (lambda tmp: path_scenes.environment_spheres(12), dict(spp=3, rr_depth=0)),
    # area and directional lights of the unnormalised falloff (and NEE's nearness choice), many objects (a bundled scene)
    "wizard-cat": (lambda tmp: "wizard_cat", dict(spp=2, width=20, height=15, max_depth=3)),
    # a spot light and a physical point light, a thin-lens camera (two numbers of each sample's stream for the lens)
    "spot-point-thin-lens": (lambda tmp: spot_lens_scene(), dict(spp=3)),
}


@pytest.mark.slow
@pytest.mark.parametrize("case", list(CASES))
def test_the_wavefront_renders_the_megakernels_bits_on_every_feature(tmp_path, case):
    make, settings = CASES[case]
    scene = make(tmp_path)
    scene = Scene.from_dict(scene, base_dir=tmp_path) if isinstance(scene, dict) else scene
    a, b, _ = both(scene, megakernel_tiles=64, wavefront_tiles=5, seed=9, **settings)
    assert_same(a, b)
    assert a.image.mean() > 1e-3  # something lit: the comparison is of something


@pytest.mark.slow
def test_instanced_meshes_render_the_megakernels_bits(tmp_path):
    a, b, r = both(copies_scene(tmp_path, 6), spp=2, width=20, height=16, instancing=True, seed=2, aovs=AOVS)
    assert r.tracer.defines.get("INSTANCED") == 1
    assert_same(a, b)


@pytest.mark.slow
def test_a_later_pass_continues_each_pixels_sequence_the_same_way():
    """Progressive passes (--time-budget) launch with first_sample > 0: the wavefront's slots number their samples
    from it as render_path does."""
    scene = Scene.from_dict(path_scenes.cornell_box(8))
    a = Renderer(scene, integrator="path", path_schedule="megakernel", spp=2)
    b = Renderer(scene, integrator="path", path_schedule="wavefront", spp=2, tracer=a.tracer)
    pixels = np.arange(64, dtype=np.int32)[::-1].copy()  # the image backwards: a slot's pixel is not its index
    for first_sample in (0, 6):
        ours, theirs = (r.launch(pixels, "stratified", 1, True, first_sample) for r in (a, b))
        for x, y in zip(ours, theirs):
            assert (x is None and y is None) or x.tobytes() == y.tobytes()


PACKED_ARITHMETIC = r"^\s*[0-9a-f]+:\s+v(?:add|sub|mul|div|sqrt|min|max|fn?m(?:add|sub)\d*)ps\s.*%zmm"


@pytest.mark.slow
def test_intels_runtime_vectorises_the_shade_kernel_across_work_items(device):
    """Intel's OpenCL CPU runtime compiles wave_shade a second time with 16 work-items in the lanes of zmm registers
    (docs/lanes.md; 3,559 packed single-precision arithmetic instructions when measured, render_path none).  A shade step that gains a
    construct its vectoriser refuses (a traversal loop, an out-of-line call) loses that copy and fails here.  Skipped on
    other drivers (PoCL 3.1 vectorises none of it)."""
    import re
    import shutil
    import subprocess
    import tempfile

    from tools.kernel_asm import object_code

    if "intel" not in device.name.lower() or shutil.which("objdump") is None:
        pytest.skip(f"{device.name}: the check reads Intel's CPU runtime's binaries with objdump")
    scene = Scene.from_dict(path_scenes.cornell_box(4))
    from clrender.trace.tracer import Tracer

    Renderer(scene, tracer=Tracer(scene, device=device), integrator="path", path_schedule="wavefront", spp=1).run()
    programs = [p for (name, _), p in device._programs.items() if name == "wavefront.cl"]
    assert programs
    obj = object_code(programs[-1].binaries[0])
    assert obj is not None
    with tempfile.NamedTemporaryFile(suffix=".o") as f:
        f.write(obj)
        f.flush()
        text = subprocess.run(["objdump", "-d", "--no-show-raw-insn", f.name], capture_output=True, text=True, check=True).stdout
    functions = dict(re.findall(r"^[0-9a-f]+ <(\w+)>:\n(.*?)(?=^[0-9a-f]+ <|\Z)", text, flags=re.M | re.S))
    packed = len(re.findall(PACKED_ARITHMETIC, functions["wave_shade"], flags=re.M))
    assert packed >= 1000, packed
