"""``python -m benchmarks.planar``: µs per step of the 20-row pyramid for every planar solver, and for pymunk on
the same pyramid at the same iteration count, timed side by side in one run.

The pyramid is ``configs/planar/pyramid-20.yaml``'s scene (210 unit boxes, 5 cm apart in a row, friction
0.6), built by the scene plugin. Each planar solver steps it compiled, as the runner does (one batch row,
``solver.advance(state, steps)``), from the same fresh state every sample; its cost knob is set to
``--iterations`` where the solver has an ``iterations`` knob, and left at its default where the knob is
``substeps`` (the table gives every solver's passes over the contacts per step, so the work is in view). pymunk
gets the same boxes (mass and moment from the state, friction sqrt(mu) per shape since Chipmunk multiplies
the two coefficients, which gives mu on every contact, the ground a static box whose top is y = 0) with
``Space.iterations`` = ``--iterations`` and a collision slop of 0.01 m (the lab's), one ``Space.step`` per
step. The implementations take turns (``benchmarks.timing.interleaved``), medians are compared, and the ratios
are taken between figures of this one run; after the timed steps each row also says how far the pyramid
moved (largest sideways drift of a box and largest turn), so a fast solver that lets it fall shows as such.
"""

from __future__ import annotations

import argparse
import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.timing import Sample, interleaved

PYRAMID = Path(__file__).resolve().parent.parent / "configs" / "planar" / "pyramid-20.yaml"
Prepared = Callable[[], None]


def pyramid_spec(path: Path) -> Any:
    """The pyramid config, loaded and validated as stackx loads it."""
    from stackx.config import load

    return load(str(path))


def planar_solvers() -> list[Any]:
    """Every registered solver that steps the planar model, by name."""
    from stackx.registry import solvers

    found = []
    for entry in solvers.entries():
        cls = solvers.get(entry.name)
        if "planar" in getattr(cls, "models", ()):
            found.append(cls)
    return found


def params_for(cls: Any, iterations: int) -> Any:
    """The solver's defaults, with ``iterations`` where it has that knob."""
    fields = cls.Params.model_fields
    return cls.Params(**({"iterations": iterations} if "iterations" in fields else {}))


class StackxPyramid:
    """One planar solver stepping the pyramid compiled, from the same initial state every sample."""

    def __init__(self, cls: Any, params: Any, initial: Any, gravity: float, dt: float) -> None:
        self.cls, self.params, self.initial = cls, params, initial
        self.gravity, self.dt = np.array([gravity]), np.array([dt])
        self.last: Any = None

    def prepare(self, steps: int) -> Prepared:
        from stackx.kernel import compiled

        state = self.initial.copy()
        solver = self.cls([self.params], self.gravity, self.dt)
        self.last = state

        def go() -> None:
            with compiled(True):
                solver.advance(state, steps)

        return go

    def motion(self) -> tuple[float, float]:
        """Largest sideways drift and turn of a movable box after the last sample."""
        moving = self.initial.inv_mass[0] > 0
        drift = np.abs(self.last.x[0] - self.initial.x[0])[moving].max()
        turn = np.abs(self.last.angle[0] - self.initial.angle[0])[moving].max()
        return float(drift), float(turn)


class PymunkPyramid:
    """The same boxes in a pymunk ``Space``: ``iterations`` passes of its sequential impulses per step."""

    def __init__(self, initial: Any, iterations: int, gravity: float, dt: float) -> None:
        self.initial, self.iterations, self.gravity, self.dt = initial, iterations, gravity, dt
        self.bodies: list[Any] = []

    def prepare(self, steps: int) -> Prepared:
        import pymunk

        s = self.initial
        space = pymunk.Space()
        space.gravity = (0.0, self.gravity)
        space.iterations = self.iterations
        space.collision_slop = 0.01
        ground = pymunk.Poly(space.static_body, [(-1e3, -10.0), (1e3, -10.0), (1e3, 0.0), (-1e3, 0.0)])
        ground.friction = 1.0  # the product with each box's sqrt(mu) is mu: the ground as rough as the box
        space.add(ground)
        self.bodies = []
        for i in range(s.bodies):
            w, h, mu = 2.0 * s.hx[0, i], 2.0 * s.hy[0, i], math.sqrt(s.friction[0, i])
            if s.inv_mass[0, i] == 0.0:
                body = pymunk.Body(body_type=pymunk.Body.STATIC)
            else:
                body = pymunk.Body(1.0 / s.inv_mass[0, i], 1.0 / s.inv_inertia[0, i])
            body.position = (s.x[0, i], s.y[0, i])
            body.angle = s.angle[0, i]
            shape = pymunk.Poly.create_box(body, (w, h))
            shape.friction = mu
            space.add(body, shape)
            self.bodies.append(body)
        dt = self.dt

        def go() -> None:
            for _ in range(steps):
                space.step(dt)

        return go

    def motion(self) -> tuple[float, float]:
        s = self.initial
        moving = [i for i in range(s.bodies) if s.inv_mass[0, i] > 0]
        drift = max(abs(self.bodies[i].position.x - s.x[0, i]) for i in moving)
        turn = max(abs(self.bodies[i].angle - s.angle[0, i]) for i in moving)
        return float(drift), float(turn)


