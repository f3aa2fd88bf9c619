"""pymunk (Chipmunk2D, as Munk2D in pymunk 7) steps the column.

The column in pymunk: a ``Space`` with gravity ``(0, g)``; each box a dynamic ``Body`` of the box's mass and an
infinite moment of inertia (it cannot rotate, so with friction off it moves vertically only) carrying a box
``Poly`` of ``WIDTH`` x its height with friction 0 and elasticity 0; the floor a static box whose top is y = 0.
One step is one ``Space.step(dt)``; heights and velocities come back through ``pymunk.batch``.

Chipmunk's contact solver: sequential impulses over ``iterations`` passes with the impulses kept between steps
(warm start), and overlap beyond ``collision_slop`` pushed out by a bias velocity that leaves
``collision_bias`` of the overlap after one second. Its defaults suit a world measured in pixels: a slop of
0.1 is 10 cm in metres, ten times the lab's, so at its defaults a resting column sinks by about that much per
contact. Sleeping is off by default (``sleep_time_threshold`` null).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.registry import solvers
from stackx.solvers.engines.engine import FLOOR_DEPTH, FLOOR_WIDTH, WIDTH, Engine


class PymunkParams(BaseModel):
    """pymunk's own knobs, with pymunk's defaults (7.3)."""

    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(10, gt=0, le=100_000,
                            description="Space.iterations: solver passes per step over every contact; more make "
                                        "piles firmer and cost linearly more")
    collision_slop: float = Field(0.1, ge=0, le=10, allow_inf_nan=False,
                                  description="Space.collision_slop: overlap left alone (m); pymunk's 0.1 is made "
                                              "for pixels and lets each contact of a column sink 10 cm")
    collision_bias: float = Field((1.0 - 0.1) ** 60, gt=0, le=1, allow_inf_nan=False,
                                  description="Space.collision_bias: share of an overlap still there after one "
                                              "second; the default (1 - 0.1)^60 pushes out 10% per step at 60 Hz, "
                                              "smaller values push out faster and may bounce")
    collision_persistence: int = Field(3, ge=0, le=1000,
                                       description="Space.collision_persistence: steps a contact's impulse is kept "
                                                   "after the shapes part, so a jittering contact stays warm")
    sleep_time_threshold: float | None = Field(None, gt=0, allow_inf_nan=False,
                                               description="Space.sleep_time_threshold: seconds at rest after which "
                                                           "a group of bodies sleeps (frozen until touched); null "
                                                           "never sleeps (pymunk's default)")


class PymunkColumn:
    """One batch row: the column's boxes as pymunk bodies."""

    def __init__(self, pymunk: Any, p: PymunkParams, g: float, dt: float, y: np.ndarray, v: np.ndarray,
                 mass: np.ndarray, half: np.ndarray) -> None:
        import pymunk.batch

        self.batch = pymunk.batch
        space = pymunk.Space()
        space.gravity = (0.0, g)
        space.iterations = p.iterations
        space.collision_slop = p.collision_slop
        space.collision_bias = p.collision_bias
        space.collision_persistence = p.collision_persistence
        if p.sleep_time_threshold is not None:
            space.sleep_time_threshold = p.sleep_time_threshold
        w, d = FLOOR_WIDTH / 2, FLOOR_DEPTH
        floor = pymunk.Poly(space.static_body, [(-w, -d), (w, -d), (w, 0.0), (-w, 0.0)])
        floor.friction, floor.elasticity = 0.0, 0.0
        space.add(floor)
        self.bodies = []
        for i in range(y.shape[0]):
            body = pymunk.Body(float(mass[i]), math.inf)
            body.position = (0.0, float(y[i]))
            body.velocity = (0.0, float(v[i]))
            shape = pymunk.Poly.create_box(body, (WIDTH, 2.0 * float(half[i])))
            shape.friction, shape.elasticity = 0.0, 0.0
            space.add(body, shape)
            self.bodies.append(body)
        self.space = space
        self.dt = dt
        self.fields = pymunk.batch.BodyFields.BODY_ID | pymunk.batch.BodyFields.POSITION | \
            pymunk.batch.BodyFields.VELOCITY
        self.buffer = pymunk.batch.Buffer()
        self.ids = b""
        self.heights = self.speeds = np.zeros(0, dtype=np.intp)

    def step(self) -> None:
        self.space.step(self.dt)

    def read(self, y: np.ndarray, v: np.ndarray) -> None:
        """Heights and velocities of every body in one batch call. pymunk lists bodies in an order of its own
        (x, y, vx, vy each); which entries are the column's, bottom first, is found again when it changes."""
        self.buffer.clear()
        self.batch.get_space_bodies(self.space, self.fields, self.buffer)
        ids = bytes(self.buffer.int_buf())
        if ids != self.ids:
            listed = {int(k): n for n, k in enumerate(np.frombuffer(ids, dtype=np.uintp))}
            order = np.array([listed[b.id] for b in self.bodies], dtype=np.intp)
            self.ids, self.heights, self.speeds = ids, 4 * order + 1, 4 * order + 3
        data = np.frombuffer(self.buffer.float_buf(), dtype=np.float64)
        y[:] = data[self.heights]
        v[:] = data[self.speeds]

    def remove(self, box: int) -> None:
        body = self.bodies.pop(box)
        self.space.remove(body, *body.shapes)


@solvers.register("pymunk")
class Pymunk(Engine):
    """pymunk (Chipmunk2D): sequential impulses with warm start and a slop-and-bias push-out; one call per step."""

    Params = PymunkParams
    column = PymunkColumn
    package = "pymunk"
    distribution = "pymunk"
