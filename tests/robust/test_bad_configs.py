"""Property test: over a thousand broken configs, each ends in one located line, exit code 2, nothing written.

Each example starts from a good config (the lab's, and one with a list of boxes and a frames player) and
breaks exactly one thing: a value of the wrong type or out of range (negative or zero dt, steps or
iterations, NaN and infinities, slop < 0, percent outside (0, 1], huge numbers), an unknown or a missing
key, a whole section of the wrong type, an empty list, an unknown plugin, a path leaving the output folder,
a bad expression, a run too big for memory or time, malformed YAML, a duplicate key, bytes that are not
text. The file is written by ``yamlgen``, which knows which lines each key occupies, so the expected key
and line come from how the file was built, not from stackx. ``stackx run`` is called in-process (the same
code path as the command); a few cases also go through a real subprocess to show stderr has no traceback.
"""

from __future__ import annotations

import copy
import math
import re
import subprocess
import sys
import tempfile
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from stackx.cli import app
from tests.conftest import CONFIGS, REPO, Shown
from tests.limits import hang_limit

from .yamlgen import Path as KeyPath
from .yamlgen import dotted, emit
from .yamlgen import paths as _paths

EXAMPLES = 1200
LINE = re.compile(r"^error: (?P<file>.+?):(?P<line>\d+):(?P<col>\d+):(?: (?P<key>[^\s:]+):)? (?P<msg>\S.*)$")

LISTED = {
    "description": "Three listed boxes and a frames player.",
    "scene": {"name": "column", "boxes": [{"y": 0.6, "mass": 1.0}, {"y": 2.0, "half_height": 0.4},
                                         {"y": 3.5, "v": -1.0}]},
    "solver": {"name": "pgs", "iterations": 4, "correction": {"slop": 0.01, "percent": 0.2}},
    "dt": 0.02,
    "steps": 120,
    "limits": {"max_speed": 500.0},
    "outputs": [{"render": "frames", "path": "g{index:02d}.png", "every": 10, "count": 4, "player": "play.html"},
                {"sink": "keyvalue", "path": "listed.txt", "values": {"top": "y[2]", "gap": "y[1] - y[0]"}}],
}
BASES = {name: yaml.safe_load((CONFIGS / f"{name}.yaml").read_text())
         for name in ("03-sink", "04-fixed", "05-iters", "06-stack")} | {"listed": LISTED}

NAN, INF = math.nan, math.inf
HUGE_INTS = st.integers(min_value=9, max_value=400).map(lambda k: 10**k)
WORDS = st.sampled_from(["ten", "fast", "1/0", "", "1e400", "nan?", "[1]", "-"])
WRONG_TYPES = st.one_of(WORDS, st.just([]), st.just([1, 2]), st.just({}), st.just({"a": 1}))
NOT_FINITE = st.sampled_from([NAN, INF, -INF])


def floats(low: float, high: float) -> st.SearchStrategy[float]:
    return st.floats(min_value=low, max_value=high, allow_nan=False, allow_infinity=False)


NEGATIVE = st.one_of(floats(-1e300, -1e-300), st.integers(max_value=-1))

