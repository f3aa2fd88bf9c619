"""YAML loading that remembers where every value came from.

Configs are edited by hand, so every error must point at a line and column. PyYAML's composer keeps a mark
on each node; this module turns the node tree into plain Python data plus a table from key paths to marks.
Duplicate keys, which PyYAML silently lets the last one win, are refused, and so are aliases that would make a
few hundred bytes expand into billions of values (see ``MAX_ALIAS_NODES``), documents of more than
``MAX_NODES`` values or nested deeper than ``MAX_DEPTH``, and texts longer than ``MAX_TEXT_BYTES`` (checked
before parsing: a file by its size before it is read).

Plain scalars are read by the YAML 1.2 core schema, not PyYAML's YAML 1.1: ``1:30`` is the text "1:30", not
the base-60 number 90; ``010`` is ten, not eight; ``0x1F``, ``0o17``, ``0b101``, ``yes``, ``on`` and dates are
text (a number field then refuses them at their position). Digit separators (``100_000``) are kept, as
Python writes them. An integer longer than ``MAX_DIGITS`` digits is refused before it is converted. Explicit
tags are refused except the plain ones (``!!str``, ``!!int``, ``!!float``, ``!!bool``, ``!!null``, ``!!seq``,
``!!map``), whose text must then read as that type: ``!!int x`` is an error at its position.
"""

from __future__ import annotations

import copy
import math
import os
import re
from dataclasses import dataclass, field
from typing import Any

import yaml

from stackx.errors import ConfigError

Path = tuple[str | int, ...]

MAX_ALIAS_NODES = 100_000
"""How many YAML nodes (scalars, lists, mappings, keys) aliases may add to one document, counted as written.

An alias (``*name``) stands for the whole node its anchor names, so nine aliases of a list of nine aliases of
... grow by 9x per level: ten levels are a few hundred bytes of text and 3.5 billion values, minutes of CPU and
more memory than the machine has. Every value a config holds costs about 4 us and 250 bytes to load with its
mark, so the bound keeps the worst accepted document near 0.4 s and 25 MB. Configs reuse a section with an
alias (a solver's parameters in each of its runs, a list of boxes in a few scenes): tens to thousands of nodes.
Sweeps are written as ``grid:`` lists and expanded after loading, and text without aliases is never counted, so
no config of any size is refused for what it writes out. Only what aliases add is counted, exactly: the sum,
over the aliases as written, of the nodes each one names (anchors inside anchors included), which is what
building the data would add to the nodes written in the text.
"""


MAX_TEXT_BYTES = 1 << 20
"""Longest config text read, in UTF-8 bytes (1 MiB): a file is refused by its size before a byte is read, and
a text given as it is (a ``--set`` value, a config made from a dict) before it is parsed. The shipped configs
are 1 to 2 KB; a scene of 10,000 listed boxes fits. The limit keeps what loading one config may cost (reading,
scanning, marks) near a second, whatever the text holds: the other bounds count values, and a single value can
be a gigabyte long. It is fixed, not one of ``limits``: that section is inside the text, read after it."""

MAX_NODES = 200_000
"""How many YAML nodes one document may hold as written (a few seconds and 50 MB to load with marks). The largest
shipped config holds a few hundred; a scene of many boxes is generated (``stack: {count: ...}``), not listed."""

MAX_DEPTH = 64
"""How deeply mappings and lists may nest; configs use five or six levels."""

MAX_DIGITS = 100
"""Most digits an integer may have: ten times more than any count or step number needs, and far below the
length at which converting text to a number gets slow or is refused by Python (4,300 digits)."""

_TAG = "tag:yaml.org,2002:"
_INT = re.compile(r"[-+]?[0-9][0-9_]*")
_FLOAT = re.compile(r"[-+]?(?:\.[0-9][0-9_]*|[0-9][0-9_]*(?:\.[0-9_]*)?)(?:[eE][-+]?[0-9]+)?")
_INF = re.compile(r"[-+]?\.(?:inf|Inf|INF)")
_NAN = re.compile(r"\.(?:nan|NaN|NAN)")
_BOOL = {"true": True, "True": True, "TRUE": True, "false": False, "False": False, "FALSE": False}
_NULL = ("", "~", "null", "Null", "NULL")
PLAIN_TAGS = {_TAG + name for name in ("str", "int", "float", "bool", "null", "seq", "map", "merge")}


