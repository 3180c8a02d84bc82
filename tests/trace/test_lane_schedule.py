"""The path tracer's lane schedule (kernels/path.cl render_path_lanes, clrender/trace/lane_schedule.py; docs/lanes.md)
against its megakernel (render_path): the same lane-generic steps run 16 (or 8) pixels' paths a work-item instead of
one, so the same bits.  Each test renders a scene both ways, on different tilings, and compares the image, the object
ids, the AOVs and the ray and BVH-visit counts byte for byte: the materials of every kind (Phong glass and mirrors,
glTF, conductors, coated diffuse, thin sheets), textures, smooth and flat meshes and spheres, every light the lanes
take, a thin lens, Russian roulette, progressive passes, single-sided and alpha-tested materials, hidden emitters,
instances, both samplers and their pixel grids.
A lane that took another lane's value, a mask that let an idle lane write its state, a masked pass that kept the wrong
lobe or a sampler draw out of place fails these.  What the lanes do not take yet renders with the megakernel, and says
why (lane_schedule.falls_back)."""

import numpy as np
import pytest

from clrender.scene.scene import Scene
from clrender.trace.lane_schedule import LaneKernel
from clrender.trace.renderer import Renderer
from clrender.trace.tracer import as_scene

from tests.arealighttools import SCENE as AREA_LIGHT_SCENE
from tests.pathtools import AOVS, assert_same, env_map_scene, render_both
from tests.reference import path_scenes
from tests.scenetools import copies_scene, instanced_scene


