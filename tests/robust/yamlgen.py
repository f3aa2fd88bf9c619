"""A tiny block-style YAML writer that knows the line range of every key path it writes.

The bad-config tests break configs on purpose and must know, independently of stackx's own YAML reader,
where in the file each key landed, to check the ``line:column`` an error reports. Block style puts every
scalar on the line of its key, so a path's lines are simply counted while writing.
"""

from __future__ import annotations

from typing import Any

import yaml

Path = tuple[str | int, ...]


def scalar(value: Any) -> str:
    """One scalar (or empty collection) as a YAML flow token, quoted where YAML needs it."""
    text = yaml.safe_dump(value, default_flow_style=True, width=10**9, allow_unicode=True)
    return text.removesuffix("\n").removesuffix("\n...").strip()


def paths(node: Any, path: Path = ()) -> list[Path]:
    """Every key path in ``node`` (``()`` for the root), parents before children."""
    out = [path]
    if isinstance(node, dict):
        for k, v in node.items():
            out += paths(v, path + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out += paths(v, path + (i,))
    return out


def dotted(path: Path) -> str:
    """``("outputs", 0, "path")`` -> ``outputs[0].path``, the way stackx names keys."""
    out = ""
    for part in path:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else part)
    return out


def emit(data: Any) -> tuple[str, dict[Path, tuple[int, int]]]:
    """``(text, spans)``: the YAML, and for each key path the first and last line (1-based) it occupies."""
    lines: list[str] = []
    spans: dict[Path, tuple[int, int]] = {}

    def nested(value: Any) -> bool:
        return isinstance(value, (dict, list)) and bool(value)

    def mapping(node: dict[str, Any], path: Path, indent: int, first_prefix: str | None = None) -> None:
        for i, (key, value) in enumerate(node.items()):
            lead = first_prefix if (i == 0 and first_prefix is not None) else " " * indent
            start = len(lines) + 1
            if nested(value):
                lines.append(f"{lead}{scalar(key)}:")
                block(value, path + (key,), indent + 2)
            else:
                lines.append(f"{lead}{scalar(key)}: {scalar(value)}")
            spans[path + (key,)] = (start, len(lines))

    def sequence(node: list[Any], path: Path, indent: int) -> None:
        for i, item in enumerate(node):
            start = len(lines) + 1
            if isinstance(item, dict) and item:
                mapping(item, path + (i,), indent + 2, first_prefix=" " * indent + "- ")
            elif isinstance(item, list) and item:
                lines.append(" " * indent + "-")
                sequence(item, path + (i,), indent + 2)
            else:
                lines.append(" " * indent + "- " + scalar(item))
            spans[path + (i,)] = (start, len(lines))

    def block(node: Any, path: Path, indent: int) -> None:
        if isinstance(node, dict):
            mapping(node, path, indent)
        else:
            sequence(node, path, indent)

    if nested(data):
        block(data, (), 0)
    else:
        lines.append(scalar(data))
    spans[()] = (1, max(len(lines), 1))
    return "\n".join(lines) + "\n", spans
