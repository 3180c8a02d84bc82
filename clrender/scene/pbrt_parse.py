"""pbrt-v4's scene text: tokens, then directives with their typed parameter lists.

The grammar (pbrt-v4's src/pbrt/parser.cpp): a file is a sequence of directives, each an identifier
followed by its fixed arguments (numbers, or quoted strings) and, for the directives that take them, a
parameter list of `"type name" value` pairs, where a value is one token or a bracketed list.  `#` starts a
comment to the end of the line.  `Include` and `Import` splice another file's tokens in place (paths
relative to the main scene file's folder, as pbrt-v4 resolves them, under confine.py's rule).

Everything wrong is one UsageError line `FILE:LINE: what, and what is allowed` (clrender/errors.py).
The mapping onto clrender's scene dict is pbrt.py.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import UsageError
from .checks import shorten

MAX_FILE_BYTES = 256 << 20  # one pbrt file (a big trianglemesh is text); larger ones are refused before reading
MAX_INCLUDE_DEPTH = 16  # nested Include/Import files

# Each directive: the arguments it takes before its parameter list ("n": a number, "s": a string,
# ("n", 16): sixteen numbers, bracketed or not) and whether a parameter list follows.
DIRECTIVES = {
    "LookAt": (("n", 9), False),
    "Translate": (("n", 3), False),
    "Scale": (("n", 3), False),
    "Rotate": (("n", 4), False),
    "Transform": (("n", 16), False),
    "ConcatTransform": (("n", 16), False),
    "Identity": ((), False),
    "CoordinateSystem": (("s",), False),
    "CoordSysTransform": (("s",), False),
    "AttributeBegin": ((), False),
    "AttributeEnd": ((), False),
    "TransformBegin": ((), False),
    "TransformEnd": ((), False),
    "ReverseOrientation": ((), False),
    "WorldBegin": ((), False),
    "WorldEnd": ((), False),  # pbrt-v3's; pbrt-v4 ignores it too
    "Camera": (("s",), True),
    "Film": (("s",), True),
    "Sampler": (("s",), True),
    "Integrator": (("s",), True),
    "PixelFilter": (("s",), True),
    "Accelerator": (("s",), True),
    "ColorSpace": (("s",), False),
    "Option": ((), True),
    "Shape": (("s",), True),
    "Material": (("s",), True),
    "MakeNamedMaterial": (("s",), True),
    "NamedMaterial": (("s",), False),
    "Texture": (("s", "s", "s"), True),
    "LightSource": (("s",), True),
    "AreaLightSource": (("s",), True),
    "ObjectBegin": (("s",), False),
    "ObjectEnd": ((), False),
    "ObjectInstance": (("s",), False),
    "Include": (("s",), False),
    "Import": (("s",), False),
    "Attribute": (("s",), True),
    "MakeNamedMedium": (("s",), True),
    "MediumInterface": (("s", "s"), False),
    "ActiveTransform": ((), False),  # its argument is a bare word: refused by name in pbrt.py
    "TransformTimes": (("n", 2), False),
}

PARAM_TYPES = (
    "integer",
    "float",
    "point2",
    "vector2",
    "point3",
    "vector3",
    "normal",
    "normal3",
    "point",
    "vector",
    "bool",
    "string",
    "texture",
    "rgb",
    "spectrum",
    "blackbody",
)


@dataclass
class Token:
    kind: str  # "str", "num", "id", "[" or "]"
    value: object
    where: str  # "file:line"


@dataclass
class Param:
    type: str
    name: str
    values: list
    where: str


@dataclass
class Directive:
    name: str
    args: list
    params: dict = field(default_factory=dict)  # name -> Param
    where: str = ""


def fail(where: str, message: str):
    raise UsageError(shorten(f"{where}: {message}", 400))


def _label(path: Path) -> str:
    return str(path).replace("\n", "\\n")


def tokenize(text: str, label: str) -> list:
    """The tokens of one file's text; `label` names it in messages.  A bracketed list of plain numbers (a mesh's
    points and indices, nearly all of a big file) is read in one step as an "array" token between its brackets."""
    tokens, i, line, n = [], 0, 1, len(text)
    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            i += 1
        elif c in " \t\r\f\v,":
            i += 1
        elif c == "#":
            end = text.find("\n", i)
            i = n if end < 0 else end
        elif c == "[":
            i, line = _bracket(text, i, label, line, tokens)
        elif c == "]":
            tokens.append(Token(c, c, f"{label}:{line}"))
            i += 1
        elif c == '"':
            i, value = _string(text, i, label, line)
            tokens.append(Token("str", value, f"{label}:{line}"))
        else:
            match = _WORD.match(text, i)
            tokens.append(_word(match.group(), f"{label}:{line}"))
            i = match.end()
    return tokens


_WORD = re.compile(r'[^\s,\[\]"#]+')


def _word(word: str, where: str) -> Token:
    if word[0].isalpha():
        return Token("id", word, where)
    try:
        number = float(word)
    except ValueError:
        fail(where, f"{shorten(word, 40)!r} is not a number")
    if not math.isfinite(number):
        fail(where, f"{shorten(word, 40)!r}: allowed: finite numbers")
    return Token("num", number, where)


def _bracket(text: str, i: int, label: str, line: int, tokens: list):
    """Tokens of a "[": the bracket, and when plain numbers and then "]" follow, an "array" token of them."""
    where = f"{label}:{line}"
    tokens.append(Token("[", "[", where))
    end = text.find("]", i + 1)
    body = text[i + 1 : end] if end > 0 else ""
    if end > 0 and not any(ch in body for ch in '"#[') and body.strip():
        try:
            values = np.array(body.replace(",", " ").split(), np.float64)
        except ValueError:
            return i + 1, line  # a word in it: token by token, which names the bad one
        if not np.isfinite(values).all():
            fail(where, "a number in the list is not finite; allowed: finite numbers")
        tokens.append(Token("array", values.tolist(), where))
        return end, line + body.count("\n")
    return i + 1, line


_ESCAPES = {"n": "\n", "t": "\t", "b": "\b", "f": "\f", "r": "\r", "\\": "\\", '"': '"', "'": "'"}


def _string(text: str, i: int, label: str, line: int):
    """(index past the closing quote, the string) of the quoted string starting at text[i]."""
    out, j = [], i + 1
    while True:
        if j >= len(text) or text[j] == "\n":
            fail(f"{label}:{line}", "unterminated string (a quote opens it and none closes it on that line)")
        c = text[j]
        if c == '"':
            return j + 1, "".join(out)
        if c == "\\" and j + 1 < len(text):
            out.append(_ESCAPES.get(text[j + 1], text[j + 1]))
            j += 2
            continue
        out.append(c)
        j += 1


def read_file(path: Path, label: str) -> str:
    try:
        size = path.stat().st_size
    except OSError:
        raise UsageError(f"{label}: does not exist") from None
    if not path.is_file():
        raise UsageError(f"{label}: is not a file")
    if size > MAX_FILE_BYTES:
        raise UsageError(f"{label}: {size} bytes; allowed: at most {MAX_FILE_BYTES} (a pbrt text file)")
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise UsageError(f"{label}: cannot be read as UTF-8 text ({type(exc).__name__})") from None


class Parser:
    """Directives of a file and the files it includes, in order (`directives()`)."""

    def __init__(self, path: Path, root, resolve):
        self.path, self.root, self.resolve = Path(path), root, resolve

    def directives(self):
        yield from self._file(self.path, _label(self.path), (), "scene")

    def _file(self, path: Path, label: str, stack: tuple, what: str):
        if len(stack) > MAX_INCLUDE_DEPTH:
            fail(label, f"includes nested {len(stack)} deep; allowed: at most {MAX_INCLUDE_DEPTH}")
        key = str(path.resolve()) if path.exists() else str(path)
        if key in stack:
            fail(label, "includes itself (an Include cycle)")
        tokens = tokenize(read_file(path, f"{what} file {label}"), label)
        pos = 0
        while pos < len(tokens):
            directive, pos = self._directive(tokens, pos)
            if directive.name in ("Include", "Import"):
                name = directive.args[0]
                child = self.resolve(name, f"{directive.where}: {directive.name}")
                yield from self._file(child, _label(child), (*stack, key), f"{directive.where}: {directive.name}d")
            else:
                yield directive

    def _directive(self, tokens: list, pos: int):
        token = tokens[pos]
        if token.kind != "id":
            fail(token.where, f"expected a directive, got {_show(token)}")
        if token.value not in DIRECTIVES:
            fail(token.where, f"unknown directive {token.value!r}; allowed: {', '.join(sorted(DIRECTIVES))}")
        spec, has_params = DIRECTIVES[token.value]
        directive = Directive(token.value, [], where=token.where)
        pos += 1
        for kind in spec:
            if kind == "n" or isinstance(kind, tuple):
                pass
            elif kind == "s":
                if pos >= len(tokens) or tokens[pos].kind != "str":
                    got = _show(tokens[pos]) if pos < len(tokens) else "the end of the file"
                    fail(token.where, f"{token.value} expects a quoted string, got {got}")
                directive.args.append(tokens[pos].value)
                pos += 1
        if spec and spec[0] == "n":
            count = spec[1]
            numbers, pos = _numbers(tokens, pos, count, token)
            directive.args = numbers
        if has_params:
            pos = self._params(tokens, pos, directive)
        return directive, pos

    def _params(self, tokens: list, pos: int, directive: Directive) -> int:
        while pos < len(tokens) and tokens[pos].kind == "str":
            decl = tokens[pos]
            parts = decl.value.split()
            if len(parts) != 2 or parts[0] not in PARAM_TYPES:
                types = ", ".join(PARAM_TYPES)
                fail(decl.where, f'bad parameter declaration "{shorten(decl.value, 60)}"; allowed: "TYPE NAME" with TYPE one of {types}')
            pos += 1
            if pos >= len(tokens):
                fail(decl.where, f'parameter "{decl.value}" has no value')
            values, pos = _value(tokens, pos, decl)
            kind = parts[0]
            if len(values) == 1 and values[0].kind == "array":
                if kind in ("string", "texture", "bool"):
                    fail(values[0].where, f'parameter "{decl.value}": numbers; allowed: {"true or false" if kind == "bool" else "quoted strings"}')
                directive.params[parts[1]] = Param(kind, parts[1], values[0].value, decl.where)
                continue
            want = "str" if kind in ("string", "texture") else "bool" if kind == "bool" else ("num" if kind != "spectrum" else None)
            for v in values:
                if want == "bool":
                    if v.kind == "str" and v.value in ("true", "false"):
                        continue
                    if v.kind == "id" and v.value in ("true", "false"):
                        continue
                    fail(v.where, f'parameter "{decl.value}": {_show(v)}; allowed: true or false')
                if want is not None and v.kind != want:
                    fail(v.where, f'parameter "{decl.value}": {_show(v)}; allowed: {"a quoted string" if want == "str" else "numbers"}')
            parsed = [(v.value == "true") if want == "bool" else v.value for v in values]
            directive.params[parts[1]] = Param(kind, parts[1], parsed, decl.where)
        return pos


def _value(tokens: list, pos: int, decl: Token):
    """(the value tokens of one parameter, the position after them): one token or a bracketed list."""
    token = tokens[pos]
    if token.kind == "[" and pos + 2 < len(tokens) and tokens[pos + 1].kind == "array":
        return [tokens[pos + 1]], pos + 3  # the "]" the tokenizer found after it
    if token.kind == "[":
        start, pos = token, pos + 1
        values = []
        while pos < len(tokens) and tokens[pos].kind != "]":
            if tokens[pos].kind == "[":
                fail(tokens[pos].where, "a bracket inside a bracketed list")
            if tokens[pos].kind == "id" and tokens[pos].value not in ("true", "false"):
                fail(start.where, f'parameter "{decl.value}": unterminated bracket (reached {_show(tokens[pos])} before "]")')
            values.append(tokens[pos])
            pos += 1
        if pos >= len(tokens):
            fail(start.where, f'parameter "{decl.value}": unterminated bracket (the file ends before "]")')
        return values, pos + 1
    if token.kind in ("str", "num") or (token.kind == "id" and token.value in ("true", "false")):
        return [token], pos + 1
    fail(token.where, f'parameter "{decl.value}" has no value (got {_show(token)})')


def _numbers(tokens: list, pos: int, count: int, directive: Token):
    bracket = pos < len(tokens) and tokens[pos].kind == "["
    if bracket and pos + 1 < len(tokens) and tokens[pos + 1].kind == "array":
        if len(tokens[pos + 1].value) != count:
            fail(directive.where, f"{directive.value} expects {count} numbers, got {len(tokens[pos + 1].value)}")
        return tokens[pos + 1].value, pos + 3
    pos += bracket
    numbers = []
    while len(numbers) < count:
        if pos >= len(tokens) or tokens[pos].kind != "num":
            got = _show(tokens[pos]) if pos < len(tokens) else "the end of the file"
            fail(directive.where, f"{directive.value} expects {count} numbers, got {got} after {len(numbers)}")
        numbers.append(tokens[pos].value)
        pos += 1
    if bracket:
        if pos >= len(tokens) or tokens[pos].kind != "]":
            fail(directive.where, f'{directive.value}: unterminated bracket (expected "]" after {count} numbers)')
        pos += 1
    return numbers, pos


def _show(token: Token) -> str:
    if token.kind == "str":
        return f'"{shorten(str(token.value), 40)}"'
    if token.kind == "num":
        return f"{token.value:g}"
    return shorten(str(token.value), 40)
