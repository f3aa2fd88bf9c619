"""``python -m benchmarks.planar``: µs per step of the planar solvers and of Box2D 3.1 and pymunk on the same piles,
timed side by side in one run, with the ratios the speed targets are stated in.

Piles (unit boxes unless said, friction 0.6, gravity -9.8, dt = 1/60, every box at rest where it belongs):
pyramids of 10, 20, 30, 40 and 60 rows (5 cm apart in a row, the ``pyramid`` scene), a brick wall of 65 bricks
(1 m x 0.5 m, ten courses of 7 and 6 in running bond, 1 cm joints) and a pile of 1,000 boxes (25 courses of
40, every other course shifted a quarter box). Subjects:

- stackx's planar solvers stepping one batch row compiled on one thread, as the runner does
  (``solver.advance(state, steps)``): ``planar-pgs`` and ``planar-warm-start`` at 10 and 30 iterations,
  ``planar-soft-step``, ``planar-ngs`` and ``planar-xpbd`` at their defaults, ``planar-exact`` on piles up to
  ``--exact-boxes`` boxes (its cost is a sparse factorisation, the reference, not a speed subject);
- Box2D 3.1 (pyb2d3) at its defaults with 4 substeps, one ``world.step`` call per step, on one thread (no
  thread pool given). Sleeping is off, so it steps every box every step as stackx does (asleep, a resting
  pile costs Box2D almost nothing);
- pymunk at 10 and 30 iterations (collision slop 0.01 m), one ``Space.step`` per step.

The engines get the same boxes (mass and moment of inertia from the state), and the ground is a static box
whose top is y = 0; Box2D mixes frictions as ``sqrt(a b)`` and pymunk as ``a b``, so each is given what makes
every contact's coefficient the box's. Each sample starts from the same fresh state; implementations take
turns (``benchmarks.timing.interleaved``) and medians are compared. Every subject of the per-pile table runs
on one thread, so it is timed in the process's CPU time (``time.process_time``), which load from other
processes on the machine does not inflate; the batched figure uses threads and is wall time. Printed: the µs
per step, the ratios of the targets, the batched figure (``--batch`` rows of pyramid-20 stepped by one stackx
call of a quarter of ``--steps`` steps on a fresh solver, on every thread numba has, against Box2D stepping as
many worlds one call each) and, per subject, the exponent of a least-squares fit of cost against contact points
over the pyramids of 10, 20, 40 and 60 rows (1 is linear).
``--piles`` and ``--subjects`` restrict a run to some piles and subjects (the fit needs its four pyramids), and
``--batch 0`` leaves the batched figure out.
The drift of each pile (largest sideways motion and turn of a box over the timed steps) goes to the JSON
file, so a fast subject that lets a pile fall can be told.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.timing import Sample, fitted_exponent, interleaved

Prepared = Callable[[], None]
G, DT, FRICTION = -9.8, 1.0 / 60.0, 0.6
PYRAMIDS = (10, 20, 30, 40, 60)
SCALING = (10, 20, 40, 60)  # the pyramids the fit is over
STACKX = {  # subject name: (solver, knobs)
    "pgs 10": ("planar-pgs", {"iterations": 10}),
    "pgs 30": ("planar-pgs", {"iterations": 30}),
    "warm-start 10": ("planar-warm-start", {"iterations": 10}),
    "warm-start 30": ("planar-warm-start", {"iterations": 30}),
    "soft-step 4": ("planar-soft-step", {"substeps": 4}),
    "ngs": ("planar-ngs", {}),
    "xpbd": ("planar-xpbd", {}),
    "exact": ("planar-exact", {}),
}
BOX2D, PYMUNK = "Box2D 3.1 (4 sub.)", "pymunk {}"
RATIOS = (  # (numerator, denominator): the targets' comparisons
    ("soft-step 4", BOX2D), ("pgs 10", "pymunk 10"), ("warm-start 10", "pymunk 10"), ("pgs 30", "pymunk 30"),
    ("warm-start 30", "pymunk 30"))


def pyramid(rows: int) -> Any:
    from stackx.scenes.planar import Planar, PlanarParams, Pyramid

    return Planar(PlanarParams(pyramid=Pyramid(rows=rows, gap=0.05, friction=FRICTION))).build()


def courses(layers: int, counts: tuple[int, ...], width: float, height: float, joint: float,
            shifts: tuple[float, ...]) -> Any:
    """Bricks in ``layers`` courses, course ``k`` holding ``counts[k % len]`` bricks shifted ``shifts[k % len]``
    (m), centred on x = 0."""
    from stackx.scenes.planar import Body, Planar, PlanarParams

    boxes = []
    for k in range(layers):
        n, shift = counts[k % len(counts)], shifts[k % len(shifts)]
        left = -(n * width + (n - 1) * joint) / 2 + width / 2 + shift
        for i in range(n):
            boxes.append(Body(x=left + i * (width + joint), y=height * (k + 0.5), width=width, height=height,
                              friction=FRICTION))
    return Planar(PlanarParams(boxes=boxes)).build()


def scenes_names() -> list[str]:
    """The piles' names, as ``scenes`` keys them."""
    return [*(f"pyramid-{r}" for r in PYRAMIDS), "brick wall 65", "pile 1000"]