def exchange_materials_scene() -> dict:
    """A rough and a smooth conductor, a rough and a smooth coated diffuse and a thin sheet, spheres and boxes on a
    floor, under a physical point light, a directional light, two spot lights (Mitsuba's and pbrt's profiles) and a
    constant environment, through a thin lens."""
    scene = path_scenes.mixed(12)
    scene["materials"] = {
        **scene["materials"],
        "copper": {"type": "conductor", "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.5, 2.1], "roughness": 0.3},
        "mirror": {"type": "conductor", "eta": [0.2, 0.9, 1.1], "k": [3.9, 2.5, 2.1]},
        "plastic": {"type": "coated_diffuse", "diffuse": [0.7, 0.35, 0.1], "roughness": 0.2, "smith": "separable"},
        "gloss": {"type": "coated_diffuse", "diffuse": [0.1, 0.4, 0.7]},
        "sheet": {"type": "thin_dielectric", "ior": 1.5, "transmittance": [0.8, 0.9, 1.0]},
    }
    spheres = [("copper", -1.2, 0.0), ("mirror", -0.4, 0.4), ("gloss", 0.4, 0.0), ("sheet", 1.2, 0.4)]
    scene["objects"] = [o for o in scene["objects"] if o.get("material") in ("floor", "lamp")] + [
        {"type": "sphere", "center": [x, 0.35, z], "radius": 0.35, "material": name} for name, x, z in spheres
    ]
    scene["objects"].append(path_scenes.mesh(*path_scenes.box_mesh([0.8, 0.25, -0.9], 0.5, 20.0), "plastic"))
    scene["cameras"] = [{**scene["cameras"][0], "aperture": 0.06, "focus_distance": 3.5}]
    scene["lights"] = [
        {"type": "point", "position": [-2, 2, 2], "intensity": 6, "falloff": "inverse_square"},
        {"type": "directional", "direction": [0.3, -1, -0.2], "intensity": 0.5},
        {"type": "spot", "position": [1, 3, 1], "direction": [-0.3, -1, -0.3], "intensity": 20},
        {"type": "spot", "position": [-1, 3, 0], "direction": [0.2, -1, 0], "intensity": 10, "profile": "pbrt"},
    ]
    scene["environment"] = {"color": [0.2, 0.25, 0.3]}
    return scene


def textured_sky_scene(tmp_path) -> dict:
    """bench/assets.py's first picture: a textured, normal-mapped torus, a gold sphere and a checker floor under an HDR
    sky."""
    from bench.assets import picture_scenes

    return picture_scenes(tmp_path, 16, 12, 32)[0]


def textured_scene(tmp_path) -> dict:
    """The same picture under a constant environment (NEE's environment choice: cosine-weighted directions)."""
    return {**textured_sky_scene(tmp_path), "environment": {"color": [0.6, 0.7, 0.9]}}


def single_sided_scene() -> dict:
    """Single-sided cards (glTF doubleSided false) seen from behind, which camera rays look past, layered over one seen
    from the front, a double-sided one and a lit floor; an emitting card facing the camera (hidden under hide_emitters,
    then the culled backs behind it); a single-sided sphere."""
    away, towards = ([0, 2, 0], [2, 0, 0]), ([2, 0, 0], [0, 2, 0])  # edge_a x edge_b: -z (away from the camera), +z

    def card(x, y, z, facing, material):
        return {"type": "quad", "corner": [x, y, z], "edge_a": facing[0], "edge_b": facing[1], "material": material}

    return {
        "width": 16,
        "height": 16,
        "cameras": [{"position": [0.3, 0.2, 10], "look_at": [0, 0, 0], "up": [0, 1, 0], "fov": 40}],
        "materials": {
            "back": {"diffuse": [1, 0.2, 0.1], "double_sided": False},
            "front": {"diffuse": [0.1, 0.8, 0.2], "double_sided": False},
            "both": {"diffuse": [0.2, 0.3, 0.9]},
            "lamp": {"diffuse": [0, 0, 0], "emission": [3, 2.5, 2], "double_sided": False},
            "floor": {"diffuse": [0.8, 0.8, 0.8]},
        },
        "lights": [{"type": "directional", "direction": [0.3, 0.4, -1]}],
        "objects": [
            card(-2, -2, 3, away, "back"),
            card(-1.5, -1, 2.5, away, "back"),
            card(-1, -1.5, 2, away, "back"),
            card(0, 0, 1.5, towards, "front"),
            card(-2.5, 0.5, 1, away, "both"),
            card(0.5, -2.5, 3.5, towards, "lamp"),
            {"type": "sphere", "center": [1.6, 1.4, 1], "radius": 0.6, "material": "back"},
            card(-6, -6, 0, towards, "floor"),
        ],
        "environment": {"color": [0.2, 0.25, 0.3]},
    }


def alpha_cards_scene(tmp_path) -> dict:
    """single_sided_scene with alpha: a card masked by a checker texture's alpha (glTF MASK), a half-transparent one
    (BLEND: the path tracer keeps its point with probability alpha, a random number a layer), one single-sided, all
    over a floor that shadow rays reach through them."""
    import OpenImageIO as oiio

    texels = np.zeros((4, 4, 4), np.uint8)
    texels[..., :3] = 200
    texels[..., 3] = np.where((np.arange(4)[:, None] + np.arange(4)) % 2 == 0, 255, 0)
    out = oiio.ImageOutput.create(str(tmp_path / "holes.png"))
    assert out.open(str(tmp_path / "holes.png"), oiio.ImageSpec(4, 4, 4, "uint8"))
    assert out.write_image(texels)
    out.close()
    scene = single_sided_scene()
    scene["textures"] = {"holes": {"file": "holes.png", "filter": "nearest"}}
    scene["materials"]["holes"] = {"diffuse": [0.9, 0.9, 0.2], "diffuse_texture": "holes", "alpha": {"mode": "mask", "cutoff": 0.5}}
    scene["materials"]["veil"] = {"diffuse": [0.2, 0.9, 0.9], "alpha": {"mode": "blend", "factor": 0.4}, "double_sided": False}
    scene["objects"] += [
        {"type": "quad", "corner": [-1.8, -0.5, 4], "edge_a": [2.5, 0, 0], "edge_b": [0, 2.5, 0], "material": "holes"},
        {"type": "quad", "corner": [-0.5, -1.8, 4.5], "edge_a": [2.5, 0, 0], "edge_b": [0, 2.5, 0], "material": "veil"},
    ]
    return scene


CASES = {
    # Lambert walls, rough metal and glass spheres, an emissive quad; AOVs
    "cornell": (lambda tmp: path_scenes.cornell_box(12), dict(spp=3, aovs=AOVS)),
    # a physical parallelogram light (NEE and BSDF rays meeting it, MIS)
    "area-light": (lambda tmp: AREA_LIGHT_SCENE, dict(spp=4, max_depth=1)),
    # constant-environment NEE, glTF lobes, Russian roulette from the first bounce
    "environment-spheres-rr0": (lambda tmp: path_scenes.environment_spheres(12), dict(spp=3, rr_depth=0)),
    # area and directional lights of the unnormalised falloff (and NEE's nearness choice), many objects (a bundled scene)
    "wizard-cat": (lambda tmp: "wizard_cat", dict(spp=2, width=20, height=15, max_depth=3, aovs=AOVS)),
    # emissive triangles (mesh lights): NEE to them and BSDF rays meeting them; hidden from camera rays
    "mesh-light": (lambda tmp: path_scenes.mesh_light(12), dict(spp=3)),
    "mesh-light-hide-emitters": (lambda tmp: path_scenes.mesh_light(12), dict(spp=3, hide_emitters=True)),
    # the exchange lobes, point, directional and spot lights, a thin lens, the tent pixel filter
    "exchange-thin-lens": (lambda tmp: exchange_materials_scene(), dict(spp=3, pixel_filter="tent")),
    # textures (base colour, metallic-roughness, normal map), glTF metal
    "textured": (textured_scene, dict(spp=2, max_depth=4, aovs=AOVS)),
    # an environment map (NEE samples it, BSDF rays meet it), glass
    "env-map-glass": (env_map_scene, dict(spp=3, aovs=AOVS)),
    # bench/assets.py's first picture as it is: textures and glTF metal under an HDR sky
    "textured-sky": (lambda tmp: textured_sky_scene(tmp), dict(spp=2, max_depth=4)),
    # the splat films (reconstruction filters wider than a pixel: Mitsuba's tent, and its Gaussian, Mitsuba XML's default)
    "mixed-tent-splats": (lambda tmp: path_scenes.mixed(12), dict(spp=3, rfilter="tent")),
    "cornell-gaussian-splats": (lambda tmp: path_scenes.cornell_box(12), dict(spp=3, rfilter="gaussian", aovs=AOVS)),
    # single-sided materials: camera rays walked again past back faces (glTF's default), with hidden emitters too
    "single-sided": (lambda tmp: single_sided_scene(), dict(spp=3, aovs=AOVS)),
    "single-sided-hide-emitters": (lambda tmp: single_sided_scene(), dict(spp=3, hide_emitters=True)),
    # alpha-tested materials (textured MASK, BLEND): camera, bounce and shadow rays walked again past the points left out
    "alpha-cards": (alpha_cards_scene, dict(spp=3, aovs=AOVS)),
    "alpha-cards-hide-emitters": (alpha_cards_scene, dict(spp=2, hide_emitters=True)),
    # instances (smooth, mirrored, normal-mapped, alpha-tested and single-sided copies) among flat primitives
    "instanced": (lambda tmp: instanced_scene(tmp), dict(spp=3, instancing=True, hide_emitters=True, aovs=AOVS)),
    # the independent sampler (the same dimension layout as Sobol's: rng.h rng_vertex), with each pixel grid of a pass
    "cornell-independent": (lambda tmp: path_scenes.cornell_box(12), dict(spp=3, path_sampler="independent", aovs=AOVS)),
    **{
        f"cornell-independent-{sampler}-grid": (
            lambda tmp: path_scenes.cornell_box(12),
            dict(spp=n * n, samples=n, sampler=sampler, path_sampler="independent", aovs=AOVS),
        )
        for sampler, n in (("stratified", 2), ("uniform", 2), ("sobol", 3))
    },
    "alpha-cards-independent": (alpha_cards_scene, dict(spp=2, path_sampler="independent")),
    # the Gaussian pixel filter (each pixel's own samples weighted)
    "cornell-gaussian-pixels": (lambda tmp: path_scenes.cornell_box(12), dict(spp=3, pixel_filter="gaussian")),
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_lanes_render_the_megakernels_bits(tmp_path, case):
    make, settings = CASES[case]
    scene = make(tmp_path)
    scene = Scene.from_dict(scene, base_dir=tmp_path) if isinstance(scene, dict) else scene
    a, b, _ = render_both(scene, "lanes", LaneKernel, seed=9, **settings)
    assert_same(a, b)
    assert a.image.mean() > 1e-3  # something lit: the comparison is of something


def test_a_later_pass_continues_each_pixels_sequence_the_same_way():
    """Progressive passes (--time-budget) launch with first_sample > 0, and a launch's pixels need not be in order or
    fill the last work-item's lanes: the lanes number their samples from it as render_path does."""
    scene = Scene.from_dict(path_scenes.cornell_box(8))
    a = Renderer(scene, integrator="path", path_schedule="megakernel", spp=2)
    b = Renderer(scene, integrator="path", path_schedule="lanes", spp=2, tracer=a.tracer)
    pixels = np.arange(61, dtype=np.int32)[::-1].copy()  # backwards, and not a multiple of the lanes
    for first_sample in (0, 6):
        want, got = (r.launch(pixels, "uniform", 1, True, first_sample) for r in (a, b))
        for x, y in zip(want, got):
            assert x is None and y is None or x.tobytes() == y.tobytes()


FALLBACKS = {
    "a scene without primitives": (lambda tmp: {"environment": {"color": [0.5, 0.6, 0.7]}, "objects": []}, {}),
}


def test_a_scene_of_instances_only_takes_the_lanes(tmp_path):
    """n_prims counts the flat part's primitives: a scene whose every mesh is an instance has none, and its lanes' reads
    of the flat primitive 0 (a lane without a hit) read the one zeroed record every empty buffer gets (Device.to_device)."""
    from clrender.trace import lane_schedule

    r = Renderer(copies_scene(tmp_path, 3), integrator="path", path_schedule="lanes", spp=1, instancing=True)
    assert r.tracer.n_prims == 0 and r.variant.defines().get("INSTANCED")
    assert lane_schedule.falls_back(r.variant.defines(), r.tracer.n_prims, r.tracer.device.device) == ""


@pytest.mark.parametrize("reason", list(FALLBACKS))
def test_what_the_lanes_do_not_take_renders_with_the_megakernel(tmp_path, reason):
    from clrender.trace import lane_schedule

    make, settings = FALLBACKS[reason]
    scene = make(tmp_path)
    scene = Scene.from_dict(scene, base_dir=tmp_path) if isinstance(scene, dict) else as_scene(scene)
    r = Renderer(scene, integrator="path", path_schedule="lanes", spp=1, **settings)
    assert not isinstance(r.kernel, LaneKernel)
    why = lane_schedule.falls_back(r.variant.defines(), r.tracer.n_prims, r.tracer.device.device)
    assert why == reason
