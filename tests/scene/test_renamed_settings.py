"""User-facing names that say what a setting is (issues 24 and 34), and the old spellings still accepted
(docs/scene-format.md#older-spellings): the scene key `default_camera` (was `featured_camera`, before that
`seed_camera`), the material `type = "phong"` (was `"seed"`) and `splat gauss --learn scale-lum` (was `seed`)."""

import tomllib

import pytest

from clrender.cli import build_parser
from clrender.commands.render import print_scene_list
from clrender.errors import UsageError
from clrender.layout import MATERIAL_MODELS
from clrender.scene.scene import Scene, bundled_scenes
from clrender.splat.fit import LEARN, LEARN_GROUPS, FitConfig

CAMERAS = [{}, {"position": [0, 0, 1]}, {"position": [0, 1, 1]}]


def scene_toml(tmp_path, key_line):
    path = tmp_path / "s.toml"
    path.write_text(f'description = "two cameras"\n{key_line}\n[[cameras]]\nname = "one"\n[[cameras]]\nname = "two"\nposition = [0, 0, 1]\n')
    return path


# ------------------------------------------------------------------ default_camera
@pytest.mark.parametrize("old", ["featured_camera", "seed_camera"])
def test_old_and_new_scene_key_give_the_same_scene(old):
    new = Scene.from_dict({"cameras": CAMERAS, "default_camera": 2})
    assert new == Scene.from_dict({"cameras": CAMERAS, old: 2}) and new.default_camera == 2
    assert Scene.from_dict({"cameras": CAMERAS}).default_camera == 1


@pytest.mark.parametrize("old", ["featured_camera", "seed_camera"])
def test_old_attribute_names_read_and_write_the_new(old):
    scene = Scene.from_dict({"cameras": CAMERAS, "default_camera": 3})
    assert getattr(scene, old) == 3
    setattr(scene, old, 2)
    assert scene.default_camera == 2 and getattr(scene, old) == 2


def test_errors_name_the_new_key():
    for key in ("default_camera", "featured_camera", "seed_camera"):
        with pytest.raises(UsageError, match=r"default_camera: 4; allowed: whole numbers 1 to 3"):
            Scene.from_dict({"cameras": CAMERAS, key: 4})
    for old in ("featured_camera", "seed_camera"):
        with pytest.raises(UsageError, match=rf"{old}: is an older name of default_camera; give only default_camera"):
            Scene.from_dict({"cameras": CAMERAS, old: 1, "default_camera": 1})
    with pytest.raises(UsageError, match=r"seed_camera: is an older name of default_camera; give only default_camera"):
        Scene.from_dict({"cameras": CAMERAS, "seed_camera": 1, "featured_camera": 1})
    with pytest.raises(UsageError, match=r"unknown key; allowed: .*\bdefault_camera\b") as caught:
        Scene.from_dict({"bogus": 1})
    assert "seed_camera" not in str(caught.value) and "featured_camera" not in str(caught.value)


# ------------------------------------------------------------------ type = "phong"
def test_old_material_type_is_the_phong_model():
    old = Scene.from_dict({"materials": {"m": {"type": "seed", "diffuse": [1, 0, 0], "shininess": 8}}}).materials["m"]
    new = Scene.from_dict({"materials": {"m": {"type": "phong", "diffuse": [1, 0, 0], "shininess": 8}}}).materials["m"]
    assert old == new and new.model == "phong" and int(new.pack()["model"]) == MATERIAL_MODELS["phong"] == 0
    with pytest.raises(UsageError, match=r"materials\.m\.type.*'phong'") as caught:
        Scene.from_dict({"materials": {"m": {"type": "sead"}}})
    assert "'seed'" not in str(caught.value)  # the allowed list names today's spelling only


def test_bundled_scenes_use_the_new_key():
    for name, path in bundled_scenes().items():
        data = tomllib.loads(path.read_text())
        assert "default_camera" in data and "featured_camera" not in data and "seed_camera" not in data, name
        assert "seed" not in path.read_text().replace("seed = ", ""), name  # only the RNG's `seed = N`


@pytest.mark.parametrize("key", ["default_camera", "featured_camera", "seed_camera"])
def test_list_marks_the_default_camera_under_any_name(tmp_path, capsys, key):
    print_scene_list({"s": scene_toml(tmp_path, f"{key} = 2")})
    out = capsys.readouterr().out.splitlines()
    assert out[:3] == ["s: two cameras", "    --camera 1  one", "  * --camera 2  two"]
    assert out[3] == "(* the scene's default view, rendered when --camera is not given: the one it was made for; --camera picks any)"


# ------------------------------------------------------------------ --learn scale-lum
def test_learn_old_and_new_give_the_same_config():
    assert LEARN == ("scale-lum", "all") and LEARN_GROUPS["scale-lum"] == ("log_scale", "lum")
    assert FitConfig(learn="seed") == FitConfig(learn="scale-lum") and FitConfig(learn="seed").learn == "scale-lum"


@pytest.mark.parametrize("word", ["scale-lum", "seed"])
def test_learn_option_accepts_the_old_spelling(word):
    args = build_parser().parse_args(["splat", "gauss", "in.png", "-o", "out.png", "--learn", word])
    assert args.learn == "scale-lum"


def test_learn_option_refuses_other_words(capsys):
    with pytest.raises(SystemExit) as caught:
        build_parser().parse_args(["splat", "gauss", "in.png", "-o", "out.png", "--learn", "scales"])
    assert caught.value.code == 2
    assert "invalid choice: 'scales' (choose from scale-lum, all)" in capsys.readouterr().err.replace("'scale-lum', 'all'", "scale-lum, all")


# ------------------------------------------------------------------ help texts
def subparser(*words):
    parser = build_parser()
    for word in words:
        action = next(a for a in parser._actions if getattr(a, "choices", None) and word in a.choices)
        parser = action.choices[word]
    return parser


def test_help_says_what_things_are_not_whose():
    gauss = subparser("splat", "gauss").format_help()
    assert "{scale-lum,all}" in gauss and "scale-lum: log-scales and a per-splat luminance factor only (old name: seed)" in " ".join(gauss.split())
    render = subparser("render").format_help()
    assert "marks each scene's own view with *" in " ".join(render.split())
    for text in (gauss, render):
        assert "seed's" not in text and "seed-style" not in text and "the seed" not in text
