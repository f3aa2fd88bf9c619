"""``stackx run``: overrides, sweeps, runs and the files they produce, checked against the lab reference."""

from __future__ import annotations

import json
from pathlib import Path

from tests.conftest import CONFIGS, Cli
from tests.lab import reference as ref


def _kv(path: Path) -> dict[str, float]:
    return {k: float(v) for k, v in (ln.split("=", 1) for ln in path.read_text().splitlines())}


def test_set_turns_correction_on(cli: Cli, tmp_path: Path) -> None:
    """03 with correction switched on by --set is the reference's corrected drop."""
    done = cli("run", CONFIGS / "03-sink.yaml", "--out", tmp_path,
               "--set", "solver.correction={slop: 0.01, percent: 0.2}", "-q")
    assert done.returncode == 0, done.stderr
    expected = ref.max_depth(ref.simulate([1.5], 600, 10, correction=True).final)
    assert abs(_kv(tmp_path / "03-sink.txt")["depth_final"] - expected) < 1e-12


def test_sweep_over_two_keys(cli: Cli, tmp_path: Path) -> None:
    config = tmp_path / "grid.yaml"
    config.write_text("""
scene: {name: column, stack: {count: 3, y0: 1.5, spacing: 1.0}}
solver: {name: pgs, iterations: 1}
steps: 120
sweep:
  name: it{solver.iterations}_p{solver.correction.percent}
  grid:
    solver.iterations: [2, 6]
    solver.correction.percent: [0.2, 0.8]
outputs:
  - sink: keyvalue
    path: grid.txt
    values:
      a: it2_p0p2.max_depth
      b: it6_p0p8.y[-1]
      c: it6_p0p2.max_depth - it2_p0p8.max_depth
  - sink: metrics
    path: grid.json
""")
    done = cli("run", config, "--out", tmp_path / "out", "-q")
    assert done.returncode == 0, done.stderr
    got = _kv(tmp_path / "out" / "grid.txt")

    def run(iterations: int, percent: float) -> list[float]:
        return ref.simulate([1.5, 2.5, 3.5], 120, iterations, correction=True, percent=percent).final

    assert abs(got["a"] - ref.max_depth(run(2, 0.2))) < 1e-12
    assert abs(got["b"] - run(6, 0.8)[-1]) < 1e-12
    assert abs(got["c"] - (ref.max_depth(run(6, 0.2)) - ref.max_depth(run(2, 0.8)))) < 1e-12
    metrics = json.loads((tmp_path / "out" / "grid.json").read_text())
    assert list(metrics["runs"]) == sorted(["it2_p0p2", "it2_p0p8", "it6_p0p2", "it6_p0p8"])


def test_metrics_file_measures(cli: Cli, tmp_path: Path) -> None:
    assert cli("run", CONFIGS / "06-stack.yaml", "--out", tmp_path, "-q").returncode == 0
    run = json.loads((tmp_path / "06-stack.metrics.json").read_text())["runs"]["main"]
    final = ref.stack_run().final
    assert max(abs(a - b) for a, b in zip(run["y"], final)) < 1e-12
    # the peak depth over the run is at least every depth seen at the recorded frames, and the final one
    frames = ref.simulate(ref.STACK_START, 900, 15, correction=True, capture_every=1).captured
    assert run["peak_depth"] >= max(ref.max_depth(ys) for ys in frames) - 1e-12
    assert abs(run["peak_depth"] - max(ref.max_depth(ys) for ys in frames[1:] + [final])) < 1e-12
    motion = [((b - a) * 60) ** 2 for ys0, ys1 in zip(frames[-60:], frames[-59:] + [final])
              for a, b in zip(ys0, ys1)]
    assert abs(run["rms_motion"] - (sum(motion) / len(motion)) ** 0.5) < 1e-9
    timing = json.loads((tmp_path / "timing.json").read_text())
    assert timing["06-stack"]["main"]["us_per_step"] > 0