# invalid values by key name: each is refused whatever else the config says
INVALID: dict[str, st.SearchStrategy[Any]] = {
    "dt": st.one_of(st.just(0), NEGATIVE, NOT_FINITE, floats(10.001, 1e300), WRONG_TYPES, st.none()),
    "steps": st.one_of(st.just(0), st.integers(max_value=-1), st.sampled_from([0.5, 1.5, 599.9]),
                       st.integers(min_value=100_000_001, max_value=10**12), HUGE_INTS, NOT_FINITE, WRONG_TYPES,
                       st.none()),
    "gravity": st.one_of(NOT_FINITE, WRONG_TYPES, st.none()),
    "iterations": st.one_of(st.just(0), st.integers(max_value=-1), st.sampled_from([1.5, 2.25]),
                            st.integers(min_value=100_001), HUGE_INTS, NOT_FINITE, WRONG_TYPES, st.none()),
    "slop": st.one_of(NEGATIVE, NOT_FINITE, WRONG_TYPES, st.none()),
    "percent": st.one_of(st.just(0), NEGATIVE, floats(1.0001, 1e300), HUGE_INTS, NOT_FINITE, WRONG_TYPES,
                         st.none()),
    "count": st.one_of(st.just(0), st.integers(max_value=-1), st.just(2.5), st.integers(min_value=1_000_001),
                       NOT_FINITE, WRONG_TYPES, st.none()),
    "y0": st.one_of(NOT_FINITE, WRONG_TYPES, st.none()),
    "y": st.one_of(NOT_FINITE, WRONG_TYPES, st.none()),
    "v": st.one_of(NOT_FINITE, WRONG_TYPES, floats(1001, 1e300), floats(-1e300, -1001)),
    "spacing": st.one_of(st.just(0), NEGATIVE, NOT_FINITE, WRONG_TYPES, st.none()),
    "mass": st.one_of(st.just(0), NEGATIVE, NOT_FINITE, WRONG_TYPES, st.none()),
    "half_height": st.one_of(st.just(0), NEGATIVE, NOT_FINITE, WRONG_TYPES, st.none()),
    "correction": st.sampled_from([5, "on", [1], True, "fast"]),
    "description": st.sampled_from([[1], {"a": 1}, 5, None]),
    "every": st.one_of(st.just(0), st.integers(max_value=-1), WRONG_TYPES, st.none()),
    "max_speed": st.one_of(st.just(0), NEGATIVE, NOT_FINITE, WRONG_TYPES, st.none()),
    "path": st.sampled_from(["../out.txt", "/tmp/abs.txt", "", "a/../../b.txt", ".hidden.png", "sub/.x.png",
                             "manifest.json", "timing.json", "x.failed.json", "C:/x.png", "a\x01b.png"]),
    "player": st.sampled_from(["../index.html", "/index.html", ".index.html", "manifest.json"]),
}
# a section's or key's replacement by something of the wrong kind entirely
SECTIONS = {("scene",): [5, "column", [1], True], ("solver",): [5, "pgs", [1]], ("outputs",): [{}, 5, "x"],
            ("limits",): [5, [1], "x"], ("runs",): [[], 5, "x"], ("sweep",): [[], 5, "x"]}
PLUGIN_KEYS = {"scene": "name", "solver": "name"}
EXPRESSIONS = st.sampled_from(["y[99]", "nope", "1 +", "", "y[", "depth[-99]", "max(", "nowhere.y[0]", "y[0] +* 2",
                               "__import__('os')", "rms_motion(1)"])
SYNTAX = ["\tx: 1", "x: y: z", "x: [1, 2", "x: {a: 1", "x: *nope", "x: !!python/object/apply:os.system ['true']",
          'x: "open', "x: 'open", "x: @at", "x: `tick", "x: %pct", "x: \x07bell", "---\nx: 1"]
IDENT = st.text(alphabet="abcdefghijklmnopqrstuvwxyz_", min_size=1, max_size=12).map(lambda s: "zz" + s)


@dataclass
class Case:
    """A broken config and what its error must say."""

    kind: str
    data: bytes
    key: str | None  # the key the message must name (None: no key, e.g. a YAML syntax error)
    lines: tuple[int, int] | None  # the range the reported line must fall in (None: anywhere in the file)
    words: tuple[str, ...] = ()  # words the message must hold


def _get(node: Any, path: KeyPath) -> Any:
    for part in path:
        node = node[part]
    return node


def _case(kind: str, data: Any, key: KeyPath | None, at: KeyPath | None, *words: str) -> Case:
    """Write ``data`` and expect an error at ``key`` whose line lies within the lines of ``at``."""
    text, spans = emit(data)
    return Case(kind, text.encode(), dotted(key) if key is not None else None,
                spans.get(at) if at is not None else None, words)


