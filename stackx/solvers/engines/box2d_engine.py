"""Box2D 2.3 (pybox2d) steps the column.

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
        world = box2d.b2World(gravity=(0.0, g), doSleep=p.allow_sleep)
        world.warmStarting = p.warm_starting
        world.continuousPhysics = p.continuous_physics
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


@solvers.register("box2d")
class Box2D(Engine):
    """Box2D 2.3 (pybox2d): warm-started sequential impulses, then position passes; one call per step."""

    Params = Box2DParams
    column = Box2DColumn
    package = "Box2D"
    distribution = "box2d"
    knob = "velocity_iterations"

    @classmethod
    def passes(cls, params: Box2DParams) -> int:
        return params.velocity_iterations + params.position_iterations
