"""A seeded generator of hostile configs, and the contract each must meet when ``stackx run`` reads it.

Each case starts from a shipped config and changes it the way a careless or hostile user would: a value swapped
for another type, a huge, tiny or non-finite number, an odd output path or file name template, a deep nesting,
unicode and lone surrogates, an explicit YAML tag, an anchor and aliases (a few hundred bytes that stand for
billions of values), a base-60, octal or hex number, a byte flipped, the text cut short. The same seed gives
the same case, so a failure found by the 10,000-case script (``benchmarks/fuzz_configs.py``) is replayed by its
number.

The contract (``judge``): exit 0, 1 (a run that failed while stepping, with the failed-run file) or 2, never a
traceback; on exit 2 one line ``error: FILE:LINE:COL: ...`` naming the config and nothing written; on exit 0 an
output folder whose files are exactly what its manifest lists, with the bytes it hashes.
"""

from __future__ import annotations

import copy
import hashlib
import json
import random
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from tests.robust.yamlgen import paths as _paths

REPO = Path(__file__).resolve().parents[2]
BASES = ["configs/03-sink.yaml", "configs/04-fixed.yaml", "configs/05-iters.yaml", "configs/06-stack.yaml",
         "configs/examples/sor-stack.yaml", "configs/hard/load-removal.yaml", "configs/planar/ramp-slide.yaml",
         "configs/planar/ramp-stick.yaml"]
LINE = re.compile(r"^error: (?P<file>.+?):(?P<line>\d+):(?P<col>\d+):(?: (?P<key>[^\s:]+):)? (?P<msg>\S.*)$")
CAPS = ["--set", "limits.max_box_steps=60000", "--set", "limits.max_frames=40", "--set", "limits.max_work=3e6"]
"""Overrides every case runs with, so that a mutated config that is valid runs for a second, not an hour (a
run over them is refused as too big, which is itself a case of the contract)."""

NUMBERS: list[Any] = [0, -1, 1, 2, 10**9, 10**30, -(10**30), 10**400, 1e308, 1e-308, 5e-324, -0.0, 0.5, 1e300,
                      float("nan"), float("inf"), float("-inf"), 2**63, 2**64 + 1, 100_000_000, 99_999_999]
TEXTS = ["", " ", "ten", "1/0", "1:30", "0x1F", "0o17", "010", "yes", "on", "~", "null", "2024-01-01", ".inf",
         "é", "箱", "\u202e", "\U0001f4e6", "\ud800", "a\udc80b", "\x00", "\x07", "\t", "'", '"', "{", "[", "*x",
         "&a", "!x", "%", "@", "`", "--- ", "...", "x" * 5000]
PATHS = ["", ".", "..", "./a.txt", "a/./b.txt", "sub/.", "a//b.txt", "/abs.txt", "../up.txt", "a/../b.txt",
         "n" * 300, "/".join(["d"] * 2000) + "/m.json", "/".join(["d"] * 17), "CON", "aux.txt", "a\\b.txt",
         "a:b.txt", "a?.txt", "a*.png", "trail.", "trail ", "é/箱.txt", "\ud800.txt", "a\udc80.txt", "\x01.txt",
         "manifest.json", "timing.json", "x.failed.json", ".hidden", "F00.png", "f00.png/x.png", "f0",
         "{index:>1000000000}.png", "{index:099999999999}.png", "{index.real}.png", "{index!r}.png", "{}.png",
         "{index}", "{index:09d}.png", "{index:x}.png", "{{index}}.png", "{index", "05-iters.txt",
         "stack.png/x.png", "index.html", "sub/index.html"]
TAGS = ["!!int", "!!bool", "!!float", "!!str", "!!null", "!!binary", "!!timestamp", "!!set", "!!omap", "!foo",
        "!!python/object/apply:os.system", "!!python/name:os.system", "!<tag:yaml.org,2002:int>", "!"]
SCALARS_12 = ["1:30", "1:30:00", "0x10", "0o10", "010", "0b101", "1_000", "+1", ".5", "1.", "1e3", "1E-3",
              "-.inf", ".NaN", "Yes", "NO", "on", "2001-12-14", "2001-12-14t21:59:43.10-05:00", "=", "<<"]


@dataclass
class Case:
    """One mutated config: how it was made (for the report) and its bytes."""

    seed: int
    base: str
    how: str
    data: bytes


def _parent(data: Any, path: tuple[Any, ...]) -> Any:
    for part in path[:-1]:
        data = data[part]
    return data


def _dump(data: Any) -> str:
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True, width=10**6)