@st.composite
def bad_value(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    swept = set(base.get("sweep", {}).get("grid", {}))  # values every run overrides are never used
    paths = [p for p in _paths(base) if p and isinstance(p[-1], str) and p[-1] in INVALID
             and not (p[-1] == "description" and len(p) > 1) and "grid" not in p and "runs" not in p
             and dotted(p) not in swept]
    path = draw(st.sampled_from(paths))
    data = copy.deepcopy(base)
    parent = _get(data, path[:-1])
    value = parent[path[-1]] = draw(INVALID[path[-1]])
    if path[-1] == "v" and isinstance(value, float) and math.isfinite(value):
        # a valid number, but faster than limits.max_speed: refused before stepping, naming the scene
        return _case("too fast at the start", data, ("scene",), ("scene",), "max_speed")
    return _case("bad value", data, path, path)


@st.composite
def unknown_key(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    holders = [p for p in _paths(base) if isinstance(_get(base, p), dict) and "grid" not in p and "runs" not in p
               and "values" not in p and not (p and p[-1] == "bench")]
    path = draw(st.sampled_from(holders))
    name = draw(IDENT)
    data = copy.deepcopy(base)
    _get(data, path)[name] = draw(st.one_of(st.integers(), WORDS))
    return _case("unknown key", data, path + (name,), path + (name,), "unknown key")


REQUIRED = {("scene", "name"): ("scene",), ("solver", "name"): ("solver",), ("stack", "count"): None,
            ("stack", "y0"): None, ("stack", "spacing"): None, ("boxes", None, "y"): None,
            ("outputs", None, "path"): None, ("outputs", None, "sink"): None, ("outputs", None, "render"): None,
            ("outputs", None, "every"): None, ("outputs", None, "count"): None, ("outputs", None, "values"): None}


def _required(path: KeyPath) -> bool:
    for pattern in REQUIRED:
        tail = path[-len(pattern):]
        if len(tail) == len(pattern) and all(p is None or p == q for p, q in zip(pattern, tail)):
            return True
    return False


@st.composite
def missing_key(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    paths = [p for p in _paths(base) if p and isinstance(p[-1], str) and _required(p)
             and not (p[0] == "outputs" and p[-1] == "path" and "sink" not in _get(base, p[:-1]))]
    top = [p for p in (("scene",), ("solver",), ("steps",)) if p[0] in base]
    path = draw(st.sampled_from(paths + top))
    data = copy.deepcopy(base)
    del _get(data, path[:-1])[path[-1]]
    if len(path) == 1:  # a whole section gone: the error names it, at the top of the file
        return _case("missing section", data, path, None, path[0])
    return _case("missing key", data, path[:-1], path[:-1])


@st.composite
def wrong_section(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    path = draw(st.sampled_from(sorted(SECTIONS)))
    data = copy.deepcopy(base)
    data.pop("runs" if path == ("sweep",) else "sweep", None)  # the two exclude each other
    data[path[0]] = draw(st.sampled_from(SECTIONS[path]))
    return _case("wrong section", data, path, path)


@st.composite
def empty_list(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    data = copy.deepcopy(base)
    choices: list[tuple[KeyPath, Any]] = []
    if "boxes" in data["scene"]:
        choices.append((("scene", "boxes"), []))
    for i, out in enumerate(data["outputs"]):
        if "values" in out:
            choices.append((("outputs", i, "values"), {}))
    if "sweep" in data:
        key = next(iter(data["sweep"]["grid"]))
        choices += [(("sweep", "grid"), {}), (("sweep", "grid", key), [])]
    if "runs" in data:
        choices.append((("runs",), {}))
    path, empty = draw(st.sampled_from(choices))
    _get(data, path[:-1])[path[-1]] = empty
    return _case("empty list", data, path, path)


@st.composite
def unknown_plugin(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    spots = [(s, "name") for s in PLUGIN_KEYS] + [
        ("outputs", i, "sink" if "sink" in o else "render") for i, o in enumerate(base["outputs"])]
    path = draw(st.sampled_from(spots))
    data = copy.deepcopy(base)
    _get(data, path[:-1])[path[-1]] = draw(st.one_of(IDENT, st.integers(), st.just(["pgs"])))
    return _case("unknown plugin", data, path, path)


@st.composite
def bad_expression(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    spots = [("outputs", i, "values", k) for i, o in enumerate(base["outputs"]) for k in o.get("values", {})]
    path = draw(st.sampled_from(spots))
    data = copy.deepcopy(base)
    _get(data, path[:-1])[path[-1]] = draw(EXPRESSIONS)
    return _case("bad expression", data, path, path)


@st.composite
def too_big(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    """Runs that would not fit in memory or finish: refused before stepping, at the key that sizes them."""
    data = copy.deepcopy(base)
    data["scene"] = {"name": "column", "stack": {"count": 1_000_000, "y0": 0.5, "spacing": 1.0}}
    data.pop("runs", None)
    data["sweep"] = {"grid": {"solver.iterations": draw(st.lists(st.integers(1, 50), min_size=3, max_size=6,
                                                                  unique=True))}}
    data["outputs"] = [{"sink": "metrics", "path": "big.json"}]
    roomy = {"max_bodies": 10**7, "max_box_steps": 1e18}  # only the limit under test can refuse
    kind = draw(st.sampled_from(["memory", "work", "bodies", "box steps", "runs"]))
    if kind == "memory":
        data["limits"] = {**roomy, "max_memory_mb": draw(floats(1, 2000))}
        return _case("too big for memory", data, ("scene",), ("scene",), "max_memory_mb")
    data["steps"] = draw(st.integers(100_000, 100_000_000))
    data["scene"]["stack"]["count"] = count = draw(st.integers(1000, 1_000_000))
    if kind == "work":
        data["limits"] = {**roomy, "max_work": draw(floats(1, 1e6)), "max_memory_mb": 1e9}
        return _case("too much work", data, ("steps",), ("steps",), "max_work")
    if kind == "bodies":
        data["limits"] = {"max_bodies": draw(st.integers(1, count - 1))}
        return _case("too many bodies", data, ("scene", "stack", "count"), ("scene", "stack", "count"), "max_bodies")
    if kind == "box steps":
        data["limits"] = {"max_bodies": count, "max_box_steps": draw(floats(1, data["steps"] * count - 1))}
        return _case("too many box steps", data, ("steps",), ("steps",), "max_box_steps")
    runs = len(data["sweep"]["grid"]["solver.iterations"])
    data["limits"] = {"max_runs": draw(st.integers(1, runs - 1))}
    return _case("too many runs", data, ("sweep", "grid"), ("sweep", "grid"), "max_runs")


@st.composite
def malformed(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    text, _ = emit(base)
    lines = text.splitlines()
    at = draw(st.integers(2, len(lines) + 1))  # the new line's number
    indent = draw(st.sampled_from([0, len(lines[at - 2]) - len(lines[at - 2].lstrip())]))
    bad = draw(st.sampled_from(SYNTAX))
    lines.insert(at - 1, " " * indent + bad)
    return Case("malformed YAML", ("\n".join(lines) + "\n").encode(), None, (at, len(lines) + 2), ("YAML",))


@st.composite
def duplicate_key(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    text, spans = emit(base)
    lines = text.splitlines()
    keys = [p for p in spans if p and isinstance(p[-1], str)]
    path = draw(st.sampled_from(keys))
    first, last = spans[path]
    head = lines[first - 1]
    col = len(head) - len(head.lstrip(" -")) if head.lstrip().startswith("- ") else len(head) - len(head.lstrip())
    lines.insert(last, " " * col + f"{path[-1]}: {draw(st.sampled_from(['1', 'x', '[]', '{}']))}")
    return Case("duplicate key", ("\n".join(lines) + "\n").encode(), dotted(path), (last + 1, last + 1),
                ("duplicate key",))


@st.composite
def not_text(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    text, _ = emit(base)
    lines = text.encode().splitlines()
    at = draw(st.integers(1, len(lines)))
    lines[at - 1] += draw(st.sampled_from([b" \xff", b"\xfe\xfe", b" \xc3", b"\x80"]))
    return Case("not UTF-8", b"\n".join(lines) + b"\n", None, (at, at), ("UTF-8",))


@st.composite
def not_a_mapping(draw: st.DrawFn, base: dict[str, Any]) -> Case:
    data = draw(st.sampled_from([[base], "scene: column", 5, [1, 2, 3]]))
    return _case("not a mapping", data, None, ())


@st.composite
def broken_configs(draw: st.DrawFn) -> Case:
    base = BASES[draw(st.sampled_from(sorted(BASES)))]
    strategy = draw(st.sampled_from([bad_value, bad_value, bad_value, unknown_key, unknown_key, missing_key,
                                     wrong_section, empty_list, unknown_plugin, bad_expression, too_big, malformed,
                                     malformed, duplicate_key, not_text, not_a_mapping]))
    return draw(strategy(base))


def check_error(case: Case, config: Path, code: int, stderr: str, out: Path) -> None:
    """The contract for a bad config: exit 2, one located line naming the file and key, nothing written."""
    assert "Traceback" not in stderr, stderr
    assert code == 2, f"{case.kind}: exit {code}: {stderr}\n{case.data.decode(errors='replace')}"
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    m = LINE.match(lines[0])
    assert m, lines[0]
    assert m["file"] == str(config), lines[0]
    if case.key is not None:
        assert m["key"] == case.key, f"{case.kind}: expected key {case.key}: {lines[0]}"
    line_count = case.data.count(b"\n") + 1
    low, high = case.lines or (1, line_count)
    assert low <= int(m["line"]) <= high, f"{case.kind}: line not in {low}..{high}: {lines[0]}"
    assert int(m["col"]) >= 1
    for word in case.words:
        assert word in m["msg"], f"{case.kind}: {word!r} not in {lines[0]}"
    assert not out.exists(), f"{case.kind}: wrote {sorted(out.rglob('*'))}"


def test_a_thousand_broken_configs_fail_cleanly(shown: Shown) -> None:
    runner = CliRunner()
    kinds: Counter[str] = Counter()
    with tempfile.TemporaryDirectory() as tmp:
        config, out = Path(tmp) / "broken.yaml", Path(tmp) / "out"

        @settings(max_examples=EXAMPLES, deadline=None, database=None,
                  suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
        @given(broken_configs())
        def attempt(case: Case) -> None:
            config.write_bytes(case.data)
            result = runner.invoke(app, ["run", str(config), "--out", str(out), "-q"])
            assert result.exception is None or isinstance(result.exception, SystemExit), result.exc_info
            check_error(case, config, result.exit_code, result.stderr, out)
            kinds[case.kind] += 1

        attempt()
    total = sum(kinds.values())
    shown(f"{total} broken configs tried, none gave a traceback or wrote a file: "  # in the log, passing or not
          + ", ".join(f"{k} {n}" for k, n in sorted(kinds.items())))
    assert total >= 1000
    assert len(kinds) >= 14, kinds


SUBPROCESS_CASES = ["dt: -0.1", "steps: .nan", "  iterations: 0", "  iterations: [", "steps: 900\nsteps: 5"]


def test_real_processes_print_no_traceback(tmp_path: Path) -> None:
    stack = (CONFIGS / "06-stack.yaml").read_text()
    swaps = {"dt: -0.1": "dt: 1/60", "steps: .nan": "steps: 900", "  iterations: 0": "  iterations: 15",
             "  iterations: [": "  iterations: 15", "steps: 900\nsteps: 5": "steps: 900"}
    for i, new in enumerate(SUBPROCESS_CASES):
        config = tmp_path / f"case{i}.yaml"
        config.write_text(stack.replace(swaps[new], new, 1))
        out = tmp_path / f"out{i}"
        done = subprocess.run([sys.executable, "-m", "stackx", "run", str(config), "--out", str(out)], cwd=REPO,
                              capture_output=True, text=True, timeout=hang_limit(120))
        assert done.returncode == 2, done.stderr
        assert "Traceback" not in done.stderr and done.stdout == ""
        assert len(done.stderr.strip().splitlines()) == 1 and LINE.match(done.stderr.strip()), done.stderr
        assert not out.exists()
