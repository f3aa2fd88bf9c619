"""Box2D v3 (pyb2d3, Box2D 3.1) steps the column.

The column in Box2D v3: a world with gravity ``(0, g)``; each box a dynamic body with fixed rotation (so with
friction off it moves vertically only) and one box polygon of ``WIDTH`` x its height (v3 polygons have no skin),
friction 0 and restitution 0, its mass set to the box's; the floor a static box whose top is y = 0. One step is
one ``world.step(dt, substeps)``; heights and velocities come back for all bodies at once, in single precision
(Box2D computes in float32).

The solver is the soft step that ``stackx.solvers.soft_step`` transcribes: ``substeps`` substeps each with a
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

SPECULATIVE_DISTANCE = 0.02  # Box2D v3's b2_speculativeDistance: 4 x b2_linearSlop (0.005 m), compiled in


class Box2D3Params(BaseModel):
    """Box2D v3's own knobs, with its defaults (b2DefaultWorldDef, 4 substeps as its samples step)."""

    model_config = ConfigDict(extra="forbid")
    substeps: int = Field(4, gt=0, le=10_000,
                          description="substeps per step (world.step's subStepCount), each a solve and a relax pass: "
                                      "more make contacts stiffer at linear cost")
    contact_hertz: float = Field(30.0, gt=0, allow_inf_nan=False,
                                 description="contact stiffness as a spring frequency (Hz), at most a quarter of the "
                                             "substep rate: higher sinks less under load")
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
        world = b2.World(gravity=(0.0, g), contact_hertz=p.contact_hertz,
                         contact_damping_ratio=p.contact_damping_ratio, maximum_linear_speed=p.maximum_linear_speed)
        world.set_contact_tuning(p.contact_hertz, p.contact_damping_ratio, p.contact_push_velocity)
        world.sleeping_enabled = p.enable_sleep
        world.continuous_enabled = p.enable_continuous
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


@solvers.register("box2d-v3")
class Box2D3(Engine):
    """Box2D v3 (pyb2d3): substepped soft contacts with relax and speculative contacts; one call per step."""

    Params = Box2D3Params
    column = Box2D3Column
    package = "pyb2d3"
    distribution = "pyb2d3"

    @classmethod
    def passes(cls, params: Box2D3Params) -> int:
        return 2 * params.substeps
