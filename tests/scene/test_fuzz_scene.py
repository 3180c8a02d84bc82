"""Scene files under hostile input: every bad scene is one short UsageError, every good one renders finite.

The first half pins the defects of issue 14 (each failed on the old reader); the second half is a
hypothesis fuzzer that mutates the bundled scenes.  Its examples that once broke something are kept
below as @example lines, so they run in every profile.

Long run (>= 10,000 scene cases):  CLRENDER_FUZZ_EXAMPLES=10000 pytest tests/scene/test_fuzz_scene.py -m slow
(or --hypothesis-profile=long where tests/conftest.py registers it).
"""

from __future__ import annotations

import copy
import math
import os
import re
import time
import tomllib

import numpy as np
import pytest

from clrender.errors import UsageError
from clrender.scene.scene import Scene, bundled_scenes

MAX_MESSAGE = 300  # characters: a message is a line a person reads, not a dump of the value
CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")
TINY = dict(width=8, height=6, aa="none", light_samples=1, max_depth=3)


def usage_error(data, tmp_path=None, **kwargs) -> str:
    """The message of the UsageError Scene.from_dict raises, checked to be one short clean line."""
    with pytest.raises(UsageError) as err:
        Scene.from_dict(data, base_dir=tmp_path or ".", where="s.toml", **kwargs)
    message = str(err.value)
    assert "\n" not in message and not CONTROL.search(message), repr(message)
    assert len(message) <= MAX_MESSAGE, len(message)
    assert message.startswith("s.toml: "), message
    return message


def render_tiny(scene: Scene) -> np.ndarray:
    from clrender.trace.renderer import render

    return render(scene, **TINY)


def sphere_scene(**sphere) -> dict:
    obj = {"type": "sphere", "center": [0, 0, -3], "radius": 1, **sphere}
    return {"objects": [obj], "lights": [{"type": "point", "position": [2, 2, 0]}]}


