"""MuJoCo steps the column and the planar model.

The column in MuJoCo: z up, gravity ``(0, 0, g)``; each box a body on the world with one slide joint along z, so
it moves vertically only and its joint position is its height; a box geom of ``WIDTH`` x ``WIDTH`` x its height
and the box's mass; the floor the infinite plane z = 0. Contacts are frictionless (``condim`` 1): the boxes
cannot move sideways, and friction would only add constraint rows. One step of the column is one call,
``mj_step(model, data, substeps)``: MuJoCo's timestep is ``dt / substeps``. Heights and velocities are the
joints' ``qpos`` and ``qvel``, in double precision.

The planar model in MuJoCo (``stackx.solvers.engines.planar`` says what every engine shares): the plane is
MuJoCo's x-z plane, z up. Each movable box is a body with three joints, slide along x, slide along z and a hinge
about -y (so that its position is the box's counter-clockwise angle): its ``qpos`` and ``qvel`` are the state's
``x, y, angle`` and ``vx, vy, w``. Its geom is a box of the box's half-sizes and ``DEPTH`` deep in y, with the
box's mass and its moment of inertia about y. A static box is a body without joints (welded to the world) at
its pose; the ground is the infinite plane z = 0. Contacts have friction (``condim`` 3, the pyramidal cone's
limit along x is exactly mu N). MuJoCo gives a contact the larger of its two geoms' coefficients unless one
geom has the higher ``priority``: boxes have priority 1 over the plane, so the ground takes each box's own
coefficient, and two boxes of different coefficients meet through an explicit ``pair`` carrying sqrt(mu_a
mu_b) (their automatic contact excluded).

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

import math
from functools import partial
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.registry import solvers
from stackx.solvers.engines.engine import WIDTH, Engine
from stackx.solvers.engines.planar import Boxes


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


def option_xml(p: MujocoParams, g: float, dt: float) -> str:
    """The MJCF ``option`` of the params, gravity ``(0, 0, g)`` and MuJoCo's timestep ``dt / substeps``."""
    flags = "" if p.warmstart else '<flag warmstart="disable"/>'
    return (f'<option timestep="{_num(dt / p.substeps)}" gravity="0 0 {_num(g)}" solver="{p.solver}" '
            f'iterations="{p.iterations}" tolerance="{_num(p.tolerance)}" ls_iterations="{p.ls_iterations}" '
            f'noslip_iterations="{p.noslip_iterations}" cone="{p.cone}" integrator="{p.integrator}" '
            f'impratio="{_num(p.impratio)}">{flags}</option>')


def column_xml(p: MujocoParams, g: float, dt: float, mass: np.ndarray, half: np.ndarray) -> str:
    """The MJCF model of the column: the floor plane and one body with a slide joint per box, bottom first."""
    option = option_xml(p, g, dt)
    geom = (f'<geom condim="1" solref="{" ".join(map(_num, p.solref))}" '
            f'solimp="{" ".join(map(_num, p.solimp))}"/>')
    w = _num(WIDTH / 2)
    boxes = "".join(f'<body name="box{i}"><joint name="lift{i}" type="slide" axis="0 0 1"/>'
                    f'<geom type="box" size="{w} {w} {_num(half[i])}" mass="{_num(mass[i])}"/></body>'
                    for i in range(mass.shape[0]))
    return (f'<mujoco model="column">{option}<default>{geom}</default><worldbody>'
            f'<geom name="floor" type="plane" size="0 0 1"/>{boxes}</worldbody></mujoco>')


DEPTH = 0.5  # half-depth (m, along y) of a planar box's geom: the plane's boxes are slabs 1 m deep
PLANE_PRIORITY, BOX_PRIORITY = 0, 1  # a box's coefficient wins over the plane's


def planar_xml(p: MujocoParams, g: float, dt: float, boxes: Boxes) -> str:
    """The MJCF model of a planar row: the plane, then one body per box in state order (``box{i}``)."""
    option = option_xml(p, g, dt)
    soft = f'solref="{" ".join(map(_num, p.solref))}" solimp="{" ".join(map(_num, p.solimp))}"'
    bodies, pairs = [], []
    for i in range(boxes.x.shape[0]):
        mu = float(boxes.friction[i])
        size = f'{_num(boxes.hx[i])} {_num(DEPTH)} {_num(boxes.hy[i])}'
        geom = (f'<geom name="g{i}" type="box" size="{size}" friction="{_num(mu)} 0.005 0.0001" condim="3" '
                f'priority="{BOX_PRIORITY}" {soft}')
        if boxes.static[i]:
            half = float(boxes.angle[i]) / 2  # a turn about -y: quaternion (cos, 0, -sin, 0) of half the angle
            quat = f'{_num(math.cos(half))} 0 {_num(-math.sin(half))} 0'
            bodies.append(f'<body name="box{i}" pos="{_num(boxes.x[i])} 0 {_num(boxes.y[i])}" quat="{quat}">'
                          f'{geom}/></body>')
        else:
            inertia = _num(boxes.inertia[i])
            bodies.append(f'<body name="box{i}"><joint type="slide" axis="1 0 0"/><joint type="slide" axis="0 0 1"/>'
                          f'<joint type="hinge" axis="0 -1 0"/><inertial pos="0 0 0" mass="{_num(boxes.mass[i])}" '
                          f'diaginertia="{inertia} {inertia} {inertia}"/>{geom} mass="0"/></body>')
    for i in range(boxes.x.shape[0]):
        for j in range(i + 1, boxes.x.shape[0]):
            a, b = float(boxes.friction[i]), float(boxes.friction[j])
            if a != b and not (boxes.static[i] and boxes.static[j]):
                mu = _num(math.sqrt(a * b))
                pairs.append(f'<exclude body1="box{i}" body2="box{j}"/>')
                pairs.append(f'<pair geom1="g{i}" geom2="g{j}" condim="3" friction="{mu} {mu} 0.005 0.0001 0.0001" '
                             f'{soft}/>')
    contact = f'<contact>{"".join(pairs)}</contact>' if pairs else ""
    return (f'<mujoco model="planar">{option}<worldbody><geom name="ground" type="plane" size="0 0 1" '
            f'condim="3" priority="{PLANE_PRIORITY}" {soft}/>{"".join(bodies)}</worldbody>{contact}</mujoco>')


class MujocoPlanar:
    """One batch row of the planar model as MuJoCo bodies on planar joints (joints 3k, 3k+1, 3k+2 are the k-th
    movable box's x, y, angle)."""

    def __init__(self, mujoco: Any, p: MujocoParams, g: float, dt: float, boxes: Boxes) -> None:
        self.model = mujoco.MjModel.from_xml_string(planar_xml(p, g, dt, boxes))
        self.data = mujoco.MjData(self.model)
        i = boxes.movable
        self.data.qpos[:] = np.stack([boxes.x[i], boxes.y[i], boxes.angle[i]], axis=1).ravel()
        self.data.qvel[:] = np.stack([boxes.vx[i], boxes.vy[i], boxes.w[i]], axis=1).ravel()
        self.movable = i
        self.step = partial(mujoco.mj_step, self.model, self.data, p.substeps)

    def read(self, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
             w: np.ndarray) -> None:
        i = self.movable
        x[i], y[i], angle[i] = self.data.qpos[0::3], self.data.qpos[1::3], self.data.qpos[2::3]
        vx[i], vy[i], w[i] = self.data.qvel[0::3], self.data.qvel[1::3], self.data.qvel[2::3]


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
    planar = MujocoPlanar
    package = "mujoco"
    distribution = "mujoco"
    knob = "substeps"
