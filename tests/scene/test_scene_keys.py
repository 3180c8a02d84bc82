"""docs/scene-format.md's key table against the readers' declarations: every key a reader accepts is in
the table under its section and type, and every key the table lists is accepted (issue 24).

Each reader declares its keys once (a `TypeReader` next to what it builds); these tests also check that
a table holding any other key is refused with exactly the declared keys as what is allowed."""

import re
from pathlib import Path

import pytest

from clrender.errors import UsageError
from clrender.scene.camera import CAMERA_READER
from clrender.scene.lights import LIGHT_READERS
from clrender.scene.materials import MATERIAL_READER, MODEL_KEYS
from clrender.scene.scene import ENVIRONMENT_READER, OBJECT_READERS, TOP_KEYS, Scene
from clrender.scene.textures import TEXTURE_READER

DOC = Path(__file__).resolve().parents[2] / "docs" / "scene-format.md"
SECTIONS = {
    "top level": "",
    "`[environment]`": "environment",
    "`[[cameras]]`": "cameras",
    "`[materials.NAME]`": "materials",
    "`[textures.NAME]`": "textures",
    "`[[lights]]`": "lights",
    "`[[objects]]`": "objects",
}


def documented_keys() -> dict:
    """{(section, type or ""): set of keys} from the "## Keys" table; a row whose section cell is a plain word
    (`point`, `sphere`) lists the keys of that type of the section above it, an empty cell continues the row above."""
    text = DOC.read_text(encoding="utf-8")
    table = text.split("\n## Keys\n", 1)[1].split("\n## ", 1)[0]
    keys, section, group = {}, None, None
    for line in table.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if not line.startswith("|") or len(cells) < 4 or cells[0] == "section" or set(cells[0]) <= {"-"} and cells[0]:
            continue
        if cells[0] in SECTIONS:
            section = SECTIONS[cells[0]]
            group = (section, "")
        elif cells[0]:
            assert section in ("lights", "objects"), f"row {line!r}: a type of which section?"
            group = (section, cells[0])
        names = re.findall(r"`([a-z_]+)`", cells[1])
        assert names, f"row {line!r} names no key"
        keys.setdefault(group, set()).update(names)
    return keys


def declared_keys() -> dict:
    """The same structure from the code: each type's keys are the section's common ones plus its own."""
    keys = {
        ("", ""): set(TOP_KEYS),
        ("environment", ""): set(ENVIRONMENT_READER.keys),
        ("cameras", ""): set(CAMERA_READER.keys),
        ("materials", ""): set(MATERIAL_READER.keys),
        ("textures", ""): set(TEXTURE_READER.keys),
    }
    for section, readers in (("lights", LIGHT_READERS), ("objects", OBJECT_READERS)):
        common = set.intersection(*(set(r.keys) for r in readers.values()))
        keys[(section, "")] = common
        keys.update({(section, kind): set(r.keys) - common for kind, r in readers.items()})
    return keys


def test_the_docs_key_table_lists_exactly_the_keys_each_reader_accepts():
    documented, declared = documented_keys(), declared_keys()
    # the top level's tables ([[cameras]], ...) are keys of the top level too
    documented[("", "")] |= {name for name in SECTIONS.values() if name}
    assert sorted(documented) == sorted(declared), "the table's sections and types differ from the readers'"
    for group in declared:
        assert documented[group] == declared[group], (
            f"{group}: accepted but not documented: {sorted(declared[group] - documented[group])}; "
            f"documented but not accepted: {sorted(documented[group] - declared[group])}"
        )


def refused_keys(data) -> list:
    """The keys a scene dict's "unknown key" message allows."""
    with pytest.raises(UsageError, match="unknown key; allowed: ") as info:
        Scene.from_dict(data)
    return str(info.value).split("allowed: ", 1)[1].split(", ")


@pytest.mark.parametrize(
    "data, reader_keys",
    [({"zz": 1}, TOP_KEYS), ({"environment": {"zz": 1}}, ENVIRONMENT_READER.keys), ({"cameras": [{"zz": 1}]}, CAMERA_READER.keys)]
    + [({"materials": {"m": {"zz": 1}}}, MODEL_KEYS["phong"]), ({"textures": {"t": {"file": "t.png", "zz": 1}}}, TEXTURE_READER.keys)]
    + [({"materials": {"m": {"type": kind, "zz": 1}}}, keys) for kind, keys in MODEL_KEYS.items()]
    + [({"lights": [{"type": kind, "zz": 1}]}, reader.keys) for kind, reader in LIGHT_READERS.items()]
    + [({"objects": [{"type": kind, "zz": 1}]}, reader.keys) for kind, reader in OBJECT_READERS.items()],
    ids=lambda value: value if isinstance(value, str) else None,
)
def test_a_table_with_another_key_is_refused_naming_exactly_the_declared_keys(data, reader_keys):
    assert refused_keys(data) == sorted(reader_keys)
