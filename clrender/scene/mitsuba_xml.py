"""Mitsuba 3's scene format, read with the standard library's XML parser: the document layer.

This module turns a Mitsuba XML file into a tree of `Plugin` records: `<default>` and `-D` values
substituted for `$name`, `<include>`d files spliced in, `ref`s resolved, properties typed (`float`,
`integer`, `boolean`, `string`, `rgb`, `spectrum`, `point`, `vector`) and transforms composed into 4x4
matrices in Mitsuba's order (each operation multiplies from the left: the first written applies first).
It knows nothing of what a plugin means: mitsuba_plugins.py maps plugins onto clrender's scene dict.

Every refusal is one UsageError line naming the file and line: `scene.xml:41: ...`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from xml.parsers import expat

import numpy as np

from ..errors import UsageError, shown

MAX_XML_BYTES = 64 * 2**20  # a scene file (its meshes live in other files)
MAX_INCLUDE_DEPTH = 16
MAX_XML_DEPTH = 64  # elements nested in one another (the readers recurse once a level)
# the tags that make a plugin object; volumes and media are refused by name (mitsuba_plugins.py)
OBJECT_TAGS = ("scene", "shape", "bsdf", "texture", "emitter", "sensor", "film", "rfilter", "sampler", "integrator", "medium", "phase", "volume")
PROPERTY_TAGS = ("float", "integer", "boolean", "string", "rgb", "spectrum", "point", "vector", "transform")
TRANSFORM_OPS = ("translate", "rotate", "scale", "matrix", "lookat")


@dataclass
class Element:
    """One XML element as written: tag, attributes, children, and where it is (file:line)."""

    tag: str
    attrs: dict
    line: int
    file: str
    children: list = field(default_factory=list)

    @property
    def where(self) -> str:
        return f"{self.file}:{self.line}"


@dataclass
class Plugin:
    """A Mitsuba object (`<shape type="obj">`, ...): its typed properties and its nested objects."""

    tag: str  # shape, bsdf, emitter, ...
    type: str  # the plugin name
    id: str | None
    where: str  # file:line, for messages
    props: dict = field(default_factory=dict)  # name -> value (float, int, bool, str, tuple, 4x4 ndarray)
    prop_lines: dict = field(default_factory=dict)  # name -> file:line
    children: list = field(default_factory=list)  # (name or None, Plugin), in file order
    used: set = field(default_factory=set)  # properties a mapper read (the rest are reported)

    def get(self, name: str, default=None):
        self.used.add(name)
        return self.props.get(name, default)

    def has(self, name: str) -> bool:
        return name in self.props

    def child(self, name: str):
        """The nested object given this name (a ref or an inline plugin), or None."""
        return next((p for n, p in self.children if n == name), None)

    def nested(self, tag: str) -> list:
        return [p for _, p in self.children if p.tag == tag]

    def fail(self, message: str):
        raise UsageError(f"{self.where}: {message}")


# ---------------------------------------------------------------------- XML text
def _parse_file(path: Path, shown_name: str) -> Element:
    """The element tree of one file, each element with its line (expat, no entity expansion beyond the standard)."""
    if not path.is_file():
        raise UsageError(f"{shown_name}: file does not exist")
    size = path.stat().st_size
    if size > MAX_XML_BYTES:
        raise UsageError(f"{shown_name}: {size} bytes; allowed: at most {MAX_XML_BYTES} for a scene file")
    parser = expat.ParserCreate()
    root: list = []
    stack: list = []

    def start(tag, attrs):
        if len(stack) >= MAX_XML_DEPTH:
            raise UsageError(f"{shown_name}:{parser.CurrentLineNumber}: elements nested more than {MAX_XML_DEPTH} deep")
        el = Element(tag, dict(attrs), parser.CurrentLineNumber, shown_name)
        (stack[-1].children if stack else root).append(el)
        stack.append(el)

    def entity(*_):
        raise UsageError(f"{shown_name}:{parser.CurrentLineNumber}: entity declarations are not allowed in a scene file")

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    parser.EntityDeclHandler = entity
    try:
        parser.Parse(path.read_bytes(), True)
    except expat.ExpatError as exc:
        raise UsageError(f"{shown_name}:{exc.lineno}: not valid XML ({expat.errors.messages[exc.code]})") from None
    if not root or root[0].tag != "scene":
        raise UsageError(f"{shown_name}:1: a Mitsuba scene file's root element is <scene>, not {shown('<' + (root[0].tag if root else '') + '>')}")
    return root[0]


# ---------------------------------------------------------------------- numbers and substitution
_NUMBER_SPLIT = re.compile(r"[\s,]+")


def numbers(text: str, where: str, what: str, count=None) -> list:
    """Floats from Mitsuba's "1, 2, 3" or "1 2 3" form; a wrong count or a non-number is one line."""
    parts = [p for p in _NUMBER_SPLIT.split(text.strip()) if p]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise UsageError(f"{where}: {what} {shown(text)} is not a number") from None
    if not all(math.isfinite(v) for v in values):
        raise UsageError(f"{where}: {what} {shown(text)} is not finite")
    if count is not None and len(values) not in ((count,) if isinstance(count, int) else count):
        raise UsageError(f"{where}: {what} {shown(text)}: expected {count} numbers, got {len(values)}")
    return values


