"""Hand-built planar worlds for the solver tests: one batch row of boxes, stepped by a named solver."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from stackx import kernel
from stackx.models.planar.collide import collide
from stackx.models.planar.state import PlanarState, box_mass
from stackx.registry import solvers

G, DT = -9.8, 1.0 / 60.0


def world(boxes: list[dict[str, Any]]) -> PlanarState:
    """One row of boxes given as dicts: ``x, y`` and optionally ``angle, vx, vy, w, hx, hy, density, mu,
    static`` (defaults: unit box of density 1, mu 0.5, at rest)."""
    cols: dict[str, list[float]] = {k: [] for k in PlanarState.BODY}
    for box in boxes:
        hx, hy = box.get("hx", 0.5), box.get("hy", 0.5)
        mass, inertia = box_mass(hx, hy, box.get("density", 1.0))
        static = box.get("static", False)
        values = {"x": box["x"], "y": box["y"], "angle": box.get("angle", 0.0), "vx": box.get("vx", 0.0),
                  "vy": box.get("vy", 0.0), "w": box.get("w", 0.0), "inv_mass": 0.0 if static else 1.0 / mass,
                  "inv_inertia": 0.0 if static else 1.0 / inertia, "hx": hx, "hy": hy, "friction": box.get("mu", 0.5)}
        for k in PlanarState.BODY:
            cols[k].append(values[k])
    return PlanarState(*(np.array([cols[k]], dtype=np.float64) for k in PlanarState.BODY))


def solver(name: str, params: dict[str, Any] | None = None, g: float = G, dt: float = DT) -> Any:
    cls = solvers.get(name)
    return cls([cls.Params(**(params or {}))], np.array([g]), np.array([dt]))


def held_memory(solver: Any, state: PlanarState) -> list[tuple[bytes, bytes]]:
    """Per row, the keys and impulses a memory solver holds for its next step, as bytes: a row's memory is
    read only up to its ``held`` (the rest of the room is whatever was there)."""
    keys, carried, count = solver.memory(state)
    return [(keys[b, :count[b]].tobytes(), carried[b, :count[b]].tobytes()) for b in range(state.batch)]


def run(name: str, state: PlanarState, steps: int, params: dict[str, Any] | None = None, g: float = G,
        compiled: bool | None = None) -> PlanarState:
    """Step ``state`` in place (plain, compiled, or the kernel's default when ``compiled`` is None)."""
    s = solver(name, params, g)
    if compiled is None:
        s.advance(state, steps)
    else:
        with kernel.compiled(compiled):
            s.advance(state, steps)
    return state


def lowest_corner(x: float, y: float, angle: float, hx: float, hy: float) -> float:
    """Height of a box's lowest corner, from its geometry."""
    return y - abs(math.sin(angle)) * hx - abs(math.cos(angle)) * hy


def deepest(state: PlanarState) -> float:
    """The largest overlap of row 0 (0 when nothing overlaps), by the model's own collision test."""
    room = 8 * state.bodies + 8
    out = (np.zeros(room, np.int64), np.zeros(room, np.int64), np.zeros((room, 2)), np.zeros((room, 2)),
           np.zeros(room), np.zeros(room, np.int64))
    n = collide(state.x[0], state.y[0], state.angle[0], state.hx[0], state.hy[0], state.inv_mass[0] == 0.0, 0.0,
                *out)
    return float(max(out[4][:n].max(), 0.0)) if n else 0.0


def ramp(angle: float, mu: float, slide_from: float = 3.0) -> PlanarState:
    """A static plank tilted by ``angle`` (rising to the right), high above the ground, and a unit box resting
    flat on it ``slide_from`` m up the slope from the plank's centre, both of friction ``mu``."""
    c, s = math.cos(angle), math.sin(angle)
    plank = {"x": 0.0, "y": 20.0, "angle": angle, "hx": 12.0, "hy": 0.5, "static": True, "mu": mu}
    lx, ly = slide_from, 1.0  # the box's centre in the plank's frame: on its top face
    box = {"x": c * lx - s * ly, "y": 20.0 + s * lx + c * ly, "angle": angle, "mu": mu}
    return world([plank, box])


def laid_step(s: PlanarState, ids: np.ndarray, table: np.ndarray, count: int,
              block: bool) -> tuple[int, int, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Row 0 of ``s`` laid out for the passes as a solver lays out its step (``stackx.solvers.planar.passes``):
    the manifolds, the visiting groups, the groups' running tally, and the links, rows and bodies the passes
    read and write (velocities loaded)."""
    from stackx.solvers.planar import passes as laid
    from stackx.solvers.planar.wavefront import manifold_starts

    first, order, group, tally, latest, links, rows, bodies = laid.laid_workspace(ids.shape[0], s.bodies)
    m = manifold_starts(ids, count, first)
    groups = laid.visiting_order(ids, table, first, m, latest, group, tally, order)
    laid.lay_out(s.x[0], s.y[0], s.inv_mass[0], s.inv_inertia[0], s.friction[0], ids, table, first, order, m, DT,
                 block, links, rows)
    laid.load_velocities(s.vx[0], s.vy[0], s.w[0], s.inv_mass[0], s.inv_inertia[0], bodies)
    return m, groups, tally, links, rows, bodies
