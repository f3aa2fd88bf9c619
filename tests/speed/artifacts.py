"""Comparing two output folders written by the compiled and the plain path.

Text values (``key=value`` files and every number inside JSON files) must agree to ``TOLERANCE``; every other
file (PNG, HTML) must be byte-identical. ``timing.json`` holds wall-clock times and is left out.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

TOLERANCE = 1e-12
WALL_CLOCK = {"timing.json"}


def _numbers_differ(a: Any, b: Any, where: str) -> list[str]:
    """Paths inside two JSON documents where they differ (numbers by more than TOLERANCE)."""
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            return [f"{where}: keys {sorted(a)} != {sorted(b)}"]
        return [d for k in a for d in _numbers_differ(a[k], b[k], f"{where}.{k}")]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{where}: length {len(a)} != {len(b)}"]
        return [d for i, (x, y) in enumerate(zip(a, b)) for d in _numbers_differ(x, y, f"{where}[{i}]")]
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        same = (math.isnan(a) and math.isnan(b)) or a == b or abs(a - b) <= TOLERANCE
        return [] if same else [f"{where}: {a!r} != {b!r}"]
    return [] if a == b else [f"{where}: {a!r} != {b!r}"]


def _text_pairs(path: Path) -> dict[str, Any]:
    pairs: dict[str, Any] = {}
    for line in path.read_text().splitlines():
        key, _, value = line.partition("=")
        try:
            pairs[key] = float(value)
        except ValueError:
            pairs[key] = value
    return pairs


def differences(a: Path, b: Path) -> list[str]:
    """Every way the artifacts of folder ``a`` differ from those of ``b`` (empty: the same)."""
    names_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file() and p.name not in WALL_CLOCK}
    names_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file() and p.name not in WALL_CLOCK}
    out = [f"only in one folder: {sorted(map(str, names_a ^ names_b))}"] if names_a != names_b else []
    for name in sorted(names_a & names_b):
        fa, fb = a / name, b / name
        if name.suffix == ".json":
            out += _numbers_differ(json.loads(fa.read_text()), json.loads(fb.read_text()), str(name))
        elif name.suffix == ".txt":
            out += _numbers_differ(_text_pairs(fa), _text_pairs(fb), str(name))
        elif fa.read_bytes() != fb.read_bytes():
            out.append(f"{name}: bytes differ")
    return out
