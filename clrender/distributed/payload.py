"""Shipping a scene to workers: a plain dict plus its numpy arrays, never a file path.

A worker may not see the client's files (scene TOML, mesh files, the bunny
cache), so the client sends the scene as it is in memory: `split(scene)`
turns the Scene dataclasses into a JSON-able description and pulls every
numpy array out into a flat {name: array} dict, which the client scatters to
the cluster once.  `join` rebuilds the same Scene on the worker.  The key is
a hash of both, so workers can cache a built Tracer per scene.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import json
from dataclasses import dataclass

import numpy as np

# Only classes from our own package are rebuilt from a description.
_TRUSTED_PREFIX = "clrender."


@dataclass
class ScenePayload:
    description: dict  # the Scene as nested dicts/lists/numbers; arrays replaced by {"__array__": name}
    arrays: dict  # name -> numpy array (mesh vertices, faces, normals)
    key: str  # sha256 of description and array bytes: equal keys, equal scenes
    code: str = ""  # the client's code_fingerprint(); workers refuse to render with other code

    @property
    def nbytes(self) -> int:
        return sum(a.nbytes for a in self.arrays.values())


_FINGERPRINT: str | None = None


def code_fingerprint() -> str:
    """A hash of this process's clrender sources and kernels (computed once per process).

    The client and every worker must run the same code, or the images differ
    (or the results cannot even be unpickled): tasks check it first.
    """
    global _FINGERPRINT
    if _FINGERPRINT is None:
        from pathlib import Path

        from ..device import kernel_dir

        package = Path(__file__).resolve().parent.parent
        # what a worker runs: the library and the kernels (not the command line, which only the client runs)
        files = [p for p in sorted(package.rglob("*.py")) if "commands" not in p.relative_to(package).parts]
        files += sorted(p for p in kernel_dir().iterdir() if p.suffix in (".cl", ".h"))
        digest = hashlib.sha256()
        for path in files:
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
        _FINGERPRINT = digest.hexdigest()[:16]
    return _FINGERPRINT


def split(scene) -> ScenePayload:
    """The scene as (description dict, arrays), with its content hash."""
    arrays: dict = {}
    description = _describe(scene, arrays, "scene")
    arrays = {name: a for name, a in arrays.items() if isinstance(name, str)}  # without _describe's index by id
    digest = hashlib.sha256(json.dumps(description, sort_keys=True).encode())
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        digest.update(f"{name}{a.dtype.str}{a.shape}".encode())
        digest.update(a.tobytes())
    return ScenePayload(description, arrays, digest.hexdigest()[:32], code_fingerprint())


def join(payload: ScenePayload):
    """The Scene that `split` was given (equal field by field, arrays bit-identical)."""
    return _rebuild(payload.description, payload.arrays)


def _describe(value, arrays: dict, path: str):
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        cls = type(value)
        fields = {f.name: _describe(_field(value, f.name), arrays, f"{path}.{f.name}") for f in dataclasses.fields(value)}
        return {"__class__": f"{cls.__module__}:{cls.__qualname__}", "fields": fields}
    if isinstance(value, np.ndarray):
        for name in arrays.get(id(value), ()):  # an array several objects share (instancing's local vertices) ships once
            if arrays[name] is value:
                return {"__array__": name}
        arrays[path] = value
        arrays.setdefault(id(value), []).append(path)
        return {"__array__": path}
    if isinstance(value, tuple):
        return {"__tuple__": [_describe(v, arrays, f"{path}[{i}]") for i, v in enumerate(value)]}
    if isinstance(value, list):
        return [_describe(v, arrays, f"{path}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, dict):
        return {"__dict__": [[k, _describe(v, arrays, f"{path}.{k}")] for k, v in value.items()]}
    if isinstance(value, np.generic):
        return value.item()
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    raise TypeError(f"cannot ship {type(value).__name__} at {path} to a worker")


def _field(value, name: str):
    """A dataclass field's value; one made on first read (a shared mesh's world vertices, scene.Mesh) as it
    was given: None when the worker makes it from what the mesh keeps, so 30 copies ship one array."""
    made = getattr(type(value), name, None)
    return made.given(value) if hasattr(made, "given") else getattr(value, name)


def _rebuild(value, arrays: dict):
    if isinstance(value, list):
        return [_rebuild(v, arrays) for v in value]
    if not isinstance(value, dict):
        return value
    if "__array__" in value:
        return arrays[value["__array__"]]
    if "__tuple__" in value:
        return tuple(_rebuild(v, arrays) for v in value["__tuple__"])
    if "__dict__" in value:
        return {k: _rebuild(v, arrays) for k, v in value["__dict__"]}
    module, _, qualname = value["__class__"].partition(":")
    if not module.startswith(_TRUSTED_PREFIX):
        raise TypeError(f"refusing to rebuild {value['__class__']} from a scene payload")
    cls = getattr(importlib.import_module(module), qualname)
    fields = {k: _rebuild(v, arrays) for k, v in value["fields"].items()}
    init = {f.name for f in dataclasses.fields(cls) if f.init}
    obj = cls(**{k: v for k, v in fields.items() if k in init})
    for k, v in fields.items():
        if k not in init:
            object.__setattr__(obj, k, v)
    return obj
