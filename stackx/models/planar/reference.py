"""The planar reference solve: one step's contact problem (``problem.ContactProblem``) solved to a residual
below 1e-10 m/s, or a ``ReferenceFailure`` saying how close it got.

**Method: projected Gauss-Seidel for the active set, then Newton on it (a primal-dual active-set method).**
The solution is fixed by which mode each point is in: *separating* (no impulse), *sticking* (the point's
relative velocity is zero), or *sliding* either way (friction at ``+mu pn`` or ``-mu pn``) with its normal
held. Once the modes are known, the impulses solve one linear system: held normals and sticking tangents
give rows of the Delassus matrix ``W = J M^-1 J^T`` (the point's relative velocity equals its target), a
sliding tangent gives ``pt = +-mu pn``, a separating point gives ``pn = pt = 0``. So:

1. a few sweeps of projected Gauss-Seidel (sequential impulses with accumulated clamping, in body
   velocities: O(points) a sweep, compiled), from the caller's warm start, give a near answer;
2. each Newton round reads the modes off the current answer with the same min / clip maps the residual uses
   (held when ``pn / k_n > un - target``; sliding when ``pt - k_t ut`` leaves ``[-mu pn, mu pn]``), solves
   that mode combination's linear system exactly with a sparse LU (``W`` has a few dozen entries per row:
   each point couples only to the points of its two bodies), and checks the residual. When the modes are
   right the answer is the solution up to rounding; when they are not, the new answer shows which points
   to switch (this is semismooth Newton on the min-map, which converges locally in a few rounds);
3. a round that does not shrink the residual sends the best answer so far back to a few more sweeps.

**Why exact.** The answer is returned only once the contract's own measure, ``problem.residual`` of the
final impulses (complementarity of every normal, the friction box of every tangent, velocities recomputed
from the impulses), is below the tolerance; else the solve raises. PGS alone only approaches the solution
(its error falls by a constant factor per sweep, slowly on tall stacks); the linear solve of the right
modes lands on it.

**Redundant contacts.** A box resting flat has two points on a face, four rows for its three velocities,
so ``W`` is singular and the impulses that hold a pile are not unique (the velocities are). Every system is
solved with a proximal term: ``(W + d K^-1) p = rhs + d K^-1 p_prev`` with ``d = PROXIMAL`` (scaled by each
point's effective mass ``K``), which picks, of all the impulses that hold, the one nearest the current
answer, and whose repeated rounds converge to an exact solution of the singular system.

**Speed.** Scipy's sparse LU (SuperLU) factors a 20-row pyramid's system (800 points, 1,600 unknowns) in
milliseconds where a dense LU of the same size takes about a hundred; it is the one place scipy is used.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from stackx.kernel import kernel
from stackx.models.planar.problem import GROUND, ContactProblem, effective_masses, residual, velocities_after

TOLERANCE = 1e-10  # m/s: the contract's residual the reference reaches
PROXIMAL = 1e-3  # the proximal weight d (dimensionless: a share of each point's own effective mass)
SWEEPS = 200  # most projected Gauss-Seidel sweeps before the first Newton round, and after a lost one
CHUNK = 10  # sweeps between looks at the residual
NEAR = 1e-3  # m/s: the sweeps stop once the residual is below this (Newton takes it from there)
ROUNDS = 40  # Newton rounds before the solve gives up
REFINE = 30  # most proximal steps per Newton round (each a solve with the round's factorization)
MIN_STEP = 1.0 / 64  # the shortest Newton step tried before going back to sweeps


class ReferenceFailure(RuntimeError):
    """The reference solve did not reach its tolerance (with the residual it reached)."""


@dataclass
class Solution:
    """A solved problem: impulses per point, the bodies' velocities after, the residual (m/s), and what it
    took (Newton ``rounds`` and Gauss-Seidel ``sweeps``)."""

    pn: np.ndarray
    pt: np.ndarray
    velocity: np.ndarray
    residual: float
    rounds: int
    sweeps: int


@kernel
def project_sweeps(body_a: np.ndarray, body_b: np.ndarray, normal: np.ndarray, ra: np.ndarray, rb: np.ndarray,
                   friction: np.ndarray, target: np.ndarray, inv_mass: np.ndarray, inv_inertia: np.ndarray,
                   kn: np.ndarray, kt: np.ndarray, v: np.ndarray, pn: np.ndarray, pt: np.ndarray,
                   sweeps: int) -> None:
    """``sweeps`` passes of projected Gauss-Seidel over the points in order, in place: ``v`` (n, 3) holds the
    velocities of the impulses ``pn``, ``pt`` on entry and on exit. Per point, the normal impulse is
    clamped to ``>= 0`` in total (accumulated), then the tangent to ``[-mu pn, mu pn]`` of that new ``pn``."""
    m = body_a.shape[0]
    for _ in range(sweeps):
        for k in range(m):
            a, b = body_a[k], body_b[k]
            nx, ny = normal[k, 0], normal[k, 1]
            for axis in range(2):
                dx, dy = (nx, ny) if axis == 0 else (-ny, nx)
                u = 0.0
                if b != GROUND:
                    u += (v[b, 0] - v[b, 2] * rb[k, 1]) * dx + (v[b, 1] + v[b, 2] * rb[k, 0]) * dy
                if a != GROUND:
                    u -= (v[a, 0] - v[a, 2] * ra[k, 1]) * dx + (v[a, 1] + v[a, 2] * ra[k, 0]) * dy
                if axis == 0:
                    new = max(pn[k] - kn[k] * (u - target[k]), 0.0)
                    delta = new - pn[k]
                    pn[k] = new
                else:
                    bound = friction[k] * pn[k]
                    new = min(max(pt[k] - kt[k] * u, -bound), bound)
                    delta = new - pt[k]
                    pt[k] = new
                if b != GROUND:
                    v[b, 0] += inv_mass[b] * delta * dx
                    v[b, 1] += inv_mass[b] * delta * dy
                    v[b, 2] += inv_inertia[b] * delta * (rb[k, 0] * dy - rb[k, 1] * dx)
                if a != GROUND:
                    v[a, 0] -= inv_mass[a] * delta * dx
                    v[a, 1] -= inv_mass[a] * delta * dy
                    v[a, 2] -= inv_inertia[a] * delta * (ra[k, 0] * dy - ra[k, 1] * dx)


def jacobian(problem: ContactProblem) -> object:
    """``J`` (2m x 3n, scipy CSR): row ``k`` the normal of point ``k``, row ``m + k`` its tangent; body ``i``'s
    columns ``3i, 3i + 1, 3i + 2`` (vx, vy, w). ``J v`` is the points' relative velocities."""
    from scipy import sparse

    m, n = problem.points, problem.bodies
    t = problem.tangent()
    rows, cols, vals = [], [], []
    for offset, d in ((0, problem.normal), (m, t)):
        for body, r, sign in ((problem.body_a, problem.ra, -1.0), (problem.body_b, problem.rb, 1.0)):
            moving = np.flatnonzero(body != GROUND)
            bi, rm, dm = body[moving], r[moving], d[moving]
            arm = rm[:, 0] * dm[:, 1] - rm[:, 1] * dm[:, 0]
            for axis, value in enumerate((dm[:, 0], dm[:, 1], arm)):
                rows.append(offset + moving)
                cols.append(3 * bi + axis)
                vals.append(sign * value)
    return sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(2 * m, 3 * n))


