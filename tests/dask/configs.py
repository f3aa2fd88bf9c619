"""Configs the executor tests run: a sweep with every kind of output, and sweeps that blow up."""

from __future__ import annotations

from pathlib import Path

SWEEP = """
description: The lab's five boxes over two lengths, three percents and two iteration counts.
scene: {name: column, stack: {count: 5, y0: 2.5, spacing: 1.6}}
solver: {name: pgs, iterations: 15, correction: {slop: 0.01, percent: 0.2}}
dt: 1/60
steps: 300
sweep:
  name: r{index}
  grid: {steps: [240, 300], solver.correction.percent: [0.1, 0.2, 0.4], solver.iterations: [4, 15]}
outputs:
  - sink: keyvalue
    path: sweep.txt
    values: {low: r0.max_depth, high: "r11.y[-1]"}
  - sink: metrics
    path: sweep.metrics.json
  - render: stack
    path: stack.png
    run: r3
  - render: frames
    path: f{index:02d}.png
    every: 20
    count: 6
    run: r7
    player: index.html
"""
"""12 runs in two batches of 6 (the runner batches by steps); the frames come from the second batch."""

BLOWS = """
description: Boxes dropped under several gravities; the fast ones pass limits.max_speed at different steps.
scene: {name: column, boxes: [{y: 0.5}, {y: 30.0}]}
solver: {name: pgs}
steps: 120
limits: {max_speed: 5}
runs:
  early: {steps: 100, gravity: -1.0}
  slow: {gravity: -1.0}
  late: {gravity: -4.0}
  calm: {gravity: -2.0}
  fast: {gravity: -9.8}
  fast2: {gravity: -9.8, solver.iterations: 3}
  mild: {gravity: -3.0}
  after: {steps: 130, gravity: -1.0}
outputs:
  - sink: metrics
    path: blows.metrics.json
"""
"""Three batches (100, 120 and 130 steps). A box falling from 30 m passes 5 m/s after 5/|g| seconds: at step
31 for 'fast' and 'fast2', 76 for 'late', 101 for 'mild'; 'slow' and 'calm' never do within 120 steps. The
first batch finishes, the second blows up, the third never runs."""


def write(folder: Path, name: str, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{name}.yaml"
    path.write_text(text)
    return path