def _odd_value(rng: random.Random) -> Any:
    kind = rng.randrange(6)
    if kind == 0:
        return rng.choice(NUMBERS)
    if kind == 1:
        return rng.choice(TEXTS)
    if kind == 2:
        return rng.choice([[], {}, [1, 2], {"a": 1}, None, True, False, [[[]]], {"": None}])
    if kind == 3:  # deep nesting
        node: Any = rng.choice([1, "x"])
        for _ in range(rng.choice([10, 60, 70, 200])):
            node = [node] if rng.random() < 0.5 else {"k": node}
        return node
    if kind == 4:
        return rng.choice(PATHS)
    return rng.uniform(-1e6, 1e6) if rng.random() < 0.5 else rng.randrange(-10**6, 10**6)


def _mutate_data(rng: random.Random, data: Any) -> tuple[Any, str]:
    """A change of the loaded data: a value swapped, a key removed or added, a list emptied or grown."""
    paths = [p for p in _paths(data) if p]
    if not paths:
        return {"steps": _odd_value(rng)}, "empty config given a step count"
    path = rng.choice(paths)
    parent = _parent(data, path)
    op = rng.randrange(8)
    if op <= 2:
        parent[path[-1]] = _odd_value(rng)
        return data, f"value at {path} -> odd"
    if op == 3 and isinstance(parent, dict):
        del parent[path[-1]]
        return data, f"removed {path}"
    if op == 4 and isinstance(parent, dict):
        parent[rng.choice(["zz", "limits", "runs", "sweep", "outputs", "ünï", "0", "<<"])] = _odd_value(rng)
        return data, f"added a key beside {path}"
    if op == 5:  # an odd output path, or two outputs in each other's way
        outputs = data.get("outputs") if isinstance(data, dict) else None
        if isinstance(outputs, list) and outputs and isinstance(outputs[0], dict):
            target = rng.choice([o for o in outputs if isinstance(o, dict)])
            key = rng.choice(["path", "player", "frames", "path"])
            target[key] = rng.choice(PATHS + [o.get("path") for o in outputs if isinstance(o, dict)])
            return data, f"output {key} -> odd"
    if op == 6 and isinstance(data, dict):  # a sweep of odd shape
        data.pop("runs", None)
        keys = rng.choice([["solver.iterations"], ["dt", "gravity"], [f"x{k}" for k in range(7)], ["steps"]])
        data["sweep"] = {"grid": {k: [rng.choice(NUMBERS[:6] + [1, 2, 3]) for _ in range(rng.choice([1, 3, 10]))]
                                  for k in keys}}
        return data, "sweep grid"
    if isinstance(parent, list):
        parent.extend(copy.deepcopy(parent[-1:]) * rng.choice([1, 5]))
        return data, f"grew list {path[:-1]}"
    parent[path[-1]] = rng.choice(NUMBERS)
    return data, f"value at {path} -> number"


def _mutate_text(rng: random.Random, text: str) -> tuple[str, str]:
    """A change of the text itself: a tag, an alias bomb, a YAML 1.1 number, a byte, a cut."""
    if not text:
        text = "{}\n"
    lines = text.splitlines()
    valued = [i for i, ln in enumerate(lines) if re.match(r"^\s*(- )?[A-Za-z_0-9.]+: \S", ln)]
    op = rng.randrange(6)
    if op == 0 and valued:
        i = rng.choice(valued)
        key, _, value = lines[i].partition(": ")
        lines[i] = f"{key}: {rng.choice(TAGS)} {value}"
        return "\n".join(lines) + "\n", "tag"
    if op == 1 and valued:
        i = rng.choice(valued)
        key, _, _ = lines[i].partition(": ")
        lines[i] = f"{key}: {rng.choice(SCALARS_12)}"
        return "\n".join(lines) + "\n", "YAML 1.1 scalar"
    if op == 2:
        depth = rng.choice([3, 6, 10])
        bomb = ["bomb:", "  a0: &a0 [1, 2, 3, 4, 5, 6, 7, 8, 9]"]
        bomb += [f"  a{k}: &a{k} [{', '.join([f'*a{k - 1}'] * 9)}]" for k in range(1, depth)]
        where = rng.choice(["description", "zz", "scene"])
        bomb[0] = f"{where}:" if where != "scene" else "scene: {name: column, stack: *a1}"
        body = [ln for ln in lines if not ln.startswith(where + ":")] if where == "description" else lines
        return "\n".join(body + bomb) + "\n", f"aliases x9 deep {depth}"
    if op == 3:
        raw = bytearray(text.encode("utf-8", errors="surrogateescape"))
        at = rng.randrange(len(raw))
        raw[at] = rng.choice([0x00, 0x80, 0xFF, 0x09, 0x0D, 0x22, 0x27, 0x7B, 0x5B, 0x26, 0x2A, 0x21])
        return raw.decode("utf-8", errors="surrogateescape"), f"byte {at}"
    if op == 4:
        return text[: rng.randrange(len(text))], "cut short"
    i = rng.randrange(len(lines) + 1)
    lines.insert(i, rng.choice(["\tx: 1", "x: [1, 2", "? [a]\n: 1", "*undefined", "&a x: 1", "<<: 5",
                                "<<: *nope", "%YAML 1.1", "--- !!map", "...", "'" + "a" * 50]))
    return "\n".join(lines) + "\n", "inserted line"


