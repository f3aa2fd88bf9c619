"""Measures of finished planar runs, from the recorded states of their batch and, for the bench, the scene.

What a run is summarised by (``SCALARS``, ``VECTORS``) comes from the states alone: the final poses and
velocities, the final and peak contact depths by the model's own collision test (never a solver's report),
how far a box ever got into another (``reach``), the fastest launch, and the RMS motion over the final window.

The bench adds what needs the scene: which boxes were placed where they should stay (their **drift**: how far
they moved sideways, ``drift_x``, and turned, ``drift_angle``, from the start to the end), where the top of a
rigid pile would be (``top_rest_error``), the ramp's analytic answer (``slide_error`` where the box sticks or
slides, ``tip_turn`` where it tips or pivots), where a skidding box stopped (``stop_error``), how the boxes
that should end on a face or fallen ended (``land_tilt``, ``fall_tilt``), and how far those placed past their
support's edge fell (``drop``). Every measure is
deterministic.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from stackx.models.planar.collide import collide
from stackx.models.planar.monitor import contact_room
from stackx.models.planar.state import PlanarState

if TYPE_CHECKING:
    from stackx.run.results import RunResult

MOTION_WINDOW = 60  # steps over which the final motion is measured, as on the column

SCALARS = {
    "max_depth": "largest contact penetration in the final state, by the model's collision test (m)",
    "peak_depth": "largest contact depth after any step of the run (m)",
    "reach": "largest depth after any step as a share of the thinner body's smaller half-size (>1: passed "
             "half-way)",
    "launch": "fastest upward velocity of a movable box after it first touched something (overlapping, at zero "
              "depth or at most 2 cm apart), from positions (m/s)",
    "unsolved_steps": "steps whose velocity problem the solver solves to a tolerance (planar-exact) and missed it "
                      "on: each kept the best answer found; 0 for the other solvers",
    "first_unsolved": "the first such step, counted from 0 (-1: none)",
    "worst_unsolved": "the largest residual of an answer kept on such a step (m/s; 0: none)",
    "rms_motion": f"RMS over movable boxes and the last {MOTION_WINDOW} steps of each box's actual motion, "
                  "sqrt(dx^2 + dy^2 + (r da)^2)/dt with r its half-diagonal (m/s)",
}
VECTORS = {
    "x": "final centre, horizontal, per body (m)",
    "y": "final centre height, per body (m)",
    "angle": "final rotation, per body (rad, counter-clockwise)",
    "vx": "final horizontal velocity (m/s)",
    "vy": "final vertical velocity (m/s)",
    "w": "final angular velocity (rad/s)",
}


def half_diagonal(state: PlanarState) -> np.ndarray:
    """Distance from each box's centre to its corners, ``(batch, bodies)``: turns rotation into a speed."""
    return np.hypot(state.hx, state.hy)  # type: ignore[no-any-return]


