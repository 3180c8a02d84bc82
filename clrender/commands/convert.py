"""`clrender convert SCENE -o scene.toml`: the clrender scene a foreign scene file (Mitsuba 3 .xml,
pbrt-v4 .pbrt) becomes, written as a TOML scene (clrender/scene/foreign.py, docs/scene-formats.md).

Generated meshes (Mitsuba's rectangle, cube, disk, cylinder) are written inline; a mesh of more than
INLINE_VERTICES vertices (a .serialized mesh) is written beside the TOML file as a binary PLY (`NAME_mesh3.ply`,
without its uvs), and files the scene names (meshes, textures, maps) are named relative to the TOML file's folder.  The file's render
settings (integrator, spp, max_depth, pixel filter), which a TOML scene does not hold, are written as a
comment with the options that give them.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

from ..errors import UsageError, shown
from . import add_foreign_arguments

INLINE_VERTICES = 1000  # larger inline meshes go to a PLY file beside the scene (TOML is slow to read)
EXAMPLES = "example:\n  clrender convert cbox.xml -o cbox.toml\n  clrender render cbox.toml --integrator path --spp 64"


def add_parser(sub):
    p = sub.add_parser("convert", help="write a foreign scene file (.xml, .pbrt) as a clrender TOML scene", epilog=EXAMPLES)
    p.add_argument("scene", metavar="SCENE", help="a Mitsuba 3 .xml or pbrt-v4 .pbrt scene file")
    p.add_argument("-o", "--output", required=True, help="the TOML scene to write")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output file")
    add_foreign_arguments(p, "write")
    p.set_defaults(run=run)


def _rebase(scene: dict, source: Path, target: Path) -> dict:
    """File names relative to the source file's folder, made relative to the target's (absolute ones kept)."""

    def moved(name):
        if os.path.isabs(name):
            return name
        return os.path.relpath(os.path.abspath(source / name), os.path.abspath(target))

    for group in ("objects",):
        for o in scene.get(group, []):
            if "file" in o:
                o["file"] = moved(o["file"])
    for t in scene.get("textures", {}).values():
        t["file"] = moved(t["file"])
    if "file" in scene.get("environment", {}):
        scene["environment"]["file"] = moved(scene["environment"]["file"])
    return scene


def _mesh_files(scene: dict, output: Path, overwrite: bool) -> dict:
    """Large inline meshes written as PLY files beside `output`; their objects name the files instead."""
    import numpy as np

    from ..outputs import write_file

    for i, o in enumerate(scene.get("objects", [])):
        if o.get("type") != "mesh" or len(o.get("vertices", ())) <= INLINE_VERTICES:
            continue
        import trimesh

        mesh = trimesh.Trimesh(np.array(o.pop("vertices")), np.array(o.pop("faces")), process=False)
        o.pop("uvs", None)
        name = f"{output.stem}_mesh{i + 1}.ply"
        data = mesh.export(file_type="ply")
        write_file(output.parent / name, lambda path, data=data: Path(path).write_bytes(data), overwrite=overwrite)
        o["file"] = name
    return scene


NO_FLAG = ("hide_emitters", "rr_depth")  # render settings a foreign file may set that the command line cannot


def run(args):
    from ..outputs import check_file_output, write_file
    from ..scene.foreign import is_foreign, parse_defines, read_foreign
    from ..scene.scene import Scene
    from ..scene.toml_writer import dumps

    if not is_foreign(args.scene):
        raise UsageError(f"convert reads a foreign scene file (.xml, .pbrt), not {shown(args.scene)}")
    output = check_file_output(args.output, overwrite=args.overwrite, suffixes=(".toml",))
    source = Path(args.scene)
    foreign = read_foreign(source, parse_defines(args.defines), args.approximate)
    Scene.from_dict(foreign.scene, base_dir=source.parent, where=str(source), name=source.stem)  # refused now, not when rendered
    options = " ".join(f"--{k.replace('_', '-')} {v}" for k, v in foreign.settings.items() if k not in NO_FLAG)
    settings = ", ".join(f"{k}={v!r}" for k, v in foreign.settings.items() if k in NO_FLAG)
    options += f"; RenderSettings({settings}) (no command-line flags)" if settings else ""
    comments = [f"converted from {source.name} by clrender convert", f"its render settings: {options}"]
    scene = _rebase(foreign.scene, source.parent, output.parent)
    if foreign.substitutions:
        sys.stderr.write(f"warning: {len(foreign.substitutions)} stand-ins: " + "; ".join(foreign.substitutions) + "\n")
    from ..outputs import output_set

    with output_set(overwrite=args.overwrite):  # the TOML file and its meshes, placed together
        text = dumps(_mesh_files(scene, output, args.overwrite), comments)
        write_file(output, lambda path: Path(path).write_text(text, encoding="utf-8"), overwrite=args.overwrite)
    print(output)
    return 0