def make(seed: int) -> Case:
    """The case of ``seed``: one to three changes of one shipped config."""
    rng = random.Random(seed)
    base = rng.choice(BASES)
    text = (REPO / base).read_text()
    how = []
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        if rng.random() < 0.6 and not any(h.startswith("aliases") for h in how):
            try:
                data = yaml.safe_load(text)
            except Exception:  # noqa: BLE001 - PyYAML's own reader fails in many ways on broken text
                data = None
            if isinstance(data, dict):
                data, what = _mutate_data(rng, data)
                text = _dump(data)
                how.append(what)
                continue
        text, what = _mutate_text(rng, text)
        how.append(what)
    return Case(seed, base, "; ".join(how), text.encode("utf-8", errors="surrogateescape"))


def judge(case: Case, config: Path, out: Path, code: int, stderr: str, raised: BaseException | None) -> list[str]:
    """Every way the run of ``case`` broke the contract (see the module's docstring); empty when it kept it."""
    problems = []
    if raised is not None and not isinstance(raised, SystemExit):
        problems.append(f"traceback: {type(raised).__name__}: {str(raised)[:200]}")
    if "Traceback" in stderr:
        problems.append("traceback in stderr")
    if code not in (0, 1, 2):
        problems.append(f"exit {code}")
    lines = stderr.strip().splitlines()
    errors = [ln for ln in lines if ln.startswith("error:")]
    if code == 2:
        m = LINE.match(errors[0]) if len(errors) == 1 else None
        if m is None or m["file"] != str(config):
            problems.append(f"unlocated: {stderr.strip()[:300]}")
        if out.exists():
            problems.append(f"files left after a refusal: {sorted(str(p) for p in out.rglob('*'))[:5]}")
    elif code == 1:
        if len(errors) != 1:
            problems.append(f"exit 1 without one error line: {stderr.strip()[:300]}")
    elif code == 0 and out.exists():  # a config with nothing to write leaves the folder untouched
        problems += _incomplete(out)
    return problems


def _incomplete(out: Path) -> list[str]:
    """What makes ``out`` other than complete: a file the manifest does not list, or one it lists missing or
    with other bytes."""
    try:
        manifest = json.loads((out / "manifest.json").read_text())
    except FileNotFoundError:
        manifest = {}
    except (OSError, ValueError):
        return ["exit 0 with an unreadable manifest"]
    listed: dict[str, str] = {}
    for entry in manifest.get("experiments", {}).values():
        for name, art in entry.get("artifacts", {}).items():
            listed[name] = art["sha256"]
    problems = [] if manifest else ["exit 0 without a manifest"]
    for name, sha in listed.items():
        path = out / name
        if not path.is_file() or hashlib.sha256(path.read_bytes()).hexdigest() != sha:
            problems.append(f"incomplete: {name}")
    present = {str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()}
    if not listed and present <= {"timing.json"}:
        return []  # a config with runs and no outputs: only the run's timing is written
    stray = present - set(listed) - {"manifest.json", "timing.json"}
    stray = {n for n in stray if not n.endswith(".failed.json")}
    if stray:
        problems.append(f"files the manifest does not list: {sorted(stray)[:5]}")
    return problems


def attempt(case: Case, folder: Path) -> tuple[int, list[str]]:
    """Run ``stackx run`` on ``case`` in this process (the command's own code path, as the command line calls
    it) in a fresh ``folder``; return its exit code and what it broke of the contract."""
    from typer.testing import CliRunner

    from stackx.cli import app

    config, out = folder / "case.yaml", folder / "out"
    config.write_bytes(case.data)
    result = CliRunner().invoke(app, ["run", str(config), "--out", str(out), "-q", *CAPS])
    return result.exit_code, judge(case, config, out, result.exit_code, result.stderr, result.exception)
