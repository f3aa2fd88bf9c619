"""How far a solver's own answer to a step is from the step's contact conditions, needing no reference.

The reference solve (``stackx.models.planar.reference``) says how far a solver's velocities are from the
exact answer, at the cost of solving every step exactly. This module measures what a solver's answer itself
breaks, at the cost of one pass over the step's points, so it can run on every step of every run:

- with the solver's impulses (``violations``): each condition of the contract
  (``stackx.models.planar.problem``) on its own, in m/s: a point approaching faster than its target
  (*penetration*), a normal impulse below zero (*pull*, as the velocity it would give the point alone),
  a point pushing while it separates faster than its target (*complementarity*, the smaller of the two), a
  tangent impulse outside Coulomb's box (*box*), and friction not opposing the slip at its bound or a point
  slipping while friction is inside the box (*dissipation*, the slip it lets through; a point that does
  not push has no friction to check);
- with velocities alone (``approach``), what a solver that keeps its impulses to itself (an engine) still
  shows: the fastest approach beyond a point's target. Friction and complementarity need the impulses.

Every figure is 0 for an exact answer, and each is the largest over the step's points. A solver's impulses
(``stackx.solvers.planar.base.StepImpulses``) reach the step's problem by ``matched``: each point of the
problem takes the impulses of the solver's point with the same ``(A, B, FEATURE)``, 0 where the solver had
no such point (it applied nothing there).
"""

from __future__ import annotations

import numpy as np

from stackx.models.planar.problem import ContactProblem, effective_masses, relative_velocities, velocities_after

CONDITIONS = ("penetration", "pull", "complementarity", "box", "dissipation")


def approach(problem: ContactProblem, velocity: np.ndarray) -> float:
    """The fastest approach beyond its target of any point of ``problem`` under body velocities ``velocity``
    (n, 3), m/s: ``max(target - un, 0)``; 0 without points."""
    if problem.points == 0:
        return 0.0
    un, _ = relative_velocities(problem, velocity)
    return float(np.maximum(problem.target - un, 0.0).max())


def matched(keys: np.ndarray, own_keys: np.ndarray, own_pn: np.ndarray,
            own_pt: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The impulses ``own_pn``, ``own_pt`` of the points ``own_keys`` ``(k, 3)`` at the points ``keys``
    ``(m, 3)`` (both ``(A, B, FEATURE)``): ``(pn, pt)``, each ``(m,)``, 0 at a point ``own_keys`` lacks. Both
    lists come from ``collide`` in the same order when the solver found the points the problem has, and are
    then compared in one pass."""
    if own_keys.shape == keys.shape and np.array_equal(own_keys, keys):
        return np.asarray(own_pn, np.float64), np.asarray(own_pt, np.float64)
    index = {(a, b, f): i for i, (a, b, f) in enumerate(own_keys.tolist())}
    pn, pt = np.zeros(keys.shape[0]), np.zeros(keys.shape[0])
    for j, (a, b, f) in enumerate(keys.tolist()):
        i = index.get((a, b, f))
        if i is not None:
            pn[j], pt[j] = own_pn[i], own_pt[i]
    return pn, pt


def violations(problem: ContactProblem, pn: np.ndarray, pt: np.ndarray) -> dict[str, float]:
    """Each contact condition's largest violation (m/s) by impulses ``pn``, ``pt`` (see the module text);
    the velocities are those the impulses give."""
    if problem.points == 0:
        return dict.fromkeys(CONDITIONS, 0.0)
    kn, kt = effective_masses(problem)
    un, ut = relative_velocities(problem, velocities_after(problem, pn, pt))
    gap = un - problem.target
    bound = problem.friction * pn
    inside = np.abs(pt) < bound
    slip_against = np.where(pt >= bound, np.maximum(ut, 0.0), 0.0) + np.where(pt <= -bound, np.maximum(-ut, 0.0), 0.0)
    out = {"penetration": np.maximum(-gap, 0.0), "pull": np.maximum(-pn / kn, 0.0),
           "complementarity": np.maximum(np.minimum(pn / kn, gap), 0.0),
           "box": np.maximum(np.abs(pt) - np.maximum(bound, 0.0), 0.0) / kt,
           "dissipation": np.where(pn > 0.0, np.where(inside, np.abs(ut), slip_against), 0.0)}
    return {k: float(v.max()) for k, v in out.items()}
