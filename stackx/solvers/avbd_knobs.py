"""The knobs of Augmented Vertex Block Descent (Giles, Diaz and Yuksel, ACM TOG 44(4), SIGGRAPH 2025) that the
column's ``avbd`` and the planar ``planar-avbd`` share, at the defaults of the authors' 2D demo: the same
method on one degree of freedom per box or three, so the same numbers trade the same things."""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, model_validator


class AVBDKnobs(BaseModel):
    """The knobs the AVBD paper and its authors' 2D demo name, at the demo's defaults; each model's solver adds
    its own."""

    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(10, gt=0, le=100_000,
                            description="primal-dual iterations per step (the demo's 10): each moves every body "
                                        "once and updates every row's force; more let the stiffness ramp further "
                                        "and the forces settle, at linear cost")
    beta: float = Field(1e5, gt=0, allow_inf_nan=False,
                        description="how fast a pushing row's stiffness grows per iteration, times its gap error "
                                    "(N/m^2; the demo's 1e5): larger holds heavy loads in fewer iterations, too "
                                    "large makes light boxes under them stiff springs that ring")
    post_stabilize: bool = Field(True, description="keep each row's whole force into the next step and undo the "
                                                   "overlap a step began with in one extra Newton sweep after the "
                                                   "velocities are taken, so the fix moves boxes without launching "
                                                   "them (the demo's current default); off: the paper's alpha "
                                                   "stabilisation, under which a resting load sinks a little each "
                                                   "step (the force decays by alpha gamma)")
    alpha: float = Field(0.99, ge=0, le=1, allow_inf_nan=False,
                         description="without post_stabilize, the share of the overlap present at a step's start "
                                     "that the step leaves alone (the demo's 0.99): near 1 undoes old overlap "
                                     "slowly and quietly, 0 undoes it within the step as velocity and throws "
                                     "boxes apart; ignored with post_stabilize")
    gamma: float = Field(0.99, gt=0, le=1, allow_inf_nan=False,
                         description="decay of each row's stiffness (and, with alpha, its force) carried into the "
                                     "next step (the demo's 0.99): below 1 lets a stiffness that was needed once "
                                     "relax; smaller forgets the load faster and lets the pile sink each step")
    penalty_min: float = Field(1e3, gt=0, allow_inf_nan=False,
                               description="stiffness a row starts from and never decays below (N/m; the demo's "
                                           "1e3): larger stops a landing box sooner but stiffens every new contact")
    penalty_max: float = Field(1e9, gt=0, allow_inf_nan=False,
                               description="most a row's stiffness may reach (N/m; the demo's 1e9): bounds how "
                                           "ill-conditioned a body's Newton step gets, and so the overlap a heavy "
                                           "load leaves")

    @model_validator(mode="after")
    def _bounds_in_order(self) -> AVBDKnobs:
        if self.penalty_min > self.penalty_max:
            raise ValueError(f"penalty_min ({self.penalty_min:g}) must not exceed penalty_max "
                             f"({self.penalty_max:g})")
        return self
