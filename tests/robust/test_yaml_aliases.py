"""Aliases: a config reusing a section loads as if written out; an alias bomb stops at once, located."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from stackx.errors import ConfigError
from stackx.config.yamlsrc import MAX_ALIAS_NODES, load_text
from tests.conftest import CONFIGS, REPO
from tests.limits import hang_limit

LEVELS, WIDTH = 10, 9
MEASURE = """import json, resource, subprocess, sys, time
started = time.perf_counter()
code = subprocess.run(sys.argv[1:]).returncode
wall = time.perf_counter() - started
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
print(json.dumps([code, usage.ru_utime + usage.ru_stime, wall, usage.ru_maxrss]))
"""


def _bomb() -> str:
    """Ten anchors, each a list of nine aliases of the one before (the first a list of nine scalars)."""
    lines = [f"a0: &a0 [{', '.join(['x'] * WIDTH)}]"]
    lines += [f"a{k}: &a{k} [{', '.join([f'*a{k - 1}'] * WIDTH)}]" for k in range(1, LEVELS + 1)]
    return "\n".join(lines) + "\n"


def _first_alias_past_the_bound(text: str) -> tuple[int, int, str]:
    """Line, column and anchor of the first alias after which the nodes added by aliases pass the bound: a
    plain count over the text, line by line (a list of n items expands to 1 + its items' sizes)."""
    sizes: dict[str, int] = {}
    added = 0
    for number, line in enumerate(text.splitlines(), start=1):
        name = line.split(":")[0]
        items = line[line.index("[") + 1:line.index("]")].split(", ")
        column = line.index("[") + 2
        size = 1
        for item in items:
            if item.startswith("*"):
                added += sizes[item[1:]]
                if added > MAX_ALIAS_NODES:
                    return number, column, item[1:]
                size += sizes[item[1:]]
            else:
                size += 1
            column += len(item) + 2
        sizes[name] = size
    raise AssertionError("the bomb never passes the bound")


def test_an_alias_bomb_stops_located_in_well_under_a_second_and_little_memory(tmp_path: Path) -> None:
    bomb = _bomb()
    assert len(bomb) < 600  # a few hundred bytes ...
    config = tmp_path / "bomb.yaml"
    config.write_text(bomb + (CONFIGS / "03-sink.yaml").read_text())
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (str(REPO), os.environ.get("PYTHONPATH")) if p)}
    # A small Python process starts stackx and reports its CPU time and peak memory: a child started straight
    # from pytest would count pytest's own memory, which the child's high-water mark inherits at the fork.
    done = subprocess.run([sys.executable, "-c", MEASURE, sys.executable, "-m", "stackx", "validate", str(config)],
                          cwd=tmp_path, env=env, capture_output=True, text=True, timeout=hang_limit(60))
    code, cpu, wall, peak_kb = json.loads(done.stdout)
    message = done.stderr
    peak_mb = peak_kb / 1024  # ru_maxrss is in kilobytes on Linux
    print(f"alias bomb of {LEVELS} levels: exit {code}, {cpu:.2f} s CPU, {wall:.2f} s wall, peak {peak_mb:.0f} MB")
    assert code == 2, message
    line, col, anchor = _first_alias_past_the_bound(bomb)
    assert message.count("\n") == 1 and message.startswith(f"error: {config}:{line}:{col}: alias *{anchor} "), message
    assert f"at most {MAX_ALIAS_NODES:,} nodes" in message
    assert cpu < 1.0  # ... that used to take minutes (and exhaust memory) before the unknown-key error
    assert peak_mb < 200


def _reused(items: int, aliases: int) -> str:
    """An anchored list of ``items`` scalars, then ``aliases`` aliases of it."""
    return f"one: &one [{', '.join(map(str, range(items)))}]\nmany: [{', '.join(['*one'] * aliases)}]\n"


def test_aliases_adding_exactly_the_bound_load_as_if_written_out() -> None:
    """Each alias of a list of n scalars adds n + 1 nodes; aliases adding exactly the bound are accepted and give
    the data PyYAML builds from the same text; one alias more is refused at that alias."""
    items = 999
    aliases = MAX_ALIAS_NODES // (items + 1)
    assert aliases * (items + 1) == MAX_ALIAS_NODES
    text = _reused(items, aliases)
    assert load_text(text, "reuse.yaml").data == yaml.safe_load(text)
    with pytest.raises(ConfigError) as caught:
        load_text(_reused(items, aliases + 1), "reuse.yaml")
    err = caught.value
    assert (err.file, err.line, err.col) == ("reuse.yaml", 2, len("many: [") + 1 + aliases * len("*one, "))


def test_a_config_reusing_a_box_through_an_alias_runs_as_written_out(tmp_path: Path) -> None:
    """The everyday use: a box written once, anchored, and reused in a second run that adds one above it."""
    from stackx.config.experiment import load

    shared = tmp_path / "shared.yaml"
    sink = (CONFIGS / "03-sink.yaml").read_text()
    box = "{y: 1.5, v: 0.0, half_height: 0.5, mass: 1.0}"
    shared.write_text(sink.replace(f"    - {box}\n", f"    - &box {box}\n").replace(": depth[0]", ": two.depth[0]")
                      + "runs:\n  one: {}\n  two: {scene.boxes: [*box, {y: 3.0, half_height: 0.5, mass: 1.0}]}\n")
    written = tmp_path / "written.yaml"
    written.write_text(yaml.safe_dump(yaml.safe_load(shared.read_text()), sort_keys=False))
    assert "*box" in shared.read_text() and "*box" not in written.read_text()
    spec = load(str(shared))
    assert [[b["y"] for b in r["scene"]["boxes"]] for r in spec.resolved["runs"]] == [[1.5], [1.5, 3.0]]
    assert spec.resolved == load(str(written)).resolved


def test_an_alias_inside_the_node_it_names_is_refused_located() -> None:
    line = "loop: &loop [1, [2, *loop]]"
    with pytest.raises(ConfigError) as caught:
        load_text(f"solver:\n  name: pgs\n{line}\n", "loop.yaml")
    err = caught.value
    assert (err.line, err.col) == (3, line.index("*loop") + 1) and "inside the node it names" in err.message