def pymunk_version() -> str | None:
    """pymunk's version, or None where it is not installed."""
    try:
        import pymunk
    except ImportError:
        return None
    return str(pymunk.version)


def run(json_path: Path, iterations: int, steps: int, repeats: int, config: Path) -> dict[str, Any]:
    from rich.console import Console
    from rich.table import Table

    console = Console(width=150)
    spec = pyramid_spec(config)
    first = spec.runs[0]
    initial = first.scene.build()
    gravity, dt = float(first.gravity), float(first.dt)
    subjects: dict[str, Any] = {}
    passes: dict[str, int] = {}
    knobs: dict[str, str] = {}
    for cls in planar_solvers():
        params = params_for(cls, iterations)
        name = cls.plugin_name
        subjects[name] = StackxPyramid(cls, params, initial, gravity, dt)
        passes[name] = cls.passes(params)
        knobs[name] = ", ".join(f"{k}={getattr(params, k)}" for k in ("iterations", "substeps")
                                if hasattr(params, k))
    version = pymunk_version()
    if version is not None:
        subjects["pymunk"] = PymunkPyramid(initial, iterations, gravity, dt)
        passes["pymunk"] = iterations
        knobs["pymunk"] = f"iterations={iterations}"
    for sub in subjects.values():  # compile (or load the cache) and import before anything is timed
        sub.prepare(1)()
    samples: dict[str, Sample] = interleaved({n: (lambda s=s: s.prepare(steps), steps) for n, s in subjects.items()},
                                             repeats)
    reference = samples.get("pymunk")
    table = Table(title=f"{config.name}: {initial.bodies} boxes, {steps} steps per sample, {repeats} samples each, "
                        f"iterations {iterations}" + (f", pymunk {version}" if version else ", pymunk not installed"))
    for col in ("solver", "knob", "passes/step", "µs/step (median)", "µs/step (min)", "÷ pymunk",
                "drift (m)", "turn (rad)"):
        table.add_column(col, justify="left" if col in ("solver", "knob") else "right")
    rows: dict[str, Any] = {}
    for name, sample in samples.items():
        drift, turn = subjects[name].motion()
        ratio = None if reference is None else sample.per_unit / reference.per_unit
        rows[name] = {**sample.as_dict(), "knob": knobs[name], "passes": passes[name], "over_pymunk": ratio,
                      "drift_m": drift, "turn_rad": turn}
        table.add_row(name, knobs[name], str(passes[name]), f"{sample.per_unit * 1e6:.0f}",
                      f"{min(sample.seconds) / sample.units * 1e6:.0f}", "-" if ratio is None else f"{ratio:.2f}",
                      f"{drift:.3g}", f"{turn:.3g}")
    console.print(table)
    doc = {"config": str(config), "boxes": initial.bodies, "steps": steps, "repeats": repeats,
           "iterations": iterations, "pymunk": version, "us_per_step": rows}
    json_path.parent.mkdir(parents=True, exist_ok=True)
    json_path.write_text(json.dumps(doc, indent=2) + "\n")
    console.print(f"figures written to {json_path}")
    return doc


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.planar", description=(
        "µs per step of the 20-row pyramid for every planar solver and for pymunk at the same iteration count, "
        "timed side by side in one run; writes the figures to a JSON file."))
    parser.add_argument("--json", type=Path, default=Path("out/planar-speed.json"), help="where the figures go")
    parser.add_argument("--iterations", type=int, default=10,
                        help="iterations of the solvers that have that knob, and pymunk's (default 10)")
    parser.add_argument("--steps", type=int, default=60, help="steps per timed sample (default 60)")
    parser.add_argument("--repeats", type=int, default=5, help="samples per implementation (default 5)")
    parser.add_argument("--config", type=Path, default=PYRAMID, help="the pyramid's config")
    args = parser.parse_args()
    if args.iterations < 1 or args.steps < 1 or args.repeats < 1:
        parser.error("--iterations, --steps and --repeats must be at least 1")
    run(args.json, args.iterations, args.steps, args.repeats, args.config)


if __name__ == "__main__":
    main()
