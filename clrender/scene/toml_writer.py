"""The scene dict as TOML text (`clrender convert`): the inverse of reading a TOML scene, for the dicts
foreign readers make (numbers, strings, booleans, lists and tables of them)."""

from __future__ import annotations

import json
import math

SECTION_ORDER = ("environment", "cameras", "textures", "materials", "lights", "objects")


def _key(name: str) -> str:
    return name if name and all(c.isalnum() or c in "_-" for c in name) else json.dumps(name)


def value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"{v} has no TOML scene form")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string is JSON's escaping
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(value(x) for x in v) + "]"
    if hasattr(v, "tolist"):
        return value(v.tolist())
    raise TypeError(f"{type(v).__name__} has no TOML form")


def _table(lines: list, header: str, table: dict):
    lines += ["", header]
    lines += [f"{_key(k)} = {value(v)}" for k, v in table.items()]


def dumps(scene: dict, comments=()) -> str:
    lines = [f"# {c}" for c in comments]
    lines += [f"{_key(k)} = {value(v)}" for k, v in scene.items() if k not in SECTION_ORDER]
    if "environment" in scene:
        _table(lines, "[environment]", scene["environment"])
    for name in ("textures", "materials"):
        for key, table in scene.get(name, {}).items():
            _table(lines, f"[{name}.{_key(key)}]", table)
    for name in ("cameras", "lights", "objects"):
        for table in scene.get(name, []):
            _table(lines, f"[[{name}]]", table)
    return "\n".join(lines) + "\n"
