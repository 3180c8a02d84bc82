"""Scene files of other renderers: one entry point for every foreign format clrender reads.

A foreign reader turns its file into the scene dict a TOML scene is (so it is checked the same way) plus
the render settings the file asks for (`Foreign`, mitsuba_plugins.py): Mitsuba 3's XML (`.xml`,
mitsuba_plugins.read_mitsuba) and pbrt-v4's files (`.pbrt`, pbrt.read_pbrt_file).  `defines` are the
command line's `-D name=value` (Mitsuba's `$name` parameters); `approximate` renders what cannot be read
with documented stand-ins instead of refusing it.  scene.py's `Scene.from_file` makes the Scene (imports
go one way: scene.py imports this module, never the reverse).
"""

from __future__ import annotations

from pathlib import Path

from ..errors import UsageError, shown

SUFFIXES = (".xml", ".pbrt")


def is_foreign(path) -> bool:
    return Path(str(path)).suffix.lower() in SUFFIXES


def parse_defines(items) -> dict:
    """`-D name=value` options as a dict (the later of two equal names wins)."""
    out = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep or not name.isidentifier():
            raise UsageError(f"-D {shown(item)}: expected NAME=VALUE, NAME a letter or _ then letters, digits or _")
        out[name] = value
    return out


def read_foreign(path, defines: dict | None = None, approximate: bool = False, allow_outside: bool = True):
    """The Foreign record (scene dict, settings, substitutions) of a foreign scene file."""
    path = Path(path)
    if not path.is_file():
        raise UsageError(f"scene file {shown(str(path))} does not exist")
    if path.suffix.lower() == ".xml":
        from .mitsuba_plugins import read_mitsuba

        return read_mitsuba(path, defines, approximate, allow_outside)
    from .mitsuba_plugins import Foreign
    from .pbrt import read_pbrt_file

    pbrt = read_pbrt_file(path, defines, approximate, allow_outside)
    return Foreign(pbrt.scene, pbrt.settings, pbrt.substitutions)
