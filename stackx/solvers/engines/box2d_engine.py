"""Box2D 2.3 (pybox2d) steps the column and the planar model.

The column in Box2D 2.3: a ``b2World`` with gravity ``(0, g)``; each box a dynamic body with ``fixedRotation``
(so with friction off it moves vertically only) and one polygon fixture, friction 0 and restitution 0, its mass
set to the box's; the floor a static box whose top is y = 0. One step is one ``b2World.Step(dt,
velocity_iterations, position_iterations)``. Box2D computes in single precision: heights and velocities come
back rounded to float32.

Box2D 2.3 polygons carry a skin, ``b2_polygonRadius`` = 0.01 m: a polygon collides as its outline grown by the
skin, and the manual has the drawn shape be the outline. So a box of half-height h is a polygon of half-height
h - 0.01 (and half-width ``WIDTH``/2 - 0.01) whose outline is the box: a resting box then overlaps its support
by about Box2D's linear slop, 0.005 m, as in Box2D v3, instead of floating 0.015 m above it (as a polygon of the
box's own size does, outline and all). Boxes less than 0.01 m high cannot be built.

The planar model in Box2D 2.3 (``stackx.solvers.engines.planar`` says what every engine shares): each box a
body at its pose (static boxes static bodies) with one polygon fixture inside the skin as above, carrying the
box's coefficient (Box2D mixes sqrt(f_a f_b), as stackx does) and restitution 0, its mass and moment of
inertia set to the box's; angles and velocities come back in single precision.

The solver: sequential impulses over ``velocity_iterations`` passes, warm-started from the last step, then
``position_iterations`` nonlinear Gauss-Seidel passes that move positions to undo overlap beyond the linear slop
(0.005 m) with a Baumgarte factor 0.2, at most 0.2 m per step. Those three are compiled into the library and
are not knobs. Bodies at rest for half a second fall asleep (``allow_sleep``), frozen until something touches
them; a body moves at most 2 m per step.
"""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.registry import solvers
from stackx.solvers.engines.engine import FLOOR_DEPTH, FLOOR_WIDTH, WIDTH, Engine
from stackx.solvers.engines.planar import BOX_BIT, GROUND_DEPTH, GROUND_WIDTH, Boxes, ground_bit, ground_groups, mask


class Box2DParams(BaseModel):
    """Box2D 2.3's own knobs, with the defaults of its manual and testbed."""

    model_config = ConfigDict(extra="forbid")
    velocity_iterations: int = Field(8, gt=0, le=100_000,
                                     description="velocity passes per step over every contact (b2World.Step): "
                                                 "more make piles firmer and cost linearly more")
    position_iterations: int = Field(3, ge=0, le=100_000,
                                     description="position passes per step that push overlap beyond the linear "
                                                 "slop out (b2World.Step); 0 leaves it to sink")
    warm_starting: bool = Field(True, description="b2World.warmStarting: start each step from the impulses of the "
                                                  "last one; off rebuilds every load from zero each step")
    continuous_physics: bool = Field(True, description="b2World.continuousPhysics: time of impact against static "
                                                       "bodies (the floor), so a fast box does not pass through")
    allow_sleep: bool = Field(True, description="b2World.allowSleeping: bodies at rest for 0.5 s sleep, frozen "
                                                "until touched")


class Box2DColumn:
    """One batch row: the column's boxes as Box2D 2.3 bodies."""

    def __init__(self, box2d: Any, p: Box2DParams, g: float, dt: float, y: np.ndarray, v: np.ndarray,
                 mass: np.ndarray, half: np.ndarray) -> None:
        skin = box2d.b2_polygonRadius
        thin = [i for i in range(y.shape[0]) if not half[i] > skin]
        if thin:
            raise ValueError(f"box {thin[0]} has half-height {half[thin[0]]} m, not above Box2D's polygon skin "
                             f"{skin:.3g} m: Box2D 2.3 cannot build it")
        world = make_world(box2d, p, g)
        floor = world.CreateStaticBody(position=(0.0, -FLOOR_DEPTH / 2))
        floor.CreatePolygonFixture(box=(FLOOR_WIDTH / 2 - skin, FLOOR_DEPTH / 2 - skin), friction=0.0)
        self.bodies = []
        for i in range(y.shape[0]):
            body = world.CreateDynamicBody(position=(0.0, float(y[i])), linearVelocity=(0.0, float(v[i])),
                                           fixedRotation=True)
            body.CreatePolygonFixture(box=(WIDTH / 2 - skin, float(half[i]) - skin), density=1.0, friction=0.0,
                                      restitution=0.0)
            body.massData = box2d.b2MassData(mass=float(mass[i]), center=(0.0, 0.0), I=0.0)
            self.bodies.append(body)
        self.world = world
        self.step = partial(world.Step, dt, p.velocity_iterations, p.position_iterations)

    def read(self, y: np.ndarray, v: np.ndarray) -> None:
        y[:] = [b.position.y for b in self.bodies]
        v[:] = [b.linearVelocity.y for b in self.bodies]

    def remove(self, box: int) -> None:
        self.world.DestroyBody(self.bodies.pop(box))


