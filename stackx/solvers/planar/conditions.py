"""How far a solver's own answer to a step is from the step's contact conditions, needing no reference.

The reference solve (``stackx.solvers.planar.reference``) says how far a solver's velocities are from the
exact answer, at the cost of solving every step exactly. This module measures what a solver's answer itself
breaks, at the cost of one pass over the step's points, so it can run on every step of every run:

- with the solver's impulses (``violations``): each condition of the contract
  (``stackx.solvers.planar.problem``) on its own, in m/s: a point approaching faster than its target
  (*penetration*), a normal impulse below zero (*pull*, as the velocity it would give the point alone),
  a point pushing while it separates faster than its target (*complementarity*, the smaller of the two), a
  tangent impulse outside Coulomb's box (*box*), and friction not opposing the slip at its bound or a point
  slipping while friction is inside the box (*dissipation*, the slip it lets through, at most the
  friction's distance from its bound as a speed, so a friction at its bound but for rounding reads as at
  it, as in the residual; a point that does not push has no friction to check);
- with velocities alone (``approach``), what a solver that keeps its impulses to itself (an engine) still
  shows: the fastest approach beyond a point's target. Friction and complementarity need the impulses.

Every figure is 0 for an exact answer, and each is the largest over the step's points (NaN if any point's
is). Each is one or two compiled passes over the points (``stackx.kernel``; plain Python under
``STACKX_JIT=0``): a few tens of microseconds on a 20-row pyramid's step of about 1,000 points, where the
same in whole-array numpy calls took 20 times as long (``python3 -m benchmarks.planar_reference``'s ``own us``
column gives it per step of real runs). A solver's impulses
(``stackx.solvers.planar.base.StepImpulses``) reach the step's problem by ``matched``: each point of the
problem takes the impulses of the solver's point with the same ``(A, B, FEATURE)``, 0 where the solver had
no such point (it applied nothing there).
"""

from __future__ import annotations

import numpy as np

from stackx.kernel import compiled, enabled, kernel, leaf
from stackx.solvers.planar.problem import ContactProblem
from stackx.solvers.planar.contacts import COLUMNS, PN, PT, recall

CONDITIONS = ("penetration", "pull", "complementarity", "box", "dissipation")


@leaf
def point_velocity(velocity: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, body: int, rx: float,
                   ry: float, dx: float, dy: float) -> tuple[float, float]:
    """One side of a point: its velocity along the unit direction ``(dx, dy)`` at arm ``(rx, ry)``, and its
    share of the inverse effective mass along it (both 0 for the ground)."""
    if body < 0:
        return 0.0, 0.0
    along = (velocity[body, 0] - velocity[body, 2] * ry) * dx + (velocity[body, 1] + velocity[body, 2] * rx) * dy
    arm = rx * dy - ry * dx
    return along, inv_mass[body] + inv_inertia[body] * arm * arm


@leaf
def relative(velocity: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray, body_a: np.ndarray,
             body_b: np.ndarray, ra: np.ndarray, rb: np.ndarray, k: int, dx: float,
             dy: float) -> tuple[float, float]:
    """Point ``k``'s relative velocity along ``(dx, dy)`` and its inverse effective mass along it."""
    ua, wa = point_velocity(velocity, inv_mass, inv_inertia, body_a[k], ra[k, 0], ra[k, 1], dx, dy)
    ub, wb = point_velocity(velocity, inv_mass, inv_inertia, body_b[k], rb[k, 0], rb[k, 1], dx, dy)
    return ub - ua, wa + wb


@leaf
def raise_to(out: np.ndarray, i: int, value: float) -> None:
    """``out[i] = max(out[i], value)``, NaN winning."""
    if not value <= out[i]:
        out[i] = value


@kernel
def fastest_approach(inv_mass: np.ndarray, inv_inertia: np.ndarray, velocity: np.ndarray, body_a: np.ndarray,
                     body_b: np.ndarray, normal: np.ndarray, ra: np.ndarray, rb: np.ndarray,
                     target: np.ndarray) -> float:
    """``approach`` on the problem's arrays."""
    out = np.zeros(1)
    for k in range(body_a.shape[0]):
        un, _ = relative(velocity, inv_mass, inv_inertia, body_a, body_b, ra, rb, k, normal[k, 0], normal[k, 1])
        raise_to(out, 0, max(target[k] - un, 0.0) if un == un else un)
    return out[0]


