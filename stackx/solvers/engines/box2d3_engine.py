"""Box2D v3 (pyb2d3, Box2D 3.1) steps the column and the planar model.

The column in Box2D v3: a world with gravity ``(0, g)``; each box a dynamic body with fixed rotation (so with
friction off it moves vertically only) and one box polygon of ``WIDTH`` x its height (v3 polygons have no skin),
friction 0 and restitution 0, its mass set to the box's; the floor a static box whose top is y = 0. One step is
one ``world.step(dt, substeps)``; heights and velocities come back for all bodies at once, in single precision
(Box2D computes in float32).

The planar model in Box2D v3 (``stackx.solvers.engines.planar`` says what every engine shares): each box a
body at its pose (static boxes static bodies) with one box polygon carrying the box's coefficient (Box2D mixes
sqrt(f_a f_b), as stackx does) and restitution 0, its mass and moment of inertia set to the box's. Poses and
velocities come back for all bodies at once in single precision; the angle, which Box2D keeps as a rotation,
is read as atan2 and unwrapped against the last step's.

The solver is the soft step that ``stackx.solvers.column.soft_step`` transcribes: ``substeps`` substeps each with a
warm-started solve whose bias treats overlap as a stiff, damped spring (``contact_hertz``, at most a quarter of
the substep rate, twice as stiff against static bodies; ``contact_damping_ratio``), pushing out at most
``contact_push_velocity``, then a relax pass without bias. Contacts take part from 0.02 m apart (Box2D's
speculative distance, four linear slops), allowed to close their gap within the step; that distance is compiled
into the library and is not a knob, but the bench measures the engine's error against the exact solve with it
(``speculative``). Bodies at rest for half a second fall asleep (``enable_sleep``), frozen until touched.
"""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from stackx.registry import solvers
from stackx.solvers.engines.engine import FLOOR_DEPTH, FLOOR_WIDTH, WIDTH, Engine
from stackx.solvers.engines.planar import (BOX_BIT, GROUND_DEPTH, GROUND_WIDTH, Boxes, ground_bit, ground_groups,
                                           mask, unwrap)

SPECULATIVE_DISTANCE = 0.02  # Box2D v3's b2_speculativeDistance: 4 x b2_linearSlop (0.005 m), compiled in


class Box2D3Params(BaseModel):
    """Box2D v3's own knobs, with its defaults (b2DefaultWorldDef, 4 substeps as its samples step)."""

    model_config = ConfigDict(extra="forbid")
    substeps: int = Field(4, gt=0, le=10_000,
                          description="substeps per step (world.step's subStepCount), each a solve and a relax pass: "
                                      "more make contacts stiffer at linear cost")
    contact_hertz: float | None = Field(30.0, gt=0, allow_inf_nan=False,
                                        description="contact stiffness as a spring frequency (Hz), at most a quarter "
                                                    "of the substep rate: higher sinks less under load; null: that "
                                                    "quarter, so stiffness grows with the substeps")

    def hertz(self, dt: float) -> float:
        """The contact hertz given to the world: ``contact_hertz``, or a quarter of the substep rate."""
        return self.contact_hertz if self.contact_hertz is not None else 0.25 * self.substeps / dt
    contact_damping_ratio: float = Field(10.0, ge=0, allow_inf_nan=False,
                                         description="damping of the contact spring: 10 pushes out without bouncing")
    contact_push_velocity: float = Field(3.0, gt=0, allow_inf_nan=False,
                                         description="fastest separating speed the contact bias asks for (m/s): "
                                                     "bounds how hard a deep overlap is pushed out")
    maximum_linear_speed: float = Field(400.0, gt=0, allow_inf_nan=False,
                                        description="speed no body exceeds (m/s)")
    enable_sleep: bool = Field(True, description="bodies at rest for 0.5 s sleep, frozen until touched")
    enable_continuous: bool = Field(True, description="continuous collision against static bodies (the floor), "
                                                      "so a fast box does not pass through")

    @property
    def speculative(self) -> float:
        """Gap (m) below which a contact takes part: what the bench's exact step uses for this engine."""
        return SPECULATIVE_DISTANCE