def contacts(state: PlanarState, b: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Row ``b``'s touching points by the model's collision test (no margin): ``body_a`` (-1 the ground),
    ``body_b`` and ``depth`` (m, positive overlapping)."""
    x, y, angle, hx, hy = (getattr(state, k)[b] for k in ("x", "y", "angle", "hx", "hy"))
    room = contact_room(x.shape[0])
    while True:
        body_a, body_b = np.empty(room, np.int64), np.empty(room, np.int64)
        normal, point = np.empty((room, 2)), np.empty((room, 2))
        depth, feature = np.empty(room), np.empty(room, np.int64)
        count = collide(x, y, angle, hx, hy, state.inv_mass[b] == 0.0, 0.0, body_a, body_b, normal, point, depth,
                        feature)
        if count <= room:
            return body_a[:count], body_b[:count], depth[:count]
        room = count


def max_depth(state: PlanarState, b: int = 0) -> float:
    """The deepest overlap of row ``b`` (m), 0 when nothing overlaps."""
    depth = contacts(state, b)[2]
    return float(max(0.0, depth.max())) if depth.size else 0.0


def motion_steps(steps: int) -> range:
    """The steps whose states ``rms_motion`` needs: the last ``MOTION_WINDOW`` + 1."""
    return range(max(0, steps - MOTION_WINDOW), steps + 1)


def rms_motion(frames: Mapping[int, PlanarState], steps: int, dt: np.ndarray) -> np.ndarray:
    """Per batch row, the RMS over movable boxes and the window's steps of each box's actual motion per step,
    ``sqrt(dx^2 + dy^2 + (r da)^2)/dt``; what solvers store as velocities does not count. Each row is summed
    from its own contiguous values, so a run gives the same bits in a batch as alone."""
    window = motion_steps(steps)
    first = frames[window[0]]
    batch = first.batch
    if len(window) < 2:
        return np.zeros(batch)
    pose = np.stack([np.stack([frames[k].x, frames[k].y, frames[k].angle]) for k in window])  # (w, 3, batch, n)
    step = np.diff(pose, axis=0)
    r = half_diagonal(first)
    sq = (step[:, 0] ** 2 + step[:, 1] ** 2 + (r[None] * step[:, 2]) ** 2) / np.asarray(dt, float)[None, :, None] ** 2
    out = np.zeros(batch)
    movable = first.inv_mass != 0.0
    for b in range(batch):
        values = np.ascontiguousarray(sq[:, b, movable[b]]).ravel()
        out[b] = np.sqrt(values.mean()) if values.size else 0.0
    return out


def state_measures(state: PlanarState) -> dict[str, float | list[float]]:
    """The measures one state (a batch of one) gives on its own: all but ``rms_motion``."""
    out: dict[str, float | list[float]] = {k: getattr(state, k)[0].tolist() for k in VECTORS}
    out.update({"max_depth": max_depth(state), "peak_depth": float(max(state.peak_depth[0], 0.0)),
                "reach": float(max(state.reach[0], 0.0)), "launch": float(max(state.launch[0], 0.0)),
                "unsolved_steps": int(state.unsolved[0]), "first_unsolved": int(state.first_unsolved[0]),
                "worst_unsolved": float(state.worst_unsolved[0])})
    return out


def measure(frames: Mapping[int, PlanarState], steps: int, dt: np.ndarray) -> list[dict[str, float | list[float]]]:
    """Every named measure of every row of a batch (``frames[steps]`` the final states)."""
    motion = rms_motion(frames, steps, dt)
    final = frames[steps]
    return [{**state_measures(final.row(b)), "rms_motion": float(motion[b])} for b in range(final.batch)]


def drift(start: PlanarState, end: PlanarState, bodies: list[int]) -> dict[str, float]:
    """How far the ``bodies`` (placed where they should stay) moved from ``start`` to ``end`` (row 0 of each):
    ``drift_x``, the largest horizontal displacement (m), and ``drift_angle``, the largest change of angle
    (rad). A box that slides off or topples shows in one or the other; sinking into a contact does not (depth
    and the top's rest height judge that)."""
    if not bodies:
        return {}
    idx = np.asarray(bodies)
    return {"drift_x": float(np.abs(end.x[0, idx] - start.x[0, idx]).max()),
            "drift_angle": float(np.abs(end.angle[0, idx] - start.angle[0, idx]).max())}


def tilts(start: PlanarState, end: PlanarState, lands: list[int], falls: list[int]) -> dict[str, float]:
    """How the boxes that should end on a face or fallen did (row 0): ``land_tilt``, the largest distance of a
    landing box's final angle from a multiple of 90 degrees (rad; 0 lying flat or upright on a face), and
    ``fall_tilt``, the smallest final tilt from upright of a box placed to topple (rad, folded into
    [0, pi/2]; a domino leaning on the next reads its lean, one still standing reads 0)."""
    out: dict[str, float] = {}
    quarter = np.pi / 2
    if lands:
        a = end.angle[0, np.asarray(lands)]
        out["land_tilt"] = float(np.abs(a - quarter * np.round(a / quarter)).max())
    if falls:
        a = np.abs(np.remainder(end.angle[0, np.asarray(falls)] + np.pi, 2 * np.pi) - np.pi)  # [0, pi]
        out["fall_tilt"] = float(np.minimum(a, np.pi - a).min())
    return out


def dropped(start: PlanarState, end: PlanarState, drops: list[int]) -> dict[str, float]:
    """How far the boxes placed past their support's edge fell (row 0): ``drop``, the smallest of their falls
    from start to end, each in its own heights (its full height, ``2 hy``). A box that fell off a ledge one
    box high onto the ground reads at least 1; one still on its support reads about 0. Its final angle is not
    read: a box tumbling off a ledge may end on any face."""
    if not drops:
        return {}
    idx = np.asarray(drops)
    fell = (start.y[0, idx] - end.y[0, idx]) / (2 * start.hy[0, idx])
    return {"drop": float(fell.min())}


def slide(end: PlanarState, box: int, angle: float, expected: float, time: float) -> dict[str, float]:
    """A ramp box's acceleration down the slope of ``angle`` (rad), from its final velocity after ``time``
    seconds from rest (symplectic steps give ``v = a t`` exactly under a constant force), and its distance
    from ``expected``: ``slide_acceleration`` and ``slide_error`` (m/s^2)."""
    down = -(end.vx[0, box] * np.cos(angle) + end.vy[0, box] * np.sin(angle))
    measured = float(down) / time
    return {"slide_acceleration": measured, "slide_error": abs(measured - expected)}


def tipped(start: PlanarState, end: PlanarState, box: int) -> dict[str, float]:
    """How far a ramp box that should go over its downhill corner turned (row 0): ``tip_turn``, its final angle
    minus its starting one (rad, counter-clockwise, which is downhill: the slope falls towards -x). Lying on its
    next face it reads pi/2; a box that stayed on its base reads about 0, one that fell uphill reads negative."""
    return {"tip_turn": float(end.angle[0, box] - start.angle[0, box])}


def stopped(start: PlanarState, end: PlanarState, box: int, shortest: float, longest: float) -> dict[str, float]:
    """Where a skidding box stopped (row 0): ``stop_distance``, how far it went along x from its start (m), and
    ``stop_error``, how far that lies outside [``shortest``, ``longest``] as a share of ``longest`` (0 inside):
    the distance of the model's own steps and v^2 / (2 mu g), between which every step size lands."""
    distance = float(end.x[0, box] - start.x[0, box])
    return {"stop_distance": distance, "stop_error": max(shortest - distance, distance - longest, 0.0) / longest}


def bench_measures(result: RunResult) -> dict[str, float]:
    """What the bench's criteria read beyond the run's measures, from the scene: ``boxes``; ``drift_x`` and
    ``drift_angle`` where boxes should rest; ``top_rest_error`` (final height of the pile's top box minus its
    height on rigid boxes, negative when the pile sank), ``rest_contacts`` (contacts under it) and ``top_p2p``
    (its peak-to-peak height over the final window) where the scene is one pile; ``slide_acceleration`` /
    ``slide_error`` on a ramp whose box sticks or slides (and ``slide_turn``, how far a sliding one turned,
    rad), ``tip_turn`` on one whose box tips or pivots; ``stop_distance`` / ``stop_error`` on a skid;
    ``land_tilt`` and ``fall_tilt`` where boxes should end on a face or fallen; ``drop`` where boxes should fall
    off their support."""
    scene, final, steps = result.spec.scene, result.final, result.spec.steps
    out: dict[str, float] = {"boxes": float(final.bodies)}
    start = scene.build()
    out.update(drift(start, final, scene.rests()))
    out.update(tilts(start, final, scene.lands(), scene.falls()))
    out.update(dropped(start, final, getattr(scene, "drops", list)()))
    top = scene.rest_top()
    if top is not None:
        body, height, contacts_below = top
        tops = [float(result.frames[k].y[0, body]) for k in motion_steps(steps)]
        out.update({"top_rest_error": float(final.y[0, body]) - height, "rest_contacts": float(contacts_below),
                    "top_p2p": max(tops) - min(tops)})
    slope = scene.slope()
    if slope is not None and slope.turns_over:
        out.update(tipped(start, final, slope.box))
    elif slope is not None:
        out.update(slide(final, slope.box, slope.angle, slope.acceleration(result.spec.gravity),
                         steps * result.spec.dt))
        if not slope.sticks:  # not placed at rest, so drift does not see it turn: it must slide flat
            out["slide_turn"] = float(abs(final.angle[0, slope.box] - start.angle[0, slope.box]))
    stop = getattr(scene, "stop", lambda: None)()
    if stop is not None:
        gravity = result.spec.gravity
        out.update(stopped(start, final, stop.box, stop.stepped(gravity, result.spec.dt), stop.distance(gravity)))
    return out


def unjudged(scene: Any) -> tuple[str, ...]:
    """Measures whose check cannot pass or fail on this scene: a box sliding down a ramp never settles, and
    where one that goes over its corner ends up is not stated (it may land and stay, or tumble on)."""
    slope = getattr(scene, "slope", lambda: None)()
    return ("rms_motion",) if slope is not None and not slope.sticks else ()