@kernel
def condition_violations(inv_mass: np.ndarray, inv_inertia: np.ndarray, velocity: np.ndarray,
                         body_a: np.ndarray, body_b: np.ndarray, normal: np.ndarray, ra: np.ndarray,
                         rb: np.ndarray, friction: np.ndarray, target: np.ndarray, pn: np.ndarray,
                         pt: np.ndarray) -> np.ndarray:
    """``violations`` on the problem's arrays, in ``CONDITIONS``' order: one pass applying the impulses to a
    copy of the free velocities, one measuring each point."""
    v = velocity.copy()
    for k in range(body_a.shape[0]):
        nx, ny = normal[k, 0], normal[k, 1]
        px, py = pn[k] * nx - pt[k] * ny, pn[k] * ny + pt[k] * nx
        for body, rx, ry, sign in ((body_a[k], ra[k, 0], ra[k, 1], -1.0), (body_b[k], rb[k, 0], rb[k, 1], 1.0)):
            if body >= 0:
                v[body, 0] += sign * inv_mass[body] * px
                v[body, 1] += sign * inv_mass[body] * py
                v[body, 2] += sign * inv_inertia[body] * (rx * py - ry * px)
    out = np.zeros(5)
    for k in range(body_a.shape[0]):
        nx, ny = normal[k, 0], normal[k, 1]
        un, inv_n = relative(v, inv_mass, inv_inertia, body_a, body_b, ra, rb, k, nx, ny)
        ut, inv_t = relative(v, inv_mass, inv_inertia, body_a, body_b, ra, rb, k, -ny, nx)
        gap = un - target[k]
        load = pn[k] * inv_n  # pn / k_n: the speed the normal impulse gives the point alone
        bound = friction[k] * pn[k]
        slip = 0.0
        if pn[k] > 0.0:
            if abs(pt[k]) < bound:  # held inside the box: the point must not slip, and a friction a hair
                slip = min(abs(ut), (bound - abs(pt[k])) * inv_t)  # inside its bound (rounding) is at it
            elif pt[k] >= bound:
                slip = max(ut, 0.0)  # at +mu pn friction must leave a slip along -t
            else:
                slip = max(-ut, 0.0)
        raise_to(out, 0, max(-gap, 0.0) if gap == gap else gap)
        raise_to(out, 1, max(-load, 0.0) if load == load else load)
        least = min(load, gap) if load == load and gap == gap else np.nan
        raise_to(out, 2, max(least, 0.0) if least == least else least)
        over = abs(pt[k]) - max(bound, 0.0)
        raise_to(out, 3, max(over, 0.0) * inv_t if over == over else over)
        raise_to(out, 4, slip if ut == ut else ut)
    return out


def approach(problem: ContactProblem, velocity: np.ndarray) -> float:
    """The fastest approach beyond its target of any point of ``problem`` under body velocities ``velocity``
    (n, 3), m/s: ``max(target - un, 0)``; 0 without points."""
    p = problem
    with compiled(enabled()):
        return float(fastest_approach(p.inv_mass, p.inv_inertia, np.ascontiguousarray(velocity, np.float64),
                                      p.body_a, p.body_b, p.normal, p.ra, p.rb, p.target))


def matched(keys: np.ndarray, own_keys: np.ndarray, own_pn: np.ndarray,
            own_pt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The impulses ``own_pn``, ``own_pt`` of the points ``own_keys`` ``(k, 3)`` at the points ``keys``
    ``(m, 3)`` (both ``(A, B, FEATURE)`` in ``collide``'s order): ``(pn, pt)``, each ``(m,)``, 0 at a point
    ``own_keys`` lacks. When the solver found the points the problem has, the two lists are the same; else
    one walk down both (the warm start's ``recall``)."""
    if own_keys.shape == keys.shape and np.array_equal(own_keys, keys):
        return np.asarray(own_pn, np.float64), np.asarray(own_pt, np.float64)
    m = keys.shape[0]
    table = np.zeros((m, COLUMNS))
    carried = np.ascontiguousarray(np.stack([own_pn, own_pt], axis=1), np.float64)
    with compiled(enabled()):
        recall(np.ascontiguousarray(keys, np.int64), table, m, np.ascontiguousarray(own_keys, np.int64), carried,
               own_keys.shape[0])
    return table[:, PN].copy(), table[:, PT].copy()


def violations(problem: ContactProblem, pn: np.ndarray, pt: np.ndarray) -> dict[str, float]:
    """Each contact condition's largest violation (m/s) by impulses ``pn``, ``pt`` (see the module text);
    the velocities are those the impulses give."""
    p = problem
    with compiled(enabled()):
        found = condition_violations(p.inv_mass, p.inv_inertia, p.velocity, p.body_a, p.body_b, p.normal, p.ra,
                                     p.rb, p.friction, p.target, np.ascontiguousarray(pn, np.float64),
                                     np.ascontiguousarray(pt, np.float64))
    return {name: float(value) for name, value in zip(CONDITIONS, found)}