# ------------------------------------------------------------------ issue 14's reproducers
def test_background_nested_500_deep_in_a_file_is_one_line(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text("background = " + "[" * 500 + "]" * 500 + "\n")
    with pytest.raises(UsageError) as err:
        Scene.from_file(path)
    message = str(err.value)
    assert "\n" not in message and len(message) <= MAX_MESSAGE and str(path) in message


def test_background_nested_500_deep_in_a_dict_names_the_key():
    value = []
    for _ in range(500):
        value = [value]
    assert "background" in usage_error({"background": value})


def test_material_that_is_a_list_is_refused():
    message = usage_error(sphere_scene(material=[1]))
    assert "objects[0].material" in message and "name" in message


@pytest.mark.parametrize("seed", [-1, 1.5, 2**32, "7", True])
def test_dense_generator_seed_must_be_a_whole_number_in_range(seed):
    message = usage_error({"objects": [{"type": "mesh", "generator": "dense", "params": {"n_triangles": 64, "seed": seed}}]})
    assert "objects[0].params.seed" in message and "0 to 4294967295" in message


def test_generator_range_errors_name_the_file_and_key():
    message = usage_error({"objects": [{"type": "mesh", "generator": "bunny", "params": {"resolution": 3}}]})
    assert "objects[0].params.resolution" in message and "16 to" in message


@pytest.mark.parametrize(
    "gen, params",
    [
        ("bunny", {"resolution": 256}),  # did not finish in 120 s
        ("cat", {"resolution": 10_000}),
        ("dense", {"n_triangles": 50_000_000}),  # about 24 GiB
        ("wizard_hat", {"segments": 10**9}),
        ("tower", {"segments": 10**9}),
    ],
)
def test_generator_sizes_are_bounded(gen, params):
    (key,) = params
    assert f"objects[0].params.{key}" in usage_error({"objects": [{"type": "mesh", "generator": gen, "params": params}]})


@pytest.mark.parametrize("scale", [1e-40, [1, 1e-40, 1], 1e300, 0])
def test_mesh_scale_out_of_range_is_refused_before_the_bvh(scale):
    assert "objects[0].scale" in usage_error({"objects": [{"type": "mesh", "generator": "wizard_hat", "scale": scale}]})


def test_area_light_samples_are_bounded_like_the_cli():
    light = {"type": "area", "corner": [0, 3, -3], "edge_a": [1, 0, 0], "edge_b": [0, 0, 1], "samples": 100_000}
    message = usage_error({"lights": [light]})
    assert "lights[0].samples" in message and "64" in message


@pytest.mark.parametrize(
    "data, key",
    [
        ({"ambient": [1e39, 0, 0]}, "ambient"),
        ({"background": [0, 1e300, 0]}, "background"),
        ({"materials": {"m": {"diffuse": [1e300, 0, 0]}}}, "materials.m.diffuse"),
        ({"materials": {"m": {"specular": [0, 0, 3.5e38]}}}, "materials.m.specular"),
        ({"lights": [{"type": "point", "position": [0, 1, 0], "intensity": 1e39}]}, "lights[0].intensity"),
        ({"lights": [{"type": "point", "position": [0, 1, 0], "color": [1e300, 1, 1]}]}, "lights[0].color"),
        ({"lights": [{"type": "point", "position": [4e38, 1, 0]}]}, "lights[0].position"),
        ({"cameras": [{"position": [0, 0, 1e39]}]}, "cameras[0].position"),
        ({"objects": [{"type": "sphere", "center": [0, 0, -3.5e38], "radius": 1}]}, "objects[0].center"),
        ({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1e-300}]}, "objects[0].radius"),
        ({"objects": [{"type": "sphere", "center": [0, 0, -3], "radius": 1e39}]}, "objects[0].radius"),
        ({"objects": [{"type": "triangle", "vertices": [[0, 0, 0], [1, 0, 0], [0, 1e39, 0]]}]}, "objects[0].vertices[2]"),
        ({"objects": [{"type": "mesh", "generator": "tower", "translate": [1e39, 0, 0]}]}, "objects[0].translate"),
        ({"width": 10**400}, "width"),
    ],
)
def test_values_beyond_float32_name_the_file_and_key(data, key):
    assert f"s.toml: {key}" in usage_error(data)


def test_a_tiny_sphere_at_the_eye_is_refused_or_renders_finite():
    # radius 1e-300 is 0 in float32: the kernel divided 0 by 0 for the normal
    usage_error(sphere_scene(center=[0, 0, 0], radius=1e-300))
    image = render_tiny(Scene.from_dict(sphere_scene(center=[0, 0, 0], radius=1e-6)))
    assert np.isfinite(image).all()


def test_bright_but_allowed_values_render_finite():
    data = sphere_scene(material="hot")
    data.update(ambient=[1e6] * 3, background=[1e6] * 3, materials={"hot": {"diffuse": [1] * 3, "specular": [1] * 3}})  # reflectances stop at 1
    data["lights"] = [{"type": "point", "position": [2, 2, 0], "intensity": 1e6, "color": [1e6] * 3, "falloff": "inverse_square"}]
    image = render_tiny(Scene.from_dict(data))
    assert np.isfinite(image).all() and image.max() > 1e6


def test_a_key_with_a_newline_and_escape_is_shown_escaped():
    message = usage_error({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "evil\n\x1b[31mkey": 1}]})
    assert "\\n" in message and "\\x1b" in message


def test_long_bad_values_are_cut():
    message = usage_error({"background": "x" * 5000})
    assert "..." in message or "\u2026" in message


