"""Soft Jacobi on planar boxes (Solver2D's Jacobi): every manifold solved from the same velocities, all
changes applied at the end of the pass.

Gauss-Seidel (``planar-pgs-soft``) lets each manifold see what the manifolds before it just did, so a pass
must visit them one after the other. Jacobi visits every manifold from the velocities the pass began with
and adds up what each asks of its bodies, so a pass's manifolds could all be solved at once, and the answer
does not depend on the order the boxes are listed in (up to the rounding of each body's sum). Within one
manifold the points are still visited one after the other, normals then friction, as Solver2D does.

Everything else is ``planar-pgs-soft``'s step (``stackx.solvers.planar.pgs_soft``), as Solver2D's Jacobi is its
soft PGS with Jacobi passes: soft contacts (contact hertz 30 capped at a third of the step rate, twice it with
a static side, damping ratio 10), warm started by ``(A, B, feature)``, accumulated clamping with each
point's friction within ``mu`` times its normal total, ``iterations`` biased passes, positions, then
``relax_iterations`` passes without bias. Its push-out cap is Solver2D's Jacobi's, the full 4 m/s Baumgarte
speed (soft PGS: half of it).

**Shared bodies.** A box between two manifolds (below and above) is corrected by both from the same old
velocity, so their changes add up to more than either alone: Jacobi over-counts. Solver2D sums the changes
as they are (its source points to mass splitting as the known remedy). ``relaxation`` has the column
``jacobi``'s meaning, the share of each visit's computed change applied (before the clamp), so 1 is
Solver2D's sum. Measured at 60 Hz: Solver2D's own setting (4 passes, 1) leaves a 3-box stack rocking and
walking by centimetres; 1/2 (one over the manifolds of a stacked box) holds the stack but a 10-row pyramid,
whose inner boxes are pressed by four manifolds, blows up, the more so with more passes (the relaxed
iteration itself diverges there); 0.4 with 16 passes holds both, the defaults here. Dividing each body's sum
by its number of manifolds instead was tried and is worse: the two bodies of a manifold then get unequal
shares of its impulse, momentum is not conserved, and the pyramid blows up at any pass count.
"""

from __future__ import annotations

from pydantic import Field

from stackx.registry import solvers
from stackx.solvers.planar.pgs_soft import PlanarPGSSoftParams, SoftPassesSolver


class PlanarJacobiParams(PlanarPGSSoftParams):
    """Soft PGS's knobs, Solver2D's Jacobi push-out, and the share of each change applied."""

    iterations: int = Field(16, gt=0, le=100_000,
                            description="biased velocity passes per step (Solver2D: 4, which leaves a 3-box "
                                        "stack rocking): a relaxed Jacobi pass makes less progress than a "
                                        "Gauss-Seidel one at about the same cost; 16 hold the 10-row pyramid, "
                                        "8 leave it creeping")
    push_out: float = Field(4.0, gt=0, allow_inf_nan=False,
                            description="largest separating speed the bias may ask for (m/s; Solver2D's Jacobi: "
                                        "4): keeps a deep overlap from launching boxes, at the cost of a slower "
                                        "recovery")
    relaxation: float = Field(0.4, gt=0, le=1, allow_inf_nan=False,
                              description="share of each manifold's computed change applied per pass: 1 (Solver2D) "
                                          "sums every manifold's full change, so a box between several contacts "
                                          "is over-corrected and the error grows; 1/2 (one over the contacts of "
                                          "a stacked box) holds a stack but lets a pyramid's boxes, pressed by "
                                          "four manifolds, blow up; 0.4 holds both, smaller values converge "
                                          "more slowly")


@solvers.register("planar-jacobi")
class PlanarJacobi(SoftPassesSolver):
    """Soft contacts solved by Jacobi passes, all from the same velocities (Solver2D's Jacobi)."""

    Params = PlanarJacobiParams
    jacobi = True