def scalar_problem(tag: str, text: str) -> str | None:
    """Why the scalar ``text`` cannot be read as ``tag`` (None when it can): a tag that is not a plain one, text
    that is not of the tag's type, or an integer too long to convert safely."""
    name = tag.removeprefix(_TAG) if tag.startswith(_TAG) else None
    if tag not in PLAIN_TAGS:
        return f"YAML tag {tag if name is None else '!!' + name!r} is not supported; write plain values"
    if name == "int":
        if not _INT.fullmatch(text):
            return f"!!int {text!r} is not a whole number"
    elif name == "float":
        if not (_FLOAT.fullmatch(text) or _INF.fullmatch(text) or _NAN.fullmatch(text)):
            return f"!!float {text!r} is not a number"
    elif name == "bool" and text not in _BOOL:
        return f"!!bool {text!r} is not true or false"
    elif name == "null" and text not in _NULL:
        return f"!!null {text!r} is not empty, ~ or null"
    if name in ("int", "float") and _INT.fullmatch(text) and sum(c.isdigit() for c in text) > MAX_DIGITS:
        return f"a number of {sum(c.isdigit() for c in text):,} digits; at most {MAX_DIGITS} are read"
    return None


def _construct_int(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> int:
    _refuse(node, "int")
    return int(node.value.replace("_", ""))


def _construct_float(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> float:
    _refuse(node, "float")
    text = node.value.replace("_", "")
    if _INF.fullmatch(text):
        return -math.inf if text.startswith("-") else math.inf
    if _NAN.fullmatch(text):
        return math.nan
    return float(text)  # never raises: digits were checked, and text too large reads as inf


def _construct_bool(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> bool:
    _refuse(node, "bool")
    return _BOOL[node.value]


def _construct_null(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> None:
    _refuse(node, "null")
    return None


def _refuse(node: yaml.ScalarNode, name: str) -> None:
    problem = scalar_problem(_TAG + name, node.value)
    if problem:
        raise yaml.constructor.ConstructorError(None, None, problem, node.start_mark)


@dataclass(frozen=True)
class Mark:
    """A 1-based line and column in a named source."""

    file: str
    line: int
    col: int


@dataclass
class Source:
    """Data loaded from one YAML document, with the mark of each value and of each mapping key."""

    file: str
    data: Any
    values: dict[Path, Mark] = field(default_factory=dict)
    keys: dict[Path, Mark] = field(default_factory=dict)

    def copy(self) -> Source:
        """A copy whose data and marks can be changed without touching this one (marks are immutable)."""
        return Source(self.file, copy.deepcopy(self.data), dict(self.values), dict(self.keys))

    def mark(self, path: Path, *, key: bool = False) -> Mark:
        """The mark of ``path`` (its key when ``key``), or of its nearest ancestor that has one."""
        table = self.keys if key else self.values
        for end in range(len(path), -1, -1):
            hit = table.get(path[:end]) or self.values.get(path[:end])
            if hit:
                return hit
        return Mark(self.file, 1, 1)

    def error(self, path: Path, message: str, *, key: bool = False) -> ConfigError:
        """A ``ConfigError`` located at ``path``."""
        m = self.mark(path, key=key)
        return ConfigError(message, file=m.file, line=m.line, col=m.col, key=dotted(path) or None)


def dotted(path: Path) -> str:
    """``("solver", "correction", "slop")`` -> ``solver.correction.slop``; list indices as ``[i]``."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _mark(file: str, node: yaml.Node) -> Mark:
    return Mark(file, node.start_mark.line + 1, node.start_mark.column + 1)


class _Loader(yaml.SafeLoader):
    """PyYAML's safe loader, counting the nodes aliases add while the document is composed.

    Composing is linear in the text (an alias is the node its anchor names, shared, not copied), so the count
    is known, and checked, at each alias before anything is built from the shared nodes.
    """

    def __init__(self, text: str, file: str) -> None:
        super().__init__(text)
        self.file = file
        self.sizes: dict[int, int] = {}  # id of a composed node -> how many nodes it expands to
        self.added = 0  # nodes added by the aliases composed so far
        self.written = 0  # nodes composed from the text
        self.depth = 0  # how many collections enclose the node being composed

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        mark = self.peek_event().start_mark
        where = {"file": self.file, "line": mark.line + 1, "col": mark.column + 1}
        self.written += 1
        if self.written > MAX_NODES:
            raise ConfigError(f"a config holds at most {MAX_NODES:,} YAML values; generate large scenes "
                              "(stack: {count: N}) instead of listing them", **where)
        if self.depth >= MAX_DEPTH:
            raise ConfigError(f"YAML nested more than {MAX_DEPTH} levels deep", **where)
        self.depth += 1
        try:
            return self._compose_counted(parent, index)
        finally:
            self.depth -= 1

    def _compose_counted(self, parent: yaml.Node | None, index: Any) -> yaml.Node:
        if self.check_event(yaml.AliasEvent):
            event = self.peek_event()
            target = self.anchors.get(event.anchor)
            if target is not None:  # an undefined alias is PyYAML's error
                self._follow(event, target)
            return super().compose_node(parent, index)
        node = super().compose_node(parent, index)
        if isinstance(node, yaml.MappingNode):
            children = [child for pair in node.value for child in pair]
        else:
            children = node.value if isinstance(node, yaml.SequenceNode) else []
        self.sizes[id(node)] = 1 + sum(self.sizes[id(child)] for child in children)
        return node

    def _follow(self, event: yaml.AliasEvent, target: yaml.Node) -> None:
        where = {"file": self.file, "line": event.start_mark.line + 1, "col": event.start_mark.column + 1}
        size = self.sizes.get(id(target))
        if size is None:
            raise ConfigError(f"alias *{event.anchor} is inside the node it names, so it never ends; "
                              "write the value out", **where)
        self.added += size
        if self.added > MAX_ALIAS_NODES:
            raise ConfigError(f"alias *{event.anchor} stands for {size:,} YAML nodes, and the aliases up to here "
                              f"add {self.added:,}; aliases may add at most {MAX_ALIAS_NODES:,} nodes to a config",
                              **where)


# YAML 1.2 core schema for plain scalars (see the module's docstring), in place of PyYAML's YAML 1.1 resolvers
_Loader.yaml_implicit_resolvers = {}
for _tag, _pattern, _first in (
        ("bool", r"^(?:true|True|TRUE|false|False|FALSE)$", "tTfF"),
        ("int", r"^[-+]?[0-9][0-9_]*$", "-+0123456789"),
        ("float", r"^(?:[-+]?(?:\.[0-9][0-9_]*|[0-9][0-9_]*(?:\.[0-9_]*)?)(?:[eE][-+]?[0-9]+)?"
                  r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$", "-+.0123456789"),
        ("null", r"^(?:~|null|Null|NULL|)$", ["~", "n", "N", ""]),
        ("merge", r"^(?:<<)$", "<")):
    _Loader.add_implicit_resolver(_TAG + _tag, re.compile(_pattern), list(_first))
for _name, _fn in (("int", _construct_int), ("float", _construct_float), ("bool", _construct_bool),
                   ("null", _construct_null)):
    _Loader.add_constructor(_TAG + _name, _fn)
_Loader.add_constructor(_TAG + "merge", lambda loader, node: node.value)  # "<<" as a value, not a key: text


def load_text(text: str, file: str) -> Source:
    """Parse one YAML document; raise ``ConfigError`` with the position of any syntax error, or naming
    ``MAX_TEXT_BYTES`` when the text is longer."""
    if len(text) > MAX_TEXT_BYTES // 4:  # a character is 1 to 4 bytes: shorter text needs no counting
        size = len(text.encode("utf-8", "surrogatepass"))
        if size > MAX_TEXT_BYTES:
            raise _too_long(size, file, advise=False)
    try:
        loader = _Loader(text, file)
    except yaml.reader.ReaderError as exc:
        raise ConfigError(f"YAML error: {exc.reason}", file=file, **_position(text, exc.position)) from None
    try:
        root = loader.get_single_node()
        src = Source(file, None)
        src.data = {} if root is None else _build(loader, root, (), src)
        return src
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line, col = (mark.line + 1, mark.column + 1) if mark else (None, None)
        problem = "; ".join(p for p in (exc.context, exc.problem) if p) or "invalid YAML"
        raise ConfigError(f"YAML syntax error: {problem}", file=file, line=line, col=col) from None
    except yaml.reader.ReaderError as exc:
        raise ConfigError(f"YAML error: {exc.reason}", file=file, **_position(text, exc.position)) from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"YAML error: {' '.join(str(exc).split())}", file=file, line=1, col=1) from None
    except RecursionError:
        raise ConfigError("YAML nested too deeply", file=file, line=1, col=1) from None
    finally:
        loader.dispose()


def _position(text: str, offset: int) -> dict[str, int]:
    """1-based line and column of a character offset in ``text``."""
    before = text[:offset]
    return {"line": before.count("\n") + 1, "col": offset - (before.rfind("\n") + 1) + 1}


def load_file(path: str) -> Source:
    """Read and parse a YAML file (errors name the file)."""
    try:
        with open(path, "rb") as fh:
            size = os.fstat(fh.fileno()).st_size
            if size > MAX_TEXT_BYTES:
                raise _too_long(size, path)
            raw = fh.read(MAX_TEXT_BYTES + 1)  # a file that grew, or a device that has no size, stops here
    except OSError as exc:
        raise ConfigError(f"cannot read: {exc.strerror or exc}", file=path) from None
    if len(raw) > MAX_TEXT_BYTES:
        raise _too_long(None, path)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        good = raw[: exc.start].decode("utf-8")
        raise ConfigError(f"not UTF-8 text: byte {raw[exc.start]:#04x} cannot start a character", file=path,
                          **_position(good, len(good))) from None
    return load_text(text, path)


def _too_long(size: int | None, file: str, advise: bool = True) -> ConfigError:
    """The error for a text of ``size`` bytes (None: more than it was read of), over ``MAX_TEXT_BYTES``; for a
    file (``advise``) with the way out, for a text given whole (a ``--set`` value, whose label is already long)
    short, so the printed line keeps the sizes."""
    told = f"{size:,} bytes" if size is not None else f"more than {MAX_TEXT_BYTES:,} bytes"
    why = f"{told} of YAML, over the 1 MiB ({MAX_TEXT_BYTES:,} bytes) a config may hold"
    if advise:
        why += "; generate many boxes (stack: {count: N}) and runs (sweep: {grid: ...}) instead of listing them"
    return ConfigError(why, file=file)


def _build(loader: _Loader, node: yaml.Node, path: Path, src: Source) -> Any:
    src.values[path] = _mark(src.file, node)
    plain = {yaml.MappingNode: "tag:yaml.org,2002:map", yaml.SequenceNode: "tag:yaml.org,2002:seq"}
    if type(node) in plain and node.tag != plain[type(node)]:  # scalars' tags are checked by the constructor
        m = _mark(src.file, node)
        raise ConfigError(f"YAML tag {node.tag!r} is not supported; write plain mappings and lists",
                          file=src.file, line=m.line, col=m.col, key=dotted(path) or None)
    if isinstance(node, yaml.MappingNode):
        loader.flatten_mapping(node)
        out: dict[Any, Any] = {}
        for knode, vnode in node.value:
            key = loader.construct_object(knode, deep=True)
            if not isinstance(key, (str, int, float, bool)) or key is None:
                raise ConfigError("mapping keys must be plain scalars", file=src.file,
                                  line=knode.start_mark.line + 1, col=knode.start_mark.column + 1)
            key = str(key) if not isinstance(key, str) else key
            if key in out:
                m = _mark(src.file, knode)
                raise ConfigError(f"duplicate key {key!r}", file=src.file, line=m.line, col=m.col,
                                  key=dotted(path + (key,)))
            src.keys[path + (key,)] = _mark(src.file, knode)
            out[key] = _build(loader, vnode, path + (key,), src)
        return out
    if isinstance(node, yaml.SequenceNode):
        return [_build(loader, item, path + (i,), src) for i, item in enumerate(node.value)]
    problem = scalar_problem(node.tag, node.value)
    if problem:
        m = _mark(src.file, node)
        raise ConfigError(problem, file=src.file, line=m.line, col=m.col, key=dotted(path) or None)
    return loader.construct_object(node, deep=True)