def scenes(exact_boxes: int) -> dict[str, Any]:
    out = {f"pyramid-{r}": pyramid(r) for r in PYRAMIDS}
    out["brick wall 65"] = courses(10, (7, 6), 1.0, 0.5, 0.01, (0.0, 0.0))
    out["pile 1000"] = courses(25, (40,), 1.0, 1.0, 0.05, (0.0, 0.25))
    return out


def contact_points(state: Any) -> int:
    """Points of the pile at rest (the model's collision test, touching or within Box2D's 2 cm)."""
    from stackx.models.planar.collide import collide

    room = 8 * state.bodies + 8
    out = (np.zeros(room, np.int64), np.zeros(room, np.int64), np.zeros((room, 2)), np.zeros((room, 2)),
           np.zeros(room), np.zeros(room, np.int64))
    return int(collide(state.x[0], state.y[0], state.angle[0], state.hx[0], state.hy[0], state.inv_mass[0] == 0.0,
                       0.02, *out))


class Subject:
    """Something that steps a pile: ``prepare(steps)`` builds it fresh and returns the timed call."""

    def prepare(self, steps: int) -> Prepared:
        raise NotImplementedError

    def motion(self) -> tuple[float, float]:
        """Largest sideways drift and turn of a movable box after the last sample."""
        raise NotImplementedError


class Stackx(Subject):
    """A planar solver stepping ``rows`` copies of the pile in one batch, compiled, on at most ``threads``."""

    def __init__(self, solver: str, knobs: dict[str, Any], initial: Any, rows: int = 1, threads: int = 1) -> None:
        from stackx.models.planar.state import PlanarState
        from stackx.registry import solvers

        self.cls = solvers.get(solver)
        self.params = self.cls.Params(**knobs)
        self.initial = initial if rows == 1 else PlanarState.concat([initial] * rows)
        self.rows, self.threads = rows, threads
        self.last: Any = None

    def prepare(self, steps: int) -> Prepared:
        from stackx.kernel import compiled, threads

        state = self.initial.copy()
        solver = self.cls([self.params] * self.rows, np.full(self.rows, G), np.full(self.rows, DT))
        self.last = state

        def go() -> None:
            with compiled(True), threads(self.threads):
                solver.advance(state, steps)

        return go

    def motion(self) -> tuple[float, float]:
        moving = self.initial.inv_mass[0] > 0
        drift = np.abs(self.last.x[0] - self.initial.x[0])[moving].max()
        turn = np.abs(self.last.angle[0] - self.initial.angle[0])[moving].max()
        return float(drift), float(turn)


class Engine(Subject):
    """An engine's bodies for the pile; ``positions()`` gives ``(x, angle)`` of every box."""

    def __init__(self, initial: Any) -> None:
        self.initial = initial
        self.world: Any = None

    def positions(self) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def motion(self) -> tuple[float, float]:
        s = self.initial
        moving = s.inv_mass[0] > 0
        x, angle = self.positions()
        return float(np.abs(x - s.x[0])[moving].max()), float(np.abs(angle - s.angle[0])[moving].max())