def solve(problem: ContactProblem, pn: np.ndarray | None = None, pt: np.ndarray | None = None,
          tolerance: float = TOLERANCE, sweeps: int = SWEEPS, rounds: int = ROUNDS) -> Solution:
    """Solve ``problem`` to ``residual < tolerance`` (m/s), starting from impulses ``pn``, ``pt`` (a warm
    start, e.g. the last step's by feature; zeros when None). Raises ``ReferenceFailure`` when ``rounds``
    Newton rounds do not get there (see the module text for the method)."""
    m, n = problem.points, problem.bodies
    pn = np.zeros(m) if pn is None else np.array(pn, dtype=np.float64)
    pt = np.zeros(m) if pt is None else np.array(pt, dtype=np.float64)
    if m == 0:
        return Solution(pn, pt, problem.velocity.copy(), 0.0, 0, 0)
    kn, kt = effective_masses(problem)
    if not (np.isfinite(kn).all() and np.isfinite(kt).all()):
        bad = int(np.flatnonzero(~(np.isfinite(kn) & np.isfinite(kt)))[0])
        raise ReferenceFailure(f"contact point {bad} joins two immovable bodies "
                               f"({problem.body_a[bad]}, {problem.body_b[bad]}): no impulse can act on it")
    newton = ModeSystem(problem, kn, kt)
    args = (problem.body_a, problem.body_b, problem.normal, problem.ra, problem.rb, problem.friction,
            problem.target, problem.inv_mass, problem.inv_inertia, kn, kt)
    swept = 0

    def sweep(q: np.ndarray, limit: float) -> np.ndarray:
        """Projected Gauss-Seidel from ``q`` (projected first) until its residual is below ``limit`` or
        ``sweeps`` more sweeps are done."""
        nonlocal swept
        pn = np.maximum(q[:m], 0.0) * kn
        pt = np.clip(q[m:] * kt, -problem.friction * pn, problem.friction * pn)
        v = velocities_after(problem, pn, pt)
        for _ in range(0, sweeps, CHUNK):
            project_sweeps(*args, v, pn, pt, CHUNK)
            swept += CHUNK
            q = np.concatenate([pn / kn, pt / kt])
            if newton.merit(q) < limit:
                break
        return q

    q = np.concatenate([pn / kn, pt / kt])
    now = newton.merit(q)
    if now >= NEAR:
        q = sweep(q, NEAR)
        now = newton.merit(q)
    for done in range(rounds + 1):
        if now < tolerance:
            pn, pt = q[:m] * kn, q[m:] * kt
            score = residual(problem, pn, pt)
            if score < tolerance:
                return Solution(pn, pt, velocities_after(problem, pn, pt), score, done, swept)
        if done == rounds:
            break
        target = newton.step(q)
        step, after = 1.0, np.inf
        while step >= MIN_STEP:  # the largest of 1, 1/2, 1/4, ... that lowers the residual
            trial = q + step * (target - q)
            after = newton.merit(trial)
            if after < (1.0 - 1e-4 * step) * now:
                break
            step *= 0.5
        if after < (1.0 - 1e-4 * step) * now:
            q, now = trial, after
        else:  # Newton is lost here: mend the modes by sweeps
            q = sweep(q, 0.5 * now)
            now = newton.merit(q)
            newton.modes = None
    raise ReferenceFailure(f"the contact problem ({m} points, {n} bodies) was not solved to {tolerance:g} m/s "
                           f"in {rounds} Newton rounds and {swept} sweeps: best residual {now:.3g} m/s")


