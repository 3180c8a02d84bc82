"""The texture-slot table (clrender/layout.py TEXTURE_SLOT_TABLE) is the one place a slot is declared: the kernel
header's TEXTURE_* codes, the scene readers' keys and colour spaces, glTF's textureInfo keys, and the one kernel rule
(kernels/surface.h) all follow it, and no other kernel file names a slot."""

import re
from dataclasses import fields
from pathlib import Path

from clrender import layout
from clrender.layout import TEXTURE_SLOT_TABLE, TEXTURE_SLOTS
from clrender.scene import materials, textures
from clrender.scene.gltf import Document, _material

KERNELS = Path(__file__).resolve().parents[2] / "kernels"
SLOT_NAMES = [s.name for s in TEXTURE_SLOT_TABLE]


def test_the_kernel_header_numbers_the_slots_as_the_table_orders_them():
    assert list(TEXTURE_SLOTS) == SLOT_NAMES and list(TEXTURE_SLOTS.values()) == list(range(len(SLOT_NAMES)))
    assert layout.DEFINES["TEXTURE_SLOTS"] == len(TEXTURE_SLOT_TABLE)
    for code, slot in enumerate(TEXTURE_SLOT_TABLE):
        assert layout.DEFINES[f"TEXTURE_{slot.name.upper()}"] == code
    assert layout.MATERIAL_DTYPE["textures"].shape == (len(TEXTURE_SLOT_TABLE),)


def test_only_the_surface_layer_applies_slots_and_it_applies_every_one():
    """kernels/surface.h is the one kernel rule: it names every slot, and no other kernel file names one."""
    codes = {f"TEXTURE_{name.upper()}" for name in SLOT_NAMES}
    surface = (KERNELS / "surface.h").read_text()
    assert codes <= set(re.findall(r"\bTEXTURE_[A-Z_]+\b", surface))
    for path in sorted(KERNELS.glob("*.[ch]*")):
        if path.name != "surface.h":
            named = codes & set(re.findall(r"\bTEXTURE_[A-Z_]+\b", path.read_text()))
            assert not named, f"{path.name} names {sorted(named)}: slot rules belong in surface.h"


def test_every_parameter_a_slot_scales_is_one_material_at_fills():
    """Each (parameter, channels) of the table is a MaterialPoint field (or the normal the map tilts), and its
    channels are texel channels."""
    surface = (KERNELS / "surface.h").read_text()
    point = surface[surface.index("typedef struct {\n    V3 kd") : surface.index("} MaterialPoint;")]
    for slot in TEXTURE_SLOT_TABLE:
        assert slot.parameters, slot.name
        for parameter, channels in slot.parameters:
            assert set(channels) <= set("rgba"), (slot.name, channels)
            assert parameter == "normal" or re.search(rf"\b{parameter}\b", point), (slot.name, parameter)


def test_the_scene_readers_take_their_slots_from_the_table():
    assert textures.COLOUR_SLOTS == tuple(s.name for s in TEXTURE_SLOT_TABLE if s.colour) == ("base_color", "emissive")
    material_fields = {f.name for f in fields(materials.Material)}
    for slot in TEXTURE_SLOT_TABLE:
        key = f"{slot.name}_texture"
        assert key in material_fields
        models = ("gltf", "phong") if slot.models == "all" else ("gltf",)
        for model in models:
            assert key in materials.MODEL_KEYS[model], (model, key)
        if slot.alias:
            assert slot.alias in materials.MODEL_KEYS["phong"]
    assert materials.ALIAS_KEYS == {"diffuse_texture": "base_color_texture"}
    # a slot that only glTF materials take is refused in a Phong material
    assert "normal_texture" not in materials.MODEL_KEYS["phong"]


def test_gltf_reads_each_slot_at_the_key_the_table_names():
    """A glTF material with a textureInfo at every slot's key (and its strength key) reads as every slot."""
    item = {}
    read = [(i, slot) for i, slot in enumerate(TEXTURE_SLOT_TABLE) if slot.gltf]  # "": a slot glTF has no key for
    for i, slot in read:
        *tables, key = slot.gltf.split(".")
        table = item
        for name in tables:
            table = table.setdefault(name, {})
        table[key] = {"index": i, **({slot.strength: 0.25} if slot.strength else {})}
    doc = Document(Path("table.gltf"), {"materials": [item], "textures": [{"source": 0}] * len(TEXTURE_SLOT_TABLE)}, [])
    out = _material(doc, 0)
    assert len(read) == len(TEXTURE_SLOT_TABLE)
    for i, slot in read:
        ref = out[f"{slot.name}_texture"]
        assert ref["texture"] == f"texture_{i}"
        assert ref.get("strength", 1.0) == (0.25 if slot.strength else 1.0)