class Box2D(Engine):
    """Box2D 3.1 worlds (``worlds`` of them, each stepped by its own call): defaults, 4 substeps, no sleep."""

    def __init__(self, initial: Any, worlds: int = 1) -> None:
        super().__init__(initial)
        self.worlds = worlds
        self.bodies: list[Any] = []

    def build(self) -> Any:
        import pyb2d3 as b2

        s = self.initial
        world = b2.World(gravity=(0.0, G))
        world.sleeping_enabled = False
        moving = np.flatnonzero(s.inv_mass[0] > 0)
        floor_mu = float(s.friction[0, moving[0]]) if len(moving) else FRICTION
        ground = world.create_static_body(position=(0.0, 0.0))
        ground.create_polygon_shape(b2.shape_def(material=b2.surface_material(friction=floor_mu)),
                                    b2.box(1e3, 10.0, center=(0.0, -10.0)))
        bodies = []
        for i in range(s.bodies):
            place = {"position": (float(s.x[0, i]), float(s.y[0, i])), "rotation": float(s.angle[0, i])}
            static = s.inv_mass[0, i] == 0.0
            body = world.create_static_body(**place) if static else world.create_dynamic_body(**place)
            body.create_polygon_shape(b2.shape_def(density=1.0, material=b2.surface_material(
                friction=float(s.friction[0, i]))), b2.box(float(s.hx[0, i]), float(s.hy[0, i])))
            if not static:
                masses = body.mass_data
                masses.mass = 1.0 / float(s.inv_mass[0, i])
                masses.rotational_inertia = 1.0 / float(s.inv_inertia[0, i])
                body.mass_data = masses
            bodies.append(body)
        return world, bodies

    def prepare(self, steps: int) -> Prepared:
        built = [self.build() for _ in range(self.worlds)]
        worlds = [w for w, _ in built]
        self.world, self.bodies = worlds, built[0][1]  # the bodies are handles: their worlds must outlive them

        def go() -> None:
            for _ in range(steps):
                for world in worlds:
                    world.step(DT, 4)

        return go

    def positions(self) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([b.position[0] for b in self.bodies]),
                np.array([b.angle for b in self.bodies]))


class Pymunk(Engine):
    """The pile in a pymunk ``Space`` with ``iterations`` passes of sequential impulses per step."""

    def __init__(self, initial: Any, iterations: int) -> None:
        super().__init__(initial)
        self.iterations = iterations
        self.bodies: list[Any] = []

    def prepare(self, steps: int) -> Prepared:
        import pymunk

        s = self.initial
        space = pymunk.Space()
        space.gravity = (0.0, G)
        space.iterations = self.iterations
        space.collision_slop = 0.01
        ground = pymunk.Poly(space.static_body, [(-1e3, -10.0), (1e3, -10.0), (1e3, 0.0), (-1e3, 0.0)])
        ground.friction = 1.0  # Chipmunk multiplies: each box's sqrt(mu) squared against another box, 1 x mu here
        space.add(ground)
        self.world, self.bodies = space, []
        for i in range(s.bodies):
            if s.inv_mass[0, i] == 0.0:
                body = pymunk.Body(body_type=pymunk.Body.STATIC)
            else:
                body = pymunk.Body(1.0 / s.inv_mass[0, i], 1.0 / s.inv_inertia[0, i])
            body.position = (s.x[0, i], s.y[0, i])
            body.angle = s.angle[0, i]
            shape = pymunk.Poly.create_box(body, (2.0 * s.hx[0, i], 2.0 * s.hy[0, i]))
            shape.friction = math.sqrt(s.friction[0, i])
            space.add(body, shape)
            self.bodies.append(body)

        def go() -> None:
            for _ in range(steps):
                space.step(DT)

        return go

    def positions(self) -> tuple[np.ndarray, np.ndarray]:
        return np.array([b.position.x for b in self.bodies]), np.array([b.angle for b in self.bodies])


@dataclass
class Timed:
    """One scene's figures: µs per step by subject, and each subject's drift and turn."""

    us: dict[str, float]
    motion: dict[str, tuple[float, float]]