class ModeSystem:
    """The linear system of one mode combination, solved in the bodies' velocities.

    Impulses are kept scaled, ``q = p / k`` (m/s). The unknown impulses are the held normals and the sticking
    tangents (the *free* rows F); a sliding tangent follows its normal (``q_t = +-cone q_n``), a separating
    point carries nothing. With the proximal term, row ``r`` of F reads ``J_r v + d q_r = target_r + d c_r``
    and the velocities ``M v = M v0 + G q`` (``G``: each free row's impulse direction, a sliding point's
    normal column carrying its friction too). Eliminating ``q = (h - J_F v) / d`` leaves
    ``(M + G J_F / d) v = M v0 + G h / d``: one unknown per movable degree of freedom (3 per box), however
    many points touch, symmetric unless a point slides; SuperLU factors it in a few milliseconds.
    """

    def __init__(self, problem: ContactProblem, kn: np.ndarray, kt: np.ndarray) -> None:
        from scipy import sparse

        self.m = m = problem.points
        inv = np.repeat(problem.inv_mass, 3)
        inv[2::3] = problem.inv_inertia
        self.free_dof = inv > 0.0
        self.inv = inv[self.free_dof]
        jac = jacobian(problem).tocsc()
        self.jac = jac
        self.j_free = jac[:, self.free_dof].tocsr()
        self.v0 = problem.velocity.reshape(-1).copy()
        self.fixed_u = jac[:, ~self.free_dof] @ self.v0[~self.free_dof]
        self.k = np.concatenate([kn, kt])
        self.target = np.concatenate([problem.target, np.zeros(m)])
        self.cone = problem.friction * kn / kt  # the friction bound in q units: |q_t| <= cone q_n
        self.mu = problem.friction
        self.modes: np.ndarray | None = None
        self.kept = False
        self.sparse = sparse

    def merit(self, q: np.ndarray) -> float:
        """The contract's residual (m/s) of scaled impulses ``q``, from ``W`` (the min map of every normal,
        the friction box of every tangent): cheap, for the line search; the answer is checked by
        ``problem.residual``."""
        m = self.m
        gap = self.gap(q)
        qn, qt = q[:m], q[m:]
        bound = self.cone * qn
        normal = np.abs(np.minimum(qn, gap[:m]))
        tangent = np.abs(qt - np.minimum(np.maximum(qt - gap[m:], -bound), bound))
        worst = max(normal.max(), tangent.max())
        return worst if np.isfinite(worst) else np.inf

    def gap(self, q: np.ndarray) -> np.ndarray:
        """``J v - target`` (m/s) for the velocities of scaled impulses ``q``."""
        v = self.v0[self.free_dof] + self.inv * (self.j_free.T @ (self.k * q))
        return self.j_free @ v + self.fixed_u - self.target

    def step(self, q: np.ndarray) -> np.ndarray:
        """One Newton round: the modes read at ``q``, and the scaled impulses that solve that mode
        combination, by proximal steps from ``q`` (with a singular system, the answer nearest ``q``).
        ``kept`` says the modes were the last round's, whose factorization is reused."""
        from scipy.sparse.linalg import splu

        sparse, m = self.sparse, self.m
        gap = self.gap(q)
        qn, qt = q[:m], q[m:]
        held = qn > gap[:m]
        z = qt - gap[m:]
        plus = held & (z > self.cone * qn)
        minus = held & (z < -self.cone * qn)
        modes = np.concatenate([held, plus, minus])
        self.kept = self.modes is not None and np.array_equal(modes, self.modes)
        if not self.kept:
            self.modes = modes
            stick = held & ~plus & ~minus
            self.free = free = np.flatnonzero(np.concatenate([held, stick]))
            self.sign = np.where(plus, 1.0, np.where(minus, -1.0, 0.0))
            j_rows = self.j_free[free]
            # G: column r of F is k_r J_r^T, plus +-mu k_n J_t^T for a sliding normal
            slide_t = self.j_free[m + np.flatnonzero(held)].multiply((self.sign * self.mu)[held][:, None])
            extra = sparse.vstack([slide_t, sparse.csr_matrix((free.shape[0] - slide_t.shape[0], j_rows.shape[1]))])
            self.g = ((j_rows + extra).T @ sparse.diags(self.k[free])).tocsc()
            self.j_rows = j_rows
            matrix = sparse.diags(1.0 / self.inv) + (self.g @ j_rows) / PROXIMAL
            try:
                self.factors = splu(matrix.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                    options={"SymmetricMode": True})
            except RuntimeError:  # a singular mode system: the caller goes back to sweeps
                self.factors = None
        if self.factors is None:
            return np.full(2 * m, np.nan)
        free = self.free
        base = self.target[free] - self.fixed_u[free]
        momentum = self.v0[self.free_dof] / self.inv
        out = q[free]
        for _ in range(REFINE):  # proximal steps on one factorization: they converge to the modes' answer
            h = base + PROXIMAL * out
            v = self.factors.solve(momentum + self.g @ h / PROXIMAL)
            new = (h - self.j_rows @ v) / PROXIMAL
            change = np.abs(new - out).max(initial=0.0)
            out = new
            if change <= 1e-3 * TOLERANCE:
                break
        q = np.zeros(2 * m)
        q[free] = out
        q[m:] += self.sign * self.cone * q[:m]
        return q
