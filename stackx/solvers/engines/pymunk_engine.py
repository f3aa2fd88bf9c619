"""pymunk (Chipmunk2D, as Munk2D in pymunk 7) steps the column and the planar model.

The column in pymunk: a ``Space`` with gravity ``(0, g)``; each box a dynamic ``Body`` of the box's mass and an
infinite moment of inertia (it cannot rotate, so with friction off it moves vertically only) carrying a box
``Poly`` of ``WIDTH`` x its height with friction 0 and elasticity 0; the floor a static box whose top is y = 0.
One step is one ``Space.step(dt)``; heights and velocities come back through ``pymunk.batch``.

The planar model in pymunk (``stackx.solvers.engines.planar`` says what every engine shares): each box a
``Body`` of its mass and moment of inertia (a static box a static body) at its pose, carrying a box ``Poly``
of its size with elasticity 0. Chipmunk mixes two shapes' friction as the product, so a shape carries
sqrt(mu) and two boxes meet with sqrt(mu_a mu_b); the ground shape of each coefficient carries sqrt(mu) too,
giving the box its own. Poses and velocities come back through ``pymunk.batch``.

Chipmunk's contact solver: sequential impulses over ``iterations`` passes with the impulses kept between steps
(warm start), and overlap beyond ``collision_slop`` pushed out by a bias velocity that leaves
``collision_bias`` of the overlap after one second. pymunk's defaults suit a world measured in pixels: its
slop of 0.1 would be 10 cm in metres, ten times the lab's, so that a resting column sinks by about that much
per contact and a pyramid's boxes rest 10 cm into each other. stackx's default is therefore 0.01 m, the lab's
slop, which is also the depth stackx's criteria allow; every other default is pymunk's own (the bias is a
share per second and has no length in it). Sleeping is off by default (``sleep_time_threshold`` null).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.registry import solvers
from stackx.solvers.engines.engine import FLOOR_DEPTH, FLOOR_WIDTH, WIDTH, Engine
from stackx.solvers.engines.planar import BOX_BIT, GROUND_DEPTH, GROUND_WIDTH, Boxes, ground_bit, ground_groups, mask


class PymunkParams(BaseModel):
    """pymunk's own knobs, with pymunk's defaults (7.3) except the slop, given in metres (0.01, not 0.1)."""

    model_config = ConfigDict(extra="forbid")
    iterations: int = Field(10, gt=0, le=100_000,
                            description="Space.iterations: solver passes per step over every contact; more make "
                                        "piles firmer and cost linearly more")
    collision_slop: float = Field(0.01, ge=0, le=10, allow_inf_nan=False,
                                  description="Space.collision_slop: overlap left alone (m); 0.01, the lab's slop: "
                                              "pymunk's own 0.1 is made for pixels and would let each contact "
                                              "sink 10 cm; 0 pushes out every overlap and jitters")
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


class BatchReader:
    """The bodies' fields in one ``pymunk.batch`` call. pymunk lists bodies in an order of its own, ``width``
    floats each; where the wanted ``fields`` (offsets within a body's floats) of ``bodies``, in their order,
    lie in that list is found again whenever pymunk's order changes."""

    def __init__(self, batch: Any, space: Any, fields: Any, bodies: list[Any], offsets: tuple[int, ...],
                 width: int) -> None:
        self.batch, self.space, self.fields, self.bodies = batch, space, fields, bodies
        self.offsets, self.width = np.array(offsets, dtype=np.intp), width
        self.buffer = batch.Buffer()
        self.ids = b""
        self.columns = np.zeros((len(offsets), 0), dtype=np.intp)

    def read(self) -> tuple[np.ndarray, np.ndarray]:
        """All the floats pymunk gave, and per wanted field the indices of ``bodies``' values in them."""
        self.buffer.clear()
        self.batch.get_space_bodies(self.space, self.fields, self.buffer)
        ids = bytes(self.buffer.int_buf())
        if ids != self.ids or self.columns.shape[1] != len(self.bodies):
            listed = {int(k): n for n, k in enumerate(np.frombuffer(ids, dtype=np.uintp))}
            order = np.array([listed[b.id] for b in self.bodies], dtype=np.intp)
            self.ids, self.columns = ids, self.width * order[None, :] + self.offsets[:, None]
        return np.frombuffer(self.buffer.float_buf(), dtype=np.float64), self.columns


class PymunkColumn:
    """One batch row: the column's boxes as pymunk bodies."""

    def __init__(self, pymunk: Any, p: PymunkParams, g: float, dt: float, y: np.ndarray, v: np.ndarray,
                 mass: np.ndarray, half: np.ndarray) -> None:
        import pymunk.batch

        self.batch = pymunk.batch
        space = make_space(pymunk, p, g)
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
        self.reader = BatchReader(pymunk.batch, space, self.fields, self.bodies, (1, 3), 4)

    def step(self) -> None:
        self.space.step(self.dt)

    def read(self, y: np.ndarray, v: np.ndarray) -> None:
        """Heights and velocities of every body in one batch call (x, y, vx, vy each)."""
        data, (heights, speeds) = self.reader.read()
        y[:] = data[heights]
        v[:] = data[speeds]

    def remove(self, box: int) -> None:
        body = self.bodies.pop(box)
        self.space.remove(body, *body.shapes)


def make_space(pymunk: Any, p: PymunkParams, g: float) -> Any:
    """A ``Space`` with gravity ``(0, g)`` and the params' knobs."""
    space = pymunk.Space()
    space.gravity = (0.0, g)
    space.iterations = p.iterations
    space.collision_slop = p.collision_slop
    space.collision_bias = p.collision_bias
    space.collision_persistence = p.collision_persistence
    if p.sleep_time_threshold is not None:
        space.sleep_time_threshold = p.sleep_time_threshold
    return space


def box_poly(pymunk: Any, body: Any, hx: float, hy: float, mu: float, category: int, allowed: int) -> Any:
    """A box shape of half-sizes ``hx, hy`` centred on ``body``, carrying sqrt(mu), in its collision
    category."""
    shape = pymunk.Poly.create_box(body, (2.0 * hx, 2.0 * hy))
    shape.friction, shape.elasticity = math.sqrt(mu), 0.0
    shape.filter = pymunk.ShapeFilter(categories=category, mask=allowed)
    return shape


class PymunkPlanar:
    """One batch row of the planar model as pymunk bodies, in state order."""

    def __init__(self, pymunk: Any, p: PymunkParams, g: float, dt: float, boxes: Boxes) -> None:
        import pymunk.batch

        self.batch = pymunk.batch
        space = make_space(pymunk, p, g)
        values, group = ground_groups(boxes)
        for k, mu in enumerate(values):
            body = pymunk.Body(body_type=pymunk.Body.STATIC)
            body.position = (0.0, -GROUND_DEPTH / 2)
            space.add(body, box_poly(pymunk, body, GROUND_WIDTH / 2, GROUND_DEPTH / 2, mu, ground_bit(k),
                                     BOX_BIT))
        self.bodies = []
        for i in range(boxes.x.shape[0]):
            if boxes.static[i]:
                body = pymunk.Body(body_type=pymunk.Body.STATIC)
            else:
                body = pymunk.Body(float(boxes.mass[i]), float(boxes.inertia[i]))
                body.velocity = (float(boxes.vx[i]), float(boxes.vy[i]))
                body.angular_velocity = float(boxes.w[i])
                self.bodies.append(body)
            body.position = (float(boxes.x[i]), float(boxes.y[i]))
            body.angle = float(boxes.angle[i])
            space.add(body, box_poly(pymunk, body, float(boxes.hx[i]), float(boxes.hy[i]), float(boxes.friction[i]),
                                     *mask(boxes, group, i)))
        self.movable = boxes.movable
        self.space = space
        self.dt = dt
        fields = pymunk.batch.BodyFields
        self.reader = BatchReader(pymunk.batch, space,
                                  fields.BODY_ID | fields.POSITION | fields.ANGLE | fields.VELOCITY
                                  | fields.ANGULAR_VELOCITY, self.bodies, tuple(range(6)), 6)

    def step(self) -> None:
        self.space.step(self.dt)

    def read(self, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
             w: np.ndarray) -> None:
        """Every movable body's x, y, angle, vx, vy, w in one batch call (six per body)."""
        data, columns = self.reader.read()
        for out, column in zip((x, y, angle, vx, vy, w), columns):
            out[self.movable] = data[column]


@solvers.register("pymunk")
class Pymunk(Engine):
    """pymunk (Chipmunk2D): sequential impulses with warm start and a slop-and-bias push-out; one call per step."""

    Params = PymunkParams
    column = PymunkColumn
    planar = PymunkPlanar
    package = "pymunk"
    distribution = "pymunk"