_DOLLAR = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


def _substitute(text: str, defines: dict, where: str) -> str:
    def one(match):
        name = match.group(1)
        if name not in defines:
            raise UsageError(f"{where}: ${name} is not defined (give it with <default name={name!r} .../> or -D {name}=VALUE)")
        return defines[name]

    return _DOLLAR.sub(one, text)


_CAMEL = re.compile(r"([a-z0-9])([A-Z])")


def _snake(name: str) -> str:
    """Mitsuba 0.6's camelCase property names as Mitsuba 3 upgrades them (toWorld -> to_world, intIOR -> int_ior)."""
    return _CAMEL.sub(r"\1_\2", name).lower()


# ---------------------------------------------------------------------- transforms
def translate(v) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = v
    return m


def scale(v) -> np.ndarray:
    return np.diag([v[0], v[1], v[2], 1.0])


def rotate(axis, degrees: float) -> np.ndarray:
    """Rotation by `degrees` about `axis`, right-handed (Rodrigues' formula, as Mitsuba's Transform4f.rotate)."""
    a = np.asarray(axis, np.float64)
    a = a / np.linalg.norm(a)
    t = math.radians(degrees)
    c, s = math.cos(t), math.sin(t)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    m = np.eye(4)
    m[:3, :3] = c * np.eye(3) + s * k + (1 - c) * np.outer(a, a)
    return m