def time_scene(initial: Any, steps: int, repeats: int, exact: bool, console: Any,
               chosen: set[str] | None = None) -> Timed:
    """µs per step of every subject on one pile (only those named in ``chosen`` when given)."""
    subjects: dict[str, Subject] = {}
    for name, (solver, knobs) in STACKX.items():
        if solver != "planar-exact" or exact:
            subjects[name] = Stackx(solver, knobs, initial)
    subjects[BOX2D] = Box2D(initial)
    for it in (10, 30):
        subjects[PYMUNK.format(it)] = Pymunk(initial, it)
    if chosen is not None:
        subjects = {n: s for n, s in subjects.items() if n in chosen}
    for name, sub in list(subjects.items()):  # compile (or load the cache) and import before anything is timed
        try:
            sub.prepare(1)()
        except Exception as exc:  # an implementation that cannot step the pile is reported, the others timed
            console.print(f"[yellow]{name} left out: {type(exc).__name__}: {exc}[/yellow]")
            del subjects[name]
    samples: dict[str, Sample] = interleaved({n: (lambda s=s: s.prepare(steps), steps) for n, s in subjects.items()},
                                             repeats, time.process_time)
    return Timed({n: s.per_unit * 1e6 for n, s in samples.items()}, {n: subjects[n].motion() for n in samples})


def against(us: float, box2d: float) -> str:
    """How ``us`` per world-step compares with Box2D's ``box2d``, said the way round that reads true: "2.5x fewer
    than Box2D", or "1.2x more than Box2D" (a ratio below 1 put as "fewer" would hide that stackx is slower)."""
    if not (us > 0.0 and box2d > 0.0):
        return "no comparison"
    return f"{box2d / us:.1f}x fewer than Box2D" if us <= box2d else f"{us / box2d:.1f}x more than Box2D"


def time_batch(initial: Any, rows: int, steps: int, repeats: int) -> dict[str, float]:
    """µs per world-step: ``rows`` copies of the pile in one stackx batch (every thread numba has), and Box2D
    stepping as many worlds one call each."""
    import numba

    subjects: dict[str, Subject] = {name: Stackx(solver, knobs, initial, rows, numba.config.NUMBA_NUM_THREADS)
                                    for name, (solver, knobs) in STACKX.items() if solver != "planar-exact"}
    subjects[BOX2D] = Box2D(initial, rows)
    for sub in subjects.values():
        sub.prepare(1)()
    samples = interleaved({n: (lambda s=s: s.prepare(steps), steps * rows) for n, s in subjects.items()}, repeats)
    return {n: s.per_unit * 1e6 for n, s in samples.items()}


def subject_names() -> list[str]:
    """Every subject of the per-pile table, by the name the table and ``--subjects`` use."""
    return [*STACKX, BOX2D, *(PYMUNK.format(it) for it in (10, 30))]