@pytest.mark.parametrize(
    "data", [{1: 2}, {"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, 3: 4}]}, {"materials": {"m": {(1, 2): 1}}}]
)
def test_non_string_keys_are_refused(data):
    usage_error(data)


@pytest.mark.parametrize("key, n", [("cameras", 65), ("lights", 65)])
def test_counts_are_bounded(key, n):
    item = {"cameras": {}, "lights": {"type": "directional", "direction": [0, -1, 0]}}[key]
    assert key in usage_error({key: [item] * n})


def test_many_objects_are_refused_before_they_are_built():
    start = time.perf_counter()
    usage_error({"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}] * 2_000_000})
    assert time.perf_counter() - start < 5


# ------------------------------------------------------------------ mesh paths
def test_mesh_paths_may_leave_the_base_dir_unless_confined(tmp_path):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    inner = tmp_path / "scenes"
    inner.mkdir()
    climbing = {"objects": [{"type": "mesh", "file": "../tri.obj"}]}
    absolute = {"objects": [{"type": "mesh", "file": str(tmp_path / "tri.obj")}]}
    for data in (climbing, absolute):
        assert len(Scene.from_dict(data, base_dir=inner).objects[0].faces) == 1  # local files: allowed
        message = usage_error(data, inner, allow_outside=False)
        assert "objects[0].file" in message and "outside" in message
    (inner / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    inside = {"objects": [{"type": "mesh", "file": "./tri.obj"}]}
    assert len(Scene.from_dict(inside, base_dir=inner, allow_outside=False).objects) == 1


def test_a_symlink_out_of_the_base_dir_is_outside(tmp_path):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    inner = tmp_path / "scenes"
    inner.mkdir()
    (inner / "link.obj").symlink_to(tmp_path / "tri.obj")
    usage_error({"objects": [{"type": "mesh", "file": "link.obj"}]}, inner, allow_outside=False)


# ------------------------------------------------------------------ the fuzzer
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

# Generators stay small so every case renders in milliseconds (their size bounds are tested above).
SMALL_PARAMS = {
    "bunny": {"resolution": 16},
    "cat": {"resolution": 16},
    "dense": {"n_triangles": 200, "seed": 1},
    "wizard_hat": {"segments": 6},
    "tower": {"segments": 5},
}
TRI_OBJ = "v 0 0 -3\nv 1 0 -3\nv 0 1 -3\nf 1 2 3\n"


def small_base_scenes() -> dict:
    """The bundled scenes as dicts, their generated meshes made small."""
    bases = {}
    for name, path in bundled_scenes().items():
        data = tomllib.loads(path.read_text())
        for obj in data.get("objects", []):
            if "generator" in obj:
                obj["params"] = dict(SMALL_PARAMS[obj["generator"]])
        bases[name] = data
    return bases


BASES = small_base_scenes()
NASTY_FLOATS = [
    math.nan,
    math.inf,
    -math.inf,
    3.5e38,
    -3.5e38,
    1e39,
    1e300,
    -1e300,
    1e-300,
    -1e-300,
    1e-45,
    1e-40,
    0.0,
    -0.0,
    1e-7,
    1e-6,
    1e-5,
    1e6,
    -1e6,
    1.0000001e6,
    1e7,
    179.0,
    180.0,
    0.5,
    1.0,
    -1.0,
    2.0,
]
NASTY_INTS = [
    -(2**63),
    -1,
    0,
    1,
    2,
    3,
    5,
    7,
    8,
    15,
    16,
    17,
    64,
    65,
    192,
    193,
    4096,
    4097,
    16384,
    16385,
    2**31 - 1,
    2**31,
    2**32 - 1,
    2**32,
    2**63,
    10**400,
]
NASTY_TEXT = [
    "",
    "glass",
    "default",
    "mirror",
    "point",
    "area",
    "directional",
    "sphere",
    "mesh",
    "quad",
    "plane",
    "triangle",
    "bunny",
    "dense",
    "inverse_square",
    "none",
    "tri.obj",
    "missing.obj",
    "broken.obj",
    "../tri.obj",
    "evil\nkey",
    "\x1b[2J\x1b[31m",
    "\u2028",
    "\u202e",
    "\x00",
    "x" * 5000,
    "ключ",
    "🦊",
]

floats = st.sampled_from(NASTY_FLOATS) | st.floats(allow_nan=True, allow_infinity=True) | st.floats(-10, 10)
ints = st.sampled_from(NASTY_INTS) | st.integers(-5, 40)
numbers = floats | ints
texts = st.sampled_from(NASTY_TEXT) | st.text(max_size=12)
scalars = numbers | texts | st.booleans() | st.none()
vectors = st.lists(numbers, min_size=3, max_size=3) | st.lists(numbers, max_size=5)
values = st.recursive(scalars | vectors, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(texts, inner, max_size=3), max_leaves=8)


def nested(depth: int, leaf=0.5):
    value = [leaf, leaf, leaf]
    for _ in range(depth):
        value = [value]
    return value


# values at the edges of what the scene reader allows
extremes = st.sampled_from([0, 0.0, 1e-6, -1e-6, 1e-5, 1e-3, 0.01, 1, -1, 2, 5, 64, 100, 179, 1e6, -1e6, 999_999.9])
deep_values = st.integers(2, 600).map(nested)
new_objects = st.sampled_from(
    [
        {"type": "sphere", "center": [0, 0, -3], "radius": 1},
        {"type": "sphere", "center": [0, 0, 0], "radius": 1e-6},  # around the eye
        {"type": "triangle", "vertices": [[0, 0, -2], [1, 1, -2], [2, 2, -2]]},  # collinear
        {"type": "triangle", "vertices": [[0, 0, -2], [0, 0, -2], [0, 0, -2]]},  # a point
        {"type": "quad", "corner": [-1, -1, -2], "edge_a": [2, 0, 0], "edge_b": [4, 0, 0]},  # no area
        {"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1], "size": 1e-6},  # through the eye
        {"type": "mesh", "file": "tri.obj"},
        {"type": "mesh", "file": "tri.obj", "scale": 1e-6, "translate": [0, 0, -1]},
        {"type": "mesh", "file": "broken.obj"},
        {"type": "mesh", "generator": "wizard_hat", "params": {"segments": 3}, "scale": [1, 1e-6, 1], "translate": [0, 0, -2]},
        {"type": "mesh", "generator": "dense", "params": {"n_triangles": 8}, "scale": -1, "translate": [0, 0, -3], "smooth": True},
    ]
)
new_lights = st.sampled_from(
    [
        {"type": "point", "position": [0, 0, 0]},  # at the eye
        {"type": "point", "position": [0, 0, -2], "falloff": "inverse_square", "intensity": 1e6},  # on a surface
        {"type": "directional", "direction": [0, 0, -1e-6]},
        {
            "type": "area",
            "corner": [-1, -1, -2],
            "edge_a": [2, 0, 0],
            "edge_b": [0, 2, 0],
            "falloff": "inverse_square",
            "intensity": 1e6,
            "color": [1e6, 1e6, 1e6],
        },  # a light on the geometry
        {"type": "area", "corner": [0, 0, 0], "edge_a": [1e-6, 0, 0], "edge_b": [0, 1e-6, 0], "samples": 64},
    ]
)
new_cameras = st.sampled_from(
    [
        {"position": [0, 0, 0], "look_at": [0, 0, 0]},
        {"position": [0, 0, 0], "look_at": [0, 1, 0], "up": [0, 1, 0]},  # up along the view
        {"position": [0, 0, 0], "look_at": [0, 0, -1e-6], "fov": 1e-3},
        {"position": [1e6, 1e6, 1e6], "look_at": [0, 0, -3], "fov": 179},
        {"position": [0, 0, 0], "look_at": [0, 0, -1], "up": [0, 0, 0]},
    ]
)


def declared_keys(section: str, table: dict) -> list:
    """The keys the reader of a table of `section` accepts (its declaration, so keys added later are fuzzed too)."""
    from clrender.scene.camera import CAMERA_READER
    from clrender.scene.lights import LIGHT_READERS
    from clrender.scene.materials import MATERIAL_READER
    from clrender.scene.scene import ENVIRONMENT_READER, OBJECT_READERS, TOP_KEYS
    from clrender.scene.textures import TEXTURE_READER

    if section in ("lights", "objects"):
        readers = LIGHT_READERS if section == "lights" else OBJECT_READERS
        kind = table.get("type")
        chosen = [readers[kind]] if isinstance(kind, str) and kind in readers else list(readers.values())
        return sorted(set().union(*(r.keys for r in chosen)))
    fixed = {"": TOP_KEYS, "environment": ENVIRONMENT_READER.keys, "cameras": CAMERA_READER.keys}
    fixed.update(materials=MATERIAL_READER.keys, textures=TEXTURE_READER.keys)
    return sorted(fixed[section])


def declared_tables(data: dict) -> list:
    """(section, table) for every table of a scene dict that a reader reads, the top level first."""
    out = [("", data)]
    if isinstance(data.get("environment"), dict):
        out.append(("environment", data["environment"]))
    for section in ("materials", "textures"):
        if isinstance(data.get(section), dict):
            out += [(section, t) for t in data[section].values() if isinstance(t, dict)]
    for section in ("cameras", "lights", "objects"):
        if isinstance(data.get(section), list):
            out += [(section, t) for t in data[section] if isinstance(t, dict)]
    return out


def locations(node, path=()):
    """Every (container, key) in a scene dict, depth first."""
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, child in items:
        yield node, key
        yield from locations(child, (*path, key))


@st.composite
def mutated_scenes(draw, allowed_only=False):
    """A bundled scene with 1-4 mutations; allowed_only: only values at the edges of what is allowed
    and degenerate objects, lights and cameras, so that most cases get as far as rendering."""
    data = copy.deepcopy(BASES[draw(st.sampled_from(sorted(BASES)))])
    ops = (
        ["extreme", "object", "light", "camera"]
        if allowed_only
        else ["replace", "component", "scale", "delete", "add_key", "deep", "extreme", "extreme", "extreme", "object", "light", "camera"]
        + ["declared", "declared"]
    )
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(ops))
        spots = list(locations(data))
        if op in ("object", "light", "camera"):
            key, strategy = {"object": ("objects", new_objects), "light": ("lights", new_lights), "camera": ("cameras", new_cameras)}[op]
            if isinstance(data.get(key, []), list):
                item = copy.deepcopy(draw(strategy))
                data.setdefault(key, []).insert(0 if op == "camera" else len(data.get(key, [])), item)
            continue
        if op == "declared":  # any key a reader accepts, set or replaced: covers keys no bundled scene writes
            section, table = draw(st.sampled_from(declared_tables(data)))
            table[draw(st.sampled_from(declared_keys(section, table)))] = draw(values | extremes | st.lists(extremes, min_size=3, max_size=3))
            continue
        if op == "add_key":
            tables = [data] + [c[k] for c, k in spots if isinstance(c[k], dict)]
            draw(st.sampled_from(tables))[draw(texts)] = draw(values)
            continue
        if not spots:
            continue
        container, key = draw(st.sampled_from(spots))
        old = container[key]
        if op == "delete":
            del container[key]
        elif op == "replace":
            container[key] = draw(values)
        elif op == "deep":
            container[key] = draw(deep_values)
        elif op == "component" and isinstance(old, list) and old:
            old[draw(st.integers(0, len(old) - 1))] = draw(numbers)
        elif op == "extreme" and isinstance(old, list) and old and all(is_num(v) for v in old):
            old[draw(st.integers(0, len(old) - 1))] = draw(extremes)  # allowed but extreme: must render finite
        elif op == "extreme" and is_num(old):
            container[key] = draw(extremes)
        elif op == "scale" and is_num(old):
            factor = draw(st.sampled_from([0, -1, 1e-30, 1e-6, 1e6, 1e30, 1e300]))
            try:
                container[key] = old * factor
            except OverflowError:  # a huge int times a float
                container[key] = math.copysign(math.inf, factor) if old > 0 else -math.copysign(math.inf, factor)
        else:
            container[key] = draw(numbers)
    return data


def is_num(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory):
    """A scene folder with one good and one broken mesh; bunny builds cached inside it, not in ~/.cache."""
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "tri.obj").write_text(TRI_OBJ)
    (folder / "broken.obj").write_text("v 0 0 nan\nf 1 1 1\nthis is not obj\n")
    (folder.parent / "tri.obj").write_text(TRI_OBJ)
    old = os.environ.get("XDG_CACHE_HOME")
    os.environ["XDG_CACHE_HOME"] = str(folder / "cache")
    yield folder
    if old is None:
        del os.environ["XDG_CACHE_HOME"]
    else:
        os.environ["XDG_CACHE_HOME"] = old


FUZZ_EXAMPLES = os.environ.get("CLRENDER_FUZZ_EXAMPLES")  # the long run sets it; else the hypothesis profile decides
FUZZ = settings(deadline=None, suppress_health_check=list(HealthCheck), **({"max_examples": int(FUZZ_EXAMPLES)} if FUZZ_EXAMPLES else {}))
STATS = {"cases": 0, "refused": 0, "rendered": 0, "slowest": 0.0}


def check_scene(data, folder):
    """The property: a short clean UsageError, or a tiny render whose every pixel is finite."""
    start = time.perf_counter()
    STATS["cases"] += 1
    try:
        scene = Scene.from_dict(data, base_dir=folder, where="fuzz.toml", allow_outside=bool(len(str(data)) % 2))
    except UsageError as exc:
        STATS["refused"] += 1
        message = str(exc)
        assert "\n" not in message and not CONTROL.search(message), repr(message)
        assert len(message) <= MAX_MESSAGE and message.startswith("fuzz.toml: "), message
        return
    image = render_tiny(scene)
    STATS["rendered"] += 1
    assert image.shape == (6, 8, 3) and np.isfinite(image).all(), scene
    STATS["slowest"] = max(STATS["slowest"], time.perf_counter() - start)
    assert time.perf_counter() - start < 60, "a tiny render took over a minute"


@FUZZ
@given(data=mutated_scenes())
def test_mutated_bundled_scenes_are_refused_cleanly_or_render_finite(data, fuzz_dir):
    check_scene(data, fuzz_dir)


@FUZZ
@given(data=mutated_scenes(allowed_only=True))
def test_scenes_at_the_edges_of_the_limits_render_finite(data, fuzz_dir):
    check_scene(data, fuzz_dir)


def test_fuzz_counts_report():
    """Prints how many cases the fuzzer ran (run with -s to see it; the long run's report quotes it)."""
    print(f"\nscene fuzz: {STATS}")
    assert STATS["cases"] == 0 or STATS["refused"] + STATS["rendered"] == STATS["cases"]


@pytest.mark.parametrize("height", [1e-12, 1e-20])
def test_a_light_touching_the_surface_it_lights_stays_finite(height):
    # the camera looks straight down at a bright plane with a point light just above it: 1/r^2
    # overflowed float32 and the pixels under the light were inf (capped at r = 1e-5 in shade.h)
    from clrender.trace.renderer import render

    data = {
        "cameras": [{"position": [0, 1, 0], "look_at": [0, -1, 0], "up": [0, 0, -1]}],
        "materials": {"white": {"diffuse": [1] * 3, "specular": [1] * 3}},  # reflectances stop at 1 (checks.ALBEDO_LIMIT)
        "objects": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 1, 0], "size": 10, "material": "white"}],
        "lights": [{"type": "point", "position": [0, height, 0], "falloff": "inverse_square", "intensity": 1e6, "color": [1e6] * 3}],
    }
    image = render(Scene.from_dict(data), width=5, height=3, aa="none")
    assert np.isfinite(image).all()
    assert image.max() > 1e20  # still the brightest thing in the scene, not dropped


@pytest.mark.parametrize(
    "data, key", [({"name": "two\nlines"}, "name"), ({"description": "\x1b[2Jclear"}, "description"), ({"materials": {"a\rb": {}}}, "materials")]
)
def test_names_shown_on_a_terminal_may_not_hold_control_characters(data, key):
    assert key in usage_error(data)
