"""Each engine driven directly on a column read from a config, written here from the engines' own APIs and
not from stackx's plugins: the yardstick the engine solvers are held to.

A column is read from the YAML with the config's documented defaults (half-height 0.5 m, mass 1 kg, at
rest, gravity -9.8); every driver builds the engine's world its own way with the engine's default settings,
steps it ``steps`` times, takes boxes away where the scene says so and returns the heights after every step.
The mapping is the one the engine solvers document: boxes ``WIDTH`` wide with rotation locked and friction
off, a Box2D 2.3 polygon inside its 0.01 m skin, MuJoCo's timestep equal to dt.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any, Callable

import numpy as np
import yaml

WIDTH = 1.0  # the engines' box width (m), as stackx.solvers.engines documents it


@dataclass
class Column:
    """A column scene as plain numbers, bottom box first."""

    y: list[float]
    v: list[float]
    mass: list[float]
    half: list[float]
    gravity: float
    dt: float
    steps: int
    removals: list[tuple[int, int]] = field(default_factory=list)  # (step, box among those left), in order


def read_column(path: Path) -> Column:
    doc = yaml.safe_load(path.read_text())
    scene = doc["scene"]
    if "stack" in scene:
        s = scene["stack"]
        boxes = [{"y": s["y0"] + i * s["spacing"], "v": s.get("v", 0.0), "mass": s.get("mass", 1.0),
                  "half_height": s.get("half_height", 0.5)} for i in range(s["count"])]
    else:
        boxes = scene["boxes"]
    dt = doc.get("dt", 1 / 60)
    left, removals = len(boxes), []
    for r in scene.get("remove", []):
        removals.append((r["step"], r.get("box", -1) % left))
        left -= 1
    return Column([float(b["y"]) for b in boxes], [float(b.get("v", 0.0)) for b in boxes],
                  [float(b.get("mass", 1.0)) for b in boxes], [float(b.get("half_height", 0.5)) for b in boxes],
                  float(doc.get("gravity", -9.8)), float(Fraction(dt)) if isinstance(dt, str) else float(dt),
                  int(doc["steps"]), removals)


@dataclass
class Trajectory:
    heights: list[np.ndarray]  # after every step (and before the first), bottom box first
    halves: list[np.ndarray]   # the half-heights of the boxes then
    y: np.ndarray              # final heights
    v: np.ndarray              # final velocities


def _run(col: Column, step: Callable[[], None], read: Callable[[], tuple[list[float], list[float]]],
         remove: Callable[[int], None]) -> Trajectory:
    halves = list(col.half)
    y0 = np.array(col.y, dtype=float)
    heights, hs = [y0], [np.array(halves)]
    gone = dict(col.removals)
    for k in range(col.steps):
        if k in gone:
            remove(gone[k])
            del halves[gone[k]]
        step()
        y, _ = read()
        heights.append(np.array(y, dtype=float))
        hs.append(np.array(halves))
    y, v = read()
    return Trajectory(heights, hs, np.array(y, dtype=float), np.array(v, dtype=float))


def drive_pymunk(col: Column) -> Trajectory:
    import pymunk

    space = pymunk.Space()  # pymunk's defaults (10 iterations, no sleeping), but a slop in metres
    space.collision_slop = 0.01
    space.collision_bias = (1 - 0.1) ** 60  # pymunk's own default rounds this through single precision
    space.gravity = 0, col.gravity
    ground = pymunk.Body(body_type=pymunk.Body.STATIC)
    ground.position = 0, -1
    plate = pymunk.Poly.create_box(ground, (60, 2))
    plate.friction = 0
    space.add(ground, plate)
    bodies = []
    for y, v, m, h in zip(col.y, col.v, col.mass, col.half):
        body = pymunk.Body(m, float("inf"))
        body.position = 0, y
        body.velocity = 0, v
        shape = pymunk.Poly(body, [(-WIDTH / 2, -h), (WIDTH / 2, -h), (WIDTH / 2, h), (-WIDTH / 2, h)])
        shape.friction = 0
        shape.elasticity = 0
        space.add(body, shape)
        bodies.append(body)

    def remove(i: int) -> None:
        body = bodies.pop(i)
        space.remove(body, *body.shapes)

    return _run(col, lambda: space.step(col.dt),
                lambda: ([b.position.y for b in bodies], [b.velocity.y for b in bodies]), remove)


def drive_box2d(col: Column) -> Trajectory:
    import Box2D

    skin = Box2D.b2_polygonRadius
    world = Box2D.b2World(gravity=(0, col.gravity))
    ground = world.CreateStaticBody(position=(0, -3))
    ground.CreateFixture(shape=Box2D.b2PolygonShape(box=(30 - skin, 3 - skin)), friction=0)
    bodies = []
    for y, v, m, h in zip(col.y, col.v, col.mass, col.half):
        body = world.CreateDynamicBody(position=(0, y), fixedRotation=True)
        body.linearVelocity = (0, v)
        body.CreateFixture(shape=Box2D.b2PolygonShape(box=(WIDTH / 2 - skin, h - skin)), friction=0)
        mass = Box2D.b2MassData()
        mass.mass = m
        body.massData = mass
        bodies.append(body)

    def remove(i: int) -> None:
        world.DestroyBody(bodies.pop(i))

    return _run(col, lambda: world.Step(col.dt, 8, 3),
                lambda: ([b.position[1] for b in bodies], [b.linearVelocity[1] for b in bodies]), remove)


def drive_box2d_v3(col: Column) -> Trajectory:
    import pyb2d3

    world = pyb2d3.World(gravity=(0, col.gravity))  # Box2D v3's defaults: 30 Hz contacts, sleeping on
    ground = world.create_static_body(position=(0, -3))
    slippery = pyb2d3.surface_material(friction=0.0, restitution=0.0)
    ground.create_polygon_shape(pyb2d3.shape_def(material=slippery), pyb2d3.box(30, 3))
    bodies = []
    for y, v, m, h in zip(col.y, col.v, col.mass, col.half):
        body = world.create_dynamic_body(position=(0, y), fixed_rotation=True, linear_velocity=(0, v))
        body.create_polygon_shape(pyb2d3.shape_def(material=slippery), pyb2d3.box(WIDTH / 2, h))
        data = body.mass_data
        data.mass = m
        body.mass_data = data
        bodies.append(body)

    def remove(i: int) -> None:
        bodies.pop(i).destroy()

    return _run(col, lambda: world.step(col.dt, 4),
                lambda: ([b.position[1] for b in bodies], [b.linear_velocity[1] for b in bodies]), remove)


def drive_mujoco(col: Column) -> Trajectory:
    """MuJoCo at its defaults; a box taken away is a new model without it, the others' state carried over."""
    import mujoco

    boxes = list(zip(col.mass, col.half))
    qpos, qvel = np.array(col.y), np.array(col.v)

    def build() -> tuple[Any, Any]:
        bodies = "".join(
            f'<body pos="0 0 0"><inertial pos="0 0 0" mass="{m!r}" diaginertia="1 1 1"/>'
            f'<joint type="slide" axis="0 0 1"/><geom type="box" size="{WIDTH / 2} {WIDTH / 2} {h!r}" '
            f'contype="1" conaffinity="1" condim="1" mass="0"/></body>' for m, h in boxes)
        model = mujoco.MjModel.from_xml_string(
            f'<mujoco><option timestep="{col.dt!r}" gravity="0 0 {col.gravity!r}"/><worldbody>'
            f'<geom type="plane" size="10 10 0.1" condim="1"/>{bodies}</worldbody></mujoco>')
        return model, mujoco.MjData(model)

    state: dict[str, Any] = {}
    state["model"], state["data"] = build()
    state["data"].qpos[:], state["data"].qvel[:] = qpos, qvel

    def remove(i: int) -> None:
        old = state["data"]
        keep = [j for j in range(len(boxes)) if j != i]
        boxes.pop(i)
        state["model"], state["data"] = build()
        d = state["data"]
        d.qpos[:], d.qvel[:], d.qacc_warmstart[:] = old.qpos[keep], old.qvel[keep], old.qacc_warmstart[keep]

    return _run(col, lambda: mujoco.mj_step(state["model"], state["data"]),
                lambda: (list(state["data"].qpos), list(state["data"].qvel)), remove)


DRIVERS: dict[str, Callable[[Column], Trajectory]] = {
    "pymunk": drive_pymunk, "box2d": drive_box2d, "box2d-v3": drive_box2d_v3, "mujoco": drive_mujoco}


def peak_depth(t: Trajectory) -> float:
    """The deepest any contact (the floor's, or a pair's) went at any step, the start included; 0 for none."""
    peak = 0.0
    for y, h in zip(t.heights, t.halves):
        d = np.concatenate([[h[0] - y[0]], (h[:-1] + h[1:]) - (y[1:] - y[:-1])])
        peak = max(peak, float(d.max()))
    return peak