def make_world(box2d: Any, p: Box2DParams, g: float) -> Any:
    """A ``b2World`` with gravity ``(0, g)`` and the params' knobs."""
    world = box2d.b2World(gravity=(0.0, g), doSleep=p.allow_sleep)
    world.warmStarting = p.warm_starting
    world.continuousPhysics = p.continuous_physics
    return world


class Box2DPlanar:
    """One batch row of the planar model as Box2D 2.3 bodies, in state order."""

    def __init__(self, box2d: Any, p: Box2DParams, g: float, dt: float, boxes: Boxes) -> None:
        skin = box2d.b2_polygonRadius
        thin = [i for i in range(boxes.x.shape[0]) if not min(boxes.hx[i], boxes.hy[i]) > skin]
        if thin:
            raise ValueError(f"box {thin[0]} has a half-size not above Box2D's polygon skin {skin:.3g} m: "
                             "Box2D 2.3 cannot build it")
        world = make_world(box2d, p, g)
        values, group = ground_groups(boxes)
        for k, mu in enumerate(values):
            ground = world.CreateStaticBody(position=(0.0, -GROUND_DEPTH / 2))
            ground.CreatePolygonFixture(box=(GROUND_WIDTH / 2 - skin, GROUND_DEPTH / 2 - skin), friction=mu,
                                        restitution=0.0, categoryBits=ground_bit(k), maskBits=BOX_BIT)
        self.bodies = []
        for i in range(boxes.x.shape[0]):
            pose = dict(position=(float(boxes.x[i]), float(boxes.y[i])), angle=float(boxes.angle[i]))
            if boxes.static[i]:
                body = world.CreateStaticBody(**pose)
            else:
                body = world.CreateDynamicBody(**pose, linearVelocity=(float(boxes.vx[i]), float(boxes.vy[i])),
                                               angularVelocity=float(boxes.w[i]))
            category, allowed = mask(boxes, group, i)
            body.CreatePolygonFixture(box=(float(boxes.hx[i]) - skin, float(boxes.hy[i]) - skin), density=1.0,
                                      friction=float(boxes.friction[i]), restitution=0.0, categoryBits=category,
                                      maskBits=allowed)
            if not boxes.static[i]:
                body.massData = box2d.b2MassData(mass=float(boxes.mass[i]), center=(0.0, 0.0),
                                                 I=float(boxes.inertia[i]))
                self.bodies.append(body)
        self.movable = boxes.movable
        self.world = world
        self.step = partial(world.Step, dt, p.velocity_iterations, p.position_iterations)

    def read(self, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
             w: np.ndarray) -> None:
        values = np.array([(*b.position, b.angle, *b.linearVelocity, b.angularVelocity) for b in self.bodies])
        for k, out in enumerate((x, y, angle, vx, vy, w)):
            out[self.movable] = values[:, k]


@solvers.register("box2d")
class Box2D(Engine):
    """Box2D 2.3 (pybox2d): warm-started sequential impulses, then position passes; one call per step."""

    Params = Box2DParams
    column = Box2DColumn
    planar = Box2DPlanar
    package = "Box2D"
    distribution = "box2d"
    knob = "velocity_iterations"

    @classmethod
    def passes(cls, params: Box2DParams) -> int:
        return params.velocity_iterations + params.position_iterations
