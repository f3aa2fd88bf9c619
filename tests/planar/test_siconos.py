"""The reference against Siconos (INRIA), an independent implementation of the same 2D frictional contact
problem, on recorded step problems. Optional: Debian's ``python3-siconos`` is importable only by the system
interpreter (``/usr/bin/python3``), so each problem goes to a subprocess of it; the test is skipped, saying
why, where that interpreter cannot import ``siconos``.

Siconos states a step as ``FrictionContactProblem(2, nc, W, q, mu)``: the Delassus matrix ``W = J M^-1 J^T``
over the points' (normal, tangent) pairs, ``q`` the free relative velocities minus the targets, Coulomb's
coefficients. Both matrices are built here from this file's own Jacobian (``test_reference._jacobian``, the
contract written out point by point), and Siconos's Lemke solver (``fc2d_lexicolemke``: lexicographic
Lemke pivoting on the 2D problem written as an LCP) answers it.

**What must agree, and what need not.** A box resting flat has two points on a face: four conditions for
three velocities, so ``W`` is singular and the impulses that hold a pile are not unique (the share between
a face's two points, and so its friction, may move along the null space of ``J^T``). Both answers must meet
every condition (``problem.residual`` of each below the tolerance); the bodies' velocities, which every
answer of these steps gives alike (the null space changes no velocity), must agree to what the two
residuals allow.
"""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest

from stackx.solvers.planar.problem import ContactProblem, residual
from stackx.solvers.planar.reference import solve
from tests.planar.test_reference import _jacobian, _recorded
from tests.limits import hang_limit

SYSTEM = "/usr/bin/python3"

SOLVE = """
import json, sys
import numpy as np
import siconos.numerics as sn
out = []
for d in json.load(sys.stdin):
    w, q, mu = np.array(d["W"]), np.array(d["q"]), np.array(d["mu"])
    problem = sn.FrictionContactProblem(2, mu.size, w, q, mu)
    options = sn.SolverOptions(sn.SICONOS_FRICTION_2D_LEMKE)
    r, v = np.zeros(2 * mu.size), np.zeros(2 * mu.size)
    info = sn.fc2d_driver(problem, r, v, options)
    out.append({"info": int(info), "r": r.tolist()})
json.dump(out, sys.stdout)
"""


def _siconos_ready() -> str | None:
    """None when the system interpreter imports siconos, else why not."""
    if shutil.which(SYSTEM) is None:
        return f"{SYSTEM} is absent"
    done = subprocess.run([SYSTEM, "-c", "import siconos.numerics"], capture_output=True, text=True)
    return None if done.returncode == 0 else f"{SYSTEM} cannot import siconos: {done.stderr.strip()[-200:]}"


def _siconos(problems: list[ContactProblem]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Siconos's impulses ``(pn, pt)`` for each problem (its solver must report success)."""
    sent = []
    for p in problems:
        jac = _jacobian(p)
        inv = np.repeat(p.inv_mass, 3)
        inv[2::3] = p.inv_inertia
        target = np.zeros(2 * p.points)
        target[0::2] = p.target
        sent.append({"W": (jac @ (inv[:, None] * jac.T)).tolist(),
                     "q": (jac @ p.velocity.reshape(-1) - target).tolist(), "mu": p.friction.tolist()})
    done = subprocess.run([SYSTEM, "-c", SOLVE], input=json.dumps(sent), capture_output=True, text=True, timeout=hang_limit(600))
    assert done.returncode == 0, done.stderr[-2000:]
    answers = json.loads(done.stdout)
    assert [a["info"] for a in answers] == [0] * len(problems)
    return [(np.array(a["r"])[0::2], np.array(a["r"])[1::2]) for a in answers]


WHY = _siconos_ready()
needs_siconos = pytest.mark.skipif(WHY is not None, reason=WHY or "")

# domino_step: step 345 of a row of 20 dominoes (0.2 x 2 m, 1 m apart, mu 0.6, the first tipped 15 degrees)
# under planar-exact, with the impulses it started from
# domino_pgs_step and stack40_ngs_step: steps whose fallback needs Lemke's walk (test_pivoting)
RECORDED = ("landing_step", "stack_steps", "trembling_stack_step", "xpbd_pyramid_step", "domino_step",
            "domino_pgs_step", "stack40_ngs_step")
# rows of dominoes whose steps have two answers: velocities apart by about 1e-6 m/s (domino_step) and 2e-2 m/s
# (domino_pgs_step: a falling row under planar-pgs), each answer meeting every condition
TWO_ANSWERS = ("domino_step", "domino_pgs_step")


@needs_siconos
def test_siconos_and_the_reference_meet_every_condition_with_the_same_velocities() -> None:
    steps = [(name, p, pn, pt) for name in RECORDED for p, pn, pt in _recorded(name)]
    theirs = _siconos([p for _, p, _, _ in steps])
    for (name, p, pn, pt), (their_pn, their_pt) in zip(steps, theirs):
        # Siconos's answer judged by our contract: its pivoting ends on the right modes; what its dense tableau,
        # updated pivot after pivot, leaves is up to 1.5e-6 m/s on the stacks, 1e-12 on the landing step
        theirs_off = residual(p, their_pn, their_pt)
        assert theirs_off < 1e-5, name
        jac = _jacobian(p)
        inv = np.repeat(p.inv_mass, 3)
        inv[2::3] = p.inv_inertia
        impulse = np.zeros(2 * p.points)
        impulse[0::2], impulse[1::2] = their_pn, their_pt
        their_v = p.velocity + (inv * (jac.T @ impulse)).reshape(-1, 3)
        ours = solve(p, pn, pt)
        assert residual(p, ours.pn, ours.pt) < 1e-10, name
        if name in TWO_ANSWERS:
            # rows of dominoes: both answers meet every condition (ours to 1e-10 m/s, Siconos's to 1e-12) and
            # their velocities differ: with friction the velocities need not be unique either (the problem is
            # not monotone), and these steps have two answers
            assert theirs_off < 1e-12
            continue
        # elsewhere the same velocities, to what Siconos's residual allows (a point's velocity error moves its
        # bodies by about as much)
        assert np.abs(ours.velocity - their_v).max() < 10 * theirs_off + 1e-8, name