def look_at(origin, target, up) -> np.ndarray:
    """Mitsuba's look_at: +z towards the target, +y the `up` made orthogonal, +x = up x dir (to the image's left)."""
    o, t, u = (np.asarray(v, np.float64) for v in (origin, target, up))
    d = t - o
    d = d / np.linalg.norm(d)
    left = np.cross(u, d)
    left = left / np.linalg.norm(left)
    new_up = np.cross(d, left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, new_up, d, o
    return m


def _xyz(el: Element, attrs: dict, default: float) -> list:
    """A point or vector: x, y, z attributes, or value="x, y, z" (one number: all three)."""
    if "value" in attrs:
        v = numbers(attrs["value"], el.where, f"<{el.tag}> value", (1, 3))
        return v * 3 if len(v) == 1 else v
    return [numbers(attrs[k], el.where, f"<{el.tag}> {k}", 1)[0] if k in attrs else default for k in "xyz"]


def _transform_op(el: Element, attrs: dict) -> np.ndarray:
    if el.tag == "translate":
        return translate(_xyz(el, attrs, 0.0))
    if el.tag == "scale":
        return scale(_xyz(el, attrs, 1.0))
    if el.tag == "rotate":
        axis = _xyz(el, attrs, 0.0)
        if "angle" not in attrs or math.hypot(*axis) == 0:
            raise UsageError(f"{el.where}: <rotate> needs an axis (x, y, z or value) and an angle in degrees")
        return rotate(axis, numbers(attrs["angle"], el.where, "<rotate> angle", 1)[0])
    if el.tag == "matrix":
        v = numbers(attrs.get("value", ""), el.where, "<matrix> value", (9, 16))
        if len(v) == 9:
            m = np.eye(4)
            m[:3, :3] = np.reshape(v, (3, 3))
            return m
        return np.reshape(np.array(v, np.float64), (4, 4))
    if el.tag == "lookat":
        o, t = (numbers(attrs.get(k, ""), el.where, f"<lookat> {k}", 3) for k in ("origin", "target"))
        u = numbers(attrs["up"], el.where, "<lookat> up", 3) if "up" in attrs else [0.0, 1.0, 0.0]
        if np.linalg.norm(np.subtract(t, o)) == 0 or np.linalg.norm(np.cross(u, np.subtract(t, o))) == 0:
            raise UsageError(f"{el.where}: <lookat> origin equals target, or up is parallel to the view")
        return look_at(o, t, u)
    raise UsageError(f"{el.where}: <{el.tag}> is not a transform (supported: {', '.join(TRANSFORM_OPS)})")


# ---------------------------------------------------------------------- the document
class Document:
    """A scene file read into Plugins: `scene` is the root, `ids` every object with an id."""

    def __init__(self, path, defines: dict | None = None, root=None):
        self.path = Path(path)
        self.folder = self.path.parent
        self.root = Path(root) if root is not None else self.folder  # includes may not leave it
        self.defines = dict(defines or {})  # -D values win over <default>
        self.version = (3, 0, 0)
        self.ids: dict = {}  # id -> Element, across includes
        self.included: list = []  # resolved paths of the include stack (cycles)
        top = _parse_file(self.path, self.path.name)
        self._version(top)
        elements = self._expand(top.children, self.path.resolve(), 0)
        self._index(elements)
        self.resolving: list = []  # ids whose refs are being followed (cycles)
        self.made: dict = {}  # id -> Plugin (a ref shares the object)
        self.scene = Plugin("scene", "scene", None, top.where)
        self._fill(self.scene, elements)

    def _version(self, top: Element):
        text = top.attrs.get("version", "3.0.0")
        try:
            self.version = tuple(int(p) for p in _substitute(text, self.defines, top.where).split("."))
        except ValueError:
            raise UsageError(f"{top.where}: scene version {shown(text)} is not a version like 3.0.0") from None

    def _expand(self, elements: list, file: Path, depth: int) -> list:
        """Children with <default> taken in, $names substituted and <include>d files spliced in, recursively."""
        out = []
        for el in elements:
            attrs = {k: _substitute(v, self.defines, el.where) for k, v in el.attrs.items()}
            if el.tag == "default":
                if "name" not in attrs or "value" not in attrs:
                    raise UsageError(f"{el.where}: <default> needs name and value")
                self.defines.setdefault(attrs["name"], attrs["value"])
                continue
            if el.tag == "include":
                out.extend(self._include(el, attrs, file, depth))
                continue
            copy = Element(el.tag, attrs, el.line, el.file)
            copy.children = self._expand(el.children, file, depth)
            out.append(copy)
        return out

    def _include(self, el: Element, attrs: dict, file: Path, depth: int) -> list:
        name = attrs.get("filename")
        if not name:
            raise UsageError(f"{el.where}: <include> needs a filename")
        path = (file.parent / name).resolve()
        if not path.is_relative_to(self.root.resolve()):
            raise UsageError(f"{el.where}: include {shown(name)} is outside the scene folder; allowed: files inside it")
        if path in self.included or path == self.path.resolve() or depth >= MAX_INCLUDE_DEPTH:
            raise UsageError(f"{el.where}: include {shown(name)} includes itself (an include cycle)")
        if path.suffix.lower() != ".xml":
            raise UsageError(f"{el.where}: include {shown(name)}: only .xml files can be included")
        shown_name = str(path.relative_to(self.root.resolve()))
        if not path.is_file():
            raise UsageError(f"{el.where}: include {shown(name)} does not exist")
        top = _parse_file(path, shown_name)
        self.included.append(path)
        try:
            return self._expand(top.children, path, depth + 1)
        finally:
            self.included.pop()

    def _index(self, elements: list):
        stack = list(elements)
        while stack:
            el = stack.pop()
            if el.tag in OBJECT_TAGS and "id" in el.attrs:
                if el.attrs["id"] in self.ids:
                    raise UsageError(f"{el.where}: id {shown(el.attrs['id'])} is already used at {self.ids[el.attrs['id']].where}")
                self.ids[el.attrs["id"]] = el
            stack.extend(el.children)

    # ------------------------------------------------------------------ objects
    def plugin(self, el: Element) -> Plugin:
        """The Plugin of an object element (made once per id: refs share it)."""
        ident = el.attrs.get("id")
        if ident is not None and ident in self.made:
            return self.made[ident]
        if el.tag != "scene" and "type" not in el.attrs:
            raise UsageError(f"{el.where}: <{el.tag}> needs a type")
        p = Plugin(el.tag, el.attrs.get("type", "scene"), ident, el.where)
        self._fill(p, el.children)
        if ident is not None:
            self.made[ident] = p
        return p

    def _ref(self, el: Element) -> Plugin:
        ident = el.attrs.get("id")
        if ident not in self.ids:
            raise UsageError(f"{el.where}: ref {shown(ident or '')} names no object (ids: {', '.join(sorted(self.ids)) or 'none'})")
        if ident in self.resolving:
            raise UsageError(f"{el.where}: ref {shown(ident)} refers to itself (a reference cycle: {' -> '.join(self.resolving + [ident])})")
        self.resolving.append(ident)
        try:
            return self.plugin(self.ids[ident])
        finally:
            self.resolving.pop()

    def _fill(self, p: Plugin, children: list):
        for el in children:
            name = el.attrs.get("name")
            if name is not None and self.version < (2, 0, 0):
                name = _snake(name)
            if el.tag in OBJECT_TAGS:
                if el.tag == "scene":
                    raise UsageError(f"{el.where}: <scene> inside a scene")
                p.children.append((name, self.plugin(el)))  # an object with an id nested in another is made there; refs share it
            elif el.tag == "ref":
                p.children.append((name, self._ref(el)))
            elif el.tag in PROPERTY_TAGS:
                if name is None:
                    raise UsageError(f"{el.where}: <{el.tag}> needs a name")
                p.props[name] = self._property(el)
                p.prop_lines[name] = el.where
            elif el.tag in TRANSFORM_OPS:
                raise UsageError(f"{el.where}: <{el.tag}> belongs inside a <transform>")
            elif el.tag in ("alias", "path"):
                raise UsageError(f"{el.where}: <{el.tag}> is not supported (supported: default, include, ref and the plugin and property tags)")
            else:
                known = ", ".join(OBJECT_TAGS[1:] + PROPERTY_TAGS + ("ref", "default", "include"))
                raise UsageError(f"{el.where}: <{el.tag}> is not a Mitsuba scene element (supported: {known})")

    def _property(self, el: Element):
        a, where, tag = el.attrs, el.where, el.tag
        if tag == "transform":
            m = np.eye(4)
            for op in el.children:  # each operation after the ones before it: M = op @ M
                m = _transform_op(op, op.attrs) @ m
            return m
        if tag in ("point", "vector"):
            return tuple(_xyz(el, a, 0.0))
        if "value" not in a:
            if tag == "spectrum" and "filename" in a:
                raise UsageError(
                    f"{where}: a spectrum read from a file ({shown(a['filename'])}) is not supported (supported: a value or wavelength:value pairs)"
                )
            raise UsageError(f"{where}: <{tag}> needs a value")
        text = a["value"]
        if tag == "string":
            return text
        if tag == "boolean":
            if text.strip().lower() not in ("true", "false"):
                raise UsageError(f"{where}: boolean {shown(a.get('name', ''))} value {shown(text)} is not true or false")
            return text.strip().lower() == "true"
        if tag == "integer":
            try:
                return int(text.strip())
            except ValueError:
                raise UsageError(f"{where}: integer {shown(a.get('name', ''))} value {shown(text)} is not a whole number") from None
        if tag == "float":
            return numbers(text, where, f"float {shown(a.get('name', ''))} value", 1)[0]
        if tag == "rgb":
            v = numbers(text, where, f"rgb {shown(a.get('name', ''))} value", (1, 3))
            return tuple(v * 3 if len(v) == 1 else v)
        return _spectrum(text, where, a.get("name", ""))


def _spectrum(text: str, where: str, name: str) -> tuple:
    """A spectrum as RGB: one value (grey), or the mean of wavelength:value pairs (grey; documented)."""
    if ":" not in text:
        v = numbers(text, where, f"spectrum {shown(name)} value", 1)
        return (v[0],) * 3
    values = []
    for pair in (p for p in re.split(r"[\s,]+", text.strip()) if p):
        parts = pair.split(":")
        if len(parts) != 2:
            raise UsageError(f"{where}: spectrum {shown(name)} entry {shown(pair)} is not wavelength:value")
        values.append(numbers(parts[1], where, f"spectrum {shown(name)} value", 1)[0])
    if not values:
        raise UsageError(f"{where}: spectrum {shown(name)} has no values")
    mean = sum(values) / len(values)
    return (mean,) * 3
