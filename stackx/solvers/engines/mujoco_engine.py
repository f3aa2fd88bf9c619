"""MuJoCo steps the column.

The column in MuJoCo: z up, gravity ``(0, 0, g)``; each box a body on the world with one slide joint along z, so
it moves vertically only and its joint position is its height; a box geom of ``WIDTH`` x ``WIDTH`` x its height
and the box's mass; the floor the infinite plane z = 0. Contacts are frictionless (``condim`` 1): the boxes
cannot move sideways, and friction would only add constraint rows. One step of the column is one call,
``mj_step(model, data, substeps)``: MuJoCo's timestep is ``dt / substeps``. Heights and velocities are the
joints' ``qpos`` and ``qvel``, in double precision.

MuJoCo's contacts are soft by design: a contact is a constraint whose reference acceleration pulls overlap back
like a damped spring of time constant ``solref[0]`` and damping ratio ``solref[1]``, with ``solimp`` setting
how much force it may apply at each depth; the solver (Newton by default) finds all constraint forces of a step
together, to ``tolerance`` within ``iterations``. A resting box therefore sits slightly into its support, more
under more load. MuJoCo keeps the time constant at least twice its timestep: at dt = 1/60 the default 0.02 s
becomes 1/30 s, and ``substeps`` are what make contacts stiffer again.

A box that a scene event takes away cannot leave a compiled model: its geom stops colliding (contype and
conaffinity 0) and an applied force holds its body still, so it touches nothing again.
"""

from __future__ import annotations

from functools import partial
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.registry import solvers
from stackx.solvers.engines.engine import WIDTH, Engine


class MujocoParams(BaseModel):
    """MuJoCo's own knobs, with MuJoCo's defaults (MJCF ``option``, ``geom`` solref and solimp)."""

    model_config = ConfigDict(extra="forbid")
    substeps: int = Field(1, gt=0, le=10_000,
                          description="MuJoCo steps per step of the column (its timestep is dt/substeps): more make "
                                      "contacts stiffer (the time constant may shrink to 2 timesteps) at linear cost")
    solver: Literal["Newton", "CG", "PGS"] = Field("Newton", description="the constraint solver")
    iterations: int = Field(100, gt=0, le=100_000, description="most solver iterations per timestep (the solver "
                                                              "stops earlier at the tolerance)")
    tolerance: float = Field(1e-8, ge=0, allow_inf_nan=False,
                             description="relative improvement below which the solver stops")
    ls_iterations: int = Field(50, gt=0, le=100_000, description="most line-search iterations (Newton and CG)")
    noslip_iterations: int = Field(0, ge=0, le=100_000,
                                   description="extra passes removing slip (for friction; none here)")
    cone: Literal["pyramidal", "elliptic"] = Field("pyramidal", description="friction cone (no friction here)")
    integrator: Literal["Euler", "implicitfast", "implicit", "RK4"] = Field(
        "Euler", description="time integrator (semi-implicit Euler by default)")
    impratio: float = Field(1.0, gt=0, allow_inf_nan=False, description="frictional to normal impedance ratio")
    warmstart: bool = Field(True, description="start the solver from the last timestep's accelerations")
    solref: tuple[float, float] = Field((0.02, 1.0), description="contact reference: time constant (s, at least 2 "
                                                               "timesteps) and damping ratio; smaller time "
                                                               "constants push overlap out faster")
    solimp: tuple[float, float, float, float, float] = Field(
        (0.9, 0.95, 0.001, 0.5, 2.0), description="contact impedance: dmin, dmax, width (m), midpoint, power; "
                                                  "closer to 1 is harder")


def _num(x: float) -> str:
    return repr(float(x))


def column_xml(p: MujocoParams, g: float, dt: float, mass: np.ndarray, half: np.ndarray) -> str:
    """The MJCF model of the column: the floor plane and one body with a slide joint per box, bottom first."""
    flags = "" if p.warmstart else '<flag warmstart="disable"/>'
    option = (f'<option timestep="{_num(dt / p.substeps)}" gravity="0 0 {_num(g)}" solver="{p.solver}" '
              f'iterations="{p.iterations}" tolerance="{_num(p.tolerance)}" ls_iterations="{p.ls_iterations}" '
              f'noslip_iterations="{p.noslip_iterations}" cone="{p.cone}" integrator="{p.integrator}" '
              f'impratio="{_num(p.impratio)}">{flags}</option>')
    geom = (f'<geom condim="1" solref="{" ".join(map(_num, p.solref))}" '
            f'solimp="{" ".join(map(_num, p.solimp))}"/>')
    w = _num(WIDTH / 2)
    boxes = "".join(f'<body name="box{i}"><joint name="lift{i}" type="slide" axis="0 0 1"/>'
                    f'<geom type="box" size="{w} {w} {_num(half[i])}" mass="{_num(mass[i])}"/></body>'
                    for i in range(mass.shape[0]))
    return (f'<mujoco model="column">{option}<default>{geom}</default><worldbody>'
            f'<geom name="floor" type="plane" size="0 0 1"/>{boxes}</worldbody></mujoco>')


class MujocoColumn:
    """One batch row: the column's boxes as MuJoCo bodies on slide joints (joint ``i`` is box ``i``)."""

    def __init__(self, mujoco: Any, p: MujocoParams, g: float, dt: float, y: np.ndarray, v: np.ndarray,
                 mass: np.ndarray, half: np.ndarray) -> None:
        self.model = mujoco.MjModel.from_xml_string(column_xml(p, g, dt, mass, half))
        self.data = mujoco.MjData(self.model)
        self.data.qpos[:] = y
        self.data.qvel[:] = v
        self.gravity = g
        self.step = partial(mujoco.mj_step, self.model, self.data, p.substeps)
        self.left: list[int] = list(range(y.shape[0]))  # the joints of the boxes still in the column
        self.index: np.ndarray | None = None  # those joints as an index, once a box has gone

    def read(self, y: np.ndarray, v: np.ndarray) -> None:
        if self.index is None:
            y[:] = self.data.qpos
            v[:] = self.data.qvel
        else:
            y[:] = self.data.qpos[self.index]
            v[:] = self.data.qvel[self.index]

    def remove(self, box: int) -> None:
        joint = self.left.pop(box)
        geom, body = joint + 1, joint + 1  # geom 0 is the floor, body 0 the world
        self.model.geom_contype[geom] = 0
        self.model.geom_conaffinity[geom] = 0
        self.data.qvel[joint] = 0.0
        self.data.qfrc_applied[joint] = -self.model.body_mass[body] * self.gravity
        self.index = np.array(self.left, dtype=np.intp)


@solvers.register("mujoco")
class Mujoco(Engine):
    """MuJoCo: soft contact constraints solved together (Newton), slide joints; one call per step."""

    Params = MujocoParams
    column = MujocoColumn
    package = "mujoco"
    distribution = "mujoco"
    knob = "substeps"