def run(json_path: Path, steps: int, repeats: int, batch: int, exact_boxes: int, only_piles: list[str] | None = None,
        only_subjects: list[str] | None = None) -> dict[str, Any]:
    """Time the piles (``only_piles`` of them when given) with the subjects (``only_subjects``), print the
    tables and write the figures; ``batch`` 0 leaves the batched figure out."""
    import numba
    from rich.console import Console
    from rich.table import Table

    console = Console(width=200)
    piles = scenes(exact_boxes)
    if only_piles is not None:
        piles = {name: pile for name, pile in piles.items() if name in only_piles}
    chosen = set(only_subjects) if only_subjects is not None else None
    timed: dict[str, Timed] = {}
    points: dict[str, int] = {}
    for name, initial in piles.items():
        points[name] = contact_points(initial)
        console.print(f"timing {name}: {initial.bodies} boxes, {points[name]} contact points")
        timed[name] = time_scene(initial, steps, repeats, initial.bodies <= exact_boxes, console, chosen)
    names = list(dict.fromkeys(n for t in timed.values() for n in t.us))
    table = Table(title=f"CPU µs per step (median of {repeats} samples of {steps} steps; stackx compiled, one thread)")
    table.add_column("pile")
    for n in names:
        table.add_column(n, justify="right")
    for pile, t in timed.items():
        table.add_row(f"{pile} ({piles[pile].bodies} boxes)", *(f"{t.us[n]:,.0f}" if n in t.us else "-" for n in names))
    console.print(table)
    ratios = Table(title="ratios (below 1: stackx faster)")
    ratios.add_column("pile")
    for a, b in RATIOS:
        ratios.add_column(f"{a} ÷ {b}", justify="right")
    for pile, t in timed.items():
        ratios.add_row(pile, *(f"{t.us[a] / t.us[b]:.2f}" if a in t.us and b in t.us else "-" for a, b in RATIOS))
    console.print(ratios)
    scaling = {}
    if all(f"pyramid-{r}" in timed for r in SCALING):
        sizes = [points[f"pyramid-{r}"] for r in SCALING]
        for n in names:
            costs = [timed[f"pyramid-{r}"].us.get(n) for r in SCALING]
            if all(c is not None for c in costs):
                scaling[n] = fitted_exponent(sizes, costs)  # type: ignore[arg-type]
        console.print("exponent of µs/step against contact points over pyramids " + "/".join(map(str, SCALING))
                      + f" ({'/'.join(map(str, sizes))} points): "
                      + ", ".join(f"{n} {e:.2f}" for n, e in scaling.items()))
    per_call = max(1, steps // 4)
    batched = time_batch(pyramid(20), batch, per_call, repeats) if batch else {}
    box2d = batched.get(BOX2D, math.nan)
    if batched:
        call = f"one call of {per_call} step{'s' if per_call > 1 else ''} for the batch, a fresh solver each sample"
        console.print(f"pyramid-20 x {batch} worlds, µs per world-step (stackx: {call}, "
                      f"{numba.config.NUMBA_NUM_THREADS} threads; Box2D: one call per world and step, one thread): "
                      + ", ".join(f"{n} {us:.1f} ({against(us, box2d)})" for n, us in batched.items() if n != BOX2D)
                      + f", {BOX2D} {box2d:.1f}")
    doc = {"steps": steps, "repeats": repeats, "boxes": {p: s.bodies for p, s in piles.items()},
           "contact_points": points, "us_per_step": {p: t.us for p, t in timed.items()},
           "drift_m_turn_rad": {p: t.motion for p, t in timed.items()}, "scaling_exponent": scaling,
           "batched": {"rows": batch, "steps_per_call": per_call if batch else 0,
                       "threads": numba.config.NUMBA_NUM_THREADS, "us_per_world_step": batched}}
    json_path.parent.mkdir(parents=True, exist_ok=True)
    json_path.write_text(json.dumps(doc, indent=2) + "\n")
    console.print(f"figures written to {json_path}")
    return doc


def main() -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.planar", description=(
        "µs per step of the planar solvers, Box2D 3.1 and pymunk on the same piles, timed side by side in one "
        "run, with ratios, batched stepping and a scaling fit; writes the figures to a JSON file."))
    parser.add_argument("--json", type=Path, default=Path("out/planar-speed.json"), help="where the figures go")
    parser.add_argument("--steps", type=int, default=20, help="steps per timed sample (default 20)")
    parser.add_argument("--repeats", type=int, default=5, help="samples per implementation (default 5)")
    parser.add_argument("--batch", type=int, default=64,
                        help="rows of the batched pyramid-20 (default 64; 0 leaves the batched figure out)")
    parser.add_argument("--piles", nargs="+", metavar="PILE", choices=list(scenes_names()),
                        help="time only these piles (default: all): " + ", ".join(scenes_names()))
    parser.add_argument("--subjects", nargs="+", metavar="SUBJECT", choices=subject_names(),
                        help="time only these subjects (default: all): " + ", ".join(subject_names()))
    parser.add_argument("--exact-boxes", type=int, default=500,
                        help="planar-exact is timed on piles of at most this many boxes (default 500)")
    args = parser.parse_args()
    if args.steps < 1 or args.repeats < 1 or args.batch < 0:
        parser.error("--steps and --repeats must be at least 1, --batch at least 0")
    run(args.json, args.steps, args.repeats, args.batch, args.exact_boxes, args.piles, args.subjects)


if __name__ == "__main__":
    main()