class Box2D3Column:
    """One batch row: the column's boxes as Box2D v3 bodies."""

    def __init__(self, b2: Any, p: Box2D3Params, g: float, dt: float, y: np.ndarray, v: np.ndarray,
                 mass: np.ndarray, half: np.ndarray) -> None:
        world = make_world(b2, p, g, dt)
        frictionless = b2.surface_material(friction=0.0, restitution=0.0)
        floor = world.create_static_body(position=(0.0, 0.0))
        floor.create_polygon_shape(b2.shape_def(material=frictionless),
                                   b2.box(FLOOR_WIDTH / 2, FLOOR_DEPTH / 2, center=(0.0, -FLOOR_DEPTH / 2)))
        self.bodies = []
        for i in range(y.shape[0]):
            body = world.create_dynamic_body(position=(0.0, float(y[i])), linear_velocity=(0.0, float(v[i])),
                                             fixed_rotation=True)
            body.create_polygon_shape(b2.shape_def(density=1.0, material=frictionless),
                                      b2.box(WIDTH / 2, float(half[i])))
            masses = body.mass_data
            masses.mass = float(mass[i])
            body.mass_data = masses
            self.bodies.append(body)
        self.b2 = b2
        self.world = world
        self.step = partial(world.step, dt, p.substeps)
        self._gather()

    def _gather(self) -> None:
        """The bodies as one batch, bottom first, and the arrays it fills."""
        self.batch = self.b2.Bodies()
        for body in self.bodies:
            self.batch.append(body.id)
        self.positions = np.zeros((len(self.bodies), 2), dtype=np.float32)
        self.velocities = np.zeros((len(self.bodies), 2), dtype=np.float32)

    def read(self, y: np.ndarray, v: np.ndarray) -> None:
        y[:] = self.batch.get_positions(self.positions)[:, 1]
        v[:] = self.batch.get_linear_velocities(self.velocities)[:, 1]

    def remove(self, box: int) -> None:
        self.bodies.pop(box).destroy()
        self._gather()


def make_world(b2: Any, p: Box2D3Params, g: float, dt: float) -> Any:
    """A world with gravity ``(0, g)`` and the params' knobs."""
    hertz = p.hertz(dt)
    world = b2.World(gravity=(0.0, g), contact_hertz=hertz, contact_damping_ratio=p.contact_damping_ratio,
                     maximum_linear_speed=p.maximum_linear_speed)
    world.set_contact_tuning(hertz, p.contact_damping_ratio, p.contact_push_velocity)
    world.sleeping_enabled = p.enable_sleep
    world.continuous_enabled = p.enable_continuous
    return world


class Box2D3Planar:
    """One batch row of the planar model as Box2D v3 bodies, in state order."""

    def __init__(self, b2: Any, p: Box2D3Params, g: float, dt: float, boxes: Boxes) -> None:
        world = make_world(b2, p, g, dt)

        def shape(mu: float, category: int, allowed: int) -> Any:
            return b2.shape_def(density=1.0, material=b2.surface_material(friction=mu, restitution=0.0),
                                filter=b2.make_filter(category_bits=category, mask_bits=allowed))

        values, group = ground_groups(boxes)
        for k, mu in enumerate(values):
            ground = world.create_static_body(position=(0.0, -GROUND_DEPTH / 2))
            ground.create_polygon_shape(shape(mu, ground_bit(k), BOX_BIT), b2.box(GROUND_WIDTH / 2, GROUND_DEPTH / 2))
        self.bodies = []
        for i in range(boxes.x.shape[0]):
            pose = dict(position=(float(boxes.x[i]), float(boxes.y[i])), rotation=float(boxes.angle[i]))
            if boxes.static[i]:
                body = world.create_static_body(**pose)
            else:
                body = world.create_dynamic_body(**pose, linear_velocity=(float(boxes.vx[i]), float(boxes.vy[i])),
                                                 angular_velocity=float(boxes.w[i]))
            body.create_polygon_shape(shape(float(boxes.friction[i]), *mask(boxes, group, i)),
                                      b2.box(float(boxes.hx[i]), float(boxes.hy[i])))
            if not boxes.static[i]:
                masses = body.mass_data
                masses.mass, masses.center, masses.rotational_inertia = (float(boxes.mass[i]), (0.0, 0.0),
                                                                         float(boxes.inertia[i]))
                body.mass_data = masses
                self.bodies.append(body)
        self.movable = boxes.movable
        self.world = world
        self.step = partial(world.step, dt, p.substeps)
        self.batch = b2.Bodies()
        for body in self.bodies:
            self.batch.append(body.id)
        n = len(self.bodies)
        self.positions, self.rotations, self.velocities = (np.zeros((n, 2), dtype=np.float32) for _ in range(3))
        self.spins = np.zeros(n, dtype=np.float32)

    def read(self, x: np.ndarray, y: np.ndarray, angle: np.ndarray, vx: np.ndarray, vy: np.ndarray,
             w: np.ndarray) -> None:
        at, turn = self.batch.get_positions(self.positions), self.batch.get_rotations(self.rotations)
        v, spin = self.batch.get_linear_velocities(self.velocities), self.batch.get_angular_velocities(self.spins)
        i = self.movable
        x[i], y[i] = at[:, 0], at[:, 1]
        angle[i] = unwrap(angle[i], np.arctan2(turn[:, 1].astype(np.float64), turn[:, 0].astype(np.float64)))
        vx[i], vy[i], w[i] = v[:, 0], v[:, 1], spin


@solvers.register("box2d-v3")
class Box2D3(Engine):
    """Box2D v3 (pyb2d3): substepped soft contacts with relax and speculative contacts; one call per step."""

    Params = Box2D3Params
    column = Box2D3Column
    planar = Box2D3Planar
    package = "pyb2d3"
    distribution = "pyb2d3"

    @classmethod
    def passes(cls, params: Box2D3Params) -> int:
        return 2 * params.substeps
